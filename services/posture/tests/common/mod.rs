//! What the posture tests share: the synthetic scene they render.

use airglyph_synth::{BodySpec, HandPosture, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};

/// A scene of `body` waving its right hand in `posture`, the palm turned to the
/// camera (then by `roll`), `hand_m` from the camera.
pub fn wave_scene(body: BodySpec, posture: HandPosture, hand_m: f32, roll: f32) -> SceneConfig {
    let mut cfg = SceneConfig {
        body,
        motion: MotionSpec::Pose(ScriptedPose::Wave),
        ..SceneConfig::default()
    };
    cfg.placement.distance_m = hand_m;
    cfg = cfg.framing_upper_body().unwrap();
    cfg.hands.right.posture = Some(posture);
    let truth = |cfg: &SceneConfig| Synthesizer::new(cfg.clone()).unwrap().render(0).1;
    let h = truth(&cfg).hands.right;
    cfg.hands.right.roll_deg = (-h.thumb_side.z).atan2(-h.palm_normal.z).to_degrees() + roll;
    for _ in 0..2 {
        let z = truth(&cfg).hands.right.palm_centre.z;
        cfg.placement.distance_m += hand_m - z;
    }
    cfg
}
