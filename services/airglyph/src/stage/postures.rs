//! The posture step of the pose stage: each visible hand of a skeleton classified from
//! the depth frame the skeleton was estimated from (`airglyph_posture`), while the stage
//! still holds that frame, for the postures `SkeletonMsg` carries.

use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use airglyph_ipc::wire::{Hand, POSTURE_LABEL_CAPACITY};
use airglyph_ipc::PostureMsg;
use airglyph_posture::{ArmJoints, PostureModel, Side, MAX_POSTURE_LABEL_BYTES};
use std::path::Path;
use std::sync::Arc;

// A model's labels must fit the wire's.
const _: () = assert!(MAX_POSTURE_LABEL_BYTES <= POSTURE_LABEL_CAPACITY);

/// The help of `--postures`, for the stage and for the commands that pass it on.
pub const HELP: &str = "Classify each visible hand's static posture with this model: \
    builtin (the six postures of the synthetic hands: open, fist, point, thumb_up, v, \
    pinch), off (none: skeletons carry no posture), or a posture model FILE (JSON; \
    ./off for a file named off). A FILE that does not load is refused at start";

/// Which posture model, if any, the pose stage classifies hands with.
#[derive(Debug, Clone)]
pub enum Postures {
    /// No posture step: skeletons carry none.
    Off,
    /// Classify with this model.
    Model(Arc<PostureModel>),
}

impl Postures {
    /// `builtin`, `off` or a model file, loaded now: the value parser of `--postures`,
    /// so that a file that does not load is refused, naming it and why, when the
    /// arguments are checked (`airglyph run` checks a stage's before starting any).
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "off" => Ok(Self::Off),
            "builtin" => Ok(Self::Model(Arc::new(PostureModel::builtin()))),
            "" => Err("expected builtin, off or a posture model file".into()),
            file => PostureModel::load(Path::new(file))
                .map(|m| Self::Model(Arc::new(m)))
                .map_err(|e| e.to_string()),
        }
    }

    /// The model, None when the step is off.
    pub fn model(&self) -> Option<&PostureModel> {
        match self {
            Self::Off => None,
            Self::Model(m) => Some(m),
        }
    }
}

/// Hand and elbow below this confidence are not classified: the floor under which the
/// gesture stage's tracker does not follow a hand either (its `min_confidence`).
const MIN_CONFIDENCE: f32 = 0.1;

/// Each hand's posture in [`Hand`] order: classified when the hand and its elbow are in
/// the camera's view and confident; None for a hand that is not, or where no hand was
/// found in `depth` around the joint.
pub fn classify_hands(
    model: &PostureModel,
    depth: DepthView<'_>,
    k: &Intrinsics,
    sk: &Skeleton,
) -> [Option<PostureMsg>; 2] {
    [Hand::Left, Hand::Right].map(|hand| {
        let (side, joints) = match hand {
            Hand::Left => (Side::Left, [Joint::LeftHand, Joint::LeftElbow]),
            Hand::Right => (Side::Right, [Joint::RightHand, Joint::RightElbow]),
        };
        let usable = joints
            .iter()
            .all(|j| sk.visible[j.index()] && sk.confidence[j.index()] >= MIN_CONFIDENCE);
        if !usable {
            return None;
        }
        let p = model
            .classify(depth, k, ArmJoints::from_skeleton(sk, side))
            .ok()?;
        let label = model.labels().get(p.label)?;
        // A model's labels are checked when it loads, and a share of a vote or a
        // probability is in [0, 1]; a rounding past 1 is not a reason to lose it.
        PostureMsg::new(label, p.confidence.clamp(0.0, 1.0)).ok()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use airglyph_synth::{HandPosture, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};

    #[test]
    fn builtin_off_and_a_file_that_does_not_load() {
        assert!(Postures::parse("off").unwrap().model().is_none());
        let builtin = Postures::parse("builtin").unwrap();
        assert_eq!(builtin.model().unwrap().labels().len(), 6);
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("hands.json");
        let err = Postures::parse(missing.to_str().unwrap()).unwrap_err();
        assert!(
            err.contains("hands.json") && err.contains("cannot read"),
            "{err}"
        );
        let garbage = dir.path().join("garbage.json");
        std::fs::write(&garbage, "{\"format\": \"something else\"}").unwrap();
        let err = Postures::parse(garbage.to_str().unwrap()).unwrap_err();
        assert!(
            err.contains("garbage.json") && err.contains("not an airglyph posture model"),
            "{err}"
        );
        assert!(Postures::parse("").is_err());
    }

    /// The synthetic person waving its right hand in `posture` about a metre from the
    /// camera, the palm turned to it: the frame and the exact skeleton.
    fn wave(posture: HandPosture) -> (Intrinsics, Vec<u16>, Skeleton) {
        let mut cfg = SceneConfig {
            motion: MotionSpec::Pose(ScriptedPose::Wave),
            ..SceneConfig::default()
        };
        cfg.placement.distance_m = 1.0;
        cfg = cfg.framing_upper_body().unwrap();
        cfg.hands.right.posture = Some(posture);
        let h = Synthesizer::new(cfg.clone())
            .unwrap()
            .render(0)
            .1
            .hands
            .right;
        cfg.hands.right.roll_deg = (-h.thumb_side.z).atan2(-h.palm_normal.z).to_degrees();
        let mut s = Synthesizer::new(cfg).unwrap();
        let (img, truth) = s.render(0);
        (s.intrinsics(), img.pixels().to_vec(), truth.skeleton)
    }

    #[test]
    fn a_visible_hand_is_classified_and_one_out_of_view_or_unsure_is_not() {
        let model = PostureModel::builtin();
        let (k, px, sk) = wave(HandPosture::Fist);
        let depth = DepthView::new(k.width, k.height, &px).unwrap();
        let [_, right] = classify_hands(&model, depth, &k, &sk);
        let right = right.expect("the waving hand is classified");
        let p = right.get().unwrap().unwrap();
        assert_eq!(p.label, "fist");
        assert!(p.confidence > 0.0 && p.confidence <= 1.0, "{p:?}");
        let mut hidden = sk;
        hidden.visible[Joint::RightElbow.index()] = false;
        assert_eq!(classify_hands(&model, depth, &k, &hidden)[1], None);
        let mut unsure = sk;
        unsure.confidence[Joint::RightHand.index()] = 0.05;
        assert_eq!(classify_hands(&model, depth, &k, &unsure)[1], None);
        // A hand joint where the depth image has no hand: none, not a guess.
        let wall = vec![3000u16; px.len()];
        let wall = DepthView::new(k.width, k.height, &wall).unwrap();
        assert_eq!(classify_hands(&model, wall, &k, &sk), [None, None]);
    }
}
