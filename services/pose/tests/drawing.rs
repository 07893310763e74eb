//! The person the demo shows: air-drawing with the right hand, the forearm often before
//! the chest, where the frame hardly tells it from one hanging. Tracked frame to frame,
//! the drawing hand must stay followed: a hand lost for a second loses the symbol.

use airglyph_core::Joint;
use airglyph_pose::{PoseConfig, PoseEstimator};
use airglyph_synth::{MotionSpec, SceneConfig, Synthesizer};

#[test]
fn the_drawing_hand_is_followed_through_symbols() {
    let cfg = SceneConfig {
        motion: MotionSpec::parse("draw:0123456789", None, false).expect("a drawing"),
        ..SceneConfig::default()
    };
    let mut synth = Synthesizer::new(cfg).expect("scene");
    let k = synth.intrinsics();
    let n = synth.len().expect("a drawing ends");
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let (mut lost, mut sum) = (0usize, 0.0f32);
    for i in 0..n {
        let (img, truth) = synth.render(i);
        let r = est.estimate_at(img.view(), i as f64 / 30.0);
        assert!(r.person_found, "frame {i}");
        let e = (r.skeleton[Joint::RightHand] - truth.skeleton[Joint::RightHand]).norm();
        sum += e;
        if truth.gesture.is_some() && e > 0.15 {
            lost += 1;
        }
    }
    let mean = sum / n as f32;
    assert!(
        mean < 0.06 && lost * 50 < n,
        "right hand {:.1} cm on average, 15 cm off while drawing in {lost} of {n} frames",
        mean * 100.0
    );
}
