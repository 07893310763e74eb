//! Observations beyond the seed: the trajectory normalized in position and scale,
//! resampled to equal arc length, and fixed-length feature vectors (normalized x/y,
//! direction as sin/cos, pen-up flag, 8-direction feature maps on a coarse grid); with
//! depth, their 3-D counterparts (`features3d`).

use crate::trajectory::{Point, Trajectory};
use serde::{Deserialize, Serialize};

/// A trajectory resampled at equal arc length, normalized: centred on its bounding box
/// and divided by its larger side (aspect ratio kept).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Resampled {
    /// The points, normalized.
    pub points: Vec<[f32; 2]>,
    /// For each point, whether the path reached it by pen-up travel.
    pub pen_up: Vec<bool>,
    /// Height / width of the bounding box before normalization (clamped).
    pub aspect: f32,
}

/// The bounding box (x0, y0, x1, y1) of 2D points.
pub(crate) fn bbox<'a>(points: impl IntoIterator<Item = &'a Point>) -> (f32, f32, f32, f32) {
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in points {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    (x0, y0, x1, y1)
}

/// The path's length from its first point to each of its points.
pub(crate) fn arc_lengths(pts: &[[f32; 2]]) -> Vec<f32> {
    let mut cum = Vec::with_capacity(pts.len());
    let mut total = 0.0f32;
    for (i, p) in pts.iter().enumerate() {
        if i > 0 {
            let q = pts[i - 1];
            total += ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
        }
        cum.push(total);
    }
    cum
}

/// Where arc length `target` falls on a path of at least two points whose
/// [`arc_lengths`] are `cum`: `seg` becomes the point after it, and the result is how
/// far along the span from the point before (0 to 1; 0 on a span of no length). The
/// search starts at `seg` (at least 1), so increasing targets walk the path once.
pub(crate) fn locate(cum: &[f32], target: f32, seg: &mut usize) -> f32 {
    while *seg < cum.len() - 1 && cum[*seg] < target {
        *seg += 1;
    }
    let len = cum[*seg] - cum[*seg - 1];
    if len > 0.0 {
        ((target - cum[*seg - 1]) / len).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Resamples to `n` points at equal arc length (pen-up travel included) and normalizes.
pub fn resample(t: &Trajectory, n: usize) -> Resampled {
    let n = n.max(2);
    if t.points.is_empty() {
        return Resampled {
            points: vec![[0.0, 0.0]; n],
            pen_up: vec![false; n],
            aspect: 1.0,
        };
    }
    let (x0, y0, x1, y1) = bbox(&t.points);
    let (w, h) = (x1 - x0, y1 - y0);
    let s = w.max(h).max(1e-6);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let pts: Vec<[f32; 2]> = t
        .points
        .iter()
        .map(|p| [(p[0] - cx) / s, (p[1] - cy) / s])
        .collect();
    let cum = arc_lengths(&pts);
    let total = *cum.last().unwrap_or(&0.0);
    let mut out = Vec::with_capacity(n);
    let mut up = Vec::with_capacity(n);
    let mut seg = 1usize;
    for k in 0..n {
        let target = total * k as f32 / (n - 1) as f32;
        if total <= 0.0 || pts.len() == 1 {
            out.push(pts[0]);
            up.push(false);
            continue;
        }
        let f = locate(&cum, target, &mut seg);
        let (a, b) = (pts[seg - 1], pts[seg]);
        out.push([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
        up.push(t.pen_up.get(seg).copied().unwrap_or(false));
    }
    Resampled {
        points: out,
        pen_up: up,
        aspect: (h.max(1e-6) / w.max(1e-6)).clamp(0.05, 20.0),
    }
}

/// Settings of the fixed-length feature vector.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FeatureConfig {
    /// Points of the resampled trajectory.
    pub points: usize,
    /// Grid cells per side of the direction feature maps (0 = none).
    pub grid: usize,
    /// Use the pen-up flag (false for air-drawn gestures without pen information).
    pub pen_up: bool,
    /// Read the trajectory's depth (`features3d`): what a model trained on 3-D data
    /// sees. Absent from model files of 2-D models, which stay as they were.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub depth: bool,
}

impl Default for FeatureConfig {
    fn default() -> Self {
        Self {
            points: 32,
            grid: 6,
            pen_up: false,
            depth: false,
        }
    }
}

impl FeatureConfig {
    /// The feature vector's length. Saturates instead of wrapping: a size that
    /// overflows never matches a network's input count (see [`FeatureConfig::validate`]).
    pub fn dim(&self) -> usize {
        if self.depth {
            return crate::features3d::dim(self.points, self.grid);
        }
        self.points
            .saturating_mul(5)
            .saturating_add(8usize.saturating_mul(self.grid).saturating_mul(self.grid))
            .saturating_add(2)
    }

    /// Points and grid within [`crate::limits`]; `what` names the settings in errors.
    pub fn validate(&self, what: &str) -> Result<(), String> {
        use crate::limits::{within, MAX_FEATURE_POINTS, MAX_GRID};
        within(
            &format!("{what}.points"),
            self.points,
            2,
            MAX_FEATURE_POINTS,
        )?;
        within(&format!("{what}.grid"), self.grid, 0, MAX_GRID)?;
        Ok(())
    }
}

/// The feature vector of a trajectory (length `cfg.dim()`).
pub fn feature_vector(t: &Trajectory, cfg: &FeatureConfig, out: &mut Vec<f32>) {
    if cfg.depth {
        return crate::features3d::feature_vector3(t, cfg.points, cfg.grid, cfg.pen_up, out);
    }
    out.clear();
    let r = resample(t, cfg.points);
    let n = r.points.len();
    for i in 0..n {
        let p = r.points[i];
        let a = r.points[i.saturating_sub(1)];
        let b = r.points[(i + 1).min(n - 1)];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let l = (dx * dx + dy * dy).sqrt();
        let (c, s) = if l > 1e-6 {
            (dx / l, dy / l)
        } else {
            (0.0, 0.0)
        };
        let up = if cfg.pen_up && r.pen_up[i] { 1.0 } else { 0.0 };
        out.extend_from_slice(&[p[0] * 2.0, p[1] * 2.0, c, s, up]);
    }
    if cfg.grid > 0 {
        let g = cfg.grid;
        let base = out.len();
        out.resize(base + 8 * g * g, 0.0);
        // A finer resampling for the direction maps.
        let fine = resample(t, 64);
        let m = fine.points.len();
        for i in 1..m {
            let (a, b) = (fine.points[i - 1], fine.points[i]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let l = (dx * dx + dy * dy).sqrt();
            if l < 1e-7 {
                continue;
            }
            let w = if fine.pen_up[i] && cfg.pen_up {
                0.5
            } else {
                1.0
            };
            // Direction split between the two nearest of 8 bins.
            let mut ang = dy.atan2(dx);
            if ang < 0.0 {
                ang += std::f32::consts::TAU;
            }
            let fb = ang / (std::f32::consts::TAU / 8.0);
            let b0 = fb.floor() as usize % 8;
            let b1 = (b0 + 1) % 8;
            let fa = fb - fb.floor();
            // Position split bilinearly between grid cells; coordinates in [-0.5, 0.5].
            let mx = ((a[0] + b[0]) / 2.0 + 0.5) * g as f32 - 0.5;
            let my = ((a[1] + b[1]) / 2.0 + 0.5) * g as f32 - 0.5;
            let gx0 = mx.floor();
            let gy0 = my.floor();
            let (fx, fy) = (mx - gx0, my - gy0);
            for (cy, wy) in [(gy0, 1.0 - fy), (gy0 + 1.0, fy)] {
                for (cx, wx) in [(gx0, 1.0 - fx), (gx0 + 1.0, fx)] {
                    if cx < 0.0 || cy < 0.0 || cx >= g as f32 || cy >= g as f32 {
                        continue;
                    }
                    let cell = cy as usize * g + cx as usize;
                    let v = w * l * wx * wy;
                    out[base + b0 * g * g + cell] += v * (1.0 - fa);
                    out[base + b1 * g * g + cell] += v * fa;
                }
            }
        }
        for v in &mut out[base..] {
            *v = (*v * g as f32).sqrt();
        }
    }
    out.push(r.aspect.ln() / 2.0);
    out.push(if t.pen_up.iter().any(|&u| u) && cfg.pen_up {
        1.0
    } else {
        0.0
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resample_is_equal_arc_length_and_normalized() {
        let t = Trajectory::from_points(vec![[0.0, 0.0], [10.0, 0.0], [10.0, 30.0]]);
        let r = resample(&t, 9);
        assert_eq!(r.points.len(), 9);
        let d: Vec<f32> = r
            .points
            .windows(2)
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .collect();
        for x in &d {
            assert!((x - d[0]).abs() < 1e-4, "{d:?}");
        }
        let maxc = r
            .points
            .iter()
            .flat_map(|p| p.iter())
            .fold(0.0f32, |m, v| m.max(v.abs()));
        assert!((maxc - 0.5).abs() < 1e-5);
        assert!((r.aspect - 3.0).abs() < 1e-5);
    }

    #[test]
    fn feature_vector_has_its_dimension_and_is_scale_invariant() {
        let cfg = FeatureConfig::default();
        let pts: Vec<Point> = (0..50)
            .map(|i| {
                let a = i as f32 / 49.0 * 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        let big: Vec<Point> = pts
            .iter()
            .map(|p| [p[0] * 300.0 + 7.0, p[1] * 300.0])
            .collect();
        let (mut f1, mut f2) = (Vec::new(), Vec::new());
        feature_vector(&Trajectory::from_points(pts), &cfg, &mut f1);
        feature_vector(&Trajectory::from_points(big), &cfg, &mut f2);
        assert_eq!(f1.len(), cfg.dim());
        for (a, b) in f1.iter().zip(&f2) {
            assert!((a - b).abs() < 1e-3);
        }
    }
}
