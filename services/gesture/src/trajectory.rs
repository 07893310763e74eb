//! A trajectory as the classifiers see it: 2-D points, optionally with a depth for each,
//! with the hand's travel between two pen strokes marked.

/// One 2-D point of a trajectory (x right, y down).
pub type Point = [f32; 2];

/// One 3-D point of a trajectory: x right, y down, z towards the camera (where the
/// person faces).
pub type Point3 = [f32; 3];

/// A trajectory as the classifiers see it: points with a pen-up flag that marks the
/// hand's travel between two strokes (air-drawn gestures have no pen; the flag is
/// `false` for every point of a continuous hand trajectory), and for trajectories
/// tracked in 3-D the depth of every point.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// The points, in the order drawn.
    pub points: Vec<Point>,
    /// `pen_up[i]` is true when the segment ending at point `i` is travel between strokes.
    pub pen_up: Vec<bool>,
    /// The depth of every point (z towards the camera, in the points' unit), or None
    /// for pen data and everything else drawn on a plane. A classifier trained on
    /// depth reads its absence as a flat gesture (z = 0); one trained without reads
    /// `points` only, so 2-D data gives what it gave before depth existed.
    pub depth: Option<Vec<f32>>,
}

impl Trajectory {
    /// A continuous trajectory (no pen-up travel).
    pub fn from_points(points: Vec<Point>) -> Self {
        let pen_up = vec![false; points.len()];
        Self {
            points,
            pen_up,
            depth: None,
        }
    }

    /// A continuous trajectory in 3-D.
    pub fn from_points3(points: &[Point3]) -> Self {
        Self::from_points(points.iter().map(|p| [p[0], p[1]]).collect())
            .with_depth(points.iter().map(|p| p[2]).collect())
    }

    /// The strokes joined by straight travel from each stroke's end to the next start.
    pub fn from_strokes(strokes: &[Vec<Point>]) -> Self {
        let mut t = Trajectory::default();
        for (si, s) in strokes.iter().enumerate() {
            for (pi, p) in s.iter().enumerate() {
                t.points.push(*p);
                t.pen_up.push(si > 0 && pi == 0);
            }
        }
        t
    }

    /// The same points with a depth each.
    ///
    /// # Panics
    /// When `depth` has not one value a point: a caller's error, not the data's (the
    /// readers of data check it first).
    pub fn with_depth(mut self, depth: Vec<f32>) -> Self {
        assert_eq!(depth.len(), self.points.len(), "one depth a point");
        self.depth = Some(depth);
        self
    }

    /// The same trajectory without its depth: what a 2-D camera or a pen would see.
    pub fn flattened(&self) -> Self {
        Self {
            depth: None,
            ..self.clone()
        }
    }

    /// Whether it has a depth for its points.
    pub fn has_depth(&self) -> bool {
        self.depth.is_some()
    }

    /// The points in 3-D (z = 0 without depth).
    pub fn points3(&self) -> Vec<Point3> {
        let z = |i: usize| self.depth.as_ref().and_then(|d| d.get(i)).copied();
        self.points
            .iter()
            .enumerate()
            .map(|(i, p)| [p[0], p[1], z(i).unwrap_or(0.0)])
            .collect()
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether it has no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_is_carried_and_dropped() {
        let t = Trajectory::from_points3(&[[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]);
        assert!(t.has_depth());
        assert_eq!(t.points, vec![[0.0, 1.0], [3.0, 4.0]]);
        assert_eq!(t.points3()[1], [3.0, 4.0, 5.0]);
        let flat = t.flattened();
        assert!(!flat.has_depth());
        assert_eq!(flat.points3()[1], [3.0, 4.0, 0.0]);
        assert_eq!(flat, Trajectory::from_points(t.points.clone()));
    }
}
