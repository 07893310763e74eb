//! Static hand postures from the depth image.
//!
//! Around a hand joint of the skeleton the pose stage publishes, the hand is cut out
//! of the depth image ([`segment`]), its own frame taken from its points
//! ([`hand_frame`]), described by features that do not change with the hand's place,
//! turn in the image or distance ([`features`]), and classified by a classifier
//! trained on a few labelled hands per posture ([`Classifier`]). Every way the input
//! can fail (no joint, no depth, a hand outside the image) ends in [`NoHand`].

#![warn(missing_docs)]

pub mod classify;
pub mod features;
pub mod frame;
mod geometry;
mod mask;
pub mod model;
pub mod segment;

pub use classify::{
    choose, cross_validate, Classifier, Method, Prediction, TrainError, TrainingSet,
};
pub use features::{feature_names, features, Features, FEATURE_LEN, FEATURE_VERSION};
pub use frame::{hand_frame, HandFrame};
pub use model::{PostureModel, PostureModelError, MAX_POSTURE_LABEL_BYTES};
pub use segment::{
    segment, ArmJoints, HandPixel, HandRegion, NoHand, Palm, SegmentParams, Side, Window,
};

use airglyph_core::{DepthView, Intrinsics};

/// The hand of `arm` cut out of `depth`, with its frame and features.
#[derive(Debug, Clone, PartialEq)]
pub struct Hand {
    /// Its pixels.
    pub region: HandRegion,
    /// Its principal axes.
    pub frame: HandFrame,
    /// What the classifiers read.
    pub features: Features,
}

/// Segments the hand of `arm` and describes it.
pub fn describe(
    depth: DepthView<'_>,
    k: &Intrinsics,
    arm: ArmJoints,
    params: &SegmentParams,
) -> Result<Hand, NoHand> {
    let region = segment(depth, k, arm, params)?;
    let frame = hand_frame(&region);
    let features = features(&region, &frame);
    Ok(Hand {
        region,
        frame,
        features,
    })
}
