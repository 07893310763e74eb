//! BVH reading and retargeting, with tiny clips written here for each naming convention.
#![allow(clippy::needless_range_loop)]

use airglyph_synth::bvh::{BvhClip, Convention};
use airglyph_synth::{Body, Bone, ProceduralBody};
use nalgebra::{UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::fmt::Write;
use std::path::Path;

/// A joint of a test skeleton: name, parent name, offset.
type J = (&'static str, Option<&'static str>, [f32; 3]);

/// The canonical bones and the BVH joint names that drive them, per convention.
fn names(c: Convention) -> Vec<(Bone, &'static str)> {
    use Bone::*;
    match c {
        Convention::MotionBuilder => vec![
            (Hips, "Hips"),
            (Spine, "LowerBack"),
            (Chest, "Spine1"),
            (Neck, "Neck"),
            (Head, "Head"),
            (LeftCollar, "LeftShoulder"),
            (LeftUpperArm, "LeftArm"),
            (LeftForearm, "LeftForeArm"),
            (LeftHand, "LeftHand"),
            (RightCollar, "RightShoulder"),
            (RightUpperArm, "RightArm"),
            (RightForearm, "RightForeArm"),
            (RightHand, "RightHand"),
            (LeftThigh, "LeftUpLeg"),
            (LeftShin, "LeftLeg"),
            (LeftFoot, "LeftFoot"),
            (RightThigh, "RightUpLeg"),
            (RightShin, "RightLeg"),
            (RightFoot, "RightFoot"),
        ],
        Convention::CmuAsf => vec![
            (Hips, "Hips"),
            (Spine, "Chest"),
            (Chest, "Chest2"),
            (Neck, "Neck"),
            (Head, "Head"),
            (LeftCollar, "LeftCollar"),
            (LeftUpperArm, "LeftShoulder"),
            (LeftForearm, "LeftElbow"),
            (LeftHand, "LeftWrist"),
            (RightCollar, "RightCollar"),
            (RightUpperArm, "RightShoulder"),
            (RightForearm, "RightElbow"),
            (RightHand, "RightWrist"),
            (LeftThigh, "LeftHip"),
            (LeftShin, "LeftKnee"),
            (LeftFoot, "LeftAnkle"),
            (RightThigh, "RightHip"),
            (RightShin, "RightKnee"),
            (RightFoot, "RightAnkle"),
        ],
        Convention::Ab => vec![
            (Hips, "Hips"),
            (Spine, "Ab"),
            (Chest, "Chest"),
            (Neck, "Neck"),
            (Head, "Head"),
            (LeftCollar, "LeftCollar"),
            (LeftUpperArm, "LeftShoulder"),
            (LeftForearm, "LeftElbow"),
            (LeftHand, "LeftWrist"),
            (RightCollar, "RightCollar"),
            (RightUpperArm, "RightShoulder"),
            (RightForearm, "RightElbow"),
            (RightHand, "RightWrist"),
            (LeftThigh, "LeftHip"),
            (LeftShin, "LeftKnee"),
            (LeftFoot, "LeftAnkle"),
            (RightThigh, "RightHip"),
            (RightShin, "RightKnee"),
            (RightFoot, "RightAnkle"),
        ],
    }
}

/// A skeleton in centimetres. `a_pose` puts the arms 45° down and spreads the legs, so
/// the rest pose differs from the canonical T-pose.
fn skeleton(c: Convention, a_pose: bool) -> Vec<J> {
    let n: HashMap<Bone, &'static str> = names(c).into_iter().collect();
    let (ax, ay) = if a_pose {
        (
            std::f32::consts::FRAC_1_SQRT_2,
            -std::f32::consts::FRAC_1_SQRT_2,
        )
    } else {
        (1.0, 0.0)
    };
    let leg = if a_pose { 0.17 } else { 0.0 };
    let mut j: Vec<J> = vec![
        (n[&Bone::Hips], None, [0.0, 0.0, 0.0]),
        (n[&Bone::Spine], Some(n[&Bone::Hips]), [0.0, 10.0, 0.0]),
        (n[&Bone::Chest], Some(n[&Bone::Spine]), [0.0, 20.0, 0.0]),
        (n[&Bone::Neck], Some(n[&Bone::Chest]), [0.0, 25.0, 0.0]),
        (n[&Bone::Head], Some(n[&Bone::Neck]), [0.0, 10.0, 0.0]),
    ];
    for s in [1.0f32, -1.0] {
        let b = |l: Bone| if s > 0.0 { n[&l] } else { n[&l.mirror()] };
        j.push((
            b(Bone::LeftCollar),
            Some(n[&Bone::Chest]),
            [s * 3.0, 22.0, 0.0],
        ));
        j.push((
            b(Bone::LeftUpperArm),
            Some(b(Bone::LeftCollar)),
            [s * 15.0, 0.0, 0.0],
        ));
        j.push((
            b(Bone::LeftForearm),
            Some(b(Bone::LeftUpperArm)),
            [s * 28.0 * ax, 28.0 * ay, 0.0],
        ));
        j.push((
            b(Bone::LeftHand),
            Some(b(Bone::LeftForearm)),
            [s * 25.0 * ax, 25.0 * ay, 0.0],
        ));
        j.push((
            b(Bone::LeftThigh),
            Some(n[&Bone::Hips]),
            [s * 9.0, -5.0, 0.0],
        ));
        j.push((
            b(Bone::LeftShin),
            Some(b(Bone::LeftThigh)),
            [s * 42.0 * leg, -42.0, 0.0],
        ));
        j.push((
            b(Bone::LeftFoot),
            Some(b(Bone::LeftShin)),
            [s * 42.0 * leg, -42.0, 0.0],
        ));
    }
    if c == Convention::MotionBuilder {
        // Helper joints MotionBuilder conversions carry: read and ignored.
        j.push(("LeftToeBase", Some("LeftFoot"), [0.0, -3.0, 12.0]));
        j.push(("LThumb", Some("LeftHand"), [2.0, 0.0, 2.0]));
    }
    j
}

/// Writes a BVH with the given per-joint Z/X/Y rotations (degrees) for each frame.
fn write_bvh(
    joints: &[J],
    frames: &[HashMap<&'static str, [f32; 3]>],
    root_pos: [f32; 3],
    frame_time: f32,
) -> String {
    let mut s = String::from("HIERARCHY\n");
    fn emit(s: &mut String, joints: &[J], i: usize, depth: usize) {
        let (name, parent, off) = joints[i];
        let pad = "  ".repeat(depth);
        let kw = if parent.is_none() { "ROOT" } else { "JOINT" };
        writeln!(s, "{pad}{kw} {name}\n{pad}{{").unwrap();
        writeln!(s, "{pad}  OFFSET {} {} {}", off[0], off[1], off[2]).unwrap();
        if parent.is_none() {
            writeln!(
                s,
                "{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
            )
            .unwrap();
        } else {
            writeln!(s, "{pad}  CHANNELS 3 Zrotation Xrotation Yrotation").unwrap();
        }
        let kids: Vec<usize> = (0..joints.len())
            .filter(|&k| joints[k].1 == Some(name))
            .collect();
        if kids.is_empty() {
            // The end site continues the bone's own direction.
            let n = (off[0] * off[0] + off[1] * off[1] + off[2] * off[2])
                .sqrt()
                .max(1e-6);
            let e = [off[0] / n * 5.0, off[1] / n * 5.0, off[2] / n * 5.0];
            writeln!(
                s,
                "{pad}  End Site\n{pad}  {{\n{pad}    OFFSET {} {} {}\n{pad}  }}",
                e[0], e[1], e[2]
            )
            .unwrap();
        }
        for k in kids {
            emit(s, joints, k, depth + 1);
        }
        writeln!(s, "{pad}}}").unwrap();
    }
    emit(&mut s, joints, 0, 0);
    writeln!(
        s,
        "MOTION\nFrames: {}\nFrame Time: {frame_time}",
        frames.len()
    )
    .unwrap();
    // Channel order follows the depth-first order of emit().
    let mut order = Vec::new();
    fn walk(joints: &[J], i: usize, out: &mut Vec<usize>) {
        out.push(i);
        let name = joints[i].0;
        for k in 0..joints.len() {
            if joints[k].1 == Some(name) {
                walk(joints, k, out);
            }
        }
    }
    walk(joints, 0, &mut order);
    for f in frames {
        let mut row = Vec::new();
        for &i in &order {
            if joints[i].1.is_none() {
                row.extend(root_pos.iter().map(|v| v.to_string()));
            }
            let r = f.get(joints[i].0).copied().unwrap_or([0.0; 3]);
            row.extend(r.iter().map(|v| v.to_string()));
        }
        writeln!(s, "{}", row.join(" ")).unwrap();
    }
    s
}

fn body() -> Body {
    Body::procedural(&ProceduralBody::default()).unwrap()
}

fn test_frames(c: Convention) -> Vec<HashMap<&'static str, [f32; 3]>> {
    let n: HashMap<Bone, &'static str> = names(c).into_iter().collect();
    let mut f1 = HashMap::new();
    f1.insert(n[&Bone::LeftUpperArm], [-40.0, 25.0, 10.0]);
    f1.insert(n[&Bone::LeftForearm], [0.0, 0.0, 70.0]);
    f1.insert(n[&Bone::RightUpperArm], [30.0, -20.0, -35.0]);
    f1.insert(n[&Bone::RightForearm], [0.0, 10.0, -95.0]);
    f1.insert(n[&Bone::RightHand], [15.0, 20.0, 0.0]);
    f1.insert(n[&Bone::LeftThigh], [5.0, -35.0, 0.0]);
    f1.insert(n[&Bone::LeftShin], [0.0, 60.0, 0.0]);
    f1.insert(n[&Bone::Chest], [10.0, 15.0, -20.0]);
    f1.insert(n[&Bone::Head], [0.0, 20.0, 30.0]);
    let mut f2 = f1.clone();
    f2.insert(n[&Bone::LeftForearm], [0.0, 0.0, 100.0]);
    vec![HashMap::new(), f1, f2]
}

/// Posed direction of every driven bone in the clip (its world rotation applied to its
/// rest direction) and on the retargeted canonical skeleton, for frame `f`.
fn compare(c: Convention, a_pose: bool) {
    let joints = skeleton(c, a_pose);
    let text = write_bvh(&joints, &test_frames(c), [0.0, 95.0, 0.0], 1.0 / 30.0);
    let clip = BvhClip::parse(Path::new("test.bvh"), &text).unwrap();
    assert_eq!(clip.convention, c);
    let body = body();
    let poses = clip.canonical_frames(body.tpose());
    let n: HashMap<Bone, &'static str> = names(c).into_iter().collect();
    let idx = |name: &str| clip.joints.iter().position(|j| j.name == name).unwrap();
    let (_, rest) = clip.forward(None);
    for f in 0..clip.frames.len() {
        let (rot, pos) = clip.forward(Some(f));
        let dir_src = |b: Bone| {
            let child = b.child().unwrap();
            let (i, k) = (idx(n[&b]), idx(n[&child]));
            let _ = &rest;
            (pos[k] - pos[i]).normalize()
        };
        let dir_dst = |b: Bone| (poses[f].get(b) * b.tpose_dir()).normalize();
        // Every bone points where the clip's bone points (the clip faces +z already).
        for b in Bone::ALL {
            if b.child().is_none() || b == Bone::Hips {
                continue;
            }
            let a = dir_src(b).angle(&dir_dst(b)).to_degrees();
            assert!(
                a < 0.5,
                "{c:?} a_pose={a_pose} frame {f}: {} off by {a}°",
                b.name()
            );
        }
        // Joint angles (between consecutive bones) are those of the clip.
        for (p, ch) in [
            (Bone::LeftUpperArm, Bone::LeftForearm),
            (Bone::RightUpperArm, Bone::RightForearm),
            (Bone::LeftThigh, Bone::LeftShin),
            (Bone::Spine, Bone::Chest),
        ] {
            let src = dir_src(p).angle(&dir_src(ch)).to_degrees();
            let dst = dir_dst(p).angle(&dir_dst(ch)).to_degrees();
            assert!(
                (src - dst).abs() < 0.5,
                "{c:?} frame {f}: {}–{} {src}° vs {dst}°",
                p.name(),
                ch.name()
            );
        }
        let _ = &rot;
    }
    // With a T-pose rest, twist carries over too: local rotations are the clip's.
    if !a_pose {
        let (rot, _) = clip.forward(Some(1));
        for b in [
            Bone::LeftForearm,
            Bone::RightHand,
            Bone::LeftShin,
            Bone::Head,
        ] {
            let i = idx(n[&b]);
            let parent = clip.joints[i].parent.unwrap();
            let src_local = rot[parent].inverse() * rot[i];
            let dst_local = poses[1].local(b);
            let a = src_local.angle_to(&dst_local).to_degrees();
            assert!(a < 0.5, "{c:?}: {} local rotation off by {a}°", b.name());
        }
    }
}

#[test]
fn motionbuilder_names_retarget_to_the_same_joint_angles() {
    compare(Convention::MotionBuilder, false);
    compare(Convention::MotionBuilder, true);
}

#[test]
fn cmu_asf_names_retarget_to_the_same_joint_angles() {
    compare(Convention::CmuAsf, false);
    compare(Convention::CmuAsf, true);
}

#[test]
fn ab_names_retarget_to_the_same_joint_angles() {
    compare(Convention::Ab, false);
    compare(Convention::Ab, true);
}

#[test]
fn clips_are_resampled_to_the_scene_rate() {
    let c = Convention::MotionBuilder;
    let joints = skeleton(c, false);
    // 1 s at 120 Hz, the left elbow bending linearly from 0° to 120°.
    let frames: Vec<_> = (0..121)
        .map(|i| {
            let mut m = HashMap::new();
            m.insert("LeftForeArm", [0.0, 0.0, i as f32]);
            m
        })
        .collect();
    let text = write_bvh(&joints, &frames, [0.0, 95.0, 0.0], 1.0 / 120.0);
    let clip = BvhClip::parse(Path::new("t.bvh"), &text).unwrap();
    let body = body();
    let poses = clip.retarget(body.tpose(), 30.0);
    assert_eq!(poses.len(), 31);
    for (i, p) in poses.iter().enumerate() {
        let angle = p.local(Bone::LeftForearm).angle().to_degrees();
        assert!((angle - 4.0 * i as f32).abs() < 0.1, "frame {i}: {angle}");
    }
    // Standing: the hips at the body's hip height.
    let y = poses[0].root.y;
    let want = body.tpose().head(Bone::Hips).y;
    assert!((y - want).abs() < 0.03, "{y} vs {want}");
}

#[test]
fn the_first_frame_is_turned_to_face_the_camera() {
    let c = Convention::Ab;
    let joints = skeleton(c, false);
    let mut f = HashMap::new();
    f.insert("Hips", [0.0, 0.0, 120.0]); // Z X Y: yaw 120°
    let text = write_bvh(&joints, &[f], [0.0, 95.0, 0.0], 0.01);
    let clip = BvhClip::parse(Path::new("t.bvh"), &text).unwrap();
    let p = clip.retarget(body().tpose(), 30.0);
    let fwd = p[0].get(Bone::Hips) * Vector3::z();
    assert!(fwd.angle(&Vector3::z()) < 1e-3, "{fwd:?}");
    let _ = UnitQuaternion::<f32>::identity();
}

fn err(text: &str) -> String {
    BvhClip::parse(Path::new("bad.bvh"), text)
        .unwrap_err()
        .to_string()
}

#[test]
fn an_unknown_joint_is_named_with_its_line() {
    let mut joints = skeleton(Convention::MotionBuilder, false);
    joints.push(("Tail", Some("Hips"), [0.0, 0.0, -10.0]));
    let text = write_bvh(&joints, &[HashMap::new()], [0.0; 3], 0.01);
    let line = text.lines().position(|l| l.contains("JOINT Tail")).unwrap() + 1;
    let e = err(&text);
    assert!(e.contains("unknown joint \"Tail\""), "{e}");
    assert!(e.contains(&format!("bad.bvh:{line}:")), "{e}");
}

#[test]
fn malformed_bvh_is_refused_with_file_and_line() {
    let good = write_bvh(
        &skeleton(Convention::Ab, false),
        &[HashMap::new(), HashMap::new()],
        [0.0; 3],
        0.01,
    );
    // A bad number in the hierarchy.
    let bad = good.replacen("OFFSET 0 10 0", "OFFSET 0 ten 0", 1);
    let line = bad.lines().position(|l| l.contains("ten")).unwrap() + 1;
    let e = err(&bad);
    assert!(
        e.contains(&format!("bad.bvh:{line}:")) && e.contains("\"ten\""),
        "{e}"
    );
    // A frame short of values.
    let mut lines: Vec<&str> = good.lines().collect();
    let last = lines.pop().unwrap();
    let short = last.rsplit_once(' ').unwrap().0.to_string();
    let text = format!("{}\n{}\n", lines.join("\n"), short);
    let e = err(&text);
    assert!(
        e.contains("unexpected end of file") && e.contains("frame 2"),
        "{e}"
    );
    // Not a BVH at all.
    assert!(err("hello").contains("expected \"HIERARCHY\""));
    assert!(err("").contains("bad.bvh:1:"));
    // A missing limb.
    let mut j = skeleton(Convention::Ab, false);
    j.retain(|x| !x.0.starts_with("LeftElbow") && !x.0.starts_with("LeftWrist"));
    let e = err(&write_bvh(&j, &[HashMap::new()], [0.0; 3], 0.01));
    assert!(e.contains("no joint drives the left_forearm"), "{e}");
    // A missing file.
    let e = BvhClip::load(Path::new("/nonexistent/x.bvh"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/x.bvh"), "{e}");
}

#[test]
fn the_cmu_clips_load_when_installed() {
    for f in ["01_01.bvh", "01_03.bvh", "Boxing_Toes.bvh"] {
        let p = Path::new("/usr/share/assimp/models/BVH").join(f);
        if !p.exists() {
            println!(
                "skipping {}: apt-get install assimp-testmodels",
                p.display()
            );
            continue;
        }
        let clip = BvhClip::load(&p).unwrap();
        let poses = clip.retarget(body().tpose(), 30.0);
        assert!(poses.len() > 30, "{f}");
        // Standing at the start (the boxer is knocked down later on).
        let y = poses[0].root.y;
        assert!(y > 0.7 && y < 1.2, "{f}: hips at {y}");
        assert!(poses.iter().all(|p| p.root.y > 0.0 && p.root.y < 2.5));
    }
}

#[test]
fn truncated_or_garbled_bvh_never_panics() {
    let good = write_bvh(
        &skeleton(Convention::MotionBuilder, true),
        &test_frames(Convention::MotionBuilder),
        [0.0, 95.0, 0.0],
        0.01,
    );
    for end in (0..good.len()).step_by(3) {
        let _ = BvhClip::parse(Path::new("t.bvh"), &good[..end]);
    }
    for (i, bad) in ["nan", "-1e39", "{", "}", "JOINT", "End", "9999999999"]
        .iter()
        .enumerate()
    {
        let mut words: Vec<&str> = good.split(' ').collect();
        for k in (i..words.len()).step_by(17) {
            words[k] = bad;
        }
        let text = words.join(" ");
        if let Ok(clip) = BvhClip::parse(Path::new("t.bvh"), &text) {
            let _ = clip.retarget(body().tpose(), 30.0);
        }
    }
}
