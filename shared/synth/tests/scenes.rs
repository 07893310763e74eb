//! The scenes of a camera at a desk or on a robot: near and framed from the waist up,
//! seated behind a table, arms at rest, and the sensor model against the published
//! Kinect v1 figures. Procedural body only (no external file needed).

use airglyph_core::{Intrinsics, Joint};
use airglyph_synth::sensor::SensorModel;
use airglyph_synth::{
    Background, Chair, DrawSpec, MotionSpec, Mug, Placement, Posture, Prop, SceneConfig,
    ScriptedPose, Synthesizer, Table,
};

fn kinect() -> Intrinsics {
    airglyph_core::camera::Preset::KinectV1Vga.intrinsics()
}

const LOWER: [Joint; 6] = [
    Joint::LeftHip,
    Joint::RightHip,
    Joint::LeftKnee,
    Joint::RightKnee,
    Joint::LeftFoot,
    Joint::RightFoot,
];

fn seated(motion: MotionSpec, table: bool) -> SceneConfig {
    let mut props = vec![Prop::Chair(Chair::default())];
    if table {
        props.push(Prop::Table(Table::default()));
    }
    SceneConfig {
        motion,
        posture: Posture::Seated {
            seat_height_m: Chair::default().seat_height_m,
        },
        props,
        background: Background::Room,
        placement: Placement {
            distance_m: 1.4,
            ..Placement::default()
        },
        ..SceneConfig::default()
    }
}

/// A flat wall facing the camera at `z` metres, through the sensor model: the spread
/// of its depths about their mean, and its distinct depth levels.
fn wall_through_sensor(z: f32, frame: usize) -> (f32, Vec<u16>) {
    let k = kinect();
    let mut depth = vec![(z * 1000.0).round() as u16; (k.width * k.height) as usize];
    SensorModel::default().apply(&k, &mut depth, 7, frame);
    // The middle of the image (no border effects), holes left out.
    let mut v: Vec<f64> = Vec::new();
    for y in 140..340 {
        for x in 200..440 {
            let d = depth[y * k.width as usize + x];
            if d > 0 {
                v.push(d as f64);
            }
        }
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let sd = (v.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
    let mut levels: Vec<u16> = v.iter().map(|d| *d as u16).collect();
    levels.sort_unstable();
    levels.dedup();
    (sd as f32 * 1e-3, levels)
}

#[test]
fn sensor_noise_grows_with_the_square_of_the_distance_as_measured_on_kinect_v1() {
    // Khoshelham & Elberink 2012: about 1.5 mm at 1 m, 4 cm at 5 m (σ ≈ 1.5e-3 z²).
    for z in [1.0f32, 2.0, 3.0, 4.0, 5.0] {
        let (sd, _) = wall_through_sensor(z, 0);
        let c = sd / (z * z);
        eprintln!("a wall at {z} m: σ = {:.1} mm", sd * 1e3);
        assert!(
            (1.2e-3..1.9e-3).contains(&c),
            "at {z} m: σ = {:.1} mm, {c:.2e} z²",
            sd * 1e3
        );
    }
    // Depth comes in disparity steps of 1/8 pixel: levels z² / (8 f b) apart.
    let k = kinect();
    for z in [3.0f32, 5.0] {
        let (_, levels) = wall_through_sensor(z, 1);
        let want = z * z / (8.0 * k.fx * 0.075) * 1000.0;
        let near = levels
            .windows(2)
            .map(|w| (w[1] - w[0]) as f32)
            .min_by(|a, b| (a - want).abs().total_cmp(&(b - want).abs()))
            .unwrap();
        assert!(
            (near - want).abs() < 0.1 * want,
            "at {z} m levels are {near} mm apart, want {want:.0}"
        );
        assert!(levels.len() < 12, "at {z} m: {} levels", levels.len());
    }
}

#[test]
fn the_projector_shadows_the_left_of_a_nearer_surface_and_holes_stay_small() {
    let k = kinect();
    let w = k.width as usize;
    // A board at 1.5 m before a wall at 3 m, its left edge at column 300.
    let mut depth = vec![3000u16; (k.width * k.height) as usize];
    for y in 0..k.height as usize {
        for x in 300..w {
            depth[y * w + x] = 1500;
        }
    }
    SensorModel::default().apply(&k, &mut depth, 3, 0);
    // Shadow width f b (1/z_near − 1/z_far) ≈ 14 px: the band left of the edge is empty.
    let band = (k.fx * 0.075 * (1.0 / 1.5 - 1.0 / 3.0)).round() as usize;
    let rows = 100..380;
    let empty_in_band = rows
        .clone()
        .flat_map(|y| (300 - band + 1..299).map(move |x| (x, y)))
        .filter(|(x, y)| depth[y * w + x] == 0)
        .count();
    let band_px = rows.len() * (band - 2);
    assert!(
        empty_in_band == band_px,
        "{empty_in_band} of {band_px} empty"
    );
    // Beyond the band the wall is seen, apart from a few holes.
    let lost = |xs: std::ops::Range<usize>| {
        rows.clone()
            .flat_map(|y| xs.clone().map(move |x| (x, y)))
            .filter(|(x, y)| depth[y * w + x] == 0)
            .count() as f32
            / (rows.len() * xs.len()) as f32
    };
    assert!(lost(50..250) < 0.02, "{}", lost(50..250));
    assert!(lost(350..600) < 0.02, "{}", lost(350..600));
}

#[test]
fn framed_from_the_waist_up_the_legs_are_out_of_view() {
    for distance_m in [0.9f32, 1.2, 1.5] {
        let cfg = SceneConfig {
            motion: MotionSpec::Pose(ScriptedPose::ArmsAtSides),
            background: Background::Room,
            placement: Placement {
                distance_m,
                ..Placement::default()
            },
            ..SceneConfig::default()
        }
        .framing_upper_body()
        .unwrap();
        let (_, truth) = Synthesizer::new(cfg).unwrap().render(0);
        for j in [
            Joint::Head,
            Joint::Neck,
            Joint::LeftShoulder,
            Joint::RightShoulder,
        ] {
            assert!(truth.skeleton.visible[j.index()], "{j:?} at {distance_m} m");
        }
        // At 0.9 m the lens's 43° hold 0.7 m of the body: the elbows are at its edge.
        if distance_m >= 1.2 {
            for j in [Joint::LeftElbow, Joint::RightElbow] {
                assert!(truth.skeleton.visible[j.index()], "{j:?} at {distance_m} m");
            }
        }
        for j in [
            Joint::LeftKnee,
            Joint::RightKnee,
            Joint::LeftFoot,
            Joint::RightFoot,
        ] {
            assert!(
                !truth.skeleton.visible[j.index()],
                "{j:?} at {distance_m} m"
            );
        }
    }
    // Far off, the same framing holds the whole person.
    let cfg = SceneConfig {
        motion: MotionSpec::Pose(ScriptedPose::ArmsAtSides),
        placement: Placement {
            distance_m: 3.0,
            ..Placement::default()
        },
        ..SceneConfig::default()
    }
    .framing_upper_body()
    .unwrap();
    let (_, truth) = Synthesizer::new(cfg).unwrap().render(0);
    assert!(
        truth.skeleton.visible.iter().all(|v| *v),
        "{:?}",
        truth.skeleton.visible
    );
}

#[test]
fn seated_behind_a_table_the_hands_rest_on_it_and_the_legs_are_out_of_view() {
    let cfg = seated(MotionSpec::Pose(ScriptedPose::HandsOnTable), true)
        .framing_upper_body()
        .unwrap();
    let mut synth = Synthesizer::new(cfg).unwrap();
    let (_, truth) = synth.render(0);
    let s = &truth.skeleton;
    for j in LOWER {
        assert!(
            !truth.skeleton.visible[j.index()],
            "{j:?} seen through the table"
        );
    }
    for j in [
        Joint::LeftHand,
        Joint::RightHand,
        Joint::Head,
        Joint::LeftElbow,
    ] {
        assert!(truth.skeleton.visible[j.index()], "{j:?}");
    }
    // The palms lie on the table top: a couple of centimetres above it, in the camera
    // frame too (its y is down: the camera is 1 m high before framing, so compare
    // against the hips, which sit at the seat).
    let camera = synth.camera_from_body();
    let up = camera.m * nalgebra::Vector3::y();
    let height = |j: Joint| (s.get(j) - s.get(Joint::Pelvis)).dot(&up);
    let pelvis_above_floor = 0.46 + 0.075 + 0.03;
    for j in [Joint::LeftHand, Joint::RightHand] {
        let above_table = height(j) + pelvis_above_floor - 0.74;
        assert!(
            (-0.02..0.08).contains(&above_table),
            "{j:?} {above_table} m above the table"
        );
    }
    // The knees are forward of the hips, at about the hips' height: seated.
    let knee = (s.get(Joint::LeftKnee) - s.get(Joint::LeftHip)).dot(&up);
    assert!(knee.abs() < 0.1, "knee {knee} m above the hip");
}

#[test]
fn drawing_over_a_table_never_goes_through_it() {
    let cfg = seated(
        MotionSpec::Draw(DrawSpec {
            symbols: "0123456789".into(),
            samples: None,
            repeat: false,
            rest: None,
        }),
        true,
    );
    let mut synth = Synthesizer::new(cfg).unwrap();
    let up = synth.camera_from_body().m * nalgebra::Vector3::y();
    let floor_to_camera = 1.0;
    for i in (0..synth.len().unwrap()).step_by(3) {
        let (_, truth) = synth.render(i);
        let hand = truth.skeleton.get(Joint::RightHand);
        // Height above the floor: the camera is 1 m up, looking level.
        let height = hand.coords.dot(&up) + floor_to_camera;
        assert!(
            height > 0.74,
            "frame {i}: the hand at {height} m, under the table top"
        );
    }
    assert_eq!(synth.gestures().len(), 10);
}

#[test]
fn every_rest_pose_fits_both_postures() {
    for posture in [
        Posture::Standing,
        Posture::Seated {
            seat_height_m: 0.46,
        },
    ] {
        for pose in ScriptedPose::AT_REST {
            let mut synth = Synthesizer::new(SceneConfig {
                motion: MotionSpec::Pose(pose),
                posture,
                ..SceneConfig::default()
            })
            .unwrap();
            let (depth, truth) = synth.render(0);
            assert!(truth.skeleton.is_finite());
            assert!(depth.pixels().iter().filter(|d| **d > 0).count() > 5000);
            // The hands are below the shoulders: at rest.
            let s = &truth.skeleton;
            for (hand, shoulder) in [
                (Joint::LeftHand, Joint::LeftShoulder),
                (Joint::RightHand, Joint::RightShoulder),
            ] {
                assert!(
                    s.get(hand).y > s.get(shoulder).y + 0.1,
                    "{posture:?} {pose:?}: {hand:?} not below the shoulder"
                );
            }
        }
    }
    // The rest motion moves between them without leaving the scene.
    let mut synth = Synthesizer::new(seated(MotionSpec::Rest, true)).unwrap();
    assert_eq!(synth.len(), None);
    let mut moved = 0.0f32;
    let mut last = synth.render(0).1.skeleton.get(Joint::RightHand);
    for i in (0..600).step_by(10) {
        let hand = synth.render(i).1.skeleton.get(Joint::RightHand);
        moved += (hand - last).norm();
        last = hand;
    }
    assert!(moved > 0.3, "the hands moved {moved} m in 20 s");
}

#[test]
fn furniture_that_reaches_the_camera_is_refused() {
    let cfg = SceneConfig {
        props: vec![Prop::Table(Table::default())],
        placement: Placement {
            distance_m: 1.0,
            ..Placement::default()
        },
        ..SceneConfig::default()
    };
    let e = Synthesizer::new(cfg).err().unwrap().to_string();
    assert!(
        e.contains("towards the camera") && e.contains("--distance"),
        "{e}"
    );
    let cfg = SceneConfig {
        props: vec![Prop::Table(Table {
            width_m: f32::NAN,
            ..Table::default()
        })],
        ..SceneConfig::default()
    };
    assert!(Synthesizer::new(cfg).is_err());
}

#[test]
fn a_mug_on_the_table_stands_beside_the_resting_hand_and_hides_none_of_it() {
    let resting = seated(MotionSpec::Pose(ScriptedPose::HandsOnTable), true);
    let with_mug = SceneConfig {
        props: [resting.props.clone(), vec![Prop::Mug(Mug::default())]].concat(),
        ..resting.clone()
    };
    let k = resting.intrinsics;
    let (bare, _) = Synthesizer::new(resting).unwrap().render(0);
    let mut synth = Synthesizer::new(with_mug).unwrap();
    let (img, truth) = synth.render(0);
    assert!(
        truth.visible[Joint::RightHand.index()],
        "the mug hides the hand"
    );
    let hand = truth.skeleton.get(Joint::RightHand);
    let (hu, hv) = k.project(&hand).unwrap();
    // The pixels the mug changed: all of them near the hand in the image (the mug is
    // 8 cm, about 45 px wide at 1 m) and in depth.
    let mut changed = 0;
    for v in 0..k.height {
        for u in 0..k.width {
            let (a, b) = (bare.get(u, v), img.get(u, v));
            if a == b {
                continue;
            }
            changed += 1;
            let far_px = (u as f32 - hu).hypot(v as f32 - hv);
            assert!(
                far_px < 100.0,
                "({u}, {v}) changed, {far_px:.0} px from the hand"
            );
            let z = f32::from(b) * 1e-3;
            assert!(
                (z - hand.z).abs() < 0.12,
                "({u}, {v}) at {z} m, the hand at {} m",
                hand.z
            );
        }
    }
    assert!(changed > 100, "the mug covers {changed} pixels");
}

#[test]
fn a_mug_with_no_table_under_it_is_refused() {
    let cfg = SceneConfig {
        props: vec![Prop::Mug(Mug::default())],
        ..SceneConfig::default()
    };
    let e = Synthesizer::new(cfg).err().unwrap().to_string();
    assert!(e.contains("stands on a table"), "{e}");
}
