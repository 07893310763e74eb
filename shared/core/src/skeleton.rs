//! The 16 joints and the skeleton of one frame. Each joint but the head is an anatomical
//! centre inside the body: hand = centre of the palm, foot = the ankle, torso = mid-chest
//! on the spine, pelvis = between the hips; the head is the top of the head, where
//! hand-labelled frames put it (docs/architecture.md, "Camera frame and joints").

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// One of the 16 joints, each an anatomical centre inside the body but the head (the
/// top of the head). "Left" is the person's left. The discriminant is the joint's index
/// in every array and file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum Joint {
    /// The top of the head (the crown).
    Head,
    /// Base of the neck.
    Neck,
    /// Mid-chest on the spine.
    Torso,
    /// Between the hips.
    Pelvis,
    /// The person's left shoulder.
    LeftShoulder,
    /// The person's left elbow.
    LeftElbow,
    /// Centre of the person's left palm.
    LeftHand,
    /// The person's right shoulder.
    RightShoulder,
    /// The person's right elbow.
    RightElbow,
    /// Centre of the person's right palm.
    RightHand,
    /// The person's left hip.
    LeftHip,
    /// The person's left knee.
    LeftKnee,
    /// The person's left ankle.
    LeftFoot,
    /// The person's right hip.
    RightHip,
    /// The person's right knee.
    RightKnee,
    /// The person's right ankle.
    RightFoot,
}

impl Joint {
    /// How many joints a skeleton has.
    pub const COUNT: usize = 16;

    /// Every joint in index order, the order of every array, message and file.
    pub const ALL: [Joint; Joint::COUNT] = [
        Joint::Head,
        Joint::Neck,
        Joint::Torso,
        Joint::Pelvis,
        Joint::LeftShoulder,
        Joint::LeftElbow,
        Joint::LeftHand,
        Joint::RightShoulder,
        Joint::RightElbow,
        Joint::RightHand,
        Joint::LeftHip,
        Joint::LeftKnee,
        Joint::LeftFoot,
        Joint::RightHip,
        Joint::RightKnee,
        Joint::RightFoot,
    ];

    /// The joints below the waist: what a camera at a desk or behind a table does not
    /// see.
    pub const LOWER: [Joint; 7] = [
        Joint::Pelvis,
        Joint::LeftHip,
        Joint::LeftKnee,
        Joint::LeftFoot,
        Joint::RightHip,
        Joint::RightKnee,
        Joint::RightFoot,
    ];

    /// The bones drawn in overlays: pairs of joints.
    pub const BONES: [(Joint, Joint); 15] = [
        (Joint::Head, Joint::Neck),
        (Joint::Neck, Joint::Torso),
        (Joint::Torso, Joint::Pelvis),
        (Joint::Neck, Joint::LeftShoulder),
        (Joint::LeftShoulder, Joint::LeftElbow),
        (Joint::LeftElbow, Joint::LeftHand),
        (Joint::Neck, Joint::RightShoulder),
        (Joint::RightShoulder, Joint::RightElbow),
        (Joint::RightElbow, Joint::RightHand),
        (Joint::Pelvis, Joint::LeftHip),
        (Joint::LeftHip, Joint::LeftKnee),
        (Joint::LeftKnee, Joint::LeftFoot),
        (Joint::Pelvis, Joint::RightHip),
        (Joint::RightHip, Joint::RightKnee),
        (Joint::RightKnee, Joint::RightFoot),
    ];

    /// The joint's index in [`Joint::ALL`] and in every array.
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    /// The snake_case name used in JSON output and CSV headers.
    pub fn name(self) -> &'static str {
        match self {
            Joint::Head => "head",
            Joint::Neck => "neck",
            Joint::Torso => "torso",
            Joint::Pelvis => "pelvis",
            Joint::LeftShoulder => "left_shoulder",
            Joint::LeftElbow => "left_elbow",
            Joint::LeftHand => "left_hand",
            Joint::RightShoulder => "right_shoulder",
            Joint::RightElbow => "right_elbow",
            Joint::RightHand => "right_hand",
            Joint::LeftHip => "left_hip",
            Joint::LeftKnee => "left_knee",
            Joint::LeftFoot => "left_foot",
            Joint::RightHip => "right_hip",
            Joint::RightKnee => "right_knee",
            Joint::RightFoot => "right_foot",
        }
    }

    /// The joint named `name` (snake_case, as [`Joint::name`] gives), if any.
    pub fn from_name(name: &str) -> Option<Joint> {
        Self::ALL.into_iter().find(|j| j.name() == name)
    }
}

/// The 16 joint positions of one frame (metres, camera frame) with a confidence in
/// [0, 1] and a visibility each.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Skeleton {
    /// Each joint's position, camera frame, metres, in [`Joint::ALL`] order.
    pub joints: [Point3<f32>; Joint::COUNT],
    /// Each joint's confidence in [0, 1]; 0 for a joint out of view.
    pub confidence: [f32; Joint::COUNT],
    /// Whether each joint is in the camera's view: inside the image and not behind
    /// something that is not the person (a table, the image's border). A joint out of
    /// view has confidence 0 and a position that is only a guess. A joint hidden by the
    /// person's own body is in view: it is estimated, with a lower confidence.
    pub visible: [bool; Joint::COUNT],
}

impl Skeleton {
    /// Every joint in view, with confidence 1.
    pub fn new(joints: [Point3<f32>; Joint::COUNT]) -> Self {
        Self {
            joints,
            confidence: [1.0; Joint::COUNT],
            visible: [true; Joint::COUNT],
        }
    }

    /// A joint's position.
    #[inline]
    pub fn get(&self, j: Joint) -> Point3<f32> {
        self.joints[j.index()]
    }

    /// Moves a joint.
    #[inline]
    pub fn set(&mut self, j: Joint, p: Point3<f32>) {
        self.joints[j.index()] = p;
    }

    /// Whether every coordinate and confidence is a finite number.
    pub fn is_finite(&self) -> bool {
        self.joints.iter().all(|p| p.iter().all(|c| c.is_finite()))
            && self.confidence.iter().all(|c| c.is_finite())
    }
}

impl std::ops::Index<Joint> for Skeleton {
    type Output = Point3<f32>;
    fn index(&self, j: Joint) -> &Point3<f32> {
        &self.joints[j.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_indices_and_names_round_trip() {
        for (i, j) in Joint::ALL.into_iter().enumerate() {
            assert_eq!(j.index(), i);
            assert_eq!(Joint::from_name(j.name()), Some(j));
        }
    }

    #[test]
    fn every_joint_is_on_some_bone() {
        for j in Joint::ALL {
            assert!(Joint::BONES.iter().any(|&(a, b)| a == j || b == j), "{j:?}");
        }
    }
}
