//! Measures the body template's [`Shape`] on a synthetic body: every segment's frame is
//! read off the rig bone that drives it, so the surface points the camera sees (labelled
//! by body part) and the ground-truth joints can be put in the segment frames exactly;
//! each capsule is then fitted to its segment's points by least squares (its vertical
//! extent kept) and each joint placed at its mean. Prints the shape as JSON, which
//! `Shape::makehuman` in `src/body.rs` holds.
//!
//! The frames are not the evaluation's: the scripted poses from four sides and a boxing
//! clip (Debian assimp-testmodels' `Boxing_Toes.bvh`), never CMU 01_01 or 01_03.
//!
//! `cargo run --release -p airglyph-pose --example fit_template -- [procedural]`

use airglyph_core::{Joint, Skeleton};
use airglyph_pose::body::{shortest_turn, Limbs, Segment, Shape};
use airglyph_pose::PoseConfig;
use airglyph_synth::{Affine, Bone, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};
use nalgebra::{Matrix3, Point3, Rotation3, SMatrix, SVector, Vector3};

/// The rig bone (by its canonical name) that moves each segment, and the joints that
/// give the segment's origin.
fn driver(s: Segment) -> Bone {
    use Segment::*;
    match s {
        Pelvis => Bone::Hips,
        Abdomen => Bone::Spine,
        Chest => Bone::Chest,
        Head => Bone::Neck,
        LeftCollar => Bone::LeftCollar,
        RightCollar => Bone::RightCollar,
        LeftUpperArm => Bone::LeftUpperArm,
        LeftForearm => Bone::LeftForearm,
        RightUpperArm => Bone::RightUpperArm,
        RightForearm => Bone::RightForearm,
        LeftThigh => Bone::LeftThigh,
        LeftShin => Bone::LeftShin,
        RightThigh => Bone::RightThigh,
        RightShin => Bone::RightShin,
    }
}

/// The segment whose surface a body part is.
fn segment_of_bone(b: Bone) -> Segment {
    use Segment::*;
    match b {
        Bone::Hips => Pelvis,
        Bone::Spine => Abdomen,
        Bone::Chest | Bone::LeftCollar | Bone::RightCollar => Chest,
        Bone::Neck | Bone::Head => Head,
        Bone::LeftUpperArm => LeftUpperArm,
        Bone::LeftForearm | Bone::LeftHand => LeftForearm,
        Bone::RightUpperArm => RightUpperArm,
        Bone::RightForearm | Bone::RightHand => RightForearm,
        Bone::LeftThigh => LeftThigh,
        Bone::LeftShin | Bone::LeftFoot => LeftShin,
        Bone::RightThigh => RightThigh,
        Bone::RightShin | Bone::RightFoot => RightShin,
    }
}

fn is_right(s: Segment) -> bool {
    use Segment::*;
    matches!(
        s,
        RightCollar | RightUpperArm | RightForearm | RightThigh | RightShin
    )
}

/// Per frame, each segment's origin and rotation (segment frame → camera frame).
type Frames = [(Point3<f32>, Rotation3<f32>); Segment::COUNT];

struct Rig {
    /// Rig bone index of each segment.
    bone: [usize; Segment::COUNT],
    /// Each segment's rest frame (template rest → rig rest), body frame.
    rest: [Rotation3<f32>; Segment::COUNT],
    /// Rest positions of each segment's origin (body frame).
    rest_origin: [Point3<f32>; Segment::COUNT],
}

impl Rig {
    fn new(synth: &Synthesizer) -> Self {
        let body = synth.body();
        let find = |b: Bone| {
            body.bones()
                .iter()
                .position(|r| r.canon == Some(b))
                .expect("a rig bone for every canonical bone")
        };
        let bone = Segment::ALL.map(|s| find(driver(s)));
        let identity: Vec<Affine> = body
            .bones()
            .iter()
            .map(|_| Affine {
                m: Matrix3::identity(),
                t: Vector3::zeros(),
            })
            .collect();
        let j = body.joints_from(&identity);
        let x = (j[Joint::LeftHip.index()] - j[Joint::RightHip.index()]).normalize();
        let up = j[Joint::Neck.index()] - j[Joint::Pelvis.index()];
        let y = (up - x * x.dot(&up)).normalize();
        let pelvis = Rotation3::from_basis_unchecked(&[x, y, x.cross(&y)]);
        use Segment::*;
        let head = |s: Segment| body.bones()[bone[s.index()]].head;
        let mut rest = [pelvis; Segment::COUNT];
        let mut rest_origin = [Point3::origin(); Segment::COUNT];
        rest_origin[Pelvis.index()] = j[Joint::Pelvis.index()];
        rest_origin[Abdomen.index()] = head(Abdomen);
        rest_origin[Chest.index()] = head(Chest);
        rest_origin[Head.index()] = j[Joint::Neck.index()];
        rest_origin[LeftCollar.index()] = head(LeftCollar);
        rest_origin[RightCollar.index()] = head(RightCollar);
        for (s, a, b) in [
            (LeftUpperArm, Joint::LeftShoulder, Joint::LeftElbow),
            (LeftForearm, Joint::LeftElbow, Joint::LeftHand),
            (RightUpperArm, Joint::RightShoulder, Joint::RightElbow),
            (RightForearm, Joint::RightElbow, Joint::RightHand),
            (LeftThigh, Joint::LeftHip, Joint::LeftKnee),
            (LeftShin, Joint::LeftKnee, Joint::LeftFoot),
            (RightThigh, Joint::RightHip, Joint::RightKnee),
            (RightShin, Joint::RightKnee, Joint::RightFoot),
        ] {
            let d = j[b.index()] - j[a.index()];
            rest[s.index()] = shortest_turn(&(pelvis * -Vector3::y()), &d) * pelvis;
            rest_origin[s.index()] = j[a.index()];
        }
        Self {
            bone,
            rest,
            rest_origin,
        }
    }

    /// Segment frames of a posed rig (bone transforms already in the camera frame).
    fn frames(&self, xf: &[Affine]) -> Frames {
        Segment::ALL.map(|s| {
            let a = &xf[self.bone[s.index()]];
            let r = Rotation3::from_matrix_unchecked(a.m);
            (
                a.apply(&self.rest_origin[s.index()]),
                r * self.rest[s.index()],
            )
        })
    }
}

struct Sample {
    /// Surface points with the segment they belong to.
    points: Vec<(Segment, Point3<f32>)>,
    frames: Frames,
    truth: Skeleton,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let procedural = args.iter().any(|a| a == "procedural");
    let mut base = SceneConfig::default();
    if !procedural {
        base.body = airglyph_synth::BodySpec::MakeHuman {
            assets: None,
            shape: Default::default(),
        };
    }
    let mut scenes = Vec::new();
    for pose in ScriptedPose::ALL {
        for yaw in [0.0f32, 35.0, -35.0, 180.0] {
            let mut c = base.clone();
            c.motion = MotionSpec::Pose(pose);
            c.placement.yaw_deg = yaw;
            scenes.push((c, vec![0usize]));
        }
    }
    let boxing = std::path::Path::new("/usr/share/assimp/models/BVH/Boxing_Toes.bvh");
    if boxing.exists() {
        for yaw in [0.0f32, 40.0] {
            let mut c = base.clone();
            c.motion = MotionSpec::Bvh(boxing.into());
            c.placement.follow = true;
            c.placement.yaw_deg = yaw;
            let n = Synthesizer::new(c.clone())
                .expect("scene")
                .len()
                .unwrap_or(0);
            scenes.push((c, (0..n).step_by(20).collect()));
        }
    }
    let mut samples = Vec::new();
    let mut xf = Vec::new();
    for (c, frames) in scenes {
        let mut synth = Synthesizer::new(c).expect("scene");
        let rig = Rig::new(&synth);
        let k = synth.intrinsics();
        for i in frames {
            let (img, truth) = synth.render(i);
            let pose = synth.pose(i);
            synth.body().bone_transforms(&pose, &mut xf);
            let cam = synth.camera_from_body();
            for a in &mut xf {
                *a = a.then(&cam);
            }
            let labels = synth.labels();
            let mut points = Vec::new();
            // Every second pixel: the estimator's work resolution.
            for v in (0..k.height).step_by(2) {
                for u in (0..k.width).step_by(2) {
                    let i = (v * k.width + u) as usize;
                    let d = img.get(u, v);
                    let Some(&bone) = Bone::ALL.get(labels[i] as usize) else {
                        continue;
                    };
                    if d == 0 {
                        continue;
                    }
                    let p = k.back_project(u as f32, v as f32, d as f32 * 1e-3);
                    points.push((segment_of_bone(bone), p));
                }
            }
            samples.push(Sample {
                points,
                frames: rig.frames(&xf),
                truth: truth.skeleton,
            });
        }
    }
    eprintln!("{} frames", samples.len());

    let limbs = Limbs::from_config(&PoseConfig::default().body);
    let mut shape = Shape::makehuman();
    // Joints: the truth in its segment's frame (left side), shape units.
    let joint_in = |s: &Sample, seg: Segment, j: Joint| -> Vector3<f64> {
        let (o, r) = s.frames[seg.index()];
        let mut q = r.inverse() * (s.truth[j] - o);
        if is_right(seg) {
            q.x = -q.x;
        }
        q.y /= limbs.unit(seg);
        q.cast()
    };
    let origin_in = |s: &Sample, seg: Segment, child: Segment| -> [f32; 3] {
        let (o, r) = s.frames[seg.index()];
        let q = r.inverse() * (s.frames[child.index()].0 - o);
        [q.x, q.y, q.z]
    };
    let mean = |f: &dyn Fn(&Sample) -> Vector3<f64>| -> [f32; 3] {
        let m = samples.iter().map(f).sum::<Vector3<f64>>() / samples.len() as f64;
        [m.x as f32, m.y as f32, m.z as f32]
    };
    let centre = |mut p: [f32; 3]| {
        p[0] = 0.0;
        p
    };
    use Segment::*;
    let s0 = &samples[0];
    shape.abdomen = centre(origin_in(s0, Pelvis, Abdomen));
    shape.chest = centre(origin_in(s0, Abdomen, Chest));
    shape.neck = centre(mean(&|s| joint_in(s, Chest, Joint::Neck)));
    shape.torso = centre(mean(&|s| joint_in(s, Chest, Joint::Torso)));
    // The truth's head is the top of the head; the skull's centre (`shape.head`, where
    // the seed's head chain ends) is not among the truth's joints and stays as measured
    // before the head joint moved to the top (pose NOTES, 2026-12-06, evening).
    shape.crown = centre(mean(&|s| joint_in(s, Head, Joint::Head)));
    let pair = |seg: Segment, l: Joint, r: Joint| {
        let a = mean(&|s| joint_in(s, seg, l));
        let b = mean(&|s| {
            let (o, rr) = s.frames[seg.index()];
            let mut q = rr.inverse() * (s.truth[r] - o);
            q.x = -q.x;
            q.y /= limbs.unit(seg);
            q.cast()
        });
        [
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ]
    };
    shape.hip = pair(Pelvis, Joint::LeftHip, Joint::RightHip);
    let lr = |l: Segment, r: Segment, jl: Joint, jr: Joint| {
        let a = mean(&|s| joint_in(s, l, jl));
        let b = mean(&|s| joint_in(s, r, jr));
        [
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ]
    };
    // The collarbones' rest is the chest's own turn (the prior holds them near it), so
    // their joint and the shoulder are measured in the chest's frame: the shoulder where
    // the standing body has it on average.
    shape.collar = {
        let l = origin_in(s0, Chest, LeftCollar);
        let r = origin_in(s0, Chest, RightCollar);
        [
            0.5 * (l[0] - r[0]),
            0.5 * (l[1] + r[1]),
            0.5 * (l[2] + r[2]),
        ]
    };
    let sh = pair(Chest, Joint::LeftShoulder, Joint::RightShoulder);
    shape.shoulder = [
        sh[0] - shape.collar[0],
        sh[1] - shape.collar[1],
        sh[2] - shape.collar[2],
    ];
    shape.elbow = lr(
        LeftUpperArm,
        RightUpperArm,
        Joint::LeftElbow,
        Joint::RightElbow,
    );
    shape.hand = lr(LeftForearm, RightForearm, Joint::LeftHand, Joint::RightHand);
    shape.knee = lr(LeftThigh, RightThigh, Joint::LeftKnee, Joint::RightKnee);
    shape.ankle = lr(LeftShin, RightShin, Joint::LeftFoot, Joint::RightFoot);
    for (name, j, seg) in [
        ("neck", Joint::Neck, Chest),
        ("crown", Joint::Head, Head),
        ("shoulder", Joint::LeftShoulder, Chest),
        ("hand", Joint::LeftHand, LeftForearm),
        ("ankle", Joint::LeftFoot, LeftShin),
    ] {
        let m = mean(&|s| joint_in(s, seg, j));
        let m = Vector3::new(m[0] as f64, m[1] as f64, m[2] as f64);
        let sd = (samples
            .iter()
            .map(|s| (joint_in(s, seg, j) - m).norm_squared())
            .sum::<f64>()
            / samples.len() as f64)
            .sqrt();
        eprintln!("{name}: spread {:.1} cm in its segment", sd * 100.0);
    }

    // Capsules: each segment's points in its frame (left side), nearest capsule of the
    // segment, Gauss–Newton on the ends' x and z and the radii.
    let mut local: Vec<(Segment, Vector3<f32>)> = Vec::new();
    for s in &samples {
        for &(seg, p) in &s.points {
            let (o, r) = s.frames[seg.index()];
            let mut q = r.inverse() * (p - o);
            if is_right(seg) {
                q.x = -q.x;
            }
            local.push((seg, q));
        }
    }
    for round in 0..12 {
        let ns = shape.capsules.len();
        let mut hs = vec![SMatrix::<f64, 8, 8>::zeros(); ns];
        let mut gs = vec![SVector::<f64, 8>::zeros(); ns];
        let mut rs = vec![(0.0f64, 0usize); ns];
        for (seg, q) in &local {
            // The midline segments' capsules are mirrored: a point is fitted to the
            // side's capsule it is on.
            let left = if is_right(*seg) { seg.mirrored() } else { *seg };
            let mut best: Option<(usize, f32, f32, Vector3<f32>)> = None;
            for (ci, c) in shape.capsules.iter().enumerate() {
                if c.segment != left {
                    continue;
                }
                let mut qq = *q;
                let off_midline = c.a[0] != 0.0 || c.b[0] != 0.0;
                if off_midline && qq.x < 0.0 {
                    qq.x = -qq.x;
                }
                let unit = limbs.unit(c.segment);
                let a = Vector3::new(c.a[0], c.a[1] * unit, c.a[2]);
                let b = Vector3::new(c.b[0], c.b[1] * unit, c.b[2]);
                let ab = b - a;
                let t = ((qq - a).dot(&ab) / ab.norm_squared().max(1e-12)).clamp(0.0, 1.0);
                let d = (qq - (a + ab * t)).norm() - (c.ra + (c.rb - c.ra) * t);
                if best.is_none_or(|x| d < x.1) {
                    best = Some((ci, d, t, qq - (a + ab * t)));
                }
            }
            let Some((ci, d, t, off)) = best else {
                continue;
            };
            let len = off.norm();
            if len < 1e-6 || d.abs() > 0.1 {
                continue;
            }
            let n = off / len;
            let w = 1.0 / (1.0 + (d / 0.02).powi(2));
            let mut jrow = SVector::<f64, 8>::zeros();
            for i in 0..3 {
                jrow[i] = (-n[i] * (1.0 - t)) as f64;
                jrow[4 + i] = (-n[i] * t) as f64;
            }
            jrow[3] = -(1.0 - t) as f64;
            jrow[7] = -t as f64;
            hs[ci] += jrow * jrow.transpose() * w as f64;
            gs[ci] += jrow * (w * d) as f64;
            rs[ci].0 += (d * d) as f64;
            rs[ci].1 += 1;
        }
        eprintln!(
            "round {round}: capsule rms (cm) {}",
            rs.iter()
                .map(|(s, k)| format!("{:.2}", (s / (*k).max(1) as f64).sqrt() * 100.0))
                .collect::<Vec<_>>()
                .join(" ")
        );
        for (ci, c) in shape.capsules.iter_mut().enumerate() {
            let mut h = hs[ci];
            for i in 0..8 {
                h[(i, i)] += 1e-4 + 0.05 * h[(i, i)];
            }
            let Some(ch) = h.cholesky() else { continue };
            let step = -ch.solve(&gs[ci]);
            let midline = c.a[0] == 0.0 && c.b[0] == 0.0;
            for i in [0, 2] {
                if i == 0 && midline {
                    continue;
                }
                c.a[i] += step[i] as f32;
                c.b[i] += step[4 + i] as f32;
            }
            c.ra += step[3] as f32;
            c.rb += step[7] as f32;
        }
    }
    println!("{}", serde_json::to_string_pretty(&shape).unwrap());
}
