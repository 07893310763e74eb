//! The registration's settings.

use crate::body::Shape;

/// Settings of the registration (part of [`crate::PoseConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RegisterConfig {
    /// Fit the articulated body after the geodesic estimate (false: the seed's chains).
    pub enabled: bool,
    /// Person points for the data term: every one within `thin_px` of the silhouette's
    /// edge, the others on a grid of this stride.
    pub thin_px: f32,
    /// See `thin_px`.
    pub interior_stride: usize,
    /// Gauss–Newton steps in all, and of them how many each start is given before the
    /// best one alone goes on.
    pub iterations: usize,
    /// See `iterations`.
    pub race_iterations: usize,
    /// A run stops early once a step is smaller than this (metres and radians
    /// together).
    pub converged: f32,
    /// Scale of the data term's Cauchy weight, metres.
    pub sigma: f32,
    /// Weight of a silhouette or free-space residual against one data point's.
    pub silhouette_weight: f32,
    /// See `silhouette_weight`.
    pub free_space_weight: f32,
    /// Beyond this (metres) the silhouette and free-space terms pull linearly (Huber).
    pub silhouette_scale: f32,
    /// How far the body's front may lie before the surface seen, metres.
    pub free_space_margin: f32,
    /// Weight of a limb tip's distance to its geodesic maximum, and its Cauchy scale.
    pub tip_weight: f32,
    /// See `tip_weight`.
    pub tip_sigma: f32,
    /// A hand is placed behind the fingertips seen (as the seed's chains place it) when
    /// they lie this near the fitted body's fingertips; farther, the fit's hand stays.
    pub tip_trust: f32,
    /// A limb's tip that lies on another limb of the tracked body and at least this much
    /// (metres) farther from its own is dropped. 0 = off.
    pub borrowed_tip_gap: f32,
    /// Weight of the head's and the chest's turn from their rest against their parent
    /// (per radian²): the head's turn about its own axis is not in the data at all.
    pub head_prior: f64,
    /// See `head_prior`.
    pub chest_prior: f64,
    /// See `head_prior`.
    pub abdomen_prior: f64,
    /// The collarbones' raising and bringing forward of the shoulders, against their
    /// rest turn (rotation vectors against the chest, left and right), which
    /// the calibration learns for the person.
    pub collar_prior: f64,
    /// See `collar_prior`.
    pub collar_rest: [[f32; 3]; 2],
    /// The share of the way to each well-seen frame's collarbone turns their rest moves.
    pub collar_gain: f32,
    /// Elbows and knees: weight of a twist and of a sideways bend (per radian²), of
    /// bending the wrong way beyond `hinge_slack` radians.
    pub hinge_twist_prior: f64,
    /// See `hinge_twist_prior`.
    pub hinge_side_prior: f64,
    /// See `hinge_twist_prior`.
    pub hinge_limit_prior: f64,
    /// See `hinge_twist_prior`.
    pub hinge_slack: f32,
    /// Pull of upper arms and thighs towards hanging straight down, per squared radian:
    /// a limb the camera does not see (behind the body) has nothing else to keep it.
    /// Scaled per limb by how hidden it was last frame. Stronger pulls bend limbs the
    /// camera half sees (pose NOTES, 2026-12-02).
    pub limb_rest_prior: f64,
    /// Σ w j² a limb pair's length gradient needs before it is trusted (j: metres a
    /// point moves per unit change of the length ratio).
    pub length_evidence: f64,
    /// The share of a limb pair's front surface the camera must see where the fit puts
    /// it for the frame to count towards the pair's length.
    pub length_seen: f32,
    /// When set, an arm's upper arm and forearm are learned apart (`bone_steps`) from
    /// frames whose normal equations of the two bones' length ratios have no eigenvalue
    /// below this (Σ w j², as `length_evidence`). Off (None) by default: the split it
    /// learns is biased, and a sequence with noise lost a leg with it (pose NOTES).
    pub bone_evidence: Option<f64>,
    /// Every this many frames the seed's torso registration runs and the geodesic
    /// estimate races the tracked body; in between it races only when a limb tip lies
    /// farther than `race_gap` from the tracked body's (and off its surface, see
    /// `race_off_body`).
    pub redetect_every: usize,
    /// See `redetect_every`.
    pub race_gap: f32,
    /// A strayed tip races only when it also lies this far off the tracked body's
    /// surface; 0 = wherever it lies.
    pub race_off_body: f32,
    /// Also race the tracked body with its strayed limbs taken from the geodesic
    /// estimate.
    pub race_hybrid: bool,
    /// Levenberg–Marquardt damping: relative (of the diagonal) and absolute.
    pub damping: f64,
    /// See `damping`.
    pub damping_abs: f64,
    /// The body's shape (bone lengths come from the configuration).
    pub shape: Shape,
}

impl Default for RegisterConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            thin_px: 2.0,
            interior_stride: 3,
            iterations: 10,
            race_iterations: 3,
            converged: 1e-4,
            sigma: 0.03,
            silhouette_weight: 3.0,
            free_space_weight: 4.0,
            silhouette_scale: 0.05,
            free_space_margin: 0.03,
            tip_weight: 10.0,
            tip_sigma: 0.1,
            tip_trust: 0.12,
            borrowed_tip_gap: 0.1,
            head_prior: 1.0,
            chest_prior: 3.0,
            abdomen_prior: 3.0,
            collar_prior: 3.0,
            collar_rest: [[0.0; 3]; 2],
            collar_gain: 0.02,
            hinge_twist_prior: 0.05,
            hinge_side_prior: 2.0,
            hinge_limit_prior: 5.0,
            limb_rest_prior: 0.3,
            hinge_slack: 0.15,
            length_evidence: 10.0,
            length_seen: 0.6,
            bone_evidence: None,
            redetect_every: 10,
            race_gap: 0.25,
            race_off_body: 0.05,
            race_hybrid: false,
            damping: 0.05,
            damping_abs: 0.01,
            shape: Shape::makehuman(),
        }
    }
}
