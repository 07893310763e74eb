//! The MakeHuman body: bad input always; the real body only when the asset cache is
//! there (`scripts/fetch-assets`), else the test says so and skips.

use airglyph_core::Joint;
use airglyph_synth::makehuman::{self, read_obj};
use airglyph_synth::{BodySpec, MotionSpec, SceneConfig, ScriptedPose, SynthError, Synthesizer};
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
                "{pose:?}: {j:?} d={d} z={}",
                p.z
            );
        }
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
