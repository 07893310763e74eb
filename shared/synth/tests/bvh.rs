//! BVH reading and retargeting, with tiny clips written here for each naming convention.
#![allow(clippy::needless_range_loop)]

use airglyph_synth::bvh::BvhClip;
use airglyph_synth::{Body, Bone, ProceduralBody};
use nalgebra::{UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::fmt::Write;
use std::path::Path;

/// A joint of a test skeleton: name, parent name, offset.
type J = (&'static str, Option<&'static str>, [f32; 3]);

/// A joint that drives no canonical bone.
#[derive(Clone, Copy)]
enum Extra {
    /// Inserted halfway between a bone's joint and its parent joint.
    Above(&'static str, Bone),
    /// A leaf under a joint, at an offset.
    Leaf(&'static str, &'static str, [f32; 3]),
}

/// How one conversion names and arranges a skeleton.
struct Rig {
    name: &'static str,
    bones: Vec<(Bone, &'static str)>,
    extra: Vec<Extra>,
    /// A ROOT above the hips (3ds Max's `Bip01`).
    root: Option<&'static str>,
    /// The collars hang from the neck's joint (3ds Max's Biped).
    collars_on_neck: bool,
    /// The thighs hang from the spine's joint (3ds Max's Biped).
    thighs_on_spine: bool,
}

impl Rig {
    fn plain(name: &'static str, bones: Vec<(Bone, &'static str)>) -> Self {
        Rig {
            name,
            bones,
            extra: Vec::new(),
            root: None,
            collars_on_neck: false,
            thighs_on_spine: false,
        }
    }

    fn n(&self) -> HashMap<Bone, &'static str> {
        self.bones.iter().copied().collect()
    }
}

/// Names side by side: the left ones given, the right ones made by `right`.
fn sided(
    spine: [&'static str; 5],
    left: [&'static str; 7],
    right: impl Fn(&'static str) -> String,
) -> Vec<(Bone, &'static str)> {
    use Bone::*;
    let mut v: Vec<(Bone, &'static str)> = [Hips, Spine, Chest, Neck, Head]
        .into_iter()
        .zip(spine)
        .collect();
    let limbs = [
        LeftCollar,
        LeftUpperArm,
        LeftForearm,
        LeftHand,
        LeftThigh,
        LeftShin,
        LeftFoot,
    ];
    for (b, n) in limbs.into_iter().zip(left) {
        v.push((b, n));
        v.push((b.mirror(), Box::leak(right(n).into_boxed_str())));
    }
    v
}

fn swap_prefix(from: &'static str, to: &'static str) -> impl Fn(&'static str) -> String {
    move |n| n.replacen(from, to, 1)
}

/// The conversions met in the wild: CMU's own three and ASF names, DAZ, Mixamo and
/// 3ds Max's Biped.
fn rigs() -> Vec<Rig> {
    use Bone::*;
    let mb = {
        let mut r = Rig::plain(
            "MotionBuilder (CMU, cgspeed)",
            sided(
                ["Hips", "LowerBack", "Spine1", "Neck", "Head"],
                [
                    "LeftShoulder",
                    "LeftArm",
                    "LeftForeArm",
                    "LeftHand",
                    "LeftUpLeg",
                    "LeftLeg",
                    "LeftFoot",
                ],
                swap_prefix("Left", "Right"),
            ),
        );
        r.extra = vec![
            Extra::Above("Spine", Chest),
            Extra::Above("Neck1", Head),
            Extra::Above("LHipJoint", LeftThigh),
            Extra::Above("RHipJoint", RightThigh),
            Extra::Leaf("LeftToeBase", "LeftFoot", [0.0, -3.0, 12.0]),
            Extra::Leaf("LThumb", "LeftHand", [2.0, 0.0, 2.0]),
            Extra::Leaf("LeftFingerBase", "LeftHand", [4.0, 0.0, 0.0]),
        ];
        r
    };
    let asf_style = Rig::plain(
        "CMU ASF-style",
        sided(
            ["Hips", "Chest", "Chest2", "Neck", "Head"],
            [
                "LeftCollar",
                "LeftShoulder",
                "LeftElbow",
                "LeftWrist",
                "LeftHip",
                "LeftKnee",
                "LeftAnkle",
            ],
            swap_prefix("Left", "Right"),
        ),
    );
    let ab = Rig::plain(
        "Ab-style",
        sided(
            ["Hips", "Ab", "Chest", "Neck", "Head"],
            [
                "LeftCollar",
                "LeftShoulder",
                "LeftElbow",
                "LeftWrist",
                "LeftHip",
                "LeftKnee",
                "LeftAnkle",
            ],
            swap_prefix("Left", "Right"),
        ),
    );
    let asf = {
        let mut r = Rig::plain(
            "ASF names (amc2bvh)",
            sided(
                ["root", "lowerback", "thorax", "lowerneck", "head"],
                [
                    "lclavicle",
                    "lhumerus",
                    "lradius",
                    "lwrist",
                    "lfemur",
                    "ltibia",
                    "lfoot",
                ],
                swap_prefix("l", "r"),
            ),
        );
        r.extra = vec![
            Extra::Above("upperback", Chest),
            Extra::Above("upperneck", Head),
            Extra::Above("lhipjoint", LeftThigh),
            Extra::Above("rhipjoint", RightThigh),
            Extra::Leaf("lhand", "lwrist", [6.0, 0.0, 0.0]),
            Extra::Leaf("lfingers", "lhand", [4.0, 0.0, 0.0]),
            Extra::Leaf("lthumb", "lhand", [2.0, 0.0, 2.0]),
            Extra::Leaf("rhand", "rwrist", [-6.0, 0.0, 0.0]),
            Extra::Leaf("ltoes", "lfoot", [0.0, -3.0, 12.0]),
        ];
        r
    };
    let daz = {
        let mut r = Rig::plain(
            "DAZ-style",
            sided(
                ["hip", "abdomen", "chest", "neck", "head"],
                [
                    "lCollar", "lShldr", "lForeArm", "lHand", "lThigh", "lShin", "lFoot",
                ],
                swap_prefix("l", "r"),
            ),
        );
        r.extra = vec![
            Extra::Above("lButtock", LeftThigh),
            Extra::Above("rButtock", RightThigh),
        ];
        r
    };
    let mixamo = {
        let mut r = Rig::plain(
            "Mixamo",
            sided(
                [
                    "mixamorig:Hips",
                    "mixamorig:Spine",
                    "mixamorig:Spine2",
                    "mixamorig:Neck",
                    "mixamorig:Head",
                ],
                [
                    "mixamorig:LeftShoulder",
                    "mixamorig:LeftArm",
                    "mixamorig:LeftForeArm",
                    "mixamorig:LeftHand",
                    "mixamorig:LeftUpLeg",
                    "mixamorig:LeftLeg",
                    "mixamorig:LeftFoot",
                ],
                swap_prefix("Left", "Right"),
            ),
        );
        r.extra = vec![
            Extra::Above("mixamorig:Spine1", Chest),
            Extra::Leaf(
                "mixamorig:LeftHandIndex1",
                "mixamorig:LeftHand",
                [4.0, 0.0, 0.0],
            ),
            Extra::Leaf("mixamorig:HeadTop_End", "mixamorig:Head", [0.0, 18.0, 0.0]),
        ];
        r
    };
    let biped = {
        let mut r = Rig::plain(
            "3ds Max Biped",
            sided(
                [
                    "Bip01 Pelvis",
                    "Bip01 Spine",
                    "Bip01 Spine1",
                    "Bip01 Neck",
                    "Bip01 Head",
                ],
                [
                    "Bip01 L Clavicle",
                    "Bip01 L UpperArm",
                    "Bip01 L Forearm",
                    "Bip01 L Hand",
                    "Bip01 L Thigh",
                    "Bip01 L Calf",
                    "Bip01 L Foot",
                ],
                swap_prefix(" L ", " R "),
            ),
        );
        r.root = Some("Bip01");
        r.collars_on_neck = true;
        r.thighs_on_spine = true;
        r
    };
    vec![mb, asf_style, ab, asf, daz, mixamo, biped]
}

fn rig(name: &str) -> Rig {
    rigs().into_iter().find(|r| r.name == name).unwrap()
}

/// A skeleton in centimetres. `a_pose` puts the arms 45° down and spreads the legs, so
/// the rest pose differs from the canonical T-pose.
fn skeleton(rig: &Rig, a_pose: bool) -> Vec<J> {
    let n = rig.n();
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
        (n[&Bone::Hips], rig.root, [0.0, 0.0, 0.0]),
        (n[&Bone::Spine], Some(n[&Bone::Hips]), [0.0, 10.0, 0.0]),
        (n[&Bone::Chest], Some(n[&Bone::Spine]), [0.0, 20.0, 0.0]),
        (n[&Bone::Neck], Some(n[&Bone::Chest]), [0.0, 25.0, 0.0]),
        (n[&Bone::Head], Some(n[&Bone::Neck]), [0.0, 10.0, 0.0]),
    ];
    if let Some(root) = rig.root {
        j.insert(0, (root, None, [0.0, 0.0, 0.0]));
    }
    for s in [1.0f32, -1.0] {
        let b = |l: Bone| if s > 0.0 { n[&l] } else { n[&l.mirror()] };
        let (collar_parent, collar_at) = if rig.collars_on_neck {
            (n[&Bone::Neck], [s * 3.0, -3.0, 0.0])
        } else {
            (n[&Bone::Chest], [s * 3.0, 22.0, 0.0])
        };
        j.push((b(Bone::LeftCollar), Some(collar_parent), collar_at));
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
        let (thigh_parent, thigh_at) = if rig.thighs_on_spine {
            (n[&Bone::Spine], [s * 9.0, -15.0, 0.0])
        } else {
            (n[&Bone::Hips], [s * 9.0, -5.0, 0.0])
        };
        j.push((b(Bone::LeftThigh), Some(thigh_parent), thigh_at));
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
    for e in &rig.extra {
        match *e {
            Extra::Above(name, bone) => {
                let k = j.iter().position(|x| x.0 == n[&bone]).unwrap();
                let (_, parent, off) = j[k];
                let half = off.map(|v| v / 2.0);
                j[k] = (n[&bone], Some(name), half);
                j.push((name, parent, half));
            }
            Extra::Leaf(name, parent, off) => j.push((name, Some(parent), off)),
        }
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

fn test_frames(rig: &Rig) -> Vec<HashMap<&'static str, [f32; 3]>> {
    let n = rig.n();
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
fn compare(rig: &Rig, a_pose: bool) {
    let c = rig.name;
    let joints = skeleton(rig, a_pose);
    let text = write_bvh(&joints, &test_frames(rig), [0.0, 95.0, 0.0], 1.0 / 30.0);
    let clip = BvhClip::parse(Path::new("test.bvh"), &text).unwrap();
    let n = rig.n();
    let idx = |name: &str| clip.joints.iter().position(|j| j.name == name).unwrap();
    // Every canonical bone is driven by the joint the conversion means.
    for (b, name) in &rig.bones {
        assert_eq!(
            clip.drives[b.index()].map(|i| clip.joints[i].name.as_str()),
            Some(*name),
            "{c}: {}",
            b.name()
        );
    }
    let body = body();
    let poses = clip.canonical_frames(body.tpose());
    let (_, rest) = clip.forward(None);
    for f in 0..clip.frame_count() {
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
            let _ = &c;
            let src_local = rot[parent].inverse() * rot[i];
            let dst_local = poses[1].local(b);
            let a = src_local.angle_to(&dst_local).to_degrees();
            assert!(a < 0.5, "{c:?}: {} local rotation off by {a}°", b.name());
        }
    }
}

#[test]
fn every_conversion_retargets_to_the_same_joint_angles() {
    for rig in rigs() {
        compare(&rig, false);
        compare(&rig, true);
    }
}

#[test]
fn clips_are_resampled_to_the_scene_rate() {
    let joints = skeleton(&rig("MotionBuilder (CMU, cgspeed)"), false);
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
    let joints = skeleton(&rig("Ab-style"), false);
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

/// The clip's bone direction for a joint and the retargeted one, in every frame.
fn directions(
    clip: &BvhClip,
    from: &str,
    to: &str,
    bone: Bone,
) -> Vec<(Vector3<f32>, Vector3<f32>)> {
    let idx = |name: &str| clip.joints.iter().position(|j| j.name == name).unwrap();
    let poses = clip.canonical_frames(body().tpose());
    (0..clip.frame_count())
        .map(|f| {
            let (_, pos) = clip.forward(Some(f));
            let src = (pos[idx(to)] - pos[idx(from)]).normalize();
            (src, (poses[f].get(bone) * bone.tpose_dir()).normalize())
        })
        .collect()
}

#[test]
fn an_unknown_joint_stays_in_the_chain_and_drives_nothing() {
    let rig = rig("MotionBuilder (CMU, cgspeed)");
    let mut joints = skeleton(&rig, false);
    joints.push(("Tail", Some("Hips"), [0.0, 0.0, -10.0]));
    // An unknown joint between the upper arm and the forearm, turned 60°: the forearm
    // it carries must still point where the clip's does.
    let k = joints.iter().position(|j| j.0 == "LeftForeArm").unwrap();
    joints[k].1 = Some("Gizmo");
    joints.push(("Gizmo", Some("LeftArm"), joints[k].2.map(|v| v / 2.0)));
    joints[k].2 = joints[k].2.map(|v| v / 2.0);
    let mut f = test_frames(&rig);
    for frame in &mut f {
        frame.insert("Gizmo", [0.0, 0.0, 60.0]);
    }
    let clip = BvhClip::parse(Path::new("t.bvh"), &write_bvh(&joints, &f, [0.0; 3], 0.01)).unwrap();
    for name in ["Tail", "Gizmo"] {
        let i = clip.joints.iter().position(|j| j.name == name).unwrap();
        assert!(!clip.drives.contains(&Some(i)), "{name} drives a bone");
    }
    for (src, dst) in directions(&clip, "LeftForeArm", "LeftHand", Bone::LeftForearm) {
        assert!(src.angle(&dst).to_degrees() < 0.5, "{src:?} vs {dst:?}");
    }
}

#[test]
fn names_with_spaces_and_braces_on_the_joint_line_are_read() {
    let text = write_bvh(
        &skeleton(&rig("3ds Max Biped"), false),
        &[HashMap::new()],
        [0.0; 3],
        0.01,
    );
    // `JOINT Bip01 Neck {` on one line.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let k = lines
        .iter()
        .position(|l| l.ends_with("JOINT Bip01 Neck"))
        .unwrap();
    lines[k].push_str(" {");
    lines.remove(k + 1);
    let fixed = lines.join("\n");
    let clip = BvhClip::parse(Path::new("t.bvh"), &fixed).unwrap();
    let neck = clip.drives[Bone::Neck.index()].unwrap();
    assert_eq!(clip.joints[neck].name, "Bip01 Neck");
}

#[test]
fn a_clip_without_legs_stands_on_the_bodys_legs() {
    let rig = rig("Ab-style");
    let mut joints = skeleton(&rig, false);
    joints.retain(|j| !["Hip", "Knee", "Ankle"].iter().any(|w| j.0.ends_with(w)));
    let frames = test_frames(&rig)
        .into_iter()
        .map(|mut f| {
            f.retain(|k, _| !["Hip", "Knee", "Ankle"].iter().any(|w| k.ends_with(w)));
            f
        })
        .collect::<Vec<_>>();
    let clip = BvhClip::parse(
        Path::new("t.bvh"),
        &write_bvh(&joints, &frames, [0.0, 95.0, 0.0], 0.01),
    )
    .unwrap();
    assert!(clip.drives[Bone::LeftThigh.index()].is_none());
    let body = body();
    let poses = clip.retarget(body.tpose(), 30.0);
    let want = body.tpose().head(Bone::Hips).y;
    assert!(
        (poses[0].root.y - want).abs() < 1e-3,
        "{} vs {want}",
        poses[0].root.y
    );
    // The legs hang as the hips do.
    for p in &poses {
        assert!(p.get(Bone::LeftShin).angle_to(&p.get(Bone::Hips)) < 1e-4);
    }
    // And the arms still follow the clip.
    for (src, dst) in directions(&clip, "LeftElbow", "LeftWrist", Bone::LeftForearm) {
        assert!(src.angle(&dst).to_degrees() < 0.5);
    }
}

#[test]
fn malformed_bvh_is_refused_with_file_and_line() {
    let good = write_bvh(
        &skeleton(&rig("Ab-style"), false),
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
    // What cannot be a body: no left forearm, an arm whose parts do not hang one
    // below the other.
    let mut j = skeleton(&rig("Ab-style"), false);
    j.retain(|x| !x.0.starts_with("LeftElbow") && !x.0.starts_with("LeftWrist"));
    let e = err(&write_bvh(&j, &[HashMap::new()], [0.0; 3], 0.01));
    assert!(e.starts_with("bad.bvh: no left arm"), "{e}");
    let mut j = skeleton(&rig("Ab-style"), false);
    for x in &mut j {
        if x.0 == "RightWrist" {
            x.1 = Some("Chest");
        }
    }
    let text = write_bvh(&j, &[HashMap::new()], [0.0; 3], 0.01);
    let line = text
        .lines()
        .position(|l| l.contains("JOINT RightWrist"))
        .unwrap()
        + 1;
    let e = err(&text);
    assert!(
        e.contains(&format!("bad.bvh:{line}:"))
            && e.contains("\"RightWrist\" (right arm) does not hang below \"RightElbow\""),
        "{e}"
    );
    // A header announcing far more frames than the file holds, or no channel at all.
    let lie = good.replacen("Frames: 2", "Frames: 10000000", 1);
    let e = err(&lie);
    assert!(
        e.contains("unexpected end of file") && e.contains("10000000 frames"),
        "{e}"
    );
    let no_channels = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 0\n}\nMOTION\nFrames: 10000000\nFrame Time: 0.01\n";
    assert!(
        err(no_channels).contains("no joint has a channel"),
        "{}",
        err(no_channels)
    );
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
        let want = if f == "Boxing_Toes.bvh" {
            rig("Ab-style")
        } else {
            rig("MotionBuilder (CMU, cgspeed)")
        };
        for (b, name) in &want.bones {
            let got = clip.drives[b.index()].map(|i| clip.joints[i].name.as_str());
            assert_eq!(got, Some(*name), "{f}: {}", b.name());
        }
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
        &skeleton(&rig("MotionBuilder (CMU, cgspeed)"), true),
        &test_frames(&rig("MotionBuilder (CMU, cgspeed)")),
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
