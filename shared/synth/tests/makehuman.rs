//! The MakeHuman body: bad input always; the real body only when the asset cache is
//! there (`scripts/fetch-assets`), else the test says so and skips.

use airglyph_core::Joint;
use airglyph_synth::makehuman::{self, read_obj, shape};
use airglyph_synth::{
    BodySpec, MakeHumanShape, MotionSpec, SceneConfig, ScriptedPose, SynthError, Synthesizer,
};
use std::path::Path;

#[test]
fn a_missing_asset_cache_says_how_to_fetch_it() {
    let dir = tempfile::tempdir().unwrap();
    let e = makehuman::load(dir.path()).unwrap_err();
    assert!(matches!(e, SynthError::MissingAssets { .. }));
    let msg = e.to_string();
    assert!(msg.contains("scripts/fetch-assets"), "{msg}");
    assert!(msg.contains("base.obj"), "{msg}");
    let cfg = SceneConfig {
        body: BodySpec::MakeHuman {
            assets: Some(dir.path().to_owned()),
            shape: Default::default(),
        },
        ..SceneConfig::default()
    };
    let msg = Synthesizer::new(cfg).err().unwrap().to_string();
    assert!(msg.contains("fetch-assets"), "{msg}");
}

#[test]
fn malformed_obj_is_refused_with_file_and_line() {
    let p = Path::new("bad.obj");
    let e = read_obj(p, "v 0 0 0\nv 1 0 zero\n", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.obj:2:") && e.contains("\"zero\""), "{e}");
    let e = read_obj(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.obj:4:") && e.contains("vertex 7"), "{e}");
    let e = read_obj(p, "v 0 0 0\nf 1 2\n", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.obj:2:") && e.contains("at least 3"), "{e}");
    let e = read_obj(
        p,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\ng other\nf 1 2 3\n",
        Some("body"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("no faces in group \"body\""), "{e}");
    // A good one: a quad becomes two triangles, groups are remembered.
    let m = read_obj(
        p,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng body\nf 1/1 2/2 3/3 -1/4\n",
        Some("body"),
    )
    .unwrap();
    assert_eq!(m.tris, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.groups["body"], vec![0, 1, 2, 3]);
}

fn assets() -> Option<std::path::PathBuf> {
    let dir = makehuman::default_assets_dir();
    if makehuman::assets_present(&dir) {
        Some(dir)
    } else {
        println!(
            "skipping: no MakeHuman assets in {} (run scripts/fetch-assets)",
            dir.display()
        );
        None
    }
}

#[test]
fn makehuman_joints_lie_inside_the_silhouette() {
    let Some(dir) = assets() else { return };
    for pose in ScriptedPose::ALL {
        let cfg = SceneConfig {
            body: BodySpec::MakeHuman {
                assets: Some(dir.clone()),
                shape: Default::default(),
            },
            motion: MotionSpec::Pose(pose),
            ..SceneConfig::default()
        };
        let seen = visible_joints_inside_the_surface(cfg, &format!("{pose:?}"));
        let min_seen = if pose == ScriptedPose::Sideways {
            8
        } else {
            13
        };
        assert!(seen >= min_seen, "{pose:?}: {seen} visible");
    }
}

#[test]
fn makehuman_body_loads_whole() {
    // (Winding is checked by the silhouette test: with faces wound inward, culling would
    // show the back of the body, behind the joints.)
    let Some(dir) = assets() else { return };
    let body = makehuman::load(&dir).unwrap();
    assert!(body.triangle_count() > 20_000, "{}", body.triangle_count());
    let cfg = SceneConfig {
        body: BodySpec::MakeHuman {
            assets: Some(dir),
            shape: Default::default(),
        },
        motion: MotionSpec::Pose(ScriptedPose::TPose),
        ..SceneConfig::default()
    };
    let mut synth = Synthesizer::new(cfg).unwrap();
    let (depth, _) = synth.render(0);
    let covered = depth.pixels().iter().filter(|d| **d > 0).count();
    assert!(covered > 15_000, "{covered} pixels");
}

// Body shapes (MakeHuman's macro targets): the real ones only when the targets are in the
// cache (`airglyph fetch-assets`), else the test says so and skips.

fn targets() -> Option<std::path::PathBuf> {
    let dir = assets()?;
    if makehuman::targets_present(&dir) {
        Some(dir)
    } else {
        println!(
            "skipping: no MakeHuman macro targets in {} (rerun airglyph fetch-assets)",
            dir.display()
        );
        None
    }
}

fn shaped(dir: &Path, text: &str) -> airglyph_synth::Body {
    makehuman::load_shaped(dir, &MakeHumanShape::parse(text).unwrap()).unwrap()
}

/// The waist: the body's width across 10 cm above the pelvis, and its mean girth there
/// (the mean distance, across and front to back, of the vertices 5–20 cm above the
/// pelvis from their centre), arms left out.
fn waist(body: &airglyph_synth::Body) -> (f32, f32) {
    let j = body.rest_joints();
    let pelvis = j[Joint::Pelvis.index()].y;
    let arm = j[Joint::LeftElbow.index()].x.abs() * 0.8;
    let (mut x0, mut x1) = (f32::MAX, f32::MIN);
    let band: Vec<_> = body
        .rest_vertices()
        .iter()
        .filter(|v| v.x.abs() < arm && v.y > pelvis + 0.05 && v.y < pelvis + 0.20)
        .collect();
    for v in &band {
        if (v.y - pelvis - 0.10).abs() < 0.01 {
            (x0, x1) = (x0.min(v.x), x1.max(v.x));
        }
    }
    let n = band.len() as f32;
    let (cx, cz) = band
        .iter()
        .fold((0.0, 0.0), |a, v| (a.0 + v.x / n, a.1 + v.z / n));
    let girth = band.iter().map(|v| (v.x - cx).hypot(v.z - cz)).sum::<f32>() / n;
    (x1 - x0, girth)
}

#[test]
fn the_default_shape_is_the_base_mesh_unchanged() {
    let Some(dir) = assets() else { return };
    let plain = makehuman::load(&dir).unwrap();
    let default = makehuman::load_shaped(&dir, &MakeHumanShape::default()).unwrap();
    assert_eq!(plain.rest_vertices(), default.rest_vertices());
    assert_eq!(plain.rest_joints(), default.rest_joints());
    assert_eq!(plain.name(), "makehuman cmu_mb");
    assert_eq!(
        MakeHumanShape::parse("weight=0.5").unwrap(),
        MakeHumanShape::default()
    );
}

#[test]
fn shapes_change_the_body_as_their_names_say() {
    let Some(dir) = targets() else { return };
    let base = makehuman::load(&dir).unwrap();
    let top = |b: &airglyph_synth::Body| {
        b.rest_vertices()
            .iter()
            .map(|v| v.y)
            .fold(f32::MIN, f32::max)
    };
    let head = |b: &airglyph_synth::Body| b.rest_joints()[Joint::Head.index()].y;
    let shoulders = |b: &airglyph_synth::Body| {
        let j = b.rest_joints();
        (j[Joint::LeftShoulder.index()] - j[Joint::RightShoulder.index()]).norm()
    };
    let (bw, bd) = waist(&base);

    // Heavier: a wider and thicker waist.
    let heavy = shaped(&dir, "weight=0.95");
    let (hw, hd) = waist(&heavy);
    assert!(hw > bw + 0.01 && hd > bd + 0.005, "{hw} {hd} vs {bw} {bd}");
    // Thinner: a narrower one.
    let (tw, td) = waist(&shaped(&dir, "weight=0.05"));
    assert!(tw < bw && td < bd, "{tw} {td} vs {bw} {bd}");

    // Taller: the head higher, and the joints with it.
    let tall = shaped(&dir, "height=0.8");
    assert!(
        top(&tall) > top(&base) + 0.1,
        "{} {}",
        top(&tall),
        top(&base)
    );
    assert!(
        head(&tall) > head(&base) + 0.1,
        "{} {}",
        head(&tall),
        head(&base)
    );
    let short = shaped(&dir, "height=0.2");
    assert!(head(&short) < head(&base) - 0.05);

    // Female: shorter and narrower at the shoulders than male, and not the base.
    let female = shaped(&dir, "gender=0");
    let male = shaped(&dir, "gender=1");
    assert_ne!(female.rest_vertices(), base.rest_vertices());
    assert!(shoulders(&female) < shoulders(&base) && shoulders(&base) < shoulders(&male));
    assert!(top(&female) < top(&male) - 0.05);
    assert_eq!(female.name(), "makehuman cmu_mb (gender=0)");

    // Every joint of every shape inside the mesh's bounding box, the feet on the floor.
    for b in [
        &heavy,
        &tall,
        &short,
        &female,
        &male,
        &shaped(
            &dir,
            "gender=0,age=0.9,height=0.3,weight=0.7,muscle=0.2,proportions=0.1,asian=1",
        ),
    ] {
        let v = b.rest_vertices();
        let lo = v.iter().fold(v[0], |a, p| a.inf(p));
        let hi = v.iter().fold(v[0], |a, p| a.sup(p));
        assert!(lo.y.abs() < 1e-4, "{}: floor {}", b.name(), lo.y);
        for (j, p) in Joint::ALL.iter().zip(b.rest_joints()) {
            let inside = (0..3).all(|k| p[k] > lo[k] && p[k] < hi[k]);
            assert!(inside, "{}: {j:?} at {p:?} outside {lo:?}–{hi:?}", b.name());
        }
    }
}

#[test]
fn shaped_joints_lie_inside_the_silhouette() {
    let Some(dir) = targets() else { return };
    for text in [
        "gender=0",
        "gender=1,weight=0.95",
        "height=0.8,weight=0.1",
        "gender=0,age=0.9,height=0.3",
    ] {
        for pose in [
            ScriptedPose::Neutral,
            ScriptedPose::TPose,
            ScriptedPose::HandsNearFace,
        ] {
            let cfg = SceneConfig {
                body: BodySpec::MakeHuman {
                    assets: Some(dir.clone()),
                    shape: MakeHumanShape::parse(text).unwrap(),
                },
                motion: MotionSpec::Pose(pose),
                ..SceneConfig::default()
            };
            visible_joints_inside_the_surface(cfg, &format!("{text} {pose:?}"));
        }
    }
}

/// An asset folder with the body's three files (copied) and no targets.
fn body_only() -> Option<tempfile::TempDir> {
    let src = assets()?;
    let dir = tempfile::tempdir().unwrap();
    for f in [makehuman::OBJ, makehuman::RIG, makehuman::WEIGHTS] {
        let to = dir.path().join(f);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(src.join(f), to).unwrap();
    }
    Some(dir)
}

#[test]
fn a_missing_target_says_to_rerun_fetch_assets() {
    let Some(dir) = body_only() else { return };
    let shape = MakeHumanShape::parse("gender=0").unwrap();
    let e = makehuman::load_shaped(dir.path(), &shape).unwrap_err();
    assert!(matches!(e, SynthError::MissingTargets { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("fetch-assets") && msg.contains("macrodetails"),
        "{msg}"
    );
    // The default shape needs none.
    assert!(makehuman::load(dir.path()).is_ok());
    let cfg = SceneConfig {
        body: BodySpec::MakeHuman {
            assets: Some(dir.path().to_owned()),
            shape,
        },
        ..SceneConfig::default()
    };
    let msg = Synthesizer::new(cfg).err().unwrap().to_string();
    assert!(msg.contains("fetch-assets"), "{msg}");
}

#[test]
fn a_corrupt_target_is_refused_with_its_file() {
    use std::io::Write;
    let Some(dir) = body_only() else { return };
    let shape = MakeHumanShape::parse("weight=0.9").unwrap();
    let names: Vec<String> = shape.target_changes().into_iter().map(|t| t.0).collect();
    let gz = |text: &str| {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(text.as_bytes()).unwrap();
        e.finish().unwrap()
    };
    let write = |name: &str, bytes: &[u8]| {
        let p = shape::target_path(dir.path(), name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, bytes).unwrap();
        p
    };
    for n in &names[1..] {
        write(n, &gz("# nothing moves\n"));
    }
    // Not gzip at all.
    let first = write(&names[0], b"0 0.1 0.2 0.3\n");
    let e = makehuman::load_shaped(dir.path(), &shape)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&first.display().to_string()) && e.contains("gzip"),
        "{e}"
    );
    // Gzip, but a vertex past the mesh's end on line 2.
    write(&names[0], &gz("0 0.1 0.2 0.3\n99999999 0 0 0\n"));
    let e = makehuman::load_shaped(dir.path(), &shape)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&format!("{}:2:", first.display())), "{e}");
    // Well-formed: the body loads.
    write(&names[0], &gz("0 0.1 0.2 0.3\n"));
    assert!(makehuman::load_shaped(dir.path(), &shape).is_ok());
}

/// Renders frame 0 of `cfg` and checks that every joint the truth calls visible
/// projects onto a surface in front of it (the joint lies inside the body); returns how
/// many were visible.
fn visible_joints_inside_the_surface(cfg: SceneConfig, what: &str) -> usize {
    let mut synth = Synthesizer::new(cfg).unwrap();
    let k = synth.intrinsics();
    let (depth, truth) = synth.render(0);
    let mut seen = 0;
    for j in Joint::ALL {
        if !truth.visible[j.index()] {
            continue;
        }
        seen += 1;
        let p = truth.skeleton.get(j);
        let (u, v) = k.project(&p).unwrap();
        let d = depth.get(u.round() as u32, v.round() as u32);
        assert!(
            d > 0 && (d as f32) < p.z * 1000.0,
            "{what}: {j:?} d={d} z={}",
            p.z
        );
    }
    seen
}
