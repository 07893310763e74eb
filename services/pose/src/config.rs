//! Every tunable number of the estimator, with the seed's values where it gives them.

pub use crate::register::RegisterConfig;
use airglyph_core::Joint;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Settings of [`crate::PoseEstimator`]. `PoseConfig::default()` is what the pose stage
/// and the evaluation use; all lengths are metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PoseConfig {
    /// Frames wider than this are reduced by an integer factor (each block's nearest
    /// depth) before estimation, so 640×480 costs about what 320×240 does; 0 = never.
    pub work_width: u32,

    // --- person segmentation ---
    /// Depth band in which a person is looked for.
    pub near: f32,
    pub far: f32,
    /// Whether to find and remove a floor plane (RANSAC on the lower image half).
    pub remove_floor: bool,
    /// Points closer to the floor plane than this are floor.
    pub floor_margin: f32,
    /// Neighbouring pixels belong to one blob when their depths differ by less than
    /// `max(blob_jump_min, blob_jump_px * pixel footprint)`.
    pub blob_jump_min: f32,
    pub blob_jump_px: f32,
    /// Physical area (m², the surface seen) a blob needs to be a person.
    pub min_person_area: f32,
    pub max_person_area: f32,
    /// Vertical extent a blob needs to be a person.
    pub min_person_height: f32,
    /// Largest horizontal extent of a person (arms spread).
    pub max_person_width: f32,

    // --- torso ---
    /// Torso region: pixels whose distance-transform value is at least this share of the
    /// maximum (seed Eq. 16.2, with the inequality the right way round).
    pub torso_dt_share: f32,
    /// Torso-region points nearer the camera than the region's median depth by more
    /// than this (a hand or forearm before the chest) are left out of its PCA.
    pub torso_front_band: f32,
    /// Mutual closest points farther apart than this are not correspondences (seed: 0.1 m).
    pub icp_max_dist: f32,
    pub icp_iterations: usize,
    /// Registration whose RMS residual exceeds this is redone from the PCA initialisation.
    pub icp_reinit_residual: f32,
    /// How far along its axis the registered torso may lie from the torso region's
    /// centre when the next frame's registration starts from it (0 = unbounded).
    pub max_torso_offset: f32,
    /// Turns (degrees, about the torso axis) of the PCA frame tried when registering
    /// afresh; the lowest residual wins (the first unless another is 10 % better).
    pub reinit_yaws: Vec<f32>,
    /// Turn the torso to face where the toes point when they disagree by over 45°.
    pub feet_facing: bool,
    /// A person found afresh whose torso core is narrower than this (half width,
    /// metres; [`crate::torso::TorsoFit::core_half_width`]) may be side-on: the
    /// articulated registration also races a standing body turned a quarter either
    /// way (0 = never).
    pub side_on_half_width: f32,
    /// Half-axes of the elliptic-cylinder torso model (lateral, front-back) and its
    /// vertical extent below/above the torso joint.
    pub torso_half_width: f32,
    pub torso_half_depth: f32,
    pub torso_bottom: f32,
    pub torso_top: f32,
    /// Key points in the torso frame: x = person's left, y = up, z = forward (out of the
    /// chest), origin the model's centre. Order: neck, pelvis, left shoulder, right
    /// shoulder, left hip, right hip, torso.
    pub torso_keypoints: [[f32; 3]; 7],
    /// Height of the top of the head above the torso frame's origin: the head's geodesic
    /// maximum fixes the torso's position along its axis (0 = off).
    pub head_top_height: f32,

    // --- geodesic graph ---
    /// 8-neighbours are joined when closer than `max(edge_min, edge_px * footprint)`
    /// (times √2 for diagonals).
    pub edge_min: f32,
    pub edge_px: f32,
    /// Longest bridge over occluding foreground, and how much nearer the camera the
    /// occluder must be.
    pub bridge_max: f32,
    pub bridge_occluder: f32,
    /// Components smaller than this many nodes are dropped rather than joined.
    pub min_component: usize,
    /// A geodesic maximum must be at least this far (geodesically) from every source
    /// found before it.
    pub min_extremity: f32,
    /// How many geodesic maxima to look for: the seed's five, plus spares, since the
    /// middle of a long leg can lie geodesically farther from every source than the top
    /// of the head; the assignment leaves the spares out.
    pub max_maxima: usize,

    // --- limbs ---
    /// Target points: within `d_e` of the geodesic path (seed Eq. 16.10).
    pub d_e_arm: f32,
    pub d_e_leg: f32,
    pub d_e_head: f32,
    /// Weight of successor-segment points in a parent rotation (seed: 0.05).
    pub omega_succ: f32,
    /// Weight of target points beyond the chain's end (fingers, toes).
    pub beyond_end_weight: f32,
    pub chain_iterations: usize,
    /// Bone lengths: upper arm, forearm (elbow to palm centre), thigh, shin, neck to head.
    pub upper_arm: f32,
    pub forearm: f32,
    pub thigh: f32,
    pub shin: f32,
    pub neck_to_head: f32,
    /// The seen surface lies in front of a limb's axis: target points are pushed back
    /// along their viewing ray by this much (arm, leg, head).
    pub surface_offset_arm: f32,
    pub surface_offset_leg: f32,
    pub surface_offset_head: f32,
    /// The hand joint (palm centre) this far behind the arm's extremity (fingertips),
    /// towards the elbow, instead of at the fitted chain's end; 0 = the chain's end.
    pub hand_behind_tip: f32,
    /// After the registration, each hand moves across its forearm to the centre of the
    /// forearm's points within this radius (metres; 0 = off), set back along the
    /// camera's ray by `hand_behind_surface` ([`crate::hands`]).
    pub hand_points_radius: f32,
    pub hand_behind_surface: f32,
    /// Cost of leaving a limb without a maximum in the assignment (metres of geodesic
    /// cost), and the weight of the distance to the limb's last extremity.
    pub unassigned_cost: f32,
    /// Extra cost, for the arms and legs, of a maximum that lies beside the geodesic
    /// path of a farther one (a bent elbow or knee beside the path to the hand or foot).
    pub dominated_cost: f32,
    /// Cost per metre a head candidate lies sideways off the torso's axis (beyond 8 cm).
    pub head_off_axis_weight: f32,
    /// An arm's geodesic path that passes its shoulder no nearer than this is taken to
    /// reach the torso some hidden way (a hand against the hip); such a candidate costs
    /// `hidden_root_cost` plus how far it lies beyond the arm's reach. 0 = off.
    pub hidden_root_gap: f32,
    pub hidden_root_cost: f32,
    pub temporal_weight: f32,
    /// Confidence multiplier per frame for a limb that keeps its last fit.
    pub occluded_decay: f32,

    // --- smoothing over time ---
    /// One Euro filter of every joint coordinate: cut-off at rest (Hz; 0 = off), its
    /// rise with speed (per m/s), and the cut-off of the speed estimate that opens it.
    pub smoothing_min_cutoff: f64,
    pub smoothing_beta: f64,
    pub smoothing_d_cutoff: f64,
    /// Frame rate [`crate::PoseEstimator::estimate`] assumes between calls.
    pub nominal_fps: f64,

    // --- body-size calibration ---
    /// Learn the person's arm and leg lengths from the geodesic lengths of their limbs
    /// ([`crate::calibrate`]) instead of keeping the bone lengths above.
    pub calibrate_body: bool,
    /// What that measurement gives on the body the bone lengths above were measured on
    /// (arms, legs): the geodesic path over the surface, fingers and toes is longer
    /// than the bones. Measured on the MakeHuman body standing, drawing and walking.
    pub geodesic_reach_ratio: [f32; 2],

    // --- articulated registration (beyond the seed) ---
    pub register: RegisterConfig,
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            work_width: 320,
            near: 0.3,
            far: 6.0,
            remove_floor: true,
            floor_margin: 0.03,
            blob_jump_min: 0.15,
            blob_jump_px: 20.0,
            min_person_area: 0.05,
            max_person_area: 2.0,
            min_person_height: 0.4,
            max_person_width: 2.4,

            torso_dt_share: 0.5,
            torso_front_band: 0.12,
            icp_max_dist: 0.1,
            icp_iterations: 12,
            icp_reinit_residual: 0.035,
            max_torso_offset: 0.09,
            reinit_yaws: vec![0.0],
            feet_facing: true,
            side_on_half_width: 0.125,
            torso_half_width: 0.16,
            torso_half_depth: 0.11,
            torso_bottom: -0.30,
            torso_top: 0.20,
            // Measured on the MakeHuman body of airglyph-synth (the evaluation's body),
            // standing, in the frame the head-top anchor fixes; symmetrised.
            torso_keypoints: [
                [0.0, 0.356, -0.071],    // neck
                [0.0, -0.181, -0.038],   // pelvis
                [0.178, 0.29, -0.005],   // left shoulder
                [-0.178, 0.29, -0.005],  // right shoulder
                [0.11, -0.181, -0.039],  // left hip
                [-0.11, -0.181, -0.039], // right hip
                [0.0, 0.262, -0.074],    // torso
            ],

            head_top_height: 0.60,
            edge_min: 0.012,
            edge_px: 3.0,
            bridge_max: 0.35,
            bridge_occluder: 0.05,
            min_component: 20,
            min_extremity: 0.12,
            max_maxima: 8,

            d_e_arm: 0.05,
            d_e_leg: 0.10,
            d_e_head: 0.10,
            omega_succ: 0.05,
            beyond_end_weight: 0.1,
            chain_iterations: 12,
            upper_arm: 0.227,
            forearm: 0.272,
            thigh: 0.42,
            shin: 0.382,
            neck_to_head: 0.104,
            surface_offset_arm: 0.03,
            surface_offset_leg: 0.065,
            surface_offset_head: 0.07,
            hand_behind_tip: 0.11,
            hand_points_radius: 0.10,
            hand_behind_surface: 0.018,
            unassigned_cost: 1.2,
            dominated_cost: 0.3,
            head_off_axis_weight: 5.0,
            hidden_root_gap: 0.12,
            hidden_root_cost: 0.3,
            temporal_weight: 0.3,
            occluded_decay: 0.7,
            smoothing_min_cutoff: 3.0,
            smoothing_beta: 5.0,
            // The One Euro paper's 1 Hz lets the speed estimate trail a jump's onset by
            // several frames, the filter still closed while the body moves at 2 m/s:
            // CMU 01_01 with sensor noise 4.43 → 4.20 cm, 96.8 → 97.5 % within 10 cm,
            // 01_03 with noise 4.54 → 4.50 cm. A still joint jitters no more (median
            // second difference 0.39 mm a frame either way; 0.77 mm unsmoothed).
            smoothing_d_cutoff: 5.0,
            nominal_fps: 30.0,
            calibrate_body: true,
            geodesic_reach_ratio: [1.32, 1.21],
            register: RegisterConfig::default(),
        }
    }
}

/// The five limbs, each a chain from a torso key point to an extremity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limb {
    Head,
    LeftArm,
    RightArm,
    LeftLeg,
    RightLeg,
}

impl Limb {
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

    pub fn index(self) -> usize {
        self as usize
    }
}

impl PoseConfig {
    /// Bone lengths (root→middle, middle→end) of a limb; the head has one bone.
    pub fn bones(&self, limb: Limb) -> (f32, f32) {
        match limb {
            Limb::Head => (self.neck_to_head, 0.0),
            Limb::LeftArm | Limb::RightArm => (self.upper_arm, self.forearm),
            Limb::LeftLeg | Limb::RightLeg => (self.thigh, self.shin),
        }
    }

    /// Geodesic length beyond the end joint: fingers past the palm centre, the foot
    /// past the ankle, the skull's top past its centre.
    pub fn extremity_extra(&self, limb: Limb) -> f32 {
        match limb {
            Limb::Head => 0.10,
            Limb::LeftArm | Limb::RightArm => 0.10,
            Limb::LeftLeg | Limb::RightLeg => 0.12,
        }
    }

    pub fn d_e(&self, limb: Limb) -> f32 {
        match limb {
            Limb::Head => self.d_e_head,
            Limb::LeftArm | Limb::RightArm => self.d_e_arm,
            Limb::LeftLeg | Limb::RightLeg => self.d_e_leg,
        }
    }

    pub fn surface_offset(&self, limb: Limb) -> f32 {
        match limb {
            Limb::Head => self.surface_offset_head,
            Limb::LeftArm | Limb::RightArm => self.surface_offset_arm,
            Limb::LeftLeg | Limb::RightLeg => self.surface_offset_leg,
        }
    }

    /// The rest direction of a limb in the torso frame, for a first fit with no data.
    pub fn rest_direction(&self, limb: Limb) -> Vector3<f32> {
        match limb {
            Limb::Head => Vector3::y(),
            Limb::LeftArm => Vector3::new(0.2, -1.0, 0.0).normalize(),
            Limb::RightArm => Vector3::new(-0.2, -1.0, 0.0).normalize(),
            Limb::LeftLeg | Limb::RightLeg => -Vector3::y(),
        }
    }
}
