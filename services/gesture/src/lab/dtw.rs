//! The template baseline: dynamic time warping 1-nearest-neighbour over every training
//! sample (trajectories resampled to equal arc length and normalized).

use crate::dtw::nearest;
use crate::features::resample;
use crate::trajectory::Trajectory;

/// Templates: resampled, normalized point sequences with their class index.
#[derive(Debug, Clone, Default)]
pub struct DtwClassifier {
    /// Points every trajectory is resampled to.
    pub points: usize,
    /// Sakoe–Chiba band half-width in samples.
    pub band: usize,
    /// Every training sample, resampled, with its class.
    pub templates: Vec<(Vec<[f32; 2]>, usize)>,
}

impl DtwClassifier {
    /// A classifier without templates yet.
    pub fn new(points: usize, band: usize) -> Self {
        Self {
            points,
            band,
            templates: Vec::new(),
        }
    }

    /// Adds a training sample of class `class`.
    pub fn add(&mut self, t: &Trajectory, class: usize) {
        self.templates
            .push((resample(t, self.points).points, class));
    }

    /// The class of the nearest template (None without templates).
    pub fn classify(&self, t: &Trajectory) -> Option<usize> {
        let q = resample(t, self.points).points;
        nearest(&q, &self.templates, self.band)
    }
}
