//! The posture step's cost a frame: one hand cut out of a 640×480 depth frame around
//! its joint, its frame and its features (`describe`), and a k-NN decision, at the
//! distances a person stands from a device. Beside the pose stage's own bench
//! (`cargo bench -p airglyph-pose`): the two together must fit a frame at 30 frames/s.

use airglyph_core::{DepthImage, Intrinsics, Skeleton};
use airglyph_posture::{describe, ArmJoints, Classifier, Method, SegmentParams, Side, TrainingSet};
use airglyph_synth::{HandPosture, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

/// The procedural person waving, its right hand in `posture`, framed
/// from the waist up `distance_m` away, with the sensor model.
fn frame(posture: HandPosture, distance_m: f32) -> (DepthImage, Skeleton, Intrinsics) {
    let mut cfg = SceneConfig {
        motion: MotionSpec::Pose(ScriptedPose::Wave),
        sensor_noise: true,
        ..SceneConfig::default()
    };
    cfg.placement.distance_m = distance_m;
    let mut cfg = cfg.framing_upper_body().expect("the procedural body");
    cfg.hands.right.posture = Some(posture);
    let mut s = Synthesizer::new(cfg).expect("a scene");
    let (img, truth) = s.render(0);
    (img, truth.skeleton, s.intrinsics())
}

fn bench(c: &mut Criterion) {
    let params = SegmentParams::default();
    // A classifier of the six postures from one hand each, at 1.2 m: the decision's
    // cost does not depend on how good it is.
    let mut set = TrainingSet::new(HandPosture::ALL.map(|p| p.name().to_string()).to_vec());
    for (label, p) in HandPosture::ALL.into_iter().enumerate() {
        let (img, skel, k) = frame(p, 1.2);
        let arm = ArmJoints::from_skeleton(&skel, Side::Right);
        let hand = describe(img.view(), &k, arm, &params).expect("a hand");
        set.add(&hand.features, label, 0).expect("a sample");
    }
    let knn = Classifier::train(&set, Method::Knn { k: 1 }).expect("a classifier");
    let mut g = c.benchmark_group("posture, 640x480, sensor model");
    for distance_m in [0.8f32, 1.2, 2.0, 2.7] {
        let (img, skel, k) = frame(HandPosture::Open, distance_m);
        let arm = ArmJoints::from_skeleton(&skel, Side::Right);
        g.bench_function(format!("describe an open hand, {distance_m} m"), |b| {
            b.iter(|| black_box(describe(img.view(), &k, arm, &params)))
        });
        if let Ok(hand) = describe(img.view(), &k, arm, &params) {
            g.bench_function(format!("describe and decide, {distance_m} m"), |b| {
                b.iter(|| {
                    let h = describe(img.view(), &k, arm, &params).expect("a hand");
                    black_box(knn.predict(&h.features))
                })
            });
            black_box(hand);
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
