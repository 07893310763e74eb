//! A trajectory as the classifiers see it: 2-D points, with the hand's travel between
//! two pen strokes marked.

/// One 2-D point of a trajectory (x right, y down).
pub type Point = [f32; 2];

/// A trajectory as the classifiers see it: points with a pen-up flag that marks the
/// hand's travel between two strokes (air-drawn gestures have no pen; the flag is
/// `false` for every point of a continuous hand trajectory).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// The points, in the order drawn.
    pub points: Vec<Point>,
    /// `pen_up[i]` is true when the segment ending at point `i` is travel between strokes.
    pub pen_up: Vec<bool>,
}

impl Trajectory {
    /// A continuous trajectory (no pen-up travel).
    pub fn from_points(points: Vec<Point>) -> Self {
        let pen_up = vec![false; points.len()];
        Self { points, pen_up }
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

    /// The number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether it has no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}
