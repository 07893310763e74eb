//! Priors on the joints' turns, and how hidden each limb was (for the pull towards
//! hanging).

use super::{Gradient, Normal};
use crate::body::{rotation_vector, BodyPose, Segment};
use nalgebra::Vector3;

/// Weights of the priors on the joints' turns, per radian² (part of
/// [`super::RegisterConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct PriorsConfig {
    /// The head's turn from its rest against the chest: its turn about its own axis is
    /// not in the data at all.
    pub head: f64,
    /// The chest's turn against the abdomen.
    pub chest: f64,
    /// The abdomen's turn against the pelvis.
    pub abdomen: f64,
    /// The collarbones' raising and bringing forward of the shoulders, against their
    /// rest turn `collar_rest`...
    pub collar: f64,
    /// ...(rotation vectors against the chest, left and right), which the calibration
    /// learns for the person.
    pub collar_rest: [[f32; 3]; 2],
    /// Elbows and knees: a twist...
    pub hinge_twist: f64,
    /// ...a sideways bend...
    pub hinge_side: f64,
    /// ...and bending the wrong way beyond `hinge_slack` radians.
    pub hinge_limit: f64,
    /// See `hinge_limit`.
    pub hinge_slack: f32,
    /// Pull of upper arms and thighs towards hanging straight down: a limb the camera
    /// does not see (behind the body) has nothing else to keep it. Scaled per limb by
    /// how hidden it was last frame. Stronger pulls bend limbs the camera half sees
    /// (pose NOTES, 2026-12-02).
    pub limb_rest: f64,
}

impl Default for PriorsConfig {
    fn default() -> Self {
        Self {
            head: 1.0,
            chest: 3.0,
            abdomen: 3.0,
            collar: 3.0,
            collar_rest: [[0.0; 3]; 2],
            hinge_twist: 0.05,
            hinge_side: 2.0,
            hinge_limit: 5.0,
            hinge_slack: 0.15,
            limb_rest: 0.3,
        }
    }
}

/// Priors on each joint's turn, the rotation vector φ of a segment against its parent
/// (parent frame, x = the person's left, y = up, z = forward at rest). A world turn ω
/// of the segment changes φ by R_parentᵀ ω; its parent's turn moves both and leaves φ
/// alone. The spine and the neck keep near their rest (the head's turn about its own
/// axis is not in the data at all). Elbows and knees are hinges about x: they do not
/// bend sideways (z), twist little (y), and bend one way only (the knee back, the
/// elbow forward). Upper arms and thighs hidden last frame are pulled towards hanging
/// down ([`PriorsConfig::limb_rest`], scaled by [`hidden_limbs`]): a limb behind
/// the body is held by nothing else and would stay where the last frame that saw it (or
/// a wrong start) left it. Pulling every limb alike bent an arm raised to draw and
/// turned its collar; pulling the hidden ones only leaves the drawing arm alone.
pub(super) fn add_joint_priors(
    h: &mut Normal,
    g: &mut Gradient,
    pose: &BodyPose,
    hidden: &[f32; Segment::COUNT],
    cfg: &PriorsConfig,
) {
    use Segment::*;
    // (segment, weight per axis of φ, bending limit on φ.x: (sign, allowed))
    let hinge = |seg| (seg, [0.0, cfg.hinge_twist, cfg.hinge_side]);
    let rest = |seg: Segment| (seg, [cfg.limb_rest * hidden[seg.index()] as f64; 3]);
    let priors = [
        (Head, [cfg.head; 3]),
        (Chest, [cfg.chest; 3]),
        (Abdomen, [cfg.abdomen; 3]),
        // The collarbone points sideways (x): its turn about x is no motion at all.
        (LeftCollar, [cfg.hinge_twist, cfg.collar, cfg.collar]),
        (RightCollar, [cfg.hinge_twist, cfg.collar, cfg.collar]),
        rest(LeftUpperArm),
        rest(RightUpperArm),
        rest(LeftThigh),
        rest(RightThigh),
        hinge(LeftForearm),
        hinge(RightForearm),
        hinge(LeftShin),
        hinge(RightShin),
    ];
    for (seg, w) in priors {
        let Some(parent) = seg.parent() else { continue };
        let rp = pose.rotation[parent.index()];
        let mut phi = rotation_vector(&(rp.inverse() * pose.rotation[seg.index()]));
        // The collarbones keep near the person's own rest, learned as they move.
        match seg {
            LeftCollar => phi -= Vector3::from(cfg.collar_rest[0]),
            RightCollar => phi -= Vector3::from(cfg.collar_rest[1]),
            _ => {}
        }
        let rpm = rp.matrix().cast::<f64>();
        let o = 3 + 3 * seg.index();
        let mut add = |axis: usize, r: f32, w: f64| {
            if w <= 0.0 {
                return;
            }
            // J = e_axisᵀ R_pᵀ: the axis of the parent frame, in the camera frame.
            let d = rpm.column(axis).into_owned();
            let mut hb = h.fixed_view_mut::<3, 3>(o, o);
            hb += d * d.transpose() * w;
            let mut gr = g.fixed_rows_mut::<3>(o);
            gr += d * (w * r as f64);
        };
        for (axis, &wa) in w.iter().enumerate() {
            add(axis, phi[axis], wa);
        }
        // One-way bending: the knee flexes with φ.x > 0 (the shin goes back), the elbow
        // with φ.x < 0 (the forearm comes forward).
        let over = match seg {
            LeftShin | RightShin => (-phi.x - cfg.hinge_slack).max(0.0),
            LeftForearm | RightForearm => (phi.x - cfg.hinge_slack).max(0.0),
            _ => 0.0,
        };
        if over > 0.0 {
            let sign = if matches!(seg, LeftShin | RightShin) {
                -1.0
            } else {
                1.0
            };
            add(0, sign * over, cfg.hinge_limit);
        }
    }
}

/// How hidden each upper arm and thigh is, for the pull towards hanging: (1 − the share
/// of the limb, upper and lower segment together, the camera saw)², so a limb in sight
/// is left alone and one behind the body gets the whole pull. Other segments: 0.
pub fn hidden_limbs(seen: &[f32; Segment::COUNT]) -> [f32; Segment::COUNT] {
    use Segment::*;
    let mut hidden = [0.0; Segment::COUNT];
    for (upper, lower) in [
        (LeftUpperArm, LeftForearm),
        (RightUpperArm, RightForearm),
        (LeftThigh, LeftShin),
        (RightThigh, RightShin),
    ] {
        let seen = 0.5 * (seen[upper.index()] + seen[lower.index()]);
        hidden[upper.index()] = (1.0 - seen.clamp(0.0, 1.0)).powi(2);
    }
    hidden
}
