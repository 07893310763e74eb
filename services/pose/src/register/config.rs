//! The registration's settings, one section a part of it. Each section's type is the
//! part's own, and each part is handed its section alone, never the whole: this module
//! only gathers them, and no part whose section it gathers depends on it.

pub use super::energy::EnergyConfig;
pub use super::priors::PriorsConfig;
pub use super::sampling::SamplingConfig;
pub use super::solver::{LengthsConfig, SolverConfig};
pub use super::tips::RaceConfig;
use crate::body::Shape;

/// Settings of the registration (part of [`crate::PoseConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RegisterConfig {
    /// Fit the articulated body after the geodesic estimate (false: the seed's chains).
    pub enabled: bool,
    /// The person points the data term takes.
    pub sampling: SamplingConfig,
    /// The Gauss–Newton steps.
    pub solver: SolverConfig,
    /// The energy's terms.
    pub energy: EnergyConfig,
    /// The priors on the joints' turns.
    pub priors: PriorsConfig,
    /// When the seed's estimate races the tracked body.
    pub race: RaceConfig,
    /// What the fits tell of the person's limb lengths.
    pub lengths: LengthsConfig,
    /// The body's shape (bone lengths come from [`crate::config::BodyConfig`]).
    pub shape: Shape,
}

impl Default for RegisterConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            sampling: SamplingConfig::default(),
            solver: SolverConfig::default(),
            energy: EnergyConfig::default(),
            priors: PriorsConfig::default(),
            race: RaceConfig::default(),
            lengths: LengthsConfig::default(),
            shape: Shape::makehuman(),
        }
    }
}
