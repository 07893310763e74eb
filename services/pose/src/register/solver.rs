//! The Gauss–Newton steps: normal equations accumulated per segment (6×6) and
//! assembled once, Levenberg–Marquardt damping, and the limbs' length steps read off the
//! final pass.

use super::priors::add_joint_priors;
use super::{Fit, Gradient, Local, Normal, Pass, Problem, Registration, N, REASSIGN};
use crate::body::{BodyPose, Posed, Segment};
use nalgebra::{Matrix3, Point3, SMatrix, Vector3, Vector6};

/// Settings of the Gauss–Newton steps (part of [`super::RegisterConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct SolverConfig {
    /// Gauss–Newton steps in all...
    pub iterations: usize,
    /// ...and of them how many each start is given before the best one alone goes on.
    pub race_iterations: usize,
    /// A run stops early once a step is smaller than this (metres and radians
    /// together).
    pub converged: f32,
    /// Levenberg–Marquardt damping, relative (of the diagonal)...
    pub damping: f64,
    /// ...and absolute.
    pub damping_abs: f64,
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            iterations: 10,
            race_iterations: 3,
            converged: 1e-4,
            damping: 0.05,
            damping_abs: 0.01,
        }
    }
}

/// What the fits tell of the person's limb lengths (part of
/// [`super::RegisterConfig`]; the calibration learns from it).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct LengthsConfig {
    /// Σ w j² a limb pair's length gradient needs before it is trusted (j: metres a
    /// point moves per unit change of the length ratio).
    pub evidence: f64,
    /// The share of a limb pair's front surface the camera must see where the fit puts
    /// it for the frame to count towards the pair's length.
    pub seen: f32,
    /// When set, an arm's upper arm and forearm are learned apart (`bone_steps`) from
    /// frames whose normal equations of the two bones' length ratios have no eigenvalue
    /// below this (Σ w j², as `evidence`). Off (None) by default: the split it learns is
    /// biased, and a sequence with noise lost a leg with it (pose NOTES).
    pub bone_evidence: Option<f64>,
    /// The share of the way to each well-seen frame's collarbone turns their rest moves.
    pub collar_gain: f32,
}

impl Default for LengthsConfig {
    fn default() -> Self {
        Self {
            evidence: 10.0,
            seen: 0.6,
            bone_evidence: None,
            collar_gain: 0.02,
        }
    }
}

/// Normal equations of one step, per segment: the segment's motion is a twist (v, ω)
/// about its own joint o, and a residual r along `dir` at point x of it changes by
/// dirᵀ(v + ω × (x − o)). Sums are in f32 (lever arms are a limb long, not the
/// camera's distance), over the upper triangle of the symmetric 6×6 outer product only
/// (row by row, [`UPPER`] entries): the lower one is mirrored once, in `assemble`.
pub(super) struct Accumulator {
    pub(super) h: [[f32; UPPER]; Segment::COUNT],
    pub(super) g: [[f32; 6]; Segment::COUNT],
    /// The twists' origins: each segment's joint.
    pub(super) origin: [Point3<f32>; Segment::COUNT],
    pub(super) energy: f64,
    /// The part of `energy` the guides make (the tips', the neck's base's terms).
    pub(super) guide_energy: f64,
    /// Where each limb is rooted (shoulder, hip), for the limb-length gradient.
    pub(super) roots: [Option<Point3<f32>>; Segment::COUNT],
    /// For arms and legs: Σ w j r and Σ w j² of the residuals' derivative j by the limbs'
    /// length ratio (all points of a limb move away from its root as it grows).
    pub(super) length: [(f64, f64); 2],
    /// Per arm (left, right), the normal equations of the residuals' derivatives by the
    /// upper arm's and the forearm's length ratios apart (an upper arm's points move
    /// away from the shoulder as it grows, a forearm's with the elbow and away from
    /// it): Σ w j₁ r, Σ w j₂ r, Σ w j₁², Σ w j₁ j₂, Σ w j₂². None unless
    /// [`LengthsConfig::bone_evidence`] asks for them: every arm point of every pass
    /// would pay for sums nobody reads.
    pub(super) arm_bones: Option<[[f64; 5]; 2]>,
}

/// The upper arm's and the forearm's length-ratio steps of one arm from its normal
/// equations ([`Accumulator::arm_bones`]), or None when the frame cannot tell the two
/// bones apart: the smaller eigenvalue of the 2×2 system must exceed `evidence`. A
/// straight arm moves its tip alike whichever bone grows, and its surface points hardly
/// move along their normals: one ratio for the whole arm is all it can say. A bent
/// elbow, seen, says where the elbow is.
pub(super) fn bone_steps(l: &[f64; 5], evidence: f64) -> Option<[f32; 2]> {
    let [g1, g2, h11, h12, h22] = *l;
    let (tr, det) = (h11 + h22, h11 * h22 - h12 * h12);
    let least = 0.5 * (tr - (tr * tr - 4.0 * det).max(0.0).sqrt());
    // NaN sums (a degenerate frame) fail the first test.
    if !least.is_finite() || least <= evidence || det <= 0.0 {
        return None;
    }
    let s1 = -(h22 * g1 - h12 * g2) / det;
    let s2 = -(h11 * g2 - h12 * g1) / det;
    (s1.is_finite() && s2.is_finite()).then_some([s1 as f32, s2 as f32])
}

impl Accumulator {
    pub(super) fn new(posed: &Posed, split_arms: bool) -> Self {
        use Segment::*;
        let mut roots = [None; Segment::COUNT];
        for (root, segs) in [
            (LeftUpperArm, [LeftUpperArm, LeftForearm]),
            (RightUpperArm, [RightUpperArm, RightForearm]),
            (LeftThigh, [LeftThigh, LeftShin]),
            (RightThigh, [RightThigh, RightShin]),
        ] {
            for s in segs {
                roots[s.index()] = Some(posed.joint[root.index()]);
            }
        }
        Self {
            h: [[0.0; UPPER]; Segment::COUNT],
            g: [[0.0; 6]; Segment::COUNT],
            origin: posed.joint,
            energy: 0.0,
            guide_energy: 0.0,
            roots,
            length: [(0.0, 0.0); 2],
            arm_bones: split_arms.then_some([[0.0; 5]; 2]),
        }
    }

    /// Adds residual `r` with weight `w` in the normal equations.
    #[inline]
    pub(super) fn add(&mut self, s: Segment, x: &Point3<f32>, dir: &Vector3<f32>, r: f32, w: f32) {
        let si = s.index();
        let m = (x - self.origin[si]).cross(dir);
        let j = [dir.x, dir.y, dir.z, m.x, m.y, m.z];
        let h = &mut self.h[si];
        let mut k = 0;
        for a in 0..6 {
            let wa = w * j[a];
            for &jb in &j[a..] {
                h[k] += wa * jb;
                k += 1;
            }
        }
        let wr = w * r;
        for (ga, ja) in self.g[si].iter_mut().zip(j) {
            *ga += wr * ja;
        }
        if let Some(root) = self.roots[si] {
            let pair = usize::from(matches!(
                s,
                Segment::LeftThigh | Segment::LeftShin | Segment::RightThigh | Segment::RightShin
            ));
            let js = dir.dot(&(x - root)) as f64;
            self.length[pair].0 += w as f64 * js * r as f64;
            self.length[pair].1 += w as f64 * js * js;
            let Some(arm_bones) = &mut self.arm_bones else {
                return;
            };
            let side = match s {
                Segment::LeftUpperArm | Segment::LeftForearm => Some(0),
                Segment::RightUpperArm | Segment::RightForearm => Some(1),
                _ => None,
            };
            if let Some(side) = side {
                // A forearm's joint (the elbow) is its twist origin.
                let (j1, j2) = if matches!(s, Segment::LeftForearm | Segment::RightForearm) {
                    let o = self.origin[si];
                    (dir.dot(&(o - root)) as f64, dir.dot(&(x - o)) as f64)
                } else {
                    (js, 0.0)
                };
                let (w, r) = (w as f64, r as f64);
                let l = &mut arm_bones[side];
                l[0] += w * j1 * r;
                l[1] += w * j2 * r;
                l[2] += w * j1 * j1;
                l[3] += w * j1 * j2;
                l[4] += w * j2 * j2;
            }
        }
    }

    /// The full normal equations: about its joint o, a segment's twist is
    /// v = dt + Σ (p_j − o) × ω_j and ω = Σ ω_j over the joints j of its chain.
    pub(super) fn assemble(&self) -> (Normal, Gradient) {
        let mut hh = Normal::zeros();
        let mut gg = Gradient::zeros();
        for s in Segment::ALL {
            let si = s.index();
            let h = symmetric(&self.h[si]);
            let g = Vector6::from_row_slice(&self.g[si].map(f64::from));
            // A: 6 × N, the twist of s from the unknowns, as (column, 6×3 block)s.
            let o = self.origin[si];
            // The translation and one block a joint of the longest chain (pelvis to forearm).
            let mut cols = [(0usize, SMatrix::<f64, 6, 3>::zeros()); 7];
            let mut n = 0;
            cols[n]
                .1
                .fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            n += 1;
            for j in s.chain() {
                let p = (self.origin[j.index()] - o).cast::<f64>();
                let blk = &mut cols[n];
                blk.0 = 3 + 3 * j.index();
                blk.1
                    .fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(&p.cross_matrix());
                blk.1
                    .fixed_view_mut::<3, 3>(3, 0)
                    .copy_from(&Matrix3::identity());
                n += 1;
            }
            for (ca, a) in &cols[..n] {
                let ha = a.transpose() * h;
                let mut gr = gg.fixed_rows_mut::<3>(*ca);
                gr += a.transpose() * g;
                for (cb, b) in &cols[..n] {
                    let mut dst = hh.fixed_view_mut::<3, 3>(*ca, *cb);
                    dst += ha * b;
                }
            }
        }
        (hh, gg)
    }
}

/// Entries of a symmetric 6×6 matrix's upper triangle.
pub(super) const UPPER: usize = 21;

/// The full matrix of an upper triangle stored row by row.
pub(super) fn symmetric(upper: &[f32; UPPER]) -> Local {
    let mut m = Local::zeros();
    let mut k = 0;
    for a in 0..6 {
        for b in a..6 {
            let x = f64::from(upper[k]);
            m[(a, b)] = x;
            m[(b, a)] = x;
            k += 1;
        }
    }
    m
}

impl Registration {
    /// `steps` Gauss–Newton steps from `start`. With `finish`, a last pass measures the
    /// final pose (energy, what is seen, the length steps); without (a start racing
    /// others), the energy is the one of the last pose linearised at.
    pub(super) fn run(&self, p: &Problem, start: BodyPose, steps: usize, finish: bool) -> Fit {
        let (t, cfg) = (p.body, p.cfg);
        let mut pose = start;
        // The last pass's sums, what it saw, and whether it summed the whole energy.
        let mut measured = None;
        let mut passes = 0;
        // The index of the next pass.
        let mut next_pass = 0;
        // Each point's capsule, searched afresh every `REASSIGN` passes: in between the
        // body moves by millimetres, and the search is most of a pass's work.
        let mut assign = vec![0u16; self.data.len()];
        let last = if finish {
            steps
        } else {
            steps.saturating_sub(1)
        };
        for it in 0..=last {
            passes += 1;
            next_pass = it + 1;
            let posed = Posed::new(t, &pose);
            let pass = Pass {
                search: it % REASSIGN == 0,
                energy: it == last,
            };
            let (acc, s) = self.accumulate(p, &posed, pass, &mut assign);
            if it == steps {
                measured = Some((acc, s, pass.energy));
                break;
            }
            let (mut h, mut g) = acc.assemble();
            measured = Some((acc, s, pass.energy));
            add_joint_priors(&mut h, &mut g, &pose, p.hidden, &cfg.priors);
            for i in 0..N {
                h[(i, i)] += cfg.solver.damping * h[(i, i)] + cfg.solver.damping_abs;
            }
            let Some(ch) = h.cholesky() else {
                break;
            };
            let step = -ch.solve(&g);
            if !step.iter().all(|x| x.is_finite()) {
                break;
            }
            let dt = Vector3::new(step[0] as f32, step[1] as f32, step[2] as f32);
            let mut omega = [Vector3::zeros(); Segment::COUNT];
            for (s, w) in omega.iter_mut().enumerate() {
                let o = 3 + 3 * s;
                *w = Vector3::new(step[o] as f32, step[o + 1] as f32, step[o + 2] as f32);
                // A step is a linearisation: keep each turn small.
                let a = w.norm();
                if a > 0.3 {
                    *w *= 0.3 / a;
                }
            }
            let mut next = pose;
            next.step(&dt, &omega);
            if !next.is_finite() {
                break;
            }
            pose = next;
            if step.norm() < cfg.solver.converged as f64 {
                break;
            }
        }
        // The data term is summed only on the last pass. A run that stopped early
        // (converged, or a step it could not take) is measured where it stopped, by
        // the pass it would have made next: judged without its data term, a start that
        // could not move won every race, and the body froze for seconds (pose NOTES,
        // 2026-12-04 evening).
        let (acc, seen) = match measured {
            Some((acc, seen, true)) => (acc, seen),
            _ => {
                passes += 1;
                let pass = Pass {
                    search: next_pass % REASSIGN == 0,
                    energy: true,
                };
                self.accumulate(p, &Posed::new(t, &pose), pass, &mut assign)
            }
        };
        let (energy, guide_energy) = (acc.energy as f32, acc.guide_energy as f32);
        let (length, arm_bones) = (acc.length, acc.arm_bones);
        // A step only where the limbs carry enough evidence (about a hundred points'
        // worth of a limb's reach).
        let length_step = length.map(|(g, h)| (h > cfg.lengths.evidence).then(|| (-g / h) as f32));
        let arm_bone_steps = match (arm_bones, cfg.lengths.bone_evidence) {
            (Some(sums), Some(e)) => sums.map(|l| bone_steps(&l, e)),
            _ => [None; 2],
        };
        Fit {
            pose,
            energy,
            guide_energy,
            seen,
            length_step,
            arm_bone_steps,
            passes,
        }
    }
}
