//! People first seen side-on who then turn to face the camera: the measurement behind
//! the pose README's side-on figures. Each scene stands before floor and wall with the
//! sensor model at 640×480, 30 frames at 90° (or −90°), turns at 150° a second to face
//! the camera and holds 30 frames more. Prints e_m side-on and facing per scene, then
//! the averages and how many stay lost (facing e_m above 10 cm).
//!
//! `cargo run --release -p airglyph-pose --example turning -- [mh|procedural|both]
//!  [set:FIELD=VALUE]` (default both: MakeHuman with seven scripted poses, the
//! procedural body with four).

mod support;

use airglyph_core::Intrinsics;
use airglyph_pose::metrics::PoseEval;
use airglyph_pose::{PoseConfig, PoseEstimator};
use airglyph_synth::{
    Background, BodySpec, MotionSpec, Placement, ProceduralBody, SceneConfig, ScriptedPose,
    Synthesizer,
};

/// Frames held side-on and facing; degrees turned a frame (150°/s at 30 fps).
const HOLD: usize = 30;
const STEP_DEG: f32 = 5.0;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut cfg = PoseConfig::default();
    support::apply_sets(&mut cfg, &args);
    let which = args
        .iter()
        .find(|a| !a.starts_with("set:"))
        .map_or("both", String::as_str);
    use ScriptedPose::*;
    let mh = [
        Neutral,
        TPose,
        PointAtCamera,
        ArmAcrossTorso,
        HandsNearFace,
        Wave,
        HandsInFront,
    ];
    let procedural = [Neutral, TPose, Wave, HandsInFront];
    let mut bodies: Vec<(&str, BodySpec, &[ScriptedPose])> = Vec::new();
    if matches!(which, "mh" | "both") {
        bodies.push((
            "mh",
            BodySpec::MakeHuman {
                assets: None,
                shape: Default::default(),
            },
            &mh,
        ));
    }
    if matches!(which, "procedural" | "both") {
        bodies.push((
            "procedural",
            BodySpec::Procedural(ProceduralBody::default()),
            &procedural,
        ));
    }
    assert!(
        !bodies.is_empty(),
        "unknown body {which}: mh, procedural or both"
    );
    for (name, body, poses) in bodies {
        let (mut side_sum, mut facing_sum, mut lost, mut n) = (0.0, 0.0, 0, 0);
        for &pose in poses {
            for side in [90.0f32, -90.0] {
                let (side_on, facing) = turn(&body, pose, side, &cfg);
                println!(
                    "{name:<10} {:<18} {side:>4}°: side-on {:5.1} cm, facing {:5.1} cm",
                    pose.name(),
                    side_on * 100.0,
                    facing * 100.0
                );
                side_sum += side_on;
                facing_sum += facing;
                lost += usize::from(facing > 0.1);
                n += 1;
            }
        }
        println!(
            "{name}: {n} scenes, side-on {:.1} cm, facing {:.1} cm on average, {lost} lost facing the camera",
            side_sum * 100.0 / n as f64,
            facing_sum * 100.0 / n as f64
        );
    }
}

/// Mean e_m (metres) over the frames held side-on and over those held facing.
fn turn(body: &BodySpec, pose: ScriptedPose, side: f32, cfg: &PoseConfig) -> (f64, f64) {
    let k = Intrinsics::default();
    let turning =
        (1..(side.abs() / STEP_DEG) as usize).map(|i| side - side.signum() * STEP_DEG * i as f32);
    let yaws: Vec<f32> = std::iter::repeat_n(side, HOLD)
        .chain(turning)
        .chain(std::iter::repeat_n(0.0, HOLD))
        .collect();
    let mut scenes: Vec<(f32, Synthesizer)> = Vec::new();
    let mut est = PoseEstimator::new(k, cfg.clone());
    let (mut side_on, mut facing) = (Vec::new(), Vec::new());
    for (f, &yaw) in yaws.iter().enumerate() {
        if !scenes.iter().any(|s| s.0 == yaw) {
            let scene = SceneConfig {
                intrinsics: k,
                body: body.clone(),
                motion: MotionSpec::Pose(pose),
                placement: Placement {
                    yaw_deg: yaw,
                    ..Placement::default()
                },
                background: Background::FloorAndWall,
                sensor_noise: true,
                ..SceneConfig::default()
            };
            scenes.push((yaw, Synthesizer::new(scene).expect("scene")));
        }
        let s = scenes.iter_mut().find(|s| s.0 == yaw).expect("scene");
        let (img, truth) = s.1.render(f);
        let r = est.estimate(img.view());
        let e = f64::from(PoseEval::default().add(&r, &truth.skeleton, &k).mean());
        if f < HOLD {
            side_on.push(e);
        } else if f >= yaws.len() - HOLD {
            facing.push(e);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    (mean(&side_on), mean(&facing))
}
