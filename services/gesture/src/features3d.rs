//! The default classifier's input for trajectories with depth: the 2-D features'
//! counterpart in 3-D — resampled at equal arc length in space, normalized by the
//! larger side of the box in space, positions and unit directions in x, y and z, and
//! direction maps on the frontal grid that also say how far the hand went towards and
//! away from the camera in each cell.
//!
//! Kept apart from `features` (which calls it for a configuration with depth), so
//! that the 2-D features stay the code they were: models trained on pen data give
//! exactly what they gave.

use crate::trajectory::{Point3, Trajectory};

/// The direction maps' bins: 8 directions in the frontal plane, then towards the
/// camera and away from it.
const BINS: usize = 10;

/// The feature vector's length for `points` resampled points and a `grid` × `grid`
/// map: 7 a point, 10 maps, the aspect, the pen-up flag, the depth's share and the way
/// from the first point to the last.
pub(crate) fn dim(points: usize, grid: usize) -> usize {
    points
        .saturating_mul(7)
        .saturating_add(BINS.saturating_mul(grid).saturating_mul(grid))
        .saturating_add(6)
}

/// The bounding box (lowest and highest corner) of points in space.
pub(crate) fn bbox3<'a>(points: impl IntoIterator<Item = &'a Point3>) -> (Point3, Point3) {
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// A trajectory in space resampled to `n` points of equal arc length, centred on its
/// box and divided by the box's largest side.
pub(crate) struct Resampled3 {
    pub(crate) points: Vec<Point3>,
    pen_up: Vec<bool>,
    /// Sides of the box before normalization.
    sides: [f32; 3],
}

pub(crate) fn resample3(t: &Trajectory, n: usize) -> Resampled3 {
    let n = n.max(2);
    let raw = t.points3();
    if raw.is_empty() {
        return Resampled3 {
            points: vec![[0.0; 3]; n],
            pen_up: vec![false; n],
            sides: [0.0; 3],
        };
    }
    let (lo, hi) = bbox3(&raw);
    let sides = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let s = sides[0].max(sides[1]).max(sides[2]).max(1e-6);
    let c = [0, 1, 2].map(|k| (lo[k] + hi[k]) / 2.0);
    let pts: Vec<Point3> = raw
        .iter()
        .map(|p| [0, 1, 2].map(|k| (p[k] - c[k]) / s))
        .collect();
    let mut cum = Vec::with_capacity(pts.len());
    let mut total = 0.0f32;
    for (i, p) in pts.iter().enumerate() {
        if i > 0 {
            total += dist(&pts[i - 1], p);
        }
        cum.push(total);
    }
    let mut out = Vec::with_capacity(n);
    let mut up = Vec::with_capacity(n);
    let mut seg = 1usize;
    for k in 0..n {
        if total <= 0.0 || pts.len() == 1 {
            out.push(pts[0]);
            up.push(false);
            continue;
        }
        let target = total * k as f32 / (n - 1) as f32;
        while seg < cum.len() - 1 && cum[seg] < target {
            seg += 1;
        }
        let len = cum[seg] - cum[seg - 1];
        let f = if len > 0.0 {
            ((target - cum[seg - 1]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (a, b) = (pts[seg - 1], pts[seg]);
        out.push([0, 1, 2].map(|i| a[i] + f * (b[i] - a[i])));
        up.push(t.pen_up.get(seg).copied().unwrap_or(false));
    }
    Resampled3 {
        points: out,
        pen_up: up,
        sides,
    }
}

fn dist(a: &Point3, b: &Point3) -> f32 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
}

/// The 3-D feature vector (length [`dim`]) of `t`: `points` resampled points, a
/// `grid` × `grid` direction map, the pen-up flag when `use_pen` (see the 2-D
/// features' `FeatureConfig`).
pub(crate) fn feature_vector3(
    t: &Trajectory,
    points: usize,
    grid: usize,
    use_pen: bool,
    out: &mut Vec<f32>,
) {
    out.clear();
    let r = resample3(t, points);
    let n = r.points.len();
    for i in 0..n {
        let p = r.points[i];
        let (a, b) = (r.points[i.saturating_sub(1)], r.points[(i + 1).min(n - 1)]);
        let l = dist(&a, &b);
        let d = if l > 1e-6 {
            [0, 1, 2].map(|k| (b[k] - a[k]) / l)
        } else {
            [0.0; 3]
        };
        let up = if use_pen && r.pen_up[i] { 1.0 } else { 0.0 };
        out.extend_from_slice(&[p[0] * 2.0, p[1] * 2.0, p[2] * 2.0, d[0], d[1], d[2], up]);
    }
    if grid > 0 {
        let g = grid;
        let base = out.len();
        out.resize(base + BINS * g * g, 0.0);
        let fine = resample3(t, 64);
        for i in 1..fine.points.len() {
            let (a, b) = (fine.points[i - 1], fine.points[i]);
            let (dx, dy, dz) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
            let plane = (dx * dx + dy * dy).sqrt();
            if plane + dz.abs() < 1e-7 {
                continue;
            }
            let w = if fine.pen_up[i] && use_pen { 0.5 } else { 1.0 };
            // The frontal part of the step split between the two nearest of 8
            // directions, as the 2-D maps do; its depth part in a bin of its own.
            let mut ang = dy.atan2(dx);
            if ang < 0.0 {
                ang += std::f32::consts::TAU;
            }
            let fb = ang / (std::f32::consts::TAU / 8.0);
            let b0 = fb.floor() as usize % 8;
            let b1 = (b0 + 1) % 8;
            let fa = fb - fb.floor();
            let zbin = if dz > 0.0 { 8 } else { 9 };
            let mx = ((a[0] + b[0]) / 2.0 + 0.5) * g as f32 - 0.5;
            let my = ((a[1] + b[1]) / 2.0 + 0.5) * g as f32 - 0.5;
            let (gx0, gy0) = (mx.floor(), my.floor());
            let (fx, fy) = (mx - gx0, my - gy0);
            for (cy, wy) in [(gy0, 1.0 - fy), (gy0 + 1.0, fy)] {
                for (cx, wx) in [(gx0, 1.0 - fx), (gx0 + 1.0, fx)] {
                    if cx < 0.0 || cy < 0.0 || cx >= g as f32 || cy >= g as f32 {
                        continue;
                    }
                    let cell = cy as usize * g + cx as usize;
                    let v = w * wx * wy;
                    out[base + b0 * g * g + cell] += v * plane * (1.0 - fa);
                    out[base + b1 * g * g + cell] += v * plane * fa;
                    out[base + zbin * g * g + cell] += v * dz.abs();
                }
            }
        }
        for v in &mut out[base..] {
            *v = (*v * g as f32).sqrt();
        }
    }
    let [w, h, d] = r.sides;
    let larger = w.max(h).max(1e-6);
    out.push((h.max(1e-6) / w.max(1e-6)).clamp(0.05, 20.0).ln() / 2.0);
    out.push(if use_pen && t.pen_up.iter().any(|&u| u) {
        1.0
    } else {
        0.0
    });
    // How deep it is for its frontal size: 0 for a flat symbol, large for a push.
    out.push((d / larger).min(20.0).ln_1p());
    // Where it ends from where it starts: a helix ends nearer the camera than it began,
    // a circle tilted as much in depth ends where it began.
    let (first, last) = (r.points[0], r.points[n - 1]);
    out.extend((0..3).map(|k| 2.0 * (last[k] - first[k])));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vector(t: &Trajectory) -> Vec<f32> {
        let mut f = Vec::new();
        feature_vector3(t, 16, 4, false, &mut f);
        f
    }

    #[test]
    fn length_scale_invariance_and_depth_told_apart() {
        let circle: Vec<Point3> = (0..40)
            .map(|i| {
                let a = i as f32 / 39.0 * std::f32::consts::TAU;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let big: Vec<Point3> = circle
            .iter()
            .map(|p| [p[0] * 50.0 + 3.0, p[1] * 50.0, p[2] * 50.0 - 7.0])
            .collect();
        let (a, b) = (
            vector(&Trajectory::from_points3(&circle)),
            vector(&Trajectory::from_points3(&big)),
        );
        assert_eq!(a.len(), dim(16, 4));
        assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-3));
        // The same circle turned to face up (in the x/z plane): a line in the front
        // view, far from the upright circle.
        let up: Vec<Point3> = circle.iter().map(|p| [p[0], 0.0, p[1]]).collect();
        let c = vector(&Trajectory::from_points3(&up));
        let far: f32 = a.iter().zip(&c).map(|(x, y)| (x - y).powi(2)).sum();
        assert!(far > 1.0, "{far}");
        // Without depth it is the flat circle.
        let flat = Trajectory::from_points3(&circle).flattened();
        assert!(vector(&flat)
            .iter()
            .zip(&a)
            .all(|(x, y)| (x - y).abs() < 1e-6));
    }
}
