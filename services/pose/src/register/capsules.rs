//! The posed body's capsules in the camera frame, and the nearest-surface searches on
//! them.

use crate::body::{BodyTemplate, Posed, Segment};
use nalgebra::{Point3, Vector3};

/// A capsule of the posed body, camera frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Placed {
    pub(super) segment: Segment,
    pub(super) a: Point3<f32>,
    pub(super) ab: Vector3<f32>,
    /// 1 / |ab|² (0 for a sphere).
    pub(super) inv_len2: f32,
    pub(super) len2: f32,
    pub(super) ra: f32,
    pub(super) rb: f32,
    /// A sphere around the whole capsule, for skipping it in nearest-capsule searches.
    pub(super) centre: Point3<f32>,
    pub(super) bound: f32,
    /// Whether the camera could see any of it (inside the image, before what stands in
    /// front): a capsule out of view takes no data point, which belongs to what is seen.
    pub(super) in_view: bool,
}

impl Placed {
    /// Closest axis point, the radius there, and the signed distance to the surface.
    #[inline]
    pub(super) fn nearest(&self, p: &Point3<f32>) -> (Point3<f32>, f32, f32) {
        let t = ((p - self.a).dot(&self.ab) * self.inv_len2).clamp(0.0, 1.0);
        let c = self.a + self.ab * t;
        let r = self.ra + (self.rb - self.ra) * t;
        (c, r, (p - c).norm() - r)
    }
}

/// Whether a sphere of `radius` about `centre` lies wholly farther than `d` from `p`:
/// what a capsule's bounding sphere rules out without a square root. Never when
/// `d + radius` ≤ 0 (`p` deep inside a capsule).
#[inline]
pub(super) fn sphere_beyond(centre: &Point3<f32>, radius: f32, p: &Point3<f32>, d: f32) -> bool {
    let reach = d + radius;
    reach > 0.0 && (p - centre).norm_squared() > reach * reach
}

/// For the nearest-capsule search, per placed capsule g the others c by the gap
/// between their bounding spheres, |centre_g − centre_c| − bound_g − bound_c, least
/// first. A point whose surface distance to g is d lies within d + bound_g of g's
/// centre, so a capsule with a gap above 2d lies more than d from it: the search
/// from g stops there, after the few capsules beside g, instead of testing every one.
pub(super) struct Gaps {
    pub(super) n: usize,
    /// Row g: (gap, c) for every c ≠ g, least gap first.
    pub(super) rows: Vec<(f32, u16)>,
}

impl Gaps {
    pub(super) fn new(placed: &[Placed]) -> Self {
        let n = placed.len();
        let mut rows = Vec::with_capacity(n * n.saturating_sub(1));
        for (g, a) in placed.iter().enumerate() {
            let start = rows.len();
            rows.extend(
                placed
                    .iter()
                    .enumerate()
                    .filter(|&(c, _)| c != g)
                    .map(|(c, b)| ((a.centre - b.centre).norm() - a.bound - b.bound, c as u16)),
            );
            rows[start..].sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        }
        Self { n, rows }
    }

    pub(super) fn of(&self, g: usize) -> &[(f32, u16)] {
        let m = self.n - 1;
        &self.rows[g * m..(g + 1) * m]
    }
}

/// The capsule whose surface is nearest `p`: its index, the axis point and the signed
/// distance. The search starts from capsule `guess` (the point's last one, which is
/// mostly still the nearest) and tries only the capsules whose bounding spheres come
/// near the guess's ([`Gaps`]); of those, the ones whose bounding sphere lies farther
/// than the best so far are skipped without a square root.
#[inline]
pub(super) fn nearest_capsule(
    placed: &[Placed],
    gaps: &Gaps,
    p: &Point3<f32>,
    guess: usize,
) -> (usize, Point3<f32>, f32) {
    let (q, _, d) = placed[guess].nearest(p);
    let d = if d.is_nan() || !placed[guess].in_view {
        f32::INFINITY
    } else {
        d
    };
    let mut best = (guess, q, d);
    let within = 2.0 * best.2;
    for &(gap, ci) in gaps.of(guess) {
        if gap > within {
            break;
        }
        let ci = usize::from(ci);
        let c = &placed[ci];
        if !c.in_view {
            continue;
        }
        if sphere_beyond(&c.centre, c.bound, p, best.2) {
            continue;
        }
        let (q, _, d) = c.nearest(p);
        if d < best.2 {
            best = (ci, q, d);
        }
    }
    best
}

/// How far `p` lies from the nearest surface of `capsules` (negative inside one).
pub(super) fn surface_distance<'a>(
    capsules: impl IntoIterator<Item = &'a Placed>,
    p: &Point3<f32>,
) -> f32 {
    capsules
        .into_iter()
        .map(|c| c.nearest(p).2)
        .fold(f32::INFINITY, f32::min)
}

pub(crate) fn place(t: &BodyTemplate, posed: &Posed) -> Vec<Placed> {
    t.capsules
        .iter()
        .map(|c| {
            let a = posed.point(c.segment, &c.a);
            let b = posed.point(c.segment, &c.b);
            let ab = b - a;
            let len2 = ab.norm_squared();
            Placed {
                segment: c.segment,
                a,
                ab,
                inv_len2: if len2 > 1e-12 { 1.0 / len2 } else { 0.0 },
                len2,
                ra: c.ra,
                rb: c.rb,
                centre: a + ab * 0.5,
                bound: 0.5 * len2.sqrt() + c.ra.max(c.rb),
                in_view: true,
            }
        })
        .collect()
}

/// How far `p` lies outside the surface of the capsules of every segment but `own`.
pub(crate) fn distance_off_others(placed: &[Placed], p: &Point3<f32>, own: &[Segment]) -> f32 {
    surface_distance(placed.iter().filter(|c| !own.contains(&c.segment)), p)
}

/// Whether `segment`'s capsules hold the surface nearest `p` among the placed ones.
/// Capsules whose bounding sphere lies beyond the segment's own surface are not
/// measured.
pub(crate) fn nearest_is(placed: &[Placed], p: &Point3<f32>, segment: Segment) -> bool {
    let own = surface_distance(placed.iter().filter(|c| c.segment == segment), p);
    own.is_finite()
        && placed.iter().all(|c| {
            c.segment == segment || (p - c.centre).norm() - c.bound >= own || c.nearest(p).2 >= own
        })
}
