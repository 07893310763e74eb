//! Hand postures on real renders: each posture looks different, its size in the image
//! follows the distance, its ground truth lies on the rendered hand, and the sensor
//! model and any wrist angle still work.

use airglyph_core::Intrinsics;
use airglyph_synth::{
    Bone, FrameTruth, HandPosture, HandSpec, MotionSpec, SceneConfig, ScriptedPose, Synthesizer,
};
use nalgebra::{Point3, Vector3};

/// The right hand raised beside the head (the wave), palm turned to the camera, its
/// palm centre `hand_m` from the camera, the camera framing the upper body.
fn scene(posture: Option<HandPosture>, hand_m: f32) -> SceneConfig {
    let mut cfg = SceneConfig {
        motion: MotionSpec::Pose(ScriptedPose::Wave),
        ..SceneConfig::default()
    };
    cfg.placement.distance_m = hand_m;
    cfg = cfg.framing_upper_body().unwrap();
    cfg.hands.right.posture = posture;
    let truth = |cfg: &SceneConfig| Synthesizer::new(cfg.clone()).unwrap().render(0).1;
    // Roll turns the palm's normal towards the thumb's side about the fingers' axis:
    // the angle that points it straightest at the camera (−z).
    let h = truth(&cfg).hands.right;
    cfg.hands.right.roll_deg = (-h.thumb_side.z).atan2(-h.palm_normal.z).to_degrees();
    for _ in 0..3 {
        let z = truth(&cfg).hands.right.palm_centre.z;
        cfg.placement.distance_m += hand_m - z;
    }
    cfg
}

/// A rendered frame: depth, labels, truth.
struct Shot {
    k: Intrinsics,
    depth: Vec<u16>,
    labels: Vec<u8>,
    truth: FrameTruth,
}

fn shoot(cfg: SceneConfig) -> Shot {
    let mut s = Synthesizer::new(cfg).unwrap();
    let (img, truth) = s.render(0);
    Shot {
        k: s.intrinsics(),
        depth: img.pixels().to_vec(),
        labels: s.labels().to_vec(),
        truth,
    }
}

impl Shot {
    /// The pixels showing the right hand: (u, v, the point seen).
    fn hand(&self) -> Vec<(usize, usize, Point3<f32>)> {
        let w = self.k.width as usize;
        (0..self.labels.len())
            .filter(|&i| self.labels[i] == Bone::RightHand as u8 && self.depth[i] > 0)
            .map(|i| {
                let (u, v) = (i % w, i / w);
                let p = self
                    .k
                    .back_project(u as f32, v as f32, self.depth[i] as f32 / 1000.0);
                (u, v, p)
            })
            .collect()
    }

    /// The farthest hand point from the wrist, and how far it is.
    fn farthest(&self) -> (Point3<f32>, f32) {
        let wrist = self.truth.hands.right.wrist;
        self.hand()
            .into_iter()
            .map(|(_, _, p)| (p, (p - wrist).norm()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("hand pixels")
    }
}

#[test]
fn every_posture_renders_a_hand_of_its_own() {
    let shots: Vec<(HandPosture, Shot)> = HandPosture::ALL
        .iter()
        .map(|&p| (p, shoot(scene(Some(p), 1.2))))
        .collect();
    for (p, s) in &shots {
        assert_eq!(s.truth.hands.right.posture, Some(*p));
        assert!(s.hand().len() > 200, "{p}: {} hand pixels", s.hand().len());
    }
    for (i, (pa, a)) in shots.iter().enumerate() {
        for (pb, b) in &shots[i + 1..] {
            let hand = Bone::RightHand as u8;
            let differ = (0..a.labels.len())
                .filter(|&j| (a.labels[j] == hand) != (b.labels[j] == hand))
                .count();
            assert!(differ > 60, "{pa} and {pb} differ in {differ} pixels only");
        }
    }
}

#[test]
fn a_fist_is_smaller_than_an_open_hand() {
    let open = shoot(scene(Some(HandPosture::Open), 1.2));
    let fist = shoot(scene(Some(HandPosture::Fist), 1.2));
    let (n_open, n_fist) = (open.hand().len(), fist.hand().len());
    assert!(
        (n_fist as f32) < 0.75 * n_open as f32,
        "fist {n_fist} px, open {n_open} px"
    );
    let (_, reach_open) = open.farthest();
    let (_, reach_fist) = fist.farthest();
    assert!(
        reach_fist < 0.8 * reach_open,
        "fist reaches {reach_fist} m from the wrist, open {reach_open} m"
    );
}

/// The farthest hand pixel from the wrist is the index fingertip, a finger's length
/// beyond the palm (the knuckles are 0.45 of the hand's length from the wrist, the
/// index finger 0.5 long); in a fist nothing reaches that far.
#[test]
fn pointing_extends_one_finger() {
    for d in [0.8, 1.2, 2.0, 2.7] {
        let point = shoot(scene(Some(HandPosture::Point), d));
        let fist = shoot(scene(Some(HandPosture::Fist), d));
        let h = point.truth.hands.right;
        let len = h.length_m;
        let (tip, reach) = point.farthest();
        assert!(
            (0.85 * len..1.05 * len).contains(&reach),
            "{d} m: the farthest point is {reach} m from the wrist, the hand {len} m long"
        );
        let index = h.fingertips.unwrap()[1];
        assert!(
            (tip - index).norm() < 0.12 * len,
            "{d} m: the farthest point {tip} is not the index tip {index}"
        );
        let (_, reach_fist) = fist.farthest();
        assert!(
            reach - reach_fist > 0.25 * len,
            "{d} m: pointing reaches {reach} m, a fist {reach_fist} m"
        );
    }
}

/// The palm's width just short of the knuckles, in pixels, of an open hand facing the
/// camera: about 35 px at 1.2 m and 15 px at 2.7 m on the Kinect v1 at 640×480.
#[test]
fn the_hand_is_as_wide_as_a_hand_at_its_distance() {
    for (d, lo, hi) in [(1.2, 31.0, 40.0), (2.7, 13.0, 18.0)] {
        let s = shoot(scene(Some(HandPosture::Open), d));
        let h = s.truth.hands.right;
        let (cu, cv) = s.k.project(&h.palm_centre).unwrap();
        let ahead = h.palm_centre + h.finger_dir * 0.1;
        let (fu, fv) = s.k.project(&ahead).unwrap();
        let along = Vector3::new(fu - cu, fv - cv, 0.0).normalize();
        let across = Vector3::new(-along.y, along.x, 0.0);
        // Across the band of the palm below the knuckles, whole pixels from the palm
        // centre's line; the run of them around it is the palm (the thumb, further out,
        // is apart from it there).
        let mut seen = std::collections::BTreeSet::new();
        for (u, v, p) in s.hand() {
            let a = (p - h.wrist).dot(&h.finger_dir) / h.length_m;
            if (0.36..0.44).contains(&a) {
                let x = (u as f32 - cu) * across.x + (v as f32 - cv) * across.y;
                seen.insert(x.round() as i32);
            }
        }
        let run = |step: i32| {
            let mut x = 0;
            while seen.contains(&(x + step)) {
                x += step;
            }
            x
        };
        assert!(seen.contains(&0));
        let width = (run(1) - run(-1) + 1) as f32;
        assert!(
            (lo..hi).contains(&width),
            "{d} m: the palm is {width} px wide ({seen:?})"
        );
    }
}

/// Every fingertip of the truth that the camera sees lies on the rendered hand: the
/// pixel it projects to shows the hand within a finger's thickness of its depth.
#[test]
fn the_fingertips_of_the_truth_lie_on_the_rendered_hand() {
    for d in [0.8, 2.7] {
        for p in HandPosture::ALL {
            let s = shoot(scene(Some(p), d));
            let h = s.truth.hands.right;
            let w = s.k.width as usize;
            let mut on_hand = 0;
            for (f, tip) in h.fingertips.unwrap().iter().enumerate() {
                let (u, v) = s.k.project(tip).unwrap();
                let (u, v) = (u.round() as usize, v.round() as usize);
                // The tip is the finger's outermost point, on the silhouette's edge:
                // the hand shows at it or next to it, at its depth (a tip hidden
                // behind the hand itself is not).
                let shows = (v - 1..=v + 1)
                    .flat_map(|y| (u - 1..=u + 1).map(move |x| y * w + x))
                    .any(|i| {
                        s.labels[i] == Bone::RightHand as u8
                            && (s.depth[i] as f32 / 1000.0 - tip.z).abs() < 0.025
                    });
                if shows {
                    on_hand += 1;
                } else {
                    assert!(
                        !p.extended()[f],
                        "{d} m {p}: the straight finger {f}'s tip {tip} is not on the hand"
                    );
                }
            }
            assert!(on_hand >= 1, "{d} m {p}: no fingertip on the hand");
        }
    }
}

#[test]
fn a_pinch_brings_the_thumb_to_the_index_tip() {
    let s = shoot(scene(Some(HandPosture::Pinch), 1.2));
    let h = s.truth.hands.right;
    let tips = h.fingertips.unwrap();
    let gap = (tips[0] - tips[1]).norm();
    assert!(gap < 0.2 * h.length_m, "thumb and index tips {gap} m apart");
    let open = shoot(scene(Some(HandPosture::Open), 1.2)).truth.hands.right;
    let tips = open.fingertips.unwrap();
    assert!((tips[0] - tips[1]).norm() > 0.4 * open.length_m);
}

/// The truth says how the hand is turned: its axes are a right-angled frame, the palm
/// faces the camera in these scenes, and a turn of the wrist turns them by its angle.
#[test]
fn the_truth_gives_the_hands_orientation() {
    let cfg = scene(Some(HandPosture::Open), 1.2);
    let h = shoot(cfg.clone()).truth.hands.right;
    for v in [h.palm_normal, h.finger_dir, h.thumb_side] {
        assert!((v.norm() - 1.0).abs() < 1e-4);
    }
    assert!(h.palm_normal.dot(&h.finger_dir).abs() < 1e-4);
    assert!(h.palm_normal.dot(&h.thumb_side).abs() < 1e-4);
    assert!(h.palm_normal.z < -0.95, "{:?}", h.palm_normal);
    let mut turned = cfg.clone();
    turned.hands.right.roll_deg += 90.0;
    let t = shoot(turned).truth.hands.right;
    assert!((t.palm_normal - h.thumb_side).norm() < 1e-3);
    assert!((t.finger_dir - h.finger_dir).norm() < 1e-3);
    assert!((t.wrist - h.wrist).norm() < 1e-5);
    let mut bent = cfg;
    bent.hands.right.pitch_deg = 30.0;
    let b = shoot(bent).truth.hands.right;
    let angle = b.finger_dir.dot(&h.finger_dir).acos().to_degrees();
    assert!((angle - 30.0).abs() < 0.1, "{angle}");
    assert!(b.finger_dir.dot(&h.palm_normal) > 0.0, "bent to the palm");
}

/// A hand with no posture is the body's own, with no fingertips in the truth; asking a
/// posture of one hand leaves the other as it was.
#[test]
fn a_hand_without_posture_is_the_bodys_own() {
    let t_pose = SceneConfig {
        motion: MotionSpec::Pose(ScriptedPose::TPose),
        ..SceneConfig::default()
    };
    let plain = shoot(t_pose.clone());
    assert_eq!(plain.truth.hands.right.posture, None);
    assert_eq!(plain.truth.hands.right.fingertips, None);
    assert_eq!(plain.truth.hands.left.fingertips, None);
    let mut cfg = t_pose;
    cfg.hands.left.posture = Some(HandPosture::Fist);
    let left_only = shoot(cfg);
    let (right, left) = (Bone::RightHand as u8, Bone::LeftHand as u8);
    let mut same = 0;
    for i in 0..plain.labels.len() {
        if plain.labels[i] == right {
            assert_eq!(left_only.labels[i], right);
            assert_eq!(left_only.depth[i], plain.depth[i]);
            same += 1;
        }
    }
    assert!(same > 50, "{same}");
    assert_eq!(left_only.truth.hands.left.posture, Some(HandPosture::Fist));
    assert_eq!(left_only.truth.hands.right, plain.truth.hands.right);
    assert_eq!(left_only.truth.skeleton, plain.truth.skeleton);
    let left_px = |s: &Shot| -> Vec<usize> {
        (0..s.labels.len())
            .filter(|&i| s.labels[i] == left)
            .collect()
    };
    assert!(!left_px(&left_only).is_empty());
    assert_ne!(left_px(&left_only), left_px(&plain));
}

/// The sensor model applies to the hand as to the rest: depth near the clean render,
/// some edge pixels lost; the truth is the same.
#[test]
fn sensor_noise_still_works_on_the_hand() {
    let cfg = scene(Some(HandPosture::V), 1.2);
    let clean = shoot(cfg.clone());
    let noisy = shoot(SceneConfig {
        sensor_noise: true,
        ..cfg
    });
    assert_eq!(clean.truth, noisy.truth);
    let hand: Vec<usize> = (0..clean.labels.len())
        .filter(|&i| clean.labels[i] == Bone::RightHand as u8)
        .collect();
    let lost = hand.iter().filter(|&&i| noisy.depth[i] == 0).count();
    let mut err: Vec<i32> = hand
        .iter()
        .filter(|&&i| noisy.depth[i] > 0)
        .map(|&i| (noisy.depth[i] as i32 - clean.depth[i] as i32).abs())
        .collect();
    err.sort_unstable();
    let changed = err.iter().filter(|e| **e > 0).count();
    assert!(
        lost > 0 && lost < hand.len() / 3,
        "{lost} of {} lost",
        hand.len()
    );
    assert!(changed > 0, "the noise changed nothing");
    assert!(
        err[err.len() / 2] <= 10,
        "median error {} mm",
        err[err.len() / 2]
    );
}

/// No wrist angle breaks a render: the hand turned all the way round, bent back onto
/// the forearm, at every posture.
#[test]
fn extreme_wrist_angles_do_not_panic() {
    let base = scene(None, 1.2);
    for p in HandPosture::ALL {
        for (roll, pitch) in [
            (180.0, 0.0),
            (-360.0, 180.0),
            (359.9, -180.0),
            (90.0, 90.0),
            (0.0, -135.0),
            (1e6, -1e6),
        ] {
            let mut cfg = base.clone();
            cfg.hands.right = HandSpec {
                posture: Some(p),
                roll_deg: roll,
                pitch_deg: pitch,
                drawing: None,
            };
            cfg.hands.left = cfg.hands.right;
            let s = shoot(cfg);
            for h in [s.truth.hands.left, s.truth.hands.right] {
                assert!(h.palm_normal.iter().all(|v| v.is_finite()));
                assert!(h
                    .fingertips
                    .unwrap()
                    .iter()
                    .all(|t| t.iter().all(|v| v.is_finite())));
            }
        }
    }
    let mut cfg = base;
    cfg.hands.right.roll_deg = f32::NAN;
    let e = Synthesizer::new(cfg).err().unwrap().to_string();
    assert!(e.contains("finite"), "{e}");
}

/// A recording of a scene with hand postures has hands.csv, a row per hand and frame
/// with the truth; one without has none.
#[test]
fn a_recording_with_postures_writes_their_truth() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = scene(Some(HandPosture::Point), 1.2);
    cfg.hands.left.posture = None;
    airglyph_synth::write_recording(cfg.clone(), 2, dir.path(), |_| {}).unwrap();
    let text = std::fs::read_to_string(dir.path().join("hands.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], airglyph_synth::hand::CSV_HEADER);
    assert_eq!(lines.len(), 1 + 2 * 2);
    let columns = lines[0].split(',').count();
    for l in &lines[1..] {
        assert_eq!(l.split(',').count(), columns, "{l}");
    }
    assert!(lines[1].starts_with("0,left,,"), "{}", lines[1]);
    assert!(lines[2].starts_with("0,right,point,"), "{}", lines[2]);
    let truth = Synthesizer::new(cfg).unwrap().render(1).1.hands.right;
    let tip = truth.fingertips.unwrap()[1];
    let row: Vec<f32> = lines[4]
        .split(',')
        .skip(3)
        .map(|v| v.parse().unwrap())
        .collect();
    // length, wrist, palm, normal, finger, thumb side (1 + 5 × 3), the thumb's tip,
    // then the index's.
    assert!((row[16 + 3] - tip.x).abs() < 1e-4 && (row[18 + 3] - tip.z).abs() < 1e-4);
    let plain = tempfile::tempdir().unwrap();
    airglyph_synth::write_recording(SceneConfig::default(), 1, plain.path(), |_| {}).unwrap();
    assert!(!plain.path().join("hands.csv").exists());
}
