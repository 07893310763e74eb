//! Posture model files on real synthetic renders: a model saved and loaded names every
//! hand as the one it was made from did, and the built-in model names the postures of
//! a body it was not trained on.

use airglyph_core::{DepthView, Intrinsics, Skeleton};
use airglyph_posture::{
    describe, ArmJoints, Classifier, Method, PostureModel, SegmentParams, Side, TrainingSet,
};
use airglyph_synth::{BodySpec, HandPosture, ProceduralBody, Synthesizer};

mod common;

/// One rendered frame of `body` waving its right hand in `posture`, the palm turned to
/// the camera (then by `roll`), `hand_m` from the camera.
struct Shot {
    k: Intrinsics,
    depth: Vec<u16>,
    skeleton: Skeleton,
}

fn shoot(body: BodySpec, posture: HandPosture, hand_m: f32, roll: f32) -> Shot {
    let mut cfg = common::wave_scene(body, posture, hand_m, roll);
    cfg.sensor_noise = true;
    let mut s = Synthesizer::new(cfg).unwrap();
    let (img, truth) = s.render(0);
    Shot {
        k: s.intrinsics(),
        depth: img.pixels().to_vec(),
        skeleton: truth.skeleton,
    }
}

impl Shot {
    fn view(&self) -> DepthView<'_> {
        DepthView::new(self.k.width, self.k.height, &self.depth).unwrap()
    }
    fn arm(&self) -> ArmJoints {
        ArmJoints::from_skeleton(&self.skeleton, Side::Right)
    }
}

fn body(height_m: f32, build: f32) -> BodySpec {
    BodySpec::Procedural(ProceduralBody { height_m, build })
}

#[test]
fn a_saved_and_loaded_model_classifies_alike() {
    let labels: Vec<String> = HandPosture::ALL.iter().map(|p| p.name().into()).collect();
    let mut set = TrainingSet::new(labels);
    for (group, b) in [body(1.6, 0.9), body(1.9, 1.2)].into_iter().enumerate() {
        for (label, &posture) in HandPosture::ALL.iter().enumerate() {
            for (hand_m, roll) in [(1.0, 0.0), (1.6, 45.0)] {
                let s = shoot(b.clone(), posture, hand_m, roll);
                let h = describe(s.view(), &s.k, s.arm(), &SegmentParams::default()).unwrap();
                set.add(&h.features, label, group as u32).unwrap();
            }
        }
    }
    let test: Vec<Shot> = HandPosture::ALL
        .iter()
        .map(|&p| shoot(body(1.75, 1.1), p, 1.3, 20.0))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    for method in [Method::Knn { k: 3 }, Method::Softmax { l2: 1e-3 }] {
        let model = PostureModel::new(
            Classifier::train(&set, method).unwrap(),
            SegmentParams::default(),
            serde_json::Value::Null,
        );
        let path = dir.path().join("postures.json");
        model.save(&path).unwrap();
        let back = PostureModel::load(&path).unwrap();
        assert_eq!(back.method(), method);
        for s in &test {
            let a = model.classify(s.view(), &s.k, s.arm()).unwrap();
            let b = back.classify(s.view(), &s.k, s.arm()).unwrap();
            assert_eq!(a, b, "{method}");
        }
    }
}

#[test]
fn the_builtin_model_names_the_postures_of_an_unseen_body() {
    let model = PostureModel::builtin();
    let mut right = 0;
    let mut said = Vec::new();
    for &posture in &HandPosture::ALL {
        for hand_m in [1.0, 2.2] {
            let s = shoot(body(1.82, 1.1), posture, hand_m, 0.0);
            let p = model.classify(s.view(), &s.k, s.arm()).unwrap();
            let name = &model.labels()[p.label];
            right += (name == posture.name()) as usize;
            said.push(format!("{} at {hand_m} m: {name}", posture.name()));
        }
    }
    // Twelve hands of a body none of the training bodies has; the model's
    // leave-one-body-out accuracy is about 97 %.
    assert!(right >= 10, "{right} of 12 right: {said:?}");
}
