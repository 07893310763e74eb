//! Limbs: the assignment of geodesic maxima to limb roots, and the fitting of a
//! two-joint chain to a limb's target points by weighted closed-form rotations.

use crate::geom::{closest_on_segment, RotationAccumulator};
use nalgebra::{Point3, Vector3};

/// The least-cost assignment of maxima to limbs: `cost[m][l]` is the cost of giving
/// maximum `m` to limb `l`; a limb may stay without a maximum at `unassigned` (so fewer
/// than five maxima are fine), and each maximum serves one limb at most. Returns, for
/// each limb, the index of its maximum.
pub fn assign(cost: &[[f32; 5]], unassigned: f32) -> [Option<usize>; 5] {
    fn go(
        l: usize,
        used: u32,
        cost: &[[f32; 5]],
        unassigned: f32,
        cur: &mut [Option<usize>; 5],
        acc: f32,
        best: &mut (f32, [Option<usize>; 5]),
    ) {
        if acc >= best.0 {
            return;
        }
        if l == 5 {
            *best = (acc, *cur);
            return;
        }
        for (m, row) in cost.iter().enumerate() {
            if used & (1 << m) == 0 && row[l].is_finite() {
                cur[l] = Some(m);
                go(
                    l + 1,
                    used | (1 << m),
                    cost,
                    unassigned,
                    cur,
                    acc + row[l],
                    best,
                );
            }
        }
        cur[l] = None;
        go(l + 1, used, cost, unassigned, cur, acc + unassigned, best);
    }
    let mut best = (f32::INFINITY, [None; 5]);
    let mut cur = [None; 5];
    let cost = &cost[..cost.len().min(16)];
    go(0, 0, cost, unassigned, &mut cur, 0.0, &mut best);
    best.1
}

/// A fitted chain: root (fixed), middle and end joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chain {
    pub root: Point3<f32>,
    pub mid: Point3<f32>,
    pub end: Point3<f32>,
}

impl Chain {
    /// A chain with the given bone lengths whose bones point at `mid_dir` and then at
    /// `end_toward` (a point).
    pub fn towards(
        root: Point3<f32>,
        mid_dir: Vector3<f32>,
        end_toward: Point3<f32>,
        l1: f32,
        l2: f32,
    ) -> Chain {
        let d1 = mid_dir.try_normalize(1e-6).unwrap_or(-Vector3::y());
        let mid = root + d1 * l1;
        let d2 = (end_toward - mid).try_normalize(1e-6).unwrap_or(d1);
        Chain {
            root,
            mid,
            end: mid + d2 * l2,
        }
    }

    /// Mean squared distance of the targets to the nearer bone (targets past the end
    /// weighted by `beyond`).
    pub fn error(&self, targets: &[Point3<f32>], beyond: f32) -> f32 {
        if targets.is_empty() {
            return 0.0;
        }
        let (mut s, mut sw) = (0.0, 0.0);
        for t in targets {
            let (_, c, w) = self.nearest(t, beyond);
            s += w * (c - t).norm_squared();
            sw += w;
        }
        s / sw.max(1e-9)
    }

    /// The error of [`Chain::error`] and, from the same nearest points, the upper
    /// bone's turn about the root that [`fit_chain`]'s next step starts with: the
    /// nearest points of a step's error are those of the next step's first half, and
    /// finding them is most of the fit's work.
    fn sweep(
        &self,
        targets: &[Point3<f32>],
        omega_succ: f32,
        beyond: f32,
    ) -> (f32, RotationAccumulator) {
        let (mut s, mut sw) = (0.0, 0.0);
        let mut upper = RotationAccumulator::default();
        for t in targets {
            let (bone, c, w) = self.nearest(t, beyond);
            s += w * (c - t).norm_squared();
            sw += w;
            let w = if bone == 0 { w } else { w * omega_succ };
            upper.add(&(c - self.root), &(t - self.root), w);
        }
        (s / sw.max(1e-9), upper)
    }

    /// Which bone is nearer `t` (0 upper, 1 lower), the nearest point on it, and the
    /// target's weight (`beyond` past the end joint, else 1).
    #[inline]
    fn nearest(&self, t: &Point3<f32>, beyond: f32) -> (usize, Point3<f32>, f32) {
        let c1 = closest_on_segment(t, &self.root, &self.mid);
        let single = (self.end - self.mid).norm_squared() < 1e-12;
        let (last_a, last_b) = if single {
            (self.root, self.mid)
        } else {
            (self.mid, self.end)
        };
        let past = (t - last_b).dot(&(last_b - last_a)) > 0.0;
        let w = if past { beyond } else { 1.0 };
        if single {
            return (0, c1, w);
        }
        let c2 = closest_on_segment(t, &self.mid, &self.end);
        if (c1 - t).norm_squared() <= (c2 - t).norm_squared() {
            (0, c1, w)
        } else {
            (1, c2, w)
        }
    }

    pub fn is_finite(&self) -> bool {
        [self.root, self.mid, self.end]
            .iter()
            .all(|p| p.iter().all(|c| c.is_finite()))
    }
}

/// Fits `chain` to `targets`: each target pulls the nearest point of its nearer bone;
/// the upper bone turns about the root under its own targets (weight 1) and the lower
/// bone's (weight `omega_succ`), then the lower bone turns about the middle joint under
/// its own; repeated while the error falls. Returns the fit and its mean squared error.
pub fn fit_chain(
    mut chain: Chain,
    targets: &[Point3<f32>],
    omega_succ: f32,
    beyond: f32,
    iterations: usize,
) -> (Chain, f32) {
    if targets.is_empty() {
        return (chain, chain.error(targets, beyond));
    }
    let (mut err, mut upper) = chain.sweep(targets, omega_succ, beyond);
    let single = (chain.end - chain.mid).norm() < 1e-6;
    for _ in 0..iterations {
        let prev = chain;
        let r1 = upper.rotation();
        chain.mid = chain.root + r1 * (chain.mid - chain.root);
        chain.end = chain.root + r1 * (chain.end - chain.root);
        if !single {
            let mut acc = RotationAccumulator::default();
            for t in targets {
                let (bone, c, w) = chain.nearest(t, beyond);
                if bone == 1 {
                    acc.add(&(c - chain.mid), &(t - chain.mid), w);
                }
            }
            if acc.weight() > 0.0 {
                let r2 = acc.rotation();
                chain.end = chain.mid + r2 * (chain.end - chain.mid);
            }
        }
        let (e, next) = chain.sweep(targets, omega_succ, beyond);
        if !chain.is_finite() || e > err {
            chain = prev;
            break;
        }
        let gain = err - e;
        (err, upper) = (e, next);
        if gain < 1e-8 {
            break;
        }
    }
    (chain, err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignment_prefers_least_total_cost_and_tolerates_missing_maxima() {
        let cost = [
            [0.1, 0.9, 0.9, 2.0, 2.0],
            [0.8, 0.2, 0.3, 2.0, 2.0],
            [0.8, 0.25, 0.9, 2.0, 2.0],
        ];
        let a = assign(&cost, 1.0);
        assert_eq!(a, [Some(0), Some(2), Some(1), None, None]);
        assert_eq!(assign(&[], 1.0), [None; 5]);
    }

    /// Points along a known bent arm; a chain started straight down must find it.
    #[test]
    fn chain_fitting_recovers_a_known_arm() {
        let root = Point3::new(0.2, -0.3, 2.0);
        let mid = root + Vector3::new(0.25, 0.1, -0.1).normalize() * 0.28;
        let end = mid + Vector3::new(0.0, -1.0, -0.3).normalize() * 0.3;
        let mut targets = Vec::new();
        for i in 0..=40 {
            let s = i as f32 / 40.0;
            targets.push(root + (mid - root) * s);
            targets.push(mid + (end - mid) * s);
        }
        let init = Chain::towards(root, Vector3::new(0.3, -0.2, 0.0), end, 0.28, 0.3);
        let (fit, err) = fit_chain(init, &targets, 0.05, 1.0, 60);
        assert!(err < 1e-4, "{err}");
        assert!((fit.mid - mid).norm() < 0.02, "{:?}", fit.mid - mid);
        assert!((fit.end - end).norm() < 0.02, "{:?}", fit.end - end);
        // Bone lengths are kept.
        assert!(((fit.mid - fit.root).norm() - 0.28).abs() < 1e-4);
        assert!(((fit.end - fit.mid).norm() - 0.3).abs() < 1e-4);
    }

    #[test]
    fn empty_targets_leave_the_chain_alone() {
        let c = Chain::towards(
            Point3::new(0.0, 0.0, 2.0),
            -Vector3::y(),
            Point3::new(0.0, 1.0, 2.0),
            0.3,
            0.3,
        );
        let (f, e) = fit_chain(c, &[], 0.05, 1.0, 10);
        assert_eq!(f, c);
        assert_eq!(e, 0.0);
    }
}
