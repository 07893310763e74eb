//! Every tunable number of the estimator, with the seed's values where it gives them,
//! grouped by the step that reads it. Each group's type is defined in its step's module
//! and re-exported here. A step is handed the sections it reads, never the whole
//! [`PoseConfig`] (only the estimator holds that): this module gathers the steps'
//! types, so a step naming it would make the two depend on each other
//! (`scripts/check-imports`).

pub use crate::assign::AssignConfig;
pub use crate::body::BodyConfig;
pub use crate::calibrate::CalibrateConfig;
pub use crate::chains::ChainConfig;
pub use crate::geodesic::GeodesicConfig;
pub use crate::graph::GraphConfig;
pub use crate::hands::HandsConfig;
pub use crate::head_top::HeadConfig;
pub use crate::register::{
    EnergyConfig, LengthsConfig, PriorsConfig, RaceConfig, RegisterConfig, SamplingConfig,
    SolverConfig,
};
pub use crate::segment::SegmentConfig;
pub use crate::smooth::SmoothingConfig;
pub use crate::torso::{TorsoConfig, TorsoPoints};
// Kept at its old path, `airglyph_pose::config::Limb`; the type lives in `limb.rs`.
pub use crate::limb::Limb;
use serde::{Deserialize, Serialize};

/// Settings of [`crate::PoseEstimator`]. `PoseConfig::default()` is what the pose stage
/// and the evaluation use; all lengths are metres. In JSON (serde) every section and
/// field may be left out for its default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PoseConfig {
    /// Frames wider than this are reduced by an integer factor (each block's nearest
    /// depth) before estimation, so 640×480 costs about what 320×240 does; 0 = never.
    pub work_width: u32,
    /// Frame rate [`crate::PoseEstimator::estimate`] assumes between calls.
    pub nominal_fps: f64,
    /// Step 1: the person's pixels.
    pub segment: SegmentConfig,
    /// Step 2: the torso (distance transform, PCA, torso model registration).
    pub torso: TorsoConfig,
    /// Step 3: the geodesic graph.
    pub graph: GraphConfig,
    /// Step 4: the geodesic maxima.
    pub geodesic: GeodesicConfig,
    /// Step 5: the maxima given to the limbs.
    pub assign: AssignConfig,
    /// Step 6: the seed's two-joint chains.
    pub chains: ChainConfig,
    /// Step 7: the articulated registration (beyond the seed).
    pub register: RegisterConfig,
    /// Where the hands go once the body is fitted.
    pub hands: HandsConfig,
    /// Where the head joint (the top of the head) goes once the body is fitted.
    pub head: HeadConfig,
    /// The bone lengths of the body fitted.
    pub body: BodyConfig,
    /// Learning the person's limb lengths.
    pub calibrate: CalibrateConfig,
    /// The joints' smoothing over time.
    pub smoothing: SmoothingConfig,
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            work_width: 320,
            nominal_fps: 30.0,
            segment: SegmentConfig::default(),
            torso: TorsoConfig::default(),
            graph: GraphConfig::default(),
            geodesic: GeodesicConfig::default(),
            assign: AssignConfig::default(),
            chains: ChainConfig::default(),
            register: RegisterConfig::default(),
            hands: HandsConfig::default(),
            head: HeadConfig::default(),
            body: BodyConfig::default(),
            calibrate: CalibrateConfig::default(),
            smoothing: SmoothingConfig::default(),
        }
    }
}
