//! Step 6 (the seed's): a two-joint chain fitted to a limb's target points by weighted
//! closed-form rotations.

use crate::body::BodyConfig;
use crate::dijkstra::{Graph, INF};
use crate::geodesic::Geodesic;
use crate::geom::{closest_on_segment, RotationAccumulator};
use crate::graph::{GeoGraph, NONE};
use crate::torso::TorsoPose;
use crate::Limb;
use airglyph_core::Skeleton;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Settings of the seed's chains (part of [`crate::PoseConfig`]); lengths in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ChainConfig {
    /// Target points: within `d_e` of the geodesic path (seed Eq. 16.10), for the arms,
    /// legs and head.
    pub d_e_arm: f32,
    /// See `d_e_arm`.
    pub d_e_leg: f32,
    /// See `d_e_arm`.
    pub d_e_head: f32,
    /// Weight of successor-segment points in a parent rotation (seed: 0.05).
    pub omega_succ: f32,
    /// Weight of target points beyond the chain's end (fingers, toes).
    pub beyond_end_weight: f32,
    /// Most rotation steps of a chain's fit.
    pub iterations: usize,
    /// The seen surface lies in front of a limb's axis: target points are pushed back
    /// along their viewing ray by this much (arm, leg, head).
    pub surface_offset_arm: f32,
    /// See `surface_offset_arm`.
    pub surface_offset_leg: f32,
    /// See `surface_offset_arm`.
    pub surface_offset_head: f32,
    /// Confidence multiplier per frame for a limb that keeps its last fit.
    pub occluded_decay: f32,
}

impl Default for ChainConfig {
    fn default() -> Self {
        Self {
            d_e_arm: 0.05,
            d_e_leg: 0.10,
            d_e_head: 0.10,
            omega_succ: 0.05,
            beyond_end_weight: 0.1,
            iterations: 12,
            surface_offset_arm: 0.03,
            surface_offset_leg: 0.065,
            surface_offset_head: 0.07,
            occluded_decay: 0.7,
        }
    }
}

impl ChainConfig {
    /// How far from the geodesic path a limb's target points may lie.
    pub fn d_e(&self, limb: Limb) -> f32 {
        match limb {
            Limb::Head => self.d_e_head,
            Limb::LeftArm | Limb::RightArm => self.d_e_arm,
            Limb::LeftLeg | Limb::RightLeg => self.d_e_leg,
        }
    }

    /// How far a limb's axis lies behind the surface the camera sees.
    pub fn surface_offset(&self, limb: Limb) -> f32 {
        match limb {
            Limb::Head => self.surface_offset_head,
            Limb::LeftArm | Limb::RightArm => self.surface_offset_arm,
            Limb::LeftLeg | Limb::RightLeg => self.surface_offset_leg,
        }
    }
}

/// The rest direction of a limb in the torso frame, for a first fit with no data.
pub fn rest_direction(limb: Limb) -> Vector3<f32> {
    match limb {
        Limb::Head => Vector3::y(),
        Limb::LeftArm => Vector3::new(0.2, -1.0, 0.0).normalize(),
        Limb::RightArm => Vector3::new(-0.2, -1.0, 0.0).normalize(),
        Limb::LeftLeg | Limb::RightLeg => -Vector3::y(),
    }
}

/// What the chains carry from frame to frame per limb: its last fit, in the torso frame.
#[derive(Debug, Clone, Copy)]
pub struct LimbState {
    /// Middle joint, torso frame.
    pub mid: Point3<f32>,
    /// End joint, torso frame.
    pub end: Point3<f32>,
    /// The extremity (the geodesic maximum) it was fitted to, torso frame.
    pub extremity: Option<Point3<f32>>,
    /// The fit's confidence.
    pub confidence: f32,
}

/// The limbs' states when the chains were skipped: each follows the registered body
/// `skel` (its joints in the torso frame of `torso`), with its tip as its extremity.
pub fn following(
    skel: &Skeleton,
    tips: &[Option<Point3<f32>>; 5],
    torso: &TorsoPose,
) -> [Option<LimbState>; 5] {
    let inv = torso.inverse();
    Limb::ALL.map(|l| {
        let (_, jm, je) = l.joints();
        let end = inv.apply(&skel[je]);
        Some(LimbState {
            mid: jm.map_or(end, |j| inv.apply(&skel[j])),
            end,
            extremity: tips[l.index()].map(|m| inv.apply(&m)),
            confidence: skel.confidence[je.index()],
        })
    })
}

/// One limb's chain this frame.
#[derive(Debug, Clone)]
pub struct LimbFit {
    /// The chain, camera frame.
    pub chain: Chain,
    /// Its confidence, in [0, 1].
    pub confidence: f32,
    /// What the next frame starts from.
    pub state: LimbState,
    /// The target points it was fitted to (none when the limb kept its last fit).
    pub targets: Option<Vec<Point3<f32>>>,
}

/// The limb's geodesic path and maximum: the path's part from the geodesic maximum to
/// the cut nearest the limb's root (graph nodes), and the maximum.
pub type Found<'a> = Option<(&'a [u32], u32)>;

/// Marks of the graph nodes already taken as a limb's target points, reused from limb
/// to limb and frame to frame.
#[derive(Debug, Default)]
pub struct TargetMarks {
    stamp: Vec<u32>,
    now: u32,
}

/// The seed's two-joint chain of limb `l` from `root_p`: fitted to the target points
/// along `found`'s path and to the maximum, from the path's own bend and from the last
/// frame's fit `prev`, whichever fits better; without a maximum the last fit, trusted
/// less. `body`: the limbs' lengths; `behind_tip`: the hands'
/// [`crate::config::HandsConfig::behind_tip`] (a number, not the hands' section: the
/// hands' step takes this one's [`ChainConfig`]); `f`: the focal length, pixels.
#[allow(clippy::too_many_arguments)]
pub fn limb_chain(
    l: Limb,
    root_p: Point3<f32>,
    found: Found,
    torso: &TorsoPose,
    prev: Option<LimbState>,
    cfg: &ChainConfig,
    body: &BodyConfig,
    behind_tip: f32,
    f: f32,
    graph: &GeoGraph,
    geo: &Geodesic,
    marks: &mut TargetMarks,
) -> LimbFit {
    let (l1, l2) = body.bones(l);
    let inv = torso.inverse();
    let Some((path, maximum)) = found else {
        // Occluded: keep the last fit (in the torso frame), trusted less.
        // Long unseen, it falls back to the rest pose.
        let s = prev.filter(|s| s.confidence >= 0.1).unwrap_or_else(|| {
            let d = rest_direction(l);
            let r_local = inv.apply(&root_p);
            LimbState {
                mid: r_local + d * l1,
                end: r_local + d * (l1 + l2),
                extremity: None,
                confidence: 0.1,
            }
        });
        let conf = (s.confidence * cfg.occluded_decay).clamp(0.0, 1.0);
        let mid = torso.apply(&s.mid);
        let end = torso.apply(&s.end);
        return LimbFit {
            chain: Chain {
                root: root_p,
                mid,
                end,
            },
            confidence: conf,
            state: LimbState {
                confidence: conf,
                ..s
            },
            targets: None,
        };
    };
    let targets = gather_targets(path, l, f, cfg, graph, geo, marks);
    let mut cands: Vec<Chain> = Vec::with_capacity(2);
    // From the geodesic path: the middle joint where the path is one
    // upper bone from the root.
    let ext = graph.pos[maximum as usize];
    let ext_b = ext + ext.coords.normalize() * cfg.surface_offset(l);
    let mut mid_guess = ext_b;
    if l2 > 0.0 {
        for &p in path.iter().rev() {
            let q = graph.pos[p as usize];
            if (q - root_p).norm() >= l1 {
                mid_guess = q + q.coords.normalize() * cfg.surface_offset(l);
                break;
            }
        }
    }
    let up = torso.r * Vector3::y();
    let c0 = start_chain(root_p, mid_guess, ext_b, (l1, l2), up);
    cands.push(c0);
    if let Some(s) = prev {
        let (mid, end) = (torso.apply(&s.mid), torso.apply(&s.end));
        cands.push(start_chain(root_p, mid, end, (l1, l2), up));
    }
    let mut best: Option<(Chain, f32)> = None;
    for c in cands {
        let (fitc, e) = fit_chain(
            c,
            &targets,
            cfg.omega_succ,
            cfg.beyond_end_weight,
            cfg.iterations,
        );
        if best.is_none_or(|(_, be)| e < be) {
            best = Some((fitc, e));
        }
    }
    let (mut fitc, e) = best.unwrap_or((c0, 0.0));
    // The hand follows the fingertips seen, a palm's length behind them
    // towards the elbow, rather than where the forearm's assumed length
    // puts it: a forearm a few centimetres off would otherwise shrink
    // every stroke the hand draws towards the elbow.
    if behind_tip > 0.0 && matches!(l, Limb::LeftArm | Limb::RightArm) {
        if let Some(u) = (ext_b - fitc.mid).try_normalize(1e-6) {
            fitc.end = ext_b - u * behind_tip;
        }
    }
    let rms = e.sqrt();
    let conf = ((1.0 - rms / 0.06).clamp(0.1, 1.0)) * (targets.len() as f32 / 30.0).clamp(0.2, 1.0);
    LimbFit {
        chain: fitc,
        confidence: conf,
        state: LimbState {
            mid: inv.apply(&fitc.mid),
            end: inv.apply(&fitc.end),
            extremity: Some(inv.apply(&ext)),
            confidence: conf,
        },
        targets: Some(targets),
    }
}

/// Target points of a limb (seed Eq. 16.10): the person's points within `d_e` of
/// the geodesic path from the extremity to the limb root, no nearer the torso centre
/// (geodesically) than the path's end, pushed back along their viewing ray by the
/// limb's surface offset.
fn gather_targets(
    path: &[u32],
    l: Limb,
    f: f32,
    cfg: &ChainConfig,
    g: &GeoGraph,
    geo: &Geodesic,
    marks: &mut TargetMarks,
) -> Vec<Point3<f32>> {
    let d_e = cfg.d_e(l);
    let off = cfg.surface_offset(l);
    let mut out = Vec::new();
    if path.is_empty() {
        return out;
    }
    marks.now = marks.now.wrapping_add(1);
    if marks.now == 0 || marks.stamp.len() != g.node_count() {
        marks.stamp.clear();
        marks.stamp.resize(g.node_count(), 0);
        marks.now = 1;
    }
    let floor_d = geo
        .dist(path[path.len() - 1])
        .saturating_sub((d_e * 1000.0) as u32);
    let spacing = (d_e * 500.0) as u32;
    let mut last_d = u32::MAX;
    let (w, h) = (g.width as i32, g.height as i32);
    for (pi, &p) in path.iter().enumerate() {
        let dp = geo.dist(p);
        if pi + 1 != path.len() && last_d != u32::MAX && last_d.saturating_sub(dp) < spacing {
            continue;
        }
        last_d = dp;
        let c = g.pos[p as usize];
        let px = g.pixel_of_node[p as usize] as i32;
        let (u, v) = (px % w, px / w);
        let r = ((d_e * f / c.z).ceil() as i32).clamp(1, 200);
        let step = if r > 10 { 2 } else { 1 };
        let d2 = d_e * d_e;
        let mut vv = (v - r).max(0);
        while vv <= (v + r).min(h - 1) {
            let mut uu = (u - r).max(0);
            while uu <= (u + r).min(w - 1) {
                let b = g.node_of_pixel[(vv * w + uu) as usize];
                if b != NONE && marks.stamp[b as usize] != marks.now {
                    let q = g.pos[b as usize];
                    let db = geo.dist(b);
                    if db != INF && db >= floor_d && (q - c).norm_squared() < d2 {
                        marks.stamp[b as usize] = marks.now;
                        out.push(q + q.coords.normalize() * off);
                    }
                }
                uu += step;
            }
            vv += step;
        }
    }
    out
}

/// A chain from `root` bent towards `mid` and reaching for `end`, with bones `l1` and
/// `l2`; a limb of one bone (`l2` zero: the head) is a straight one towards `end`, or
/// along `up` when `end` is the root.
fn start_chain(
    root: Point3<f32>,
    mid: Point3<f32>,
    end: Point3<f32>,
    (l1, l2): (f32, f32),
    up: Vector3<f32>,
) -> Chain {
    if l2 > 0.0 {
        return Chain::towards(root, mid - root, end, l1, l2);
    }
    let d = (end - root).try_normalize(1e-6).unwrap_or(up);
    Chain {
        root,
        mid: root + d * l1,
        end: root + d * l1,
    }
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
