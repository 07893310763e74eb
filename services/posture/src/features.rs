//! Features of a segmented hand that do not change when the hand moves in the image,
//! turns in the image plane or comes nearer (its image grows): every length is divided
//! by the palm's radius (the largest circle inside the mask, in pixels in the image
//! and in metres in space), every angle is taken from the hand's main axis, and the
//! profile is turned over when needed so that a left hand and a right one (or the
//! palm and the back) read alike.

use crate::frame::HandFrame;
use crate::mask::fill_holes;
use crate::segment::{HandPixel, HandRegion};
use nalgebra::Point3;

/// Bins of the radial profile around the palm's centre.
pub const RADIAL_BINS: usize = 32;
/// Bins of each depth histogram.
const DEPTH_BINS: usize = 6;
/// How many of the deepest convexity defects are kept.
const DEFECTS: usize = 4;
/// A finger reaches past this many palm radii from the palm's centre (a fist's
/// knuckles reach about 1.3).
const FINGER_REACH: f32 = 1.8;
/// A convexity defect deeper than this many palm radii is a gap between fingers.
const DEEP_DEFECT: f32 = 0.5;

/// The number of features.
pub const FEATURE_LEN: usize = 7 + 1 + 1 + DEFECTS + 1 + 1 + RADIAL_BINS + 2 + 2 * DEPTH_BINS + 1;

/// The feature vector of one hand: always [`FEATURE_LEN`] finite numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Features([f32; FEATURE_LEN]);

impl Features {
    /// The values, in the order of [`feature_names`].
    pub fn values(&self) -> &[f32; FEATURE_LEN] {
        &self.0
    }

    /// Features from their values, for the classifiers that keep them as arrays.
    pub(crate) fn from_values(values: [f32; FEATURE_LEN]) -> Self {
        Self(values)
    }

    /// Features read back from a file or another program: `None` unless there are
    /// exactly [`FEATURE_LEN`] values, all finite.
    pub fn from_slice(values: &[f32]) -> Option<Self> {
        let values: [f32; FEATURE_LEN] = values.try_into().ok()?;
        values.iter().all(|v| v.is_finite()).then_some(Self(values))
    }

    /// The number of fingertips found (a feature, kept readable).
    pub fn fingertips(&self) -> usize {
        self.0[FINGERTIPS] as usize
    }
}

const FINGERTIPS: usize = 7 + 1 + 1 + DEFECTS;

/// The version of the features: raised whenever a feature is added, removed or
/// computed otherwise, so that samples and models of other features are refused
/// rather than compared.
pub const FEATURE_VERSION: u32 = 1;

/// The features' names, in order.
pub fn feature_names() -> Vec<String> {
    let mut n: Vec<String> = (1..=7).map(|i| format!("hu{i}")).collect();
    n.push("solidity".into());
    n.push("deep_defects".into());
    n.extend((0..DEFECTS).map(|i| format!("defect{i}")));
    n.push("fingertips".into());
    n.push("area_over_palm".into());
    n.extend((0..RADIAL_BINS).map(|i| format!("radial{i}")));
    n.push("spread1_over_0".into());
    n.push("spread2_over_0".into());
    n.extend((0..DEPTH_BINS).map(|i| format!("normal_hist{i}")));
    n.extend((0..DEPTH_BINS).map(|i| format!("dist3d_hist{i}")));
    n.push("reach3d".into());
    n
}

/// The features of a segmented hand and its frame.
pub fn features(region: &HandRegion, frame: &HandFrame) -> Features {
    let w = region.window();
    // The hand's bounding box (a pixel of margin all round), not the whole window:
    // the window near the camera is ten times the hand's area, and the hull's work is
    // per pixel.
    let (x0, y0, cw, ch, cropped) = crop(region.pixels(), w.u0, w.v0);
    let (ww, wh) = (cw, ch);
    let filled = fill_holes(&cropped, ww, wh);
    let mask = &filled[..];
    let area = mask.iter().filter(|&&m| m).count().max(1) as f32;

    let palm = region.palm();
    let palm_r = palm.radius_px;
    let (pcx, pcy) = (palm.u - x0 as f32, palm.v - y0 as f32);

    let mut out = Vec::with_capacity(FEATURE_LEN);
    out.extend(hu_moments(mask, ww, wh));

    let hull = convex_hull(mask, ww, wh);
    let (hull_area, hull_perimeter) = polygon_area_perimeter(&hull);
    // The hull through pixel centres misses half a pixel all round.
    out.push(area / (hull_area + 0.5 * hull_perimeter + 1.0));
    let defects = defect_depths(mask, ww, wh, &hull);
    out.push(
        defects
            .iter()
            .filter(|&&d| d > DEEP_DEFECT * palm_r)
            .count() as f32,
    );
    out.extend((0..DEFECTS).map(|i| defects.get(i).copied().unwrap_or(0.0) / palm_r));

    let radial = radial_profile(mask, ww, wh, (pcx, pcy), frame.image_angle, palm_r);
    out.push(count_fingers(&radial) as f32);
    out.push(area / (std::f32::consts::PI * palm_r * palm_r));
    out.extend(fold_mirror(&radial));

    let s = frame.spread_m;
    let s0 = s[0].max(1e-4);
    out.push(s[1] / s0);
    out.push(s[2] / s0);

    // The palm's radius in metres: the hand's own size in space.
    let palm_m = (palm_r * palm.centre.z / region.focal_px()).max(1e-3);
    let centre = palm.centre;
    out.extend(depth_histograms(region, frame, centre, palm_m));

    let values: Vec<f32> = out
        .into_iter()
        .map(|v| if v.is_finite() { v } else { 0.0 })
        .collect();
    let mut arr = [0.0; FEATURE_LEN];
    for (a, v) in arr.iter_mut().zip(values) {
        *a = v;
    }
    Features(arr)
}

/// The hand's pixels as a mask over their bounding box with a pixel of margin: its
/// first column and row in the image, its size, the mask.
fn crop(pixels: &[HandPixel], u0: u32, v0: u32) -> (u32, u32, usize, usize, Vec<bool>) {
    let (mut a, mut b) = ((u32::MAX, u32::MAX), (0u32, 0u32));
    for h in pixels {
        a = (a.0.min(h.u), a.1.min(h.v));
        b = (b.0.max(h.u), b.1.max(h.v));
    }
    if pixels.is_empty() {
        return (u0, v0, 1, 1, vec![false]);
    }
    let (x0, y0) = (a.0.saturating_sub(1), a.1.saturating_sub(1));
    let (w, h) = ((b.0 + 2 - x0) as usize, (b.1 + 2 - y0) as usize);
    let mut mask = vec![false; w * h];
    for p in pixels {
        mask[(p.v - y0) as usize * w + (p.u - x0) as usize] = true;
    }
    (x0, y0, w, h, mask)
}

/// Hu's seven moment invariants of the mask, each as sign × log10 of its magnitude
/// (their sizes span many decades); the seventh's sign flips in a mirror image and is
/// dropped.
fn hu_moments(mask: &[bool], w: usize, h: usize) -> [f32; 7] {
    let (mut m00, mut m10, mut m01) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                m00 += 1.0;
                m10 += x as f64;
                m01 += y as f64;
            }
        }
    }
    if m00 == 0.0 {
        return [0.0; 7];
    }
    let (xc, yc) = (m10 / m00, m01 / m00);
    let mut mu = [[0.0f64; 4]; 4];
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                let (dx, dy) = (x as f64 - xc, y as f64 - yc);
                for (p, row) in mu.iter_mut().enumerate() {
                    for (q, m) in row.iter_mut().enumerate() {
                        if p + q >= 2 && p + q <= 3 {
                            *m += dx.powi(p as i32) * dy.powi(q as i32);
                        }
                    }
                }
            }
        }
    }
    let eta = |p: usize, q: usize| mu[p][q] / m00.powf(1.0 + (p + q) as f64 / 2.0);
    let (n20, n02, n11) = (eta(2, 0), eta(0, 2), eta(1, 1));
    let (n30, n03, n21, n12) = (eta(3, 0), eta(0, 3), eta(2, 1), eta(1, 2));
    let a = n30 + n12;
    let b = n21 + n03;
    let hu = [
        n20 + n02,
        (n20 - n02).powi(2) + 4.0 * n11 * n11,
        (n30 - 3.0 * n12).powi(2) + (3.0 * n21 - n03).powi(2),
        a * a + b * b,
        (n30 - 3.0 * n12) * a * (a * a - 3.0 * b * b)
            + (3.0 * n21 - n03) * b * (3.0 * a * a - b * b),
        (n20 - n02) * (a * a - b * b) + 4.0 * n11 * a * b,
        ((3.0 * n21 - n03) * a * (a * a - 3.0 * b * b)
            - (n30 - 3.0 * n12) * b * (3.0 * a * a - b * b))
            .abs(),
    ];
    // Below 1e-12 a moment is noise; the floor keeps the logarithm bounded.
    hu.map(|v| (v.signum() * (v.abs().max(1e-12).log10() + 12.0)) as f32)
}

/// The convex hull of the mask's pixel centres, counter-clockwise (y down), by
/// Andrew's monotone chain over each row's outermost pixels.
fn convex_hull(mask: &[bool], w: usize, h: usize) -> Vec<(f32, f32)> {
    let mut pts = Vec::new();
    for y in 0..h {
        let row = &mask[y * w..(y + 1) * w];
        if let (Some(a), Some(b)) = (row.iter().position(|&m| m), row.iter().rposition(|&m| m)) {
            pts.push((a as f32, y as f32));
            if b != a {
                pts.push((b as f32, y as f32));
            }
        }
    }
    pts.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.total_cmp(&q.1)));
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: (f32, f32), a: (f32, f32), b: (f32, f32)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f32, f32)> = Vec::with_capacity(2 * pts.len());
    for &p in pts.iter().chain(pts.iter().rev().skip(1)) {
        let floor = if hull.len() > pts.len() { pts.len() } else { 1 };
        while hull.len() > floor && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
    hull
}

fn polygon_area_perimeter(poly: &[(f32, f32)]) -> (f32, f32) {
    if poly.len() < 3 {
        return (0.0, 0.0);
    }
    let (mut a, mut p) = (0.0, 0.0);
    for i in 0..poly.len() {
        let (x0, y0) = poly[i];
        let (x1, y1) = poly[(i + 1) % poly.len()];
        a += x0 * y1 - x1 * y0;
        p += ((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt();
    }
    (0.5 * a.abs(), p)
}

/// The convexity defects: each connected piece of the hull not covered by the mask,
/// as the greatest distance of its pixels from the hull's edges, deepest first.
fn defect_depths(mask: &[bool], w: usize, h: usize, hull: &[(f32, f32)]) -> Vec<f32> {
    if hull.len() < 3 {
        return Vec::new();
    }
    let n = hull.len();
    // Each hull edge: its two ends and its length.
    struct Edge {
        a: (f32, f32),
        b: (f32, f32),
        len: f32,
    }
    let edges: Vec<Edge> = (0..n)
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % n]);
            let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt().max(1e-6);
            Edge { a, b, len }
        })
        .collect();
    // The hull's orientation: the sign of its signed area.
    let sign = {
        let mut s = 0.0;
        for i in 0..n {
            let (x0, y0) = hull[i];
            let (x1, y1) = hull[(i + 1) % n];
            s += x0 * y1 - x1 * y0;
        }
        s.signum()
    };
    // Inside a convex polygon: on the inner side of every edge; how deep inside is the
    // least distance to an edge.
    let depth_inside = |x: f32, y: f32| -> Option<f32> {
        let mut least = f32::INFINITY;
        for &Edge { a, b, len } in &edges {
            let c = sign * ((b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0)) / len;
            if c < 0.0 {
                return None;
            }
            least = least.min(c);
        }
        Some(least)
    };
    let mut depth = vec![-1.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            if !mask[y * w + x] {
                if let Some(d) = depth_inside(x as f32, y as f32) {
                    depth[y * w + x] = d;
                }
            }
        }
    }
    let mut seen = vec![false; w * h];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if depth[start] < 0.0 || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut deepest = 0.0f32;
        while let Some(i) = stack.pop() {
            deepest = deepest.max(depth[i]);
            let (x, y) = (i % w, i / w);
            let mut visit = |j: usize| {
                if depth[j] >= 0.0 && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        out.push(deepest);
    }
    out.sort_by(|a, b| b.total_cmp(a));
    out
}

/// The farthest mask pixel from the palm's centre in each direction, in palm radii,
/// bin 0 along the hand's main axis.
fn radial_profile(
    mask: &[bool],
    w: usize,
    h: usize,
    (cx, cy): (f32, f32),
    axis: f32,
    palm_r: f32,
) -> [f32; RADIAL_BINS] {
    let mut prof = [0.0f32; RADIAL_BINS];
    let tau = std::f32::consts::TAU;
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                let (dx, dy) = (x as f32 - cx, y as f32 - cy);
                let r = (dx * dx + dy * dy).sqrt();
                let a = (dy.atan2(dx) - axis).rem_euclid(tau);
                let bin = ((a / tau * RADIAL_BINS as f32 + 0.5) as usize) % RADIAL_BINS;
                prof[bin] = prof[bin].max(r / palm_r);
            }
        }
    }
    prof
}

/// The profile folded about the main axis, bin 0 the axis: first the mean of the two
/// directions either side at each angle (0 to 180°), then the size of their
/// difference (the angles strictly between). Mirror images (a left hand and a right,
/// the palm and the back) swap the directions either side and fold alike.
fn fold_mirror(prof: &[f32; RADIAL_BINS]) -> [f32; RADIAL_BINS] {
    let mut out = [0.0f32; RADIAL_BINS];
    let half = RADIAL_BINS / 2;
    for i in 0..=half {
        let (a, b) = (prof[i], prof[(RADIAL_BINS - i) % RADIAL_BINS]);
        out[i] = 0.5 * (a + b);
        if i > 0 && i < half {
            out[half + i] = 0.5 * (a - b).abs();
        }
    }
    out
}

/// Fingers: runs of the profile reaching past [`FINGER_REACH`] palm radii within
/// 120° of the main axis (the forearm's stub lies behind).
fn count_fingers(prof: &[f32; RADIAL_BINS]) -> usize {
    let span = RADIAL_BINS / 3;
    let order: Vec<usize> = (0..=2 * span)
        .map(|k| (RADIAL_BINS + k - span) % RADIAL_BINS)
        .collect();
    let mut count = 0;
    let mut inside = false;
    for &i in &order {
        let up = prof[i] > FINGER_REACH;
        if up && !inside {
            count += 1;
        }
        inside = up;
    }
    count
}

/// The depth profile: where the hand's points lie along the palm's normal and how far
/// from the palm's centre, in palm radii, as fractions of the points.
fn depth_histograms(
    region: &HandRegion,
    frame: &HandFrame,
    centre: Point3<f32>,
    palm_m: f32,
) -> Vec<f32> {
    let mut normal = [0.0f32; DEPTH_BINS];
    let mut dist = [0.0f32; DEPTH_BINS];
    let mut reach = 0.0f32;
    let n = region.pixels().len().max(1) as f32;
    for h in region.pixels() {
        let d = h.p - centre;
        let along = d.dot(&frame.palm_normal) / palm_m;
        let i = (((along + 1.5) / 3.0) * DEPTH_BINS as f32).clamp(0.0, DEPTH_BINS as f32 - 1.0);
        normal[i as usize] += 1.0 / n;
        let r = d.norm() / palm_m;
        reach = reach.max(r);
        let j = (r / 3.6 * DEPTH_BINS as f32).clamp(0.0, DEPTH_BINS as f32 - 1.0);
        dist[j as usize] += 1.0 / n;
    }
    let mut out: Vec<f32> = normal.to_vec();
    out.extend(dist);
    out.push(reach);
    out
}
