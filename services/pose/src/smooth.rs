//! The joints smoothed over time by the One Euro filter (airglyph-core): still joints
//! stop jittering with the sensor's noise, moving ones keep up.

use airglyph_core::filter::OneEuro;
use airglyph_core::{Joint, Skeleton};
use serde::{Deserialize, Serialize};

/// Settings of the One Euro filter of every joint coordinate (part of
/// [`crate::PoseConfig`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SmoothingConfig {
    /// Cut-off at rest, Hz; 0 = no smoothing.
    pub min_cutoff: f64,
    /// The cut-off's rise with speed, per m/s.
    pub beta: f64,
    /// The cut-off of the speed estimate that opens the filter, Hz. The One Euro
    /// paper's 1 Hz lets the speed estimate trail a jump's onset by several frames, the
    /// filter still closed while the body moves fast (pose NOTES, 2026-12-02).
    pub d_cutoff: f64,
}

impl Default for SmoothingConfig {
    fn default() -> Self {
        Self {
            min_cutoff: 3.0,
            beta: 5.0,
            d_cutoff: 5.0,
        }
    }
}

/// One filter per joint coordinate, made at the first frame smoothed.
#[derive(Debug, Clone, Default)]
pub struct Smoother {
    filters: Vec<[OneEuro; 3]>,
}

impl Smoother {
    /// The joints of `s`, taken at `t` seconds, filtered over time: still joints stop
    /// jittering with the sensor's noise, moving ones keep up.
    pub fn smooth(&mut self, mut s: Skeleton, t: f64, cfg: &SmoothingConfig) -> Skeleton {
        let (fc, beta) = (cfg.min_cutoff, cfg.beta);
        if fc <= 0.0 {
            return s;
        }
        if self.filters.len() != Joint::COUNT {
            let f = OneEuro::new(fc, beta, cfg.d_cutoff);
            self.filters = vec![[f.clone(), f.clone(), f]; Joint::COUNT];
        }
        for (p, f) in s.joints.iter_mut().zip(&mut self.filters) {
            for (c, fi) in f.iter_mut().enumerate() {
                p[c] = fi.filter(p[c] as f64, t) as f32;
            }
        }
        s
    }
}
