//! The five limbs every step names (assignment, chains, body, calibration, torso key
//! points): a leaf of its own, so that naming a limb ties no step to the settings.

use airglyph_core::Joint;

/// The five limbs, each a chain from a torso key point to an extremity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limb {
    /// Neck to the top of the head.
    Head,
    /// Left shoulder to the left fingertips.
    LeftArm,
    /// Right shoulder to the right fingertips.
    RightArm,
    /// Left hip to the left toes.
    LeftLeg,
    /// Right hip to the right toes.
    RightLeg,
}

impl Limb {
    /// The five limbs in index order.
    pub const ALL: [Limb; 5] = [
        Limb::Head,
        Limb::LeftArm,
        Limb::RightArm,
        Limb::LeftLeg,
        Limb::RightLeg,
    ];

    /// Root, middle and end joint (the head has no middle joint: root neck, end head).
    pub fn joints(self) -> (Joint, Option<Joint>, Joint) {
        match self {
            Limb::Head => (Joint::Neck, None, Joint::Head),
            Limb::LeftArm => (Joint::LeftShoulder, Some(Joint::LeftElbow), Joint::LeftHand),
            Limb::RightArm => (
                Joint::RightShoulder,
                Some(Joint::RightElbow),
                Joint::RightHand,
            ),
            Limb::LeftLeg => (Joint::LeftHip, Some(Joint::LeftKnee), Joint::LeftFoot),
            Limb::RightLeg => (Joint::RightHip, Some(Joint::RightKnee), Joint::RightFoot),
        }
    }

    /// The limb's place in [`Limb::ALL`] and in per-limb arrays.
    pub fn index(self) -> usize {
        self as usize
    }
}
