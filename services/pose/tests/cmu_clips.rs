//! The two CMU clips the estimator was developed on, whole and tracked, as the issue of
//! close-range pose asked: no worse than on its first morning (01_01 3.53 cm, 01_03
//! 3.41 cm over the frames with the whole body in view). MakeHuman body, 2.7 m, the
//! camera following, no sensor model. Skipped without the body (scripts/fetch-assets)
//! or the clips (Debian's assimp-testmodels).

use airglyph_pose::metrics::PoseEval;
use airglyph_pose::{PoseConfig, PoseEstimator};
use airglyph_synth::{Background, BodySpec, MotionSpec, Placement, SceneConfig, Synthesizer};
use std::path::Path;

/// e_m (cm) over the frames with the whole body in view, every frame tracked.
fn whole_clip_error_cm(clip: &str) -> Option<f64> {
    let bvh = Path::new("/usr/share/assimp/models/BVH").join(clip);
    if !bvh.exists() {
        eprintln!(
            "skipped: {} (apt-get install assimp-testmodels)",
            bvh.display()
        );
        return None;
    }
    let body = BodySpec::MakeHuman {
        assets: None,
        shape: Default::default(),
    };
    if body.load().is_err() {
        eprintln!("skipped: the MakeHuman body is not fetched (scripts/fetch-assets)");
        return None;
    }
    let cfg = SceneConfig {
        body,
        motion: MotionSpec::Bvh(bvh),
        background: Background::FloorAndWall,
        placement: Placement {
            distance_m: 2.7,
            follow: true,
            ..Placement::default()
        },
        ..SceneConfig::default()
    };
    let mut synth = Synthesizer::new(cfg).expect("the clip loads");
    let k = synth.intrinsics();
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let mut eval = PoseEval::default();
    for i in 0..synth.len().expect("a clip ends") {
        let (img, truth) = synth.render(i);
        let r = est.estimate_at(img.view(), i as f64 / 30.0);
        eval.add(&r, &truth.skeleton, &k);
    }
    let e = eval
        .summary()
        .mean_error_whole_cm
        .expect("frames with the whole body in view");
    eprintln!("CMU {clip}: e_m {e:.3} cm");
    Some(e)
}

#[test]
fn cmu_01_01_is_no_worse_than_on_the_first_morning() {
    // A walker's re-detections once anchored the torso at the head's top in the mask,
    // which put a hand off its arm for frames at a time: 3.66 cm.
    if let Some(e) = whole_clip_error_cm("01_01.bvh") {
        assert!(e < 3.535, "CMU 01_01: e_m {e:.3} cm, against 3.53");
    }
}

#[test]
fn cmu_01_03_is_no_worse_than_on_the_first_morning() {
    if let Some(e) = whole_clip_error_cm("01_03.bvh") {
        assert!(e < 3.415, "CMU 01_03: e_m {e:.3} cm, against 3.41");
    }
}
