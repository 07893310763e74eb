//! The posture steps on real synthetic renders: the segmentation finds the hand's own
//! pixels (the renderer's labels say which they are), the features stay put when the
//! hand turns in the image or moves away, a classifier trained on other bodies tells
//! an open hand from a fist, and bad input ends in a clear "no hand".

use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use airglyph_posture::{
    describe, features, hand_frame, segment, ArmJoints, Classifier, Features, Method, NoHand,
    SegmentParams, Side, TrainingSet, FEATURE_LEN,
};
use airglyph_synth::{
    BodySpec, Bone, HandPosture, MotionSpec, ProceduralBody, SceneConfig, ScriptedPose, Synthesizer,
};
use nalgebra::{Point3, Vector3};

mod common;

use common::wave_scene as scene;

fn body(height_m: f32, build: f32) -> BodySpec {
    BodySpec::Procedural(ProceduralBody { height_m, build })
}

/// One rendered frame.
struct Shot {
    k: Intrinsics,
    depth: Vec<u16>,
    labels: Vec<u8>,
    skeleton: Skeleton,
}

fn shoot(cfg: SceneConfig) -> Shot {
    let mut s = Synthesizer::new(cfg).unwrap();
    let (img, truth) = s.render(0);
    Shot {
        k: s.intrinsics(),
        depth: img.pixels().to_vec(),
        labels: s.labels().to_vec(),
        skeleton: truth.skeleton,
    }
}

impl Shot {
    fn view(&self) -> DepthView<'_> {
        DepthView::new(self.k.width, self.k.height, &self.depth).unwrap()
    }

    fn right_arm(&self) -> ArmJoints {
        ArmJoints::from_skeleton(&self.skeleton, Side::Right)
    }

    fn describe(&self, arm: ArmJoints) -> Result<airglyph_posture::Hand, NoHand> {
        describe(self.view(), &self.k, arm, &SegmentParams::default())
    }

    /// The segmentation's overlap with the renderer's own right-hand pixels.
    fn iou(&self, arm: ArmJoints) -> f32 {
        let region = segment(self.view(), &self.k, arm, &SegmentParams::default()).unwrap();
        let w = self.k.width;
        let (mut inter, mut union) = (0, 0);
        for i in 0..self.labels.len() {
            let t = self.labels[i] == Bone::RightHand as u8 && self.depth[i] > 0;
            let s = region.contains(i as u32 % w, i as u32 / w);
            inter += (s && t) as usize;
            union += (s || t) as usize;
        }
        inter as f32 / union.max(1) as f32
    }

    /// The same frame turned a quarter in the image plane (clockwise as seen): pixel
    /// (u, v) goes to (H−1−v, u), the camera's axes and the joints with it.
    fn turned_quarter(&self) -> Shot {
        let (w, h) = (self.k.width, self.k.height);
        let mut depth = vec![0u16; self.depth.len()];
        let mut labels = vec![0u8; self.labels.len()];
        for v in 0..h {
            for u in 0..w {
                let (nu, nv) = (h - 1 - v, u);
                let (i, j) = ((v * w + u) as usize, (nv * h + nu) as usize);
                depth[j] = self.depth[i];
                labels[j] = self.labels[i];
            }
        }
        let k = Intrinsics {
            width: h,
            height: w,
            fx: self.k.fy,
            fy: self.k.fx,
            cx: (h - 1) as f32 - self.k.cy,
            cy: self.k.cx,
        };
        let mut skeleton = self.skeleton;
        for p in skeleton.joints.iter_mut() {
            *p = Point3::new(-p.y, p.x, p.z);
        }
        Shot {
            k,
            depth,
            labels,
            skeleton,
        }
    }
}

/// Moves the hand joint and elbow by a few centimetres, as a pose estimate errs.
fn perturbed(arm: ArmJoints, by: Vector3<f32>) -> ArmJoints {
    ArmJoints {
        hand: arm.hand + by,
        elbow: arm.elbow - by,
    }
}

fn all_finite(f: &Features) -> bool {
    f.values().iter().all(|v| v.is_finite())
}

#[test]
fn the_segmentation_finds_the_hands_own_pixels() {
    for posture in HandPosture::ALL {
        for d in [0.8, 1.2, 2.0, 2.7] {
            let shot = shoot(scene(body(1.75, 1.0), posture, d, 0.0));
            let arm = shot.right_arm();
            let iou = shot.iou(arm);
            assert!(iou > 0.75, "{posture} at {d} m: IoU {iou}");
            let off = shot.iou(perturbed(arm, Vector3::new(0.025, -0.02, 0.02)));
            assert!(
                off > 0.6,
                "{posture} at {d} m, joints 3.8 cm off: IoU {off}"
            );
        }
    }
}

/// The frame's finger direction runs along the forearm, and the palm's normal points
/// to the camera for a palm turned to it.
#[test]
fn the_hands_frame_follows_the_hand() {
    let mut cfg = scene(body(1.75, 1.0), HandPosture::Open, 1.2, 0.0);
    cfg.hands.right.posture = Some(HandPosture::Open);
    let mut s = Synthesizer::new(cfg).unwrap();
    let (img, truth) = s.render(0);
    let k = s.intrinsics();
    let arm = ArmJoints::from_skeleton(&truth.skeleton, Side::Right);
    let region = segment(img.view(), &k, arm, &SegmentParams::default()).unwrap();
    let frame = hand_frame(&region);
    let h = truth.hands.right;
    let along = frame.finger_dir.dot(&h.finger_dir);
    assert!(
        along > 0.85,
        "finger direction {} vs truth {}",
        frame.finger_dir,
        h.finger_dir
    );
    let facing = frame.palm_normal.dot(&h.palm_normal).abs();
    assert!(
        facing > 0.85,
        "palm normal {} vs truth {}",
        frame.palm_normal,
        h.palm_normal
    );
    assert!(
        frame.spread_m[2] < 0.5 * frame.spread_m[1],
        "{:?}",
        frame.spread_m
    );
}

/// Per feature, the spread over every posture: what "nearly the same" is measured in.
fn spread(all: &[Features]) -> [f32; FEATURE_LEN] {
    let n = all.len() as f32;
    let mut mean = [0.0; FEATURE_LEN];
    let mut sd = [0.0; FEATURE_LEN];
    for f in all {
        for (m, v) in mean.iter_mut().zip(f.values()) {
            *m += v / n;
        }
    }
    for f in all {
        for ((s, v), m) in sd.iter_mut().zip(f.values()).zip(&mean) {
            *s += (v - m).powi(2) / n;
        }
    }
    sd.map(|v: f32| v.sqrt().max(1e-3))
}

fn dist(a: &Features, b: &Features, sd: &[f32; FEATURE_LEN]) -> f32 {
    (0..FEATURE_LEN)
        .map(|i| ((a.values()[i] - b.values()[i]) / sd[i]).powi(2))
        .sum::<f32>()
        .sqrt()
}

#[test]
fn features_stay_put_when_the_hand_turns_in_the_image_or_moves_away() {
    let near: Vec<(Shot, Features)> = HandPosture::ALL
        .iter()
        .map(|&p| {
            let shot = shoot(scene(body(1.75, 1.0), p, 1.2, 0.0));
            let f = shot.describe(shot.right_arm()).unwrap().features;
            (shot, f)
        })
        .collect();
    let all: Vec<Features> = near.iter().map(|(_, f)| *f).collect();
    let sd = spread(&all);
    let between = |i: usize, f: &Features| {
        all.iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, g)| dist(f, g, &sd))
            .fold(f32::INFINITY, f32::min)
    };
    for (i, (shot, f)) in near.iter().enumerate() {
        let p = HandPosture::ALL[i];
        let turned = shot.turned_quarter();
        let g = turned.describe(turned.right_arm()).unwrap().features;
        let (same, other) = (dist(f, &g, &sd), between(i, &g));
        assert!(
            same < 0.35 * other,
            "{p} turned 90° in the image: {same} from itself, {other} from the nearest other posture"
        );
        let far = shoot(scene(body(1.75, 1.0), p, 2.0, 0.0));
        let g = far.describe(far.right_arm()).unwrap().features;
        let (same, other) = (dist(f, &g, &sd), between(i, &g));
        if std::env::var_os("POSTURE_DEBUG").is_some() {
            let names = airglyph_posture::feature_names();
            let mut c: Vec<(f32, &str, f32, f32)> = (0..FEATURE_LEN)
                .map(|j| {
                    (
                        ((f.values()[j] - g.values()[j]) / sd[j]).abs(),
                        names[j].as_str(),
                        f.values()[j],
                        g.values()[j],
                    )
                })
                .collect();
            c.sort_by(|a, b| b.0.total_cmp(&a.0));
            eprintln!("{p}: {:?}", &c[..8]);
        }
        assert!(
            same < other,
            "{p} at 2 m: {same} from itself at 1.2 m, {other} from the nearest other posture"
        );
    }
}

/// Trained on two procedural bodies, tested on a third (other height and build) at
/// 1.2 m with the hand turned and the sensor model on and off.
#[test]
fn an_open_hand_and_a_fist_are_told_apart_at_1_2_m() {
    let labels: Vec<String> = HandPosture::ALL.iter().map(|p| p.name().into()).collect();
    let mut set = TrainingSet::new(labels);
    for (g, b) in [body(1.6, 0.9), body(1.8, 1.1)].into_iter().enumerate() {
        for (l, &p) in HandPosture::ALL.iter().enumerate() {
            for (i, (d, roll)) in [
                (1.2, 0.0),
                (1.2, 45.0),
                (2.0, 180.0),
                (0.8, -45.0),
                (1.2, 180.0),
                (2.0, 0.0),
            ]
            .into_iter()
            .enumerate()
            {
                let cfg = SceneConfig {
                    sensor_noise: i % 2 == 1,
                    seed: i as u64,
                    ..scene(b.clone(), p, d, roll)
                };
                let shot = shoot(cfg);
                let f = shot.describe(shot.right_arm()).unwrap().features;
                set.add(&f, l, g as u32).unwrap();
            }
        }
    }
    let classifiers = [
        Classifier::train(&set, Method::Knn { k: 3 }).unwrap(),
        Classifier::train(&set, Method::Softmax { l2: 1e-3 }).unwrap(),
    ];
    // Per classifier: how many were right, and every answer that took an open hand
    // for a fist or a fist for an open hand.
    let mut right = [0usize; 2];
    let mut swapped: Vec<String> = Vec::new();
    let mut total = 0;
    for (l, p) in [(0, HandPosture::Open), (1, HandPosture::Fist)] {
        for roll in [0.0, -30.0, 180.0] {
            for noise in [false, true] {
                let cfg = SceneConfig {
                    sensor_noise: noise,
                    seed: 77,
                    ..scene(body(1.7, 1.3), p, 1.2, roll)
                };
                let shot = shoot(cfg);
                let f = shot.describe(shot.right_arm()).unwrap().features;
                total += 1;
                for (ci, c) in classifiers.iter().enumerate() {
                    let got = c.predict(&f);
                    assert!(got.confidence.is_finite() && got.confidence > 0.0);
                    right[ci] += (got.label == l) as usize;
                    if got.label == 1 - l {
                        swapped.push(format!("{p}, roll {roll}, noise {noise}: {}", c.method()));
                    }
                }
            }
        }
    }
    assert!(swapped.is_empty(), "open and fist swapped: {swapped:?}");
    for (c, r) in classifiers.iter().zip(right) {
        // Open hands seen turned with the sensor model may pass for a pinch (three
        // fingers out): two such misses of twelve are allowed, no swap at all.
        assert!(r + 2 >= total, "{}: {r} of {total} right", c.method());
    }
}

#[test]
fn no_hand_is_a_clear_answer() {
    let shot = shoot(scene(body(1.75, 1.0), HandPosture::Open, 1.2, 0.0));
    let arm = shot.right_arm();
    let params = SegmentParams::default();
    let k = &shot.k;
    let away = ArmJoints {
        hand: Point3::new(5.0, 0.0, 1.0),
        elbow: Point3::new(5.0, 0.3, 1.0),
    };
    assert_eq!(
        segment(shot.view(), k, away, &params),
        Err(NoHand::OutsideImage)
    );
    let behind = ArmJoints {
        hand: Point3::new(0.0, 0.0, -1.0),
        ..arm
    };
    assert_eq!(
        segment(shot.view(), k, behind, &params),
        Err(NoHand::BadJoints)
    );
    let nan = ArmJoints {
        hand: Point3::new(f32::NAN, 0.0, 1.0),
        ..arm
    };
    assert_eq!(
        segment(shot.view(), k, nan, &params),
        Err(NoHand::BadJoints)
    );
    let no_forearm = ArmJoints {
        hand: arm.hand,
        elbow: arm.hand,
    };
    assert_eq!(
        segment(shot.view(), k, no_forearm, &params),
        Err(NoHand::BadJoints)
    );
    let blank = vec![0u16; shot.depth.len()];
    let view = DepthView::new(k.width, k.height, &blank).unwrap();
    assert_eq!(segment(view, k, arm, &params), Err(NoHand::NoDepth));
    let small = DepthView::new(2, 2, &blank[..4]).unwrap();
    assert_eq!(segment(small, k, arm, &params), Err(NoHand::SizeMismatch));
    // The joints in the air a third of the way to the camera, on the same rays:
    // nothing within reach.
    let in_air = ArmJoints {
        hand: arm.hand * 0.66,
        elbow: arm.elbow * 0.66,
    };
    assert_eq!(
        segment(shot.view(), k, in_air, &params),
        Err(NoHand::NoDepth)
    );
    assert!(!NoHand::NoDepth.to_string().is_empty());
}

/// Whatever comes out for a hard case, it is a hand with finite features or a clear
/// no-hand, never a panic.
fn sane(what: &str, got: Result<airglyph_posture::Hand, NoHand>) -> Option<airglyph_posture::Hand> {
    match got {
        Ok(h) => {
            assert!(all_finite(&h.features), "{what}: {:?}", h.features);
            assert!(!h.region.pixels().is_empty(), "{what}");
            let fr = h.frame;
            assert!(fr
                .finger_dir
                .iter()
                .chain(fr.palm_normal.iter())
                .all(|c| c.is_finite()));
            let again = features(&h.region, &fr);
            assert_eq!(
                again, h.features,
                "{what}: features are a function of the region"
            );
            Some(h)
        }
        Err(e) => {
            assert!(!e.to_string().is_empty());
            None
        }
    }
}

#[test]
fn hard_cases_give_a_hand_or_a_clear_no_hand() {
    // The hand against the body: the right hand on the left shoulder.
    let mut cfg = SceneConfig {
        motion: MotionSpec::Pose(ScriptedPose::ArmAcrossTorso),
        ..SceneConfig::default()
    };
    cfg.placement.distance_m = 1.5;
    cfg = cfg.framing_upper_body().unwrap();
    cfg.hands.right.posture = Some(HandPosture::Fist);
    let shot = shoot(cfg);
    if let Some(h) = sane("hand on the shoulder", shot.describe(shot.right_arm())) {
        // Reach bounds the region: the torso behind is not swallowed whole.
        let hand_px = shot
            .labels
            .iter()
            .filter(|&&l| l == Bone::RightHand as u8)
            .count();
        assert!(
            h.region.pixels().len() < 6 * hand_px.max(1),
            "{} px",
            h.region.pixels().len()
        );
    }

    // Both hands together before the body, both in postures.
    for pose in [ScriptedPose::HandsInLap, ScriptedPose::HandsNearFace] {
        let mut cfg = SceneConfig {
            motion: MotionSpec::Pose(pose),
            sensor_noise: true,
            ..SceneConfig::default()
        };
        cfg.placement.distance_m = 1.2;
        cfg = cfg.framing_upper_body().unwrap();
        cfg.hands.right.posture = Some(HandPosture::Open);
        cfg.hands.left.posture = Some(HandPosture::Fist);
        let shot = shoot(cfg);
        for side in [Side::Left, Side::Right] {
            let arm = ArmJoints::from_skeleton(&shot.skeleton, side);
            sane(&format!("{pose:?} {side:?}"), shot.describe(arm));
        }
    }

    // The hand at the image's right border: the person moved until the hand joint is
    // 3 pixels from the edge, half the hand outside.
    let mut cfg = scene(body(1.75, 1.0), HandPosture::Open, 1.2, 0.0);
    let first = shoot(cfg.clone());
    let p = first.skeleton.get(Joint::RightHand);
    let (u, _) = first.k.project(&p).unwrap();
    cfg.placement.lateral_m += (first.k.width as f32 - 3.0 - u) * p.z / first.k.fx;
    let shot = shoot(cfg);
    let (u, _) = shot
        .k
        .project(&shot.skeleton.get(Joint::RightHand))
        .unwrap();
    assert!(u > shot.k.width as f32 - 12.0, "hand at u = {u}");
    sane("hand at the border", shot.describe(shot.right_arm()));
    // And just past it.
    let mut arm = shot.right_arm();
    arm.hand.x += 0.08;
    arm.elbow.x += 0.08;
    sane("hand past the border", shot.describe(arm));
}

#[test]
fn training_refuses_what_it_cannot_use() {
    let mut set = TrainingSet::new(vec!["open".into(), "fist".into()]);
    let shot = shoot(scene(body(1.75, 1.0), HandPosture::Open, 1.2, 0.0));
    let f = shot.describe(shot.right_arm()).unwrap().features;
    assert!(set.add(&f, 2, 0).is_err());
    set.add(&f, 0, 0).unwrap();
    assert!(Classifier::train(&set, Method::Knn { k: 1 }).is_err());
    assert!(Classifier::train(&TrainingSet::new(vec![]), Method::Softmax { l2: 0.0 }).is_err());
}
