//! Hard inputs: never a panic, never NaN, `person_found` right.

use airglyph_core::{DepthImage, Intrinsics, Joint};
use airglyph_pose::{PoseConfig, PoseEstimator, PoseResult};
use airglyph_synth::{Background, MotionSpec, Placement, SceneConfig, ScriptedPose, Synthesizer};

fn qvga() -> Intrinsics {
    Intrinsics::default().scaled_to(320, 240)
}

fn render(cfg: SceneConfig, frame: usize) -> (DepthImage, airglyph_synth::FrameTruth) {
    let mut s = Synthesizer::new(cfg).expect("scene");
    s.render(frame)
}

fn scene(pose: ScriptedPose) -> SceneConfig {
    SceneConfig {
        intrinsics: qvga(),
        motion: MotionSpec::Pose(pose),
        ..SceneConfig::default()
    }
}

/// `pose` `lateral_m` to the side, before floor and wall, with sensor noise.
fn in_the_room(lateral_m: f32, pose: ScriptedPose) -> SceneConfig {
    SceneConfig {
        placement: Placement {
            lateral_m,
            ..Placement::default()
        },
        background: Background::FloorAndWall,
        sensor_noise: true,
        ..scene(pose)
    }
}

/// A frame of xorshift noise from `seed`, each pixel's depth (mm) made by `depth`.
fn noise(seed: u32, depth: impl Fn(u32) -> u16) -> DepthImage {
    let k = qvga();
    let mut img = DepthImage::empty(k.width, k.height);
    let mut x = seed;
    for p in img.pixels_mut() {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        *p = depth(x);
    }
    img
}

/// Two frames in one: each pixel the nearer of the two.
fn nearer_of(a: &DepthImage, b: &DepthImage) -> DepthImage {
    let mut img = a.clone();
    for (p, &q) in img.pixels_mut().iter_mut().zip(b.pixels()) {
        if q > 0 && (*p == 0 || q < *p) {
            *p = q;
        }
    }
    img
}

fn check(r: &PoseResult) {
    assert!(r.skeleton.is_finite(), "{r:?}");
    assert!(r
        .skeleton
        .confidence
        .iter()
        .all(|c| (0.0..=1.0).contains(c)));
}

fn estimate_n(img: &DepthImage, k: Intrinsics, n: usize) -> PoseResult {
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let mut r = est.estimate(img.view());
    check(&r);
    for _ in 1..n {
        r = est.estimate(img.view());
        check(&r);
    }
    r
}

#[test]
fn empty_frame_has_no_person() {
    let k = qvga();
    let img = DepthImage::empty(k.width, k.height);
    assert!(!estimate_n(&img, k, 2).person_found);
}

#[test]
fn floor_and_wall_alone_have_no_person() {
    // The room of the synthetic scenes without anybody in it: floor 1 m below the
    // camera, a wall 4.2 m ahead.
    let k = qvga();
    let mut img = DepthImage::empty(k.width, k.height);
    for v in 0..k.height {
        for u in 0..k.width {
            let ray = k.back_project(u as f32, v as f32, 1.0);
            let mut z: f32 = 4.2;
            if ray.y > 0.0 {
                z = z.min(1.0 / ray.y);
            }
            img.set(u, v, (z * 1000.0) as u16);
        }
    }
    assert!(!estimate_n(&img, k, 3).person_found);
}

#[test]
fn noise_garbage_and_wrong_sizes_do_not_panic() {
    let k = qvga();
    let img = noise(12345, |x| {
        if x.is_multiple_of(3) {
            0
        } else {
            (x % 9000) as u16
        }
    });
    estimate_n(&img, k, 2);
    // A frame of another size than the intrinsics, and a tiny one.
    let mut est = PoseEstimator::new(Intrinsics::default(), PoseConfig::default());
    check(&est.estimate(img.view()));
    let tiny = DepthImage::new(3, 2, vec![1000; 6]).unwrap();
    check(&est.estimate(tiny.view()));
}

#[test]
fn a_standing_person_is_found_and_roughly_right() {
    let (img, truth) = render(scene(ScriptedPose::Neutral), 0);
    let r = estimate_n(&img, qvga(), 2);
    assert!(r.person_found);
    // The default key points and bones are the MakeHuman body's; the procedural body's
    // arms are longer, so only a coarse check here.
    for j in Joint::ALL {
        let e = (r.skeleton[j] - truth.skeleton[j]).norm();
        assert!(e < 0.25, "{j:?} off by {e} m");
    }
}

#[test]
fn a_person_before_floor_and_wall_with_noise_is_found() {
    let (img, truth) = render(in_the_room(0.0, ScriptedPose::TPose), 0);
    let r = estimate_n(&img, qvga(), 2);
    assert!(r.person_found);
    let e = (r.skeleton[Joint::Torso] - truth.skeleton[Joint::Torso]).norm();
    assert!(e < 0.15, "torso off by {e} m");
}

#[test]
fn arm_pointing_at_the_camera() {
    let (img, _) = render(scene(ScriptedPose::PointAtCamera), 0);
    assert!(estimate_n(&img, qvga(), 3).person_found);
}

#[test]
fn person_half_out_of_the_image() {
    let cfg = SceneConfig {
        placement: Placement {
            lateral_m: 1.3,
            ..Placement::default()
        },
        ..scene(ScriptedPose::Wave)
    };
    let (img, _) = render(cfg, 0);
    let k = qvga();
    // Some of the person is cut off at the right border.
    let edge = (0..k.height)
        .filter(|&v| img.get(k.width - 1, v) > 0)
        .count();
    assert!(edge > 10, "the scene should cut the person");
    assert!(estimate_n(&img, k, 3).person_found);
}

#[test]
fn two_people_one_is_found() {
    let a = SceneConfig {
        placement: Placement {
            lateral_m: -0.6,
            ..Placement::default()
        },
        ..scene(ScriptedPose::Neutral)
    };
    let b = SceneConfig {
        placement: Placement {
            lateral_m: 0.7,
            distance_m: 3.3,
            ..Placement::default()
        },
        ..scene(ScriptedPose::TPose)
    };
    let (ia, ta) = render(a, 0);
    let (ib, _) = render(b, 0);
    let img = nearer_of(&ia, &ib);
    let r = estimate_n(&img, qvga(), 2);
    assert!(r.person_found);
    // The nearer, larger person is the one tracked.
    let e = (r.skeleton[Joint::Torso] - ta.skeleton[Joint::Torso]).norm();
    assert!(e < 0.2, "torso off by {e} m");
}

/// Air-drawing before the chest: the raised forearm hides the shoulder it hangs from,
/// so in the image the arm meets the body only across depth jumps. It must stay part of
/// the person, and the hand must be found at its end (not at the bent elbow).
#[test]
fn a_forearm_raised_before_the_chest_stays_part_of_the_person() {
    let k = qvga();
    let mut synth = Synthesizer::new(SceneConfig {
        intrinsics: k,
        motion: MotionSpec::parse("draw:0", None, false).expect("draw spec"),
        ..SceneConfig::default()
    })
    .expect("scene");
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let mut errors = Vec::new();
    let mut hand_in_mask = 0;
    let frames = 38..74; // the symbol's strokes (gestures.csv of this scene)
    for i in 0..frames.end {
        let (img, truth) = synth.render(i);
        let r = est.estimate(img.view());
        check(&r);
        if !frames.contains(&i) {
            continue;
        }
        assert!(r.person_found, "frame {i}");
        let hand = truth.skeleton[Joint::RightHand];
        let (u, v) = k.project(&hand).expect("the hand is in view");
        if est.mask()[v as usize * k.width as usize + u as usize] {
            hand_in_mask += 1;
        }
        errors.push((r.skeleton[Joint::RightHand] - hand).norm());
    }
    assert_eq!(
        hand_in_mask,
        frames.len(),
        "the drawing hand left the person's mask"
    );
    errors.sort_by(f32::total_cmp);
    let median = errors[errors.len() / 2];
    let far = errors.iter().filter(|&&e| e > 0.2).count();
    assert!(median < 0.12, "drawing hand off by {median} m (median)");
    assert!(
        far <= 2,
        "drawing hand off by over 20 cm in {far} frames: {errors:?}"
    );
}

/// A person standing still before a noisy sensor: the smoothed joints jitter much less
/// from frame to frame than the raw estimates.
#[test]
fn a_still_person_does_not_jitter_with_the_sensor_noise() {
    let k = qvga();
    let cfg = SceneConfig {
        sensor_noise: true,
        ..scene(ScriptedPose::Neutral)
    };
    let mut synth = Synthesizer::new(cfg).expect("scene");
    let frames: Vec<_> = (0..40).map(|i| synth.render(i).0).collect();
    let jitter = |pcfg: PoseConfig| {
        let mut est = PoseEstimator::new(k, pcfg);
        let mut prev: Option<airglyph_core::Skeleton> = None;
        let mut sum = 0.0f32;
        for (i, img) in frames.iter().enumerate() {
            let r = est.estimate(img.view());
            check(&r);
            assert!(r.person_found);
            if let (Some(p), true) = (prev, i >= 10) {
                sum += Joint::ALL
                    .iter()
                    .map(|&j| (r.skeleton[j] - p[j]).norm())
                    .sum::<f32>();
            }
            prev = Some(r.skeleton);
        }
        sum
    };
    let mut unsmoothed = PoseConfig::default();
    unsmoothed.smoothing.min_cutoff = 0.0;
    let raw = jitter(unsmoothed);
    let smooth = jitter(PoseConfig::default());
    // The registered body already jitters a quarter of what the geodesic steps alone
    // did; the filter still takes off a third of what is left.
    assert!(smooth < 0.7 * raw, "smoothed {smooth} vs raw {raw}");
}

/// A person first seen side-on, standing before floor and wall with the sensor's noise,
/// must be found once they turn to face the camera, as people walking in from the side
/// do. The seed's torso step takes the flank for a frontal chest; before the side-on
/// starts (`PoseConfig::side_on_half_width`) the tracker stayed on that wrong body
/// here, 36 cm off on average even when facing the camera.
#[test]
fn a_person_first_seen_side_on_is_found_once_they_turn_to_the_camera() {
    use airglyph_pose::metrics::PoseEval;
    let cfg = |yaw_deg: f32| SceneConfig {
        placement: Placement {
            yaw_deg,
            ..Placement::default()
        },
        sensor_noise: true,
        background: Background::FloorAndWall,
        intrinsics: Intrinsics::default(),
        ..scene(ScriptedPose::Neutral)
    };
    // 90° for ten frames, then turning at 150° a second (30 fps) to face the camera.
    let yaws: Vec<f32> = std::iter::repeat_n(90.0, 10)
        .chain((0..=18).map(|i| 90.0 - 5.0 * i as f32))
        .chain(std::iter::repeat_n(0.0, 5))
        .collect();
    let mut scenes: Vec<(f32, Synthesizer)> = Vec::new();
    let mut est = PoseEstimator::new(Intrinsics::default(), PoseConfig::default());
    let mut last = f32::NAN;
    for (f, &yaw) in yaws.iter().enumerate() {
        if !scenes.iter().any(|s| s.0 == yaw) {
            scenes.push((yaw, Synthesizer::new(cfg(yaw)).expect("scene")));
        }
        let s = scenes.iter_mut().find(|s| s.0 == yaw).expect("scene");
        let (img, truth) = s.1.render(f);
        let r = est.estimate(img.view());
        check(&r);
        assert!(r.person_found, "frame {f} at {yaw}°");
        last = PoseEval::default()
            .add(&r, &truth.skeleton, &Intrinsics::default())
            .mean();
    }
    // The procedural body's torso joint is 11 cm off by definition (pose README), so a
    // body found right is within about 6 cm on average; the wrong one was 36 cm off.
    assert!(
        last < 0.1,
        "facing the camera, the joints are {:.0} cm off on average",
        last * 100.0
    );
}

/// One estimator through scenes that change from frame to frame (a person here, then
/// there, cut by the border, gone, noise, two people): the state it carries from the
/// last frame (the window it segments first, the tracked body) must never make the
/// next one panic, miss the person, or keep the last one's body.
#[test]
fn scenes_that_change_every_frame() {
    let k = qvga();
    let (left, left_truth) = render(in_the_room(-0.8, ScriptedPose::Wave), 0);
    let (right, right_truth) = render(in_the_room(0.8, ScriptedPose::Neutral), 0);
    let (cut, _) = render(in_the_room(1.3, ScriptedPose::Wave), 0);
    let empty = DepthImage::empty(k.width, k.height);
    let noise = noise(99, |x| 400 + (x % 5000) as u16);
    let both = nearer_of(&left, &right);
    // Each frame and where its one person's torso is (None: nobody, two people, or a
    // person half out of the image, whose torso is found 0.2 m off even alone).
    let (l, r, c) = (
        Some(left_truth.skeleton[Joint::Torso]),
        Some(right_truth.skeleton[Joint::Torso]),
        None,
    );
    let sequence = [
        (&left, true, l),
        (&left, true, l),
        (&right, true, r),
        (&noise, false, None),
        (&right, true, r),
        (&cut, true, c),
        (&left, true, l),
        (&empty, false, None),
        (&both, true, None),
        (&noise, false, None),
        (&both, true, None),
        (&cut, true, c),
        (&right, true, r),
    ];
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    for (i, (img, person, torso)) in sequence.iter().enumerate() {
        let res = est.estimate(img.view());
        check(&res);
        assert_eq!(res.person_found, *person, "frame {i}");
        if let Some(t) = torso {
            let e = (res.skeleton[Joint::Torso] - t).norm();
            assert!(e < 0.25, "frame {i}: torso off by {e} m");
        }
    }
}

/// A T-pose by the image's right side, before floor and wall: its arm, the floor and
/// the image's border enclose a piece of wall 0.8 m wide, a blob with more pixels than
/// the person, not flat enough under the noise at 4 m to be told a wall by its shape.
/// It lies behind what borders it; the person does not.
#[test]
fn a_piece_of_wall_enclosed_by_an_arm_is_no_person() {
    let (img, truth) = render(in_the_room(0.8, ScriptedPose::TPose), 0);
    let r = estimate_n(&img, qvga(), 2);
    assert!(r.person_found);
    let e = (r.skeleton[Joint::Torso] - truth.skeleton[Joint::Torso]).norm();
    assert!(e < 0.2, "torso off by {e} m");
}
