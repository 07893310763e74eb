//! The template baseline for trajectories with depth: DTW 1-nearest-neighbour over every
//! training sample, as [`super::dtw`] but on points in space (resampled to equal arc
//! length in space, centred on their box and divided by its largest side).

use crate::dtw::nearest;
use crate::features3d::resample3;
use crate::trajectory::{Point3, Trajectory};

/// Templates: resampled, normalized 3-D point sequences with their class index.
#[derive(Debug, Clone, Default)]
pub struct Dtw3dClassifier {
    /// Points every trajectory is resampled to.
    pub points: usize,
    /// Sakoe–Chiba band half-width in samples.
    pub band: usize,
    /// Every training sample, resampled, with its class.
    pub templates: Vec<(Vec<Point3>, usize)>,
}

impl Dtw3dClassifier {
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
        self.templates.push((self.resampled(t), class));
    }

    /// The points as the templates hold them: resampled in space and normalized, as the
    /// 3-D features have them.
    fn resampled(&self, t: &Trajectory) -> Vec<Point3> {
        resample3(t, self.points).points
    }

    /// The class of the nearest template (None without templates).
    pub fn classify(&self, t: &Trajectory) -> Option<usize> {
        let q = self.resampled(t);
        nearest(&q, &self.templates, self.band)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_push_and_a_pull_are_told_apart_by_depth_alone() {
        let line = |dz: f32| -> Trajectory {
            let pts: Vec<Point3> = (0..20).map(|i| [0.0, 0.0, dz * i as f32]).collect();
            Trajectory::from_points3(&pts)
        };
        let mut d = Dtw3dClassifier::new(16, 3);
        d.add(&line(1.0), 0);
        d.add(&line(-1.0), 1);
        assert_eq!(d.classify(&line(0.5)), Some(0));
        assert_eq!(d.classify(&line(-2.0)), Some(1));
        assert_eq!(Dtw3dClassifier::new(16, 3).classify(&line(1.0)), None);
    }
}
