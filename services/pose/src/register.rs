//! Articulated registration: the body template ([`crate::body`]) fitted to the person's
//! points by Gauss–Newton, beyond the seed.
//!
//! The seed's limbs are two-joint chains fitted one by one to target points around a
//! geodesic path, on a torso registered alone; a torso model that turns a few degrees
//! when an arm is raised before the chest, or slides along its own axis, then carries
//! every key point with it. Here the whole body is fitted at once, from the geodesic
//! estimate and from the last frame's fit, whichever explains the frame better:
//!
//! * data term: every sampled person point lies on the surface of the nearest capsule
//!   (signed distance, Cauchy-weighted so points the body does not explain — a bag, a
//!   second person's arm — cannot drag it);
//! * silhouette term: the body's front surface, seen from the camera, projects onto the
//!   person's pixels (a limb outside them is pulled to the nearest one);
//! * free-space term: where the camera sees a surface behind the body's front, the body
//!   cannot be (it would hide that surface);
//! * extremity term: the limbs' tips near the geodesic maxima assigned to them.
//!
//! Bone lengths and the torso's shape are fixed by the template, so no step can stretch
//! a limb or shear the torso. The unknowns are the pelvis position and a rotation per
//! segment (36 numbers); a step moves each segment by a twist that is linear in them, so
//! the normal equations are accumulated per segment (6×6) and assembled once.

use crate::body::{BodyPose, BodyTemplate, Posed, Segment, Shape};
use airglyph_core::Intrinsics;
use nalgebra::{Matrix3, Point3, SMatrix, SVector, Vector3, Vector6};

/// Unknowns of a step: the pelvis's translation, then a rotation per segment.
const N: usize = 3 + 3 * Segment::COUNT;
type Normal = SMatrix<f64, N, N>;
type Gradient = SVector<f64, N>;
type Local = SMatrix<f64, 6, 6>;

/// How far around the person's bounding box the nearest-person-pixel map reaches,
/// pixels (a limb of the body farther out is pulled towards the box's edge first).
const NEAREST_MARGIN: usize = 24;

/// For every block of 2×2 pixels of the person's bounding box (and a margin), a person
/// pixel of the nearest block that has one, by two passes of nearest-seed propagation
/// over 8-neighbours: within a few pixels of the exact answer, enough to pull a limb
/// back onto the silhouette, at a quarter of the cost of a full-resolution map.
#[derive(Debug, Default)]
struct NearestPixel {
    /// The box in blocks: first block column and row, size.
    bu0: usize,
    bv0: usize,
    w: usize,
    h: usize,
    /// Per block: a person pixel (image coordinates) of the nearest block with one,
    /// `u16::MAX` for none, and the squared distance in blocks.
    seed: Vec<(u16, u16)>,
    d2: Vec<u32>,
}

/// Pixels a block of [`NearestPixel`] covers along each axis.
const BLOCK: usize = 2;

impl NearestPixel {
    /// `bbox`: the person pixels' first and last column and row.
    fn build(&mut self, f: &Frame, bbox: Option<(usize, usize, usize, usize)>, margin: usize) {
        self.seed.clear();
        self.d2.clear();
        self.w = 0;
        self.h = 0;
        let Some((u0, v0, u1, v1)) = bbox else {
            return;
        };
        self.bu0 = u0.saturating_sub(margin) / BLOCK;
        self.bv0 = v0.saturating_sub(margin) / BLOCK;
        self.w = (u1 + margin).min(f.width - 1) / BLOCK + 1 - self.bu0;
        self.h = (v1 + margin).min(f.height - 1) / BLOCK + 1 - self.bv0;
        let (w, h) = (self.w, self.h);
        self.seed.resize(w * h, (u16::MAX, u16::MAX));
        self.d2.resize(w * h, u32::MAX);
        for v in v0..=v1 {
            let row = &f.mask[v * f.width..(v + 1) * f.width];
            for (u, &m) in row.iter().enumerate().take(u1 + 1).skip(u0) {
                if m && f.points[v * f.width + u].z > 0.0 {
                    let b = (v / BLOCK - self.bv0) * w + u / BLOCK - self.bu0;
                    if self.d2[b] != 0 {
                        self.seed[b] = (u as u16, v as u16);
                        self.d2[b] = 0;
                    }
                }
            }
        }
        // Distances between blocks, measured from the seed's block.
        let (ou, ov) = (self.bu0 as i32, self.bv0 as i32);
        let relax =
            |seed: &mut [(u16, u16)], d2: &mut [u32], i: usize, j: usize, u: i32, v: i32| {
                let q = seed[j];
                if q.0 != u16::MAX {
                    let du = q.0 as i32 / BLOCK as i32 - u - ou;
                    let dv = q.1 as i32 / BLOCK as i32 - v - ov;
                    let d = (du * du + dv * dv) as u32;
                    if d < d2[i] {
                        d2[i] = d;
                        seed[i] = q;
                    }
                }
            };
        let (seed, d2) = (&mut self.seed[..], &mut self.d2[..]);
        for v in 0..h {
            for u in 0..w {
                let i = v * w + u;
                let (ui, vi) = (u as i32, v as i32);
                if u > 0 {
                    relax(seed, d2, i, i - 1, ui, vi);
                }
                if v > 0 {
                    relax(seed, d2, i, i - w, ui, vi);
                    if u > 0 {
                        relax(seed, d2, i, i - w - 1, ui, vi);
                    }
                    if u + 1 < w {
                        relax(seed, d2, i, i - w + 1, ui, vi);
                    }
                }
            }
        }
        for v in (0..h).rev() {
            for u in (0..w).rev() {
                let i = v * w + u;
                let (ui, vi) = (u as i32, v as i32);
                if u + 1 < w {
                    relax(seed, d2, i, i + 1, ui, vi);
                }
                if v + 1 < h {
                    relax(seed, d2, i, i + w, ui, vi);
                    if u + 1 < w {
                        relax(seed, d2, i, i + w + 1, ui, vi);
                    }
                    if u > 0 {
                        relax(seed, d2, i, i + w - 1, ui, vi);
                    }
                }
            }
        }
    }

    /// A person pixel near pixel (u, v) (for a pixel beyond the box, near the box's
    /// closest block).
    fn get(&self, u: usize, v: usize) -> Option<(u16, u16)> {
        if self.w == 0 {
            return None;
        }
        let bu = (u / BLOCK).clamp(self.bu0, self.bu0 + self.w - 1) - self.bu0;
        let bv = (v / BLOCK).clamp(self.bv0, self.bv0 + self.h - 1) - self.bv0;
        let q = self.seed[bv * self.w + bu];
        (q.0 != u16::MAX).then_some(q)
    }
}

/// Settings of the registration (part of [`crate::PoseConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RegisterConfig {
    /// Fit the articulated body after the geodesic estimate (false: the seed's chains).
    pub enabled: bool,
    /// Person points for the data term: every one within `thin_px` of the silhouette's
    /// edge, the others on a grid of this stride.
    pub thin_px: f32,
    pub interior_stride: usize,
    /// Gauss–Newton steps in all, and of them how many each start is given before the
    /// best one alone goes on.
    pub iterations: usize,
    pub race_iterations: usize,
    /// A run stops early once a step is smaller than this (metres and radians
    /// together).
    pub converged: f32,
    /// Scale of the data term's Cauchy weight, metres.
    pub sigma: f32,
    /// Weight of a silhouette or free-space residual against one data point's.
    pub silhouette_weight: f32,
    pub free_space_weight: f32,
    /// Beyond this (metres) the silhouette and free-space terms pull linearly (Huber).
    pub silhouette_scale: f32,
    /// How far the body's front may lie before the surface seen, metres.
    pub free_space_margin: f32,
    /// Weight of a limb tip's distance to its geodesic maximum, and its Cauchy scale.
    pub tip_weight: f32,
    pub tip_sigma: f32,
    /// A hand is placed behind the fingertips seen (as the seed's chains place it) when
    /// they lie this near the fitted body's fingertips; farther, the fit's hand stays.
    pub tip_trust: f32,
    /// A limb's tip that lies on another limb of the tracked body and at least this much
    /// (metres) farther from its own is dropped ([`drop_borrowed_tips`]). 0 = off.
    pub borrowed_tip_gap: f32,
    /// Weight of the head's and the chest's turn from their rest against their parent
    /// (per radian²): the head's turn about its own axis is not in the data at all.
    pub head_prior: f64,
    pub chest_prior: f64,
    pub abdomen_prior: f64,
    /// The collarbones' raising and bringing forward of the shoulders, against their
    /// rest turn (rotation vectors against the chest, left and right), which
    /// [`crate::calibrate`] learns for the person.
    pub collar_prior: f64,
    pub collar_rest: [[f32; 3]; 2],
    /// The share of the way to each well-seen frame's collarbone turns their rest moves.
    pub collar_gain: f32,
    /// Elbows and knees: weight of a twist and of a sideways bend (per radian²), of
    /// bending the wrong way beyond `hinge_slack` radians.
    pub hinge_twist_prior: f64,
    pub hinge_side_prior: f64,
    pub hinge_limit_prior: f64,
    pub hinge_slack: f32,
    /// Pull of upper arms and thighs towards hanging straight down, per squared radian:
    /// a limb the camera does not see (behind the body) has nothing else to keep it.
    /// Scaled per limb by how hidden it was ([`hidden_limbs`]). At 0.3 (against 0):
    /// CMU 01_01 / 01_03 4.26 / 4.33 → 4.06 / 4.09 cm mean error, with sensor noise
    /// 94.9 / 93.3 → 96.8 / 95.5 % of joints within 10 cm; the demo's recording 33 → 34
    /// symbols of 36 (32 before the gesture stage held its body frame steady). At 0.5
    /// 01_03 with noise falls to 94.0 %, at 1.0 to 94.4 %.
    pub limb_rest_prior: f64,
    /// Σ w j² a limb pair's length gradient needs before it is trusted (j: metres a
    /// point moves per unit change of the length ratio).
    pub length_evidence: f64,
    /// The share of a limb pair's front surface the camera must see where the fit puts
    /// it for the frame to count towards the pair's length.
    pub length_seen: f32,
    /// When set, an arm's upper arm and forearm are learned apart (`bone_steps`) from
    /// frames whose normal equations of the two bones' length ratios have no eigenvalue
    /// below this (Σ w j², as `length_evidence`). Off (None) by default: at 1.5, before
    /// the gesture stage held its body frame steady, the demo named 34 symbols of 36
    /// instead of 33 (the chest turns less with the drawing arm), but CMU 01_03 with
    /// sensor noise loses a leg for about 100 frames (93.3 → 91.1 % of joints within
    /// 10 cm), and the split it learns is biased
    /// (0.92–0.97 on the MakeHuman body, whose truth is 1; 1.16 on the procedural body,
    /// whose truth is 1.055). At 3.0 01_03 is as before and the demo back at 33.
    pub bone_evidence: Option<f64>,
    /// Every this many frames the seed's torso registration runs and the geodesic
    /// estimate races the tracked body; in between it races only when a limb tip lies
    /// farther than `race_gap` from the tracked body's (and off its surface, see
    /// `race_off_body`).
    pub redetect_every: usize,
    pub race_gap: f32,
    /// A strayed tip races only when it also lies this far off the tracked body's
    /// surface ([`tips_strayed`]); 0 = wherever it lies.
    pub race_off_body: f32,
    /// Also race the tracked body with its strayed limbs taken from the geodesic
    /// estimate.
    pub race_hybrid: bool,
    /// Levenberg–Marquardt damping: relative (of the diagonal) and absolute.
    pub damping: f64,
    pub damping_abs: f64,
    /// The body's shape (bone lengths come from the configuration).
    pub shape: Shape,
}

impl Default for RegisterConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            thin_px: 2.0,
            interior_stride: 3,
            iterations: 10,
            race_iterations: 3,
            converged: 1e-4,
            sigma: 0.03,
            silhouette_weight: 3.0,
            free_space_weight: 4.0,
            silhouette_scale: 0.05,
            free_space_margin: 0.03,
            tip_weight: 10.0,
            tip_sigma: 0.1,
            tip_trust: 0.12,
            borrowed_tip_gap: 0.1,
            head_prior: 1.0,
            chest_prior: 3.0,
            abdomen_prior: 3.0,
            collar_prior: 3.0,
            collar_rest: [[0.0; 3]; 2],
            collar_gain: 0.02,
            hinge_twist_prior: 0.05,
            hinge_side_prior: 2.0,
            hinge_limit_prior: 5.0,
            limb_rest_prior: 0.3,
            hinge_slack: 0.15,
            length_evidence: 10.0,
            length_seen: 0.6,
            bone_evidence: None,
            redetect_every: 10,
            race_gap: 0.25,
            race_off_body: 0.05,
            race_hybrid: false,
            damping: 0.05,
            damping_abs: 0.01,
            shape: Shape::makehuman(),
        }
    }
}

/// The frame the body is fitted to: the organized point cloud and the person mask of
/// the work image.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    pub points: &'a [Point3<f32>],
    pub mask: &'a [bool],
    pub width: usize,
    pub height: usize,
    pub k: &'a Intrinsics,
}

/// The result of one registration.
#[derive(Debug, Clone, Copy)]
pub struct Fit {
    pub pose: BodyPose,
    /// The robust energy at the end (lower explains the frame better).
    pub energy: f32,
    /// Per segment, the share of its front surface the camera sees where the body puts
    /// it (1 = all of it; hidden or contradicted parts lower it).
    pub seen: [f32; Segment::COUNT],
    /// The change of the arms' and the legs' length ratio that would explain the frame
    /// best (one Gauss–Newton step at the final pose), when the frame says enough.
    pub length_step: [Option<f32>; 2],
    /// Per arm (left, right): the change of the upper arm's and the forearm's length
    /// ratios apart that would explain the frame best, only when the frame tells the
    /// two bones apart (a bent elbow; see `bone_steps`).
    pub arm_bone_steps: [Option<[f32; 2]>; 2],
    /// Passes over the data this fit took (all starts).
    pub passes: usize,
}

/// Reusable state: the sampled data and the nearest-person-pixel map of a frame.
#[derive(Debug, Default)]
pub struct Registration {
    /// Sampled person points and the number of pixels each stands for.
    data: Vec<(Point3<f32>, f32)>,
    nearest: NearestPixel,
}

/// A capsule of the posed body, camera frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Placed {
    segment: Segment,
    a: Point3<f32>,
    ab: Vector3<f32>,
    /// 1 / |ab|² (0 for a sphere).
    inv_len2: f32,
    len2: f32,
    ra: f32,
    rb: f32,
    /// A sphere around the whole capsule, for skipping it in nearest-capsule searches.
    centre: Point3<f32>,
    bound: f32,
}

impl Placed {
    /// Closest axis point, the radius there, and the signed distance to the surface.
    #[inline]
    fn nearest(&self, p: &Point3<f32>) -> (Point3<f32>, f32, f32) {
        let t = ((p - self.a).dot(&self.ab) * self.inv_len2).clamp(0.0, 1.0);
        let c = self.a + self.ab * t;
        let r = self.ra + (self.rb - self.ra) * t;
        (c, r, (p - c).norm() - r)
    }
}

/// Normal equations of one step, per segment: the segment's motion is a twist (v, ω)
/// about its own joint o, and a residual r along `dir` at point x of it changes by
/// dirᵀ(v + ω × (x − o)). Sums are in f32 (lever arms are a limb long, not the
/// camera's distance), over the upper triangle of the symmetric 6×6 outer product only
/// (row by row, [`UPPER`] entries): the lower one is mirrored once, in `assemble`.
struct Accumulator {
    h: [[f32; UPPER]; Segment::COUNT],
    g: [[f32; 6]; Segment::COUNT],
    /// The twists' origins: each segment's joint.
    origin: [Point3<f32>; Segment::COUNT],
    energy: f64,
    /// Where each limb is rooted (shoulder, hip), for the limb-length gradient.
    roots: [Option<Point3<f32>>; Segment::COUNT],
    /// For arms and legs: Σ w j r and Σ w j² of the residuals' derivative j by the limbs'
    /// length ratio (all points of a limb move away from its root as it grows).
    length: [(f64, f64); 2],
    /// Per arm (left, right), the normal equations of the residuals' derivatives by the
    /// upper arm's and the forearm's length ratios apart (an upper arm's points move
    /// away from the shoulder as it grows, a forearm's with the elbow and away from
    /// it): Σ w j₁ r, Σ w j₂ r, Σ w j₁², Σ w j₁ j₂, Σ w j₂². None unless
    /// [`RegisterConfig::bone_evidence`] asks for them: every arm point of every pass
    /// would pay for sums nobody reads.
    arm_bones: Option<[[f64; 5]; 2]>,
}

/// The upper arm's and the forearm's length-ratio steps of one arm from its normal
/// equations ([`Accumulator::arm_bones`]), or None when the frame cannot tell the two
/// bones apart: the smaller eigenvalue of the 2×2 system must exceed `evidence`. A
/// straight arm moves its tip alike whichever bone grows, and its surface points hardly
/// move along their normals: one ratio for the whole arm is all it can say. A bent
/// elbow, seen, says where the elbow is.
fn bone_steps(l: &[f64; 5], evidence: f64) -> Option<[f32; 2]> {
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
    fn new(posed: &Posed, split_arms: bool) -> Self {
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
            roots,
            length: [(0.0, 0.0); 2],
            arm_bones: split_arms.then_some([[0.0; 5]; 2]),
        }
    }

    /// Adds residual `r` with weight `w` in the normal equations.
    #[inline]
    fn add(&mut self, s: Segment, x: &Point3<f32>, dir: &Vector3<f32>, r: f32, w: f32) {
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
    fn assemble(&self) -> (Normal, Gradient) {
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
const UPPER: usize = 21;

/// The full matrix of an upper triangle stored row by row.
fn symmetric(upper: &[f32; UPPER]) -> Local {
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

/// For the nearest-capsule search, per placed capsule g the others c by the gap
/// between their bounding spheres, |centre_g − centre_c| − bound_g − bound_c, least
/// first. A point whose surface distance to g is d lies within d + bound_g of g's
/// centre, so a capsule with a gap above 2d lies more than d from it: the search
/// from g stops there, after the few capsules beside g, instead of testing every one.
struct Gaps {
    n: usize,
    /// Row g: (gap, c) for every c ≠ g, least gap first.
    rows: Vec<(f32, u16)>,
}

impl Gaps {
    fn new(placed: &[Placed]) -> Self {
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

    fn of(&self, g: usize) -> &[(f32, u16)] {
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
fn nearest_capsule(
    placed: &[Placed],
    gaps: &Gaps,
    p: &Point3<f32>,
    guess: usize,
) -> (usize, Point3<f32>, f32) {
    let (q, _, d) = placed[guess].nearest(p);
    let mut best = (guess, q, if d.is_nan() { f32::INFINITY } else { d });
    let within = 2.0 * best.2;
    for &(gap, ci) in gaps.of(guess) {
        if gap > within {
            break;
        }
        let ci = usize::from(ci);
        let c = &placed[ci];
        let reach = best.2 + c.bound;
        if reach > 0.0 && (p - c.centre).norm_squared() > reach * reach {
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
fn surface_distance<'a>(capsules: impl IntoIterator<Item = &'a Placed>, p: &Point3<f32>) -> f32 {
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
            }
        })
        .collect()
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

/// Whether a limb's tip (its geodesic maximum, as [`drop_borrowed_tips`] left them)
/// strayed from `tracked`, the last frame's body, so that the geodesic estimate must
/// race it: it lies farther than [`RegisterConfig::race_gap`] from its own limb's tip
/// and more than [`RegisterConfig::race_off_body`] off the body's surface. A maximum
/// on the body's surface is one the body explains where it is, whichever limb it was
/// assigned to; sensor noise makes such maxima on a knee or a hip in most frames of a
/// noisy 320×240 image, and racing on them cost every such frame the seed's chains and
/// a second start without finding a better body.
pub fn tips_strayed(
    t: &BodyTemplate,
    tracked: &BodyPose,
    tips: &[Option<Point3<f32>>; 5],
    cfg: &RegisterConfig,
) -> bool {
    let posed = Posed::new(t, tracked);
    let mut placed = None;
    tips.iter().zip(&t.tips).any(|(m, (seg, local))| {
        let Some(m) = m else { return false };
        if (posed.point(*seg, local) - m).norm() <= cfg.race_gap {
            return false;
        }
        cfg.race_off_body <= 0.0 || {
            let placed = placed.get_or_insert_with(|| place(t, &posed));
            surface_distance(placed.iter(), m) > cfg.race_off_body
        }
    })
}

/// How near (metres) a tip must lie to another limb's surface to be taken for its point.
const ON_SURFACE: f32 = 0.03;

/// Drops each limb's tip (its geodesic maximum) that lies on another limb of `tracked`,
/// the last frame's body, and well away from its own. The geodesic assignment can give
/// an arm hidden behind the body a maximum of the other arm (a bent elbow before the
/// chest); its tip term then pulled the hidden arm out to that point, and the race kept
/// the arm there for frames (CMU 01_01: a hand 45–80 cm off for 5–10 frames at a time).
pub fn drop_borrowed_tips(
    t: &BodyTemplate,
    tracked: &BodyPose,
    tips: &mut [Option<Point3<f32>>; 5],
    cfg: &RegisterConfig,
) {
    if cfg.borrowed_tip_gap <= 0.0 || tips.iter().all(Option::is_none) {
        return;
    }
    let placed = place(t, &Posed::new(t, tracked));
    let distance = |limb: crate::Limb, p: &Point3<f32>| {
        let segments = crate::body::limb_segments(limb);
        surface_distance(placed.iter().filter(|c| segments.contains(&c.segment)), p)
    };
    for l in crate::Limb::ALL {
        let Some(m) = tips[l.index()] else { continue };
        let own = distance(l, &m);
        let borrowed = crate::Limb::ALL.iter().any(|&o| {
            o != l && {
                let d = distance(o, &m);
                d < ON_SURFACE && own > d + cfg.borrowed_tip_gap
            }
        });
        if borrowed {
            tips[l.index()] = None;
        }
    }
}

/// Cauchy's weight and cost for residual `r` at scale `s`.
#[inline]
fn cauchy(r: f32, s: f32) -> (f32, f32) {
    (cauchy_weight(r, s), cauchy_cost(r, s))
}

/// Huber's weight and cost at scale `s`: quadratic near, linear far. For the body
/// outside the silhouette or before a seen surface, which is wrong however far it is
/// (a data point far from the body may be something else; a limb in empty space is
/// not), so its pull must not fade with distance.
#[inline]
fn huber(r: f32, s: f32) -> (f32, f32) {
    let a = r.abs();
    if a <= s {
        (1.0, 0.5 * r * r)
    } else {
        (s / a, s * (a - 0.5 * s))
    }
}

#[inline]
fn cauchy_weight(r: f32, s: f32) -> f32 {
    let q = (r / s) * (r / s);
    1.0 / (1.0 + q)
}

#[inline]
fn cauchy_cost(r: f32, s: f32) -> f32 {
    let q = (r / s) * (r / s);
    0.5 * s * s * q.ln_1p()
}

/// Priors on each joint's turn, the rotation vector φ of a segment against its parent
/// (parent frame, x = the person's left, y = up, z = forward at rest). A world turn ω
/// of the segment changes φ by R_parentᵀ ω; its parent's turn moves both and leaves φ
/// alone. The spine and the neck keep near their rest (the head's turn about its own
/// axis is not in the data at all). Elbows and knees are hinges about x: they do not
/// bend sideways (z), twist little (y), and bend one way only (the knee back, the
/// elbow forward). Upper arms and thighs hidden last frame are pulled towards hanging
/// down ([`RegisterConfig::limb_rest_prior`], scaled by [`hidden_limbs`]): a limb behind
/// the body is held by nothing else and would stay where the last frame that saw it (or
/// a wrong start) left it. Pulling every limb alike (0.1) bent an arm raised to draw and
/// turned its collar (the demo fell from 33 symbols of 36 to 29); pulling the hidden ones
/// only leaves the drawing arm alone.
fn add_joint_priors(
    h: &mut Normal,
    g: &mut Gradient,
    pose: &BodyPose,
    hidden: &[f32; Segment::COUNT],
    cfg: &RegisterConfig,
) {
    use Segment::*;
    // (segment, weight per axis of φ, bending limit on φ.x: (sign, allowed))
    let hinge = |seg| (seg, [0.0, cfg.hinge_twist_prior, cfg.hinge_side_prior]);
    let rest = |seg: Segment| (seg, [cfg.limb_rest_prior * hidden[seg.index()] as f64; 3]);
    let priors = [
        (Head, [cfg.head_prior; 3]),
        (Chest, [cfg.chest_prior; 3]),
        (Abdomen, [cfg.abdomen_prior; 3]),
        // The collarbone points sideways (x): its turn about x is no motion at all.
        (
            LeftCollar,
            [cfg.hinge_twist_prior, cfg.collar_prior, cfg.collar_prior],
        ),
        (
            RightCollar,
            [cfg.hinge_twist_prior, cfg.collar_prior, cfg.collar_prior],
        ),
        rest(LeftUpperArm),
        rest(RightUpperArm),
        rest(LeftThigh),
        rest(RightThigh),
        hinge(LeftForearm),
        hinge(RightForearm),
        hinge(LeftShin),
        hinge(RightShin),
    ];
    for (seg, w) in priors {
        let Some(parent) = seg.parent() else { continue };
        let rp = pose.rotation[parent.index()];
        let mut phi = (rp.inverse() * pose.rotation[seg.index()]).scaled_axis();
        // The collarbones keep near the person's own rest, learned as they move.
        match seg {
            LeftCollar => phi -= Vector3::from(cfg.collar_rest[0]),
            RightCollar => phi -= Vector3::from(cfg.collar_rest[1]),
            _ => {}
        }
        let rpm = rp.matrix().cast::<f64>();
        let o = 3 + 3 * seg.index();
        let mut add = |axis: usize, r: f32, w: f64| {
            if w <= 0.0 {
                return;
            }
            // J = e_axisᵀ R_pᵀ: the axis of the parent frame, in the camera frame.
            let d = rpm.column(axis).into_owned();
            let mut hb = h.fixed_view_mut::<3, 3>(o, o);
            hb += d * d.transpose() * w;
            let mut gr = g.fixed_rows_mut::<3>(o);
            gr += d * (w * r as f64);
        };
        for (axis, &wa) in w.iter().enumerate() {
            add(axis, phi[axis], wa);
        }
        // One-way bending: the knee flexes with φ.x > 0 (the shin goes back), the elbow
        // with φ.x < 0 (the forearm comes forward).
        let over = match seg {
            LeftShin | RightShin => (-phi.x - cfg.hinge_slack).max(0.0),
            LeftForearm | RightForearm => (phi.x - cfg.hinge_slack).max(0.0),
            _ => 0.0,
        };
        if over > 0.0 {
            let sign = if matches!(seg, LeftShin | RightShin) {
                -1.0
            } else {
                1.0
            };
            add(0, sign * over, cfg.hinge_limit_prior);
        }
    }
}

/// How hidden each upper arm and thigh is, for the pull towards hanging: (1 − the share
/// of the limb, upper and lower segment together, the camera saw)², so a limb in sight
/// is left alone and one behind the body gets the whole pull. Other segments: 0.
pub fn hidden_limbs(seen: &[f32; Segment::COUNT]) -> [f32; Segment::COUNT] {
    use Segment::*;
    let mut hidden = [0.0; Segment::COUNT];
    for (upper, lower) in [
        (LeftUpperArm, LeftForearm),
        (RightUpperArm, RightForearm),
        (LeftThigh, LeftShin),
        (RightThigh, RightShin),
    ] {
        let seen = 0.5 * (seen[upper.index()] + seen[lower.index()]);
        hidden[upper.index()] = (1.0 - seen.clamp(0.0, 1.0)).powi(2);
    }
    hidden
}

/// What one registration fits, to what, and how.
struct Problem<'a> {
    frame: &'a Frame<'a>,
    body: &'a BodyTemplate,
    tips: &'a [Option<Point3<f32>>; 5],
    /// Per segment, how hidden it was last frame (1 − seen, squared): what the pull
    /// towards hanging acts on.
    hidden: &'a [f32; Segment::COUNT],
    cfg: &'a RegisterConfig,
}

/// What a pass over the data does besides the normal equations.
#[derive(Debug, Clone, Copy)]
struct Pass {
    /// Search every point's nearest capsule (else keep the last pass's).
    search: bool,
    /// Sum the energy (only the last pass of a run needs it).
    energy: bool,
}

/// Whether a person pixel lies within a radius of the silhouette's edge: of a pixel
/// outside the mask, or of the image's border. The exact answer of the squared distance
/// transform's `d² ≤ r²`, from the few pixels within the radius, for the registration's
/// sampling alone (which needs no more than that of the transform).
struct EdgeTest {
    /// The offsets (du, dv) within the radius, nearest first (most edge pixels have a
    /// neighbour outside).
    offsets: Vec<(i32, i32)>,
}

impl EdgeTest {
    fn new(radius: f32) -> Self {
        let r2 = radius * radius;
        let reach = radius.max(0.0).floor() as i32;
        let mut offsets: Vec<(i32, i32)> = (-reach..=reach)
            .flat_map(|dv| (-reach..=reach).map(move |du| (du, dv)))
            .filter(|&(du, dv)| (du, dv) != (0, 0) && (du * du + dv * dv) as f32 <= r2)
            .collect();
        offsets.sort_by_key(|&(du, dv)| du * du + dv * dv);
        Self { offsets }
    }

    /// `(u, v)` is a person pixel of `f`.
    #[inline]
    fn near(&self, f: &Frame, u: usize, v: usize) -> bool {
        let (w, h) = (f.width as i32, f.height as i32);
        self.offsets.iter().any(|&(du, dv)| {
            let (x, y) = (u as i32 + du, v as i32 + dv);
            x < 0 || y < 0 || x >= w || y >= h || !f.mask[(y * w + x) as usize]
        })
    }
}

/// Passes between two nearest-capsule searches.
const REASSIGN: usize = 2;

impl Registration {
    /// Samples the person's points and builds the nearest-person-pixel map.
    ///
    /// Thin parts (limbs, within [`RegisterConfig::thin_px`] of the silhouette's edge)
    /// keep every pixel: a forearm is two or three pixels wide. The thick interior is
    /// taken on a grid of [`RegisterConfig::interior_stride`].
    pub fn prepare(&mut self, f: &Frame, cfg: &RegisterConfig) {
        let s = cfg.interior_stride.max(1);
        let edge = EdgeTest::new(cfg.thin_px);
        self.data.clear();
        let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0, 0);
        for v in 0..f.height {
            let row = &f.mask[v * f.width..(v + 1) * f.width];
            let Some(a) = row.iter().position(|&m| m) else {
                continue;
            };
            let b = row.iter().rposition(|&m| m).unwrap_or(a);
            (u0, u1, v0, v1) = (u0.min(a), u1.max(b), v0.min(v), v1.max(v));
            for (u, &m) in row.iter().enumerate().take(b + 1).skip(a) {
                let i = v * f.width + u;
                if !m || f.points[i].z <= 0.0 {
                    continue;
                }
                if s == 1 || edge.near(f, u, v) {
                    self.data.push((f.points[i], 1.0));
                } else if u % s == 0 && v % s == 0 {
                    self.data.push((f.points[i], (s * s) as f32));
                }
            }
        }
        let bbox = (u0 != usize::MAX).then_some((u0, v0, u1, v1));
        self.nearest.build(f, bbox, NEAREST_MARGIN);
    }

    /// How many person points the data term uses.
    pub fn data_len(&self) -> usize {
        self.data.len()
    }

    /// Fits the body from the best of several starts: each is moved
    /// [`RegisterConfig::race_iterations`] steps, and the one whose energy is then
    /// lowest goes on to [`RegisterConfig::iterations`] in all. `tips`: per limb of
    /// [`crate::Limb::ALL`], the geodesic maximum assigned to it (camera frame), if any.
    /// `None` without a start.
    pub fn fit(
        &self,
        f: &Frame,
        t: &BodyTemplate,
        starts: &[BodyPose],
        tips: &[Option<Point3<f32>>; 5],
        hidden: &[f32; Segment::COUNT],
        cfg: &RegisterConfig,
    ) -> Option<Fit> {
        let problem = Problem {
            frame: f,
            body: t,
            tips,
            hidden,
            cfg,
        };
        if let [only] = starts {
            return Some(self.run(&problem, *only, cfg.iterations, true));
        }
        let race = cfg.race_iterations.clamp(1, cfg.iterations.max(1));
        let mut best: Option<Fit> = None;
        let mut passes = 0;
        for &s in starts {
            // Each start's energy at its own final pose: the energy before the last
            // step would favour the start that moved least.
            let fit = self.run(&problem, s, race, true);
            passes += fit.passes;
            if best.is_none_or(|b| fit.energy < b.energy) {
                best = Some(fit);
            }
        }
        let b = best?;
        let mut fit = self.run(&problem, b.pose, cfg.iterations.saturating_sub(race), true);
        fit.passes += passes;
        Some(fit)
    }

    /// `steps` Gauss–Newton steps from `start`. With `finish`, a last pass measures the
    /// final pose (energy, what is seen, the length steps); without (a start racing
    /// others), the energy is the one of the last pose linearised at.
    fn run(&self, p: &Problem, start: BodyPose, steps: usize, finish: bool) -> Fit {
        let (t, cfg) = (p.body, p.cfg);
        let mut pose = start;
        let mut energy = f32::INFINITY;
        let mut seen = [0.0; Segment::COUNT];
        let mut length = [(0.0, 0.0); 2];
        let mut arm_bones = None;
        let mut passes = 0;
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
            let posed = Posed::new(t, &pose);
            let pass = Pass {
                search: it % REASSIGN == 0,
                energy: it == last,
            };
            let (acc, s) = self.accumulate(p, &posed, pass, &mut assign);
            energy = acc.energy as f32;
            seen = s;
            length = acc.length;
            arm_bones = acc.arm_bones;
            if it == steps {
                break;
            }
            let (mut h, mut g) = acc.assemble();
            add_joint_priors(&mut h, &mut g, &pose, p.hidden, cfg);
            for i in 0..N {
                h[(i, i)] += cfg.damping * h[(i, i)] + cfg.damping_abs;
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
            if step.norm() < cfg.converged as f64 {
                break;
            }
        }
        // A step only where the limbs carry enough evidence (about a hundred points'
        // worth of a limb's reach).
        let length_step = length.map(|(g, h)| (h > cfg.length_evidence).then(|| (-g / h) as f32));
        let arm_bone_steps = match (arm_bones, cfg.bone_evidence) {
            (Some(sums), Some(e)) => sums.map(|l| bone_steps(&l, e)),
            _ => [None; 2],
        };
        Fit {
            pose,
            energy,
            seen,
            length_step,
            arm_bone_steps,
            passes,
        }
    }

    fn accumulate(
        &self,
        p: &Problem,
        posed: &Posed,
        pass: Pass,
        assign: &mut [u16],
    ) -> (Accumulator, [f32; Segment::COUNT]) {
        let (f, t, tips, cfg) = (p.frame, p.body, p.tips, p.cfg);
        let placed = place(t, posed);
        let gaps = pass.search.then(|| Gaps::new(&placed));
        let mut acc = Accumulator::new(posed, cfg.bone_evidence.is_some());

        // Data: each point on its nearest capsule's surface.
        for ((p, area), ci) in self.data.iter().zip(assign.iter_mut()) {
            let (q, d) = if let Some(gaps) = &gaps {
                let (c, q, d) = nearest_capsule(&placed, gaps, p, usize::from(*ci));
                *ci = c as u16;
                (q, d)
            } else {
                let (q, _, d) = placed[*ci as usize].nearest(p);
                (q, d)
            };
            let off = p - q;
            let len = off.norm();
            if len < 1e-6 || !d.is_finite() {
                continue;
            }
            let n = off / len;
            let w = cauchy_weight(d, cfg.sigma);
            if pass.energy {
                acc.energy += (area * cauchy_cost(d, cfg.sigma)) as f64;
            }
            acc.add(placed[*ci as usize].segment, &q, &(-n), d, area * w);
        }

        // Silhouette and free space: the body's front surface as the camera sees it.
        let mut seen_n = [0u32; Segment::COUNT];
        let mut all_n = [0u32; Segment::COUNT];
        let (w, h) = (f.width as i32, f.height as i32);
        for c in &placed {
            let len = c.len2.sqrt();
            let k = ((len / 0.04).ceil() as usize + 1).max(2);
            for i in 0..k {
                let tt = i as f32 / (k - 1) as f32;
                let axis = c.a + c.ab * tt;
                let r = c.ra + (c.rb - c.ra) * tt;
                let Some(ray) = axis.coords.try_normalize(1e-6) else {
                    continue;
                };
                let s = axis - ray * r;
                let Some((u, v)) = f.k.project(&s) else {
                    continue;
                };
                let (u, v) = (u.round() as i32, v.round() as i32);
                if u < 0 || v < 0 || u >= w || v >= h {
                    continue;
                }
                let idx = (v * w + u) as usize;
                all_n[c.segment.index()] += 1;
                let person = f.mask[idx] && f.points[idx].z > 0.0;
                if person {
                    let z_obs = f.points[idx].z;
                    let gap = z_obs - s.z;
                    if gap > cfg.free_space_margin {
                        // The camera sees past the body's front: the body is not there.
                        let res = cfg.free_space_margin - gap;
                        let (wc, cost) = huber(res, cfg.silhouette_scale);
                        acc.energy += (cfg.free_space_weight * cost) as f64;
                        acc.add(
                            c.segment,
                            &s,
                            &Vector3::z(),
                            res,
                            cfg.free_space_weight * wc,
                        );
                    } else if gap > -0.05 {
                        seen_n[c.segment.index()] += 1;
                    }
                } else if let Some((qu, qv)) = self.nearest.get(u as usize, v as usize) {
                    let target = f.k.back_project(qu as f32, qv as f32, s.z);
                    let e = s - target;
                    let (wc, cost) = huber(e.norm(), cfg.silhouette_scale);
                    acc.energy += (cfg.silhouette_weight * cost) as f64;
                    let ws = cfg.silhouette_weight * wc;
                    // Both image axes: pulled only up or down, an arm held out beside
                    // the silhouette (a T-pose's arm, the person since turned side-on)
                    // stayed in the air.
                    acc.add(c.segment, &s, &Vector3::x(), e.x, ws);
                    acc.add(c.segment, &s, &Vector3::y(), e.y, ws);
                }
            }
        }

        // Tips near their geodesic maxima.
        for (tip, target) in t.tips.iter().zip(tips) {
            let Some(m) = target else { continue };
            let x = posed.point(tip.0, &tip.1);
            let e = x - m;
            let (wc, cost) = cauchy(e.norm(), cfg.tip_sigma);
            acc.energy += (cfg.tip_weight * cost) as f64;
            let wt = cfg.tip_weight * wc;
            acc.add(tip.0, &x, &Vector3::x(), e.x, wt);
            acc.add(tip.0, &x, &Vector3::y(), e.y, wt);
            acc.add(tip.0, &x, &Vector3::z(), e.z, wt);
        }
        // A segment without a surface of its own (a collarbone) is seen as its parent.
        let mut seen = [0.0; Segment::COUNT];
        for s in Segment::ALL {
            let i = s.index();
            seen[i] = if all_n[i] > 0 {
                seen_n[i] as f32 / all_n[i] as f32
            } else {
                s.parent().map_or(0.0, |p| seen[p.index()])
            };
        }
        (acc, seen)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Shape;
    use crate::PoseConfig;
    use airglyph_core::{Joint, Skeleton};
    use nalgebra::{Rotation3, Unit};

    /// The template's own surface seen by a 320×240 camera at `pose`: dense points on
    /// every capsule splatted into a z-buffer, so the registration must find the pose
    /// the body was drawn at.
    fn render(t: &BodyTemplate, pose: &BodyPose, k: &Intrinsics) -> (Vec<Point3<f32>>, Vec<bool>) {
        let (w, h) = (k.width as usize, k.height as usize);
        let mut points = vec![Point3::origin(); w * h];
        let mut mask = vec![false; w * h];
        let posed = Posed::new(t, pose);
        for c in &t.capsules {
            let a = posed.point(c.segment, &c.a);
            let b = posed.point(c.segment, &c.b);
            let axis = b - a;
            let len = axis.norm();
            let along = axis / len.max(1e-6);
            let side = along
                .cross(&Vector3::z())
                .try_normalize(1e-6)
                .unwrap_or(Vector3::x());
            let up = along.cross(&side);
            let rings = (len / 0.004).ceil() as usize + 1;
            // The caps too: run past both ends by a radius.
            for i in 0..=rings + 2 * 12 {
                let s = i as f32 / rings as f32 * len - c.ra.max(c.rb);
                for j in 0..120 {
                    let th = std::f32::consts::TAU * j as f32 / 120.0;
                    let tt = (s / len.max(1e-6)).clamp(0.0, 1.0);
                    let r = c.ra + (c.rb - c.ra) * tt;
                    let dir = side * th.cos() + up * th.sin();
                    // Past the ends, the cap's sphere.
                    let beyond = s - tt * len;
                    if beyond.abs() > r {
                        continue;
                    }
                    let rr = (r * r - beyond * beyond).sqrt();
                    let p = a + along * s + dir * rr;
                    let Some((u, v)) = k.project(&p) else {
                        continue;
                    };
                    let (u, v) = (u.round() as i64, v.round() as i64);
                    if u < 0 || v < 0 || u >= w as i64 || v >= h as i64 {
                        continue;
                    }
                    let i = v as usize * w + u as usize;
                    if !mask[i] || p.z < points[i].z {
                        points[i] = p;
                        mask[i] = true;
                    }
                }
            }
        }
        (points, mask)
    }

    fn facing(at: Point3<f32>) -> BodyPose {
        let r = Rotation3::from_basis_unchecked(&[Vector3::x(), -Vector3::y(), -Vector3::z()]);
        BodyPose {
            pelvis: at,
            rotation: [r; Segment::COUNT],
        }
    }

    /// The MakeHuman template at the default limb lengths, seen by a 320×240 camera.
    fn scene() -> (BodyTemplate, Intrinsics) {
        let cfg = PoseConfig::default();
        let t =
            BodyTemplate::from_shape(&Shape::makehuman(), &crate::body::Limbs::from_config(&cfg));
        (t, Intrinsics::default().scaled_to(320, 240))
    }

    fn frame_of<'a>(points: &'a [Point3<f32>], mask: &'a [bool], k: &'a Intrinsics) -> Frame<'a> {
        Frame {
            points,
            mask,
            width: k.width as usize,
            height: k.height as usize,
            k,
        }
    }

    /// Nothing hidden last frame.
    const SEEN: [f32; Segment::COUNT] = [0.0; Segment::COUNT];

    fn worst(t: &BodyTemplate, a: &BodyPose, b: &BodyPose) -> f32 {
        let (sa, sb): (Skeleton, Skeleton) =
            (Posed::new(t, a).skeleton(t), Posed::new(t, b).skeleton(t));
        Joint::ALL
            .iter()
            .map(|&j| (sa[j] - sb[j]).norm())
            .fold(0.0, f32::max)
    }

    #[test]
    fn registration_finds_the_pose_a_body_was_drawn_at() {
        let (t, k) = scene();
        // The truth: turned 20° to its left, the right arm raised forward, the left
        // knee bent.
        let mut truth = facing(Point3::new(0.05, 0.1, 2.6));
        let turn = |axis: Vector3<f32>, a: f32| Unit::new_normalize(axis).into_inner() * a;
        let mut w = [Vector3::zeros(); Segment::COUNT];
        w[Segment::Pelvis.index()] = turn(Vector3::y(), 0.35);
        w[Segment::RightUpperArm.index()] = turn(Vector3::x(), -1.1);
        w[Segment::RightForearm.index()] = turn(Vector3::x(), -0.5);
        w[Segment::LeftShin.index()] = turn(Vector3::x(), 0.6);
        truth.step(&Vector3::zeros(), &w);
        let (points, mask) = render(&t, &truth, &k);
        let frame = frame_of(&points, &mask, &k);
        // The start: where a person moving fast was a frame before: 6 cm off, turned
        // 8° less, the arm 11° and 17° lower, the knee straighter.
        let mut start = facing(Point3::new(0.1, 0.13, 2.62));
        let mut w0 = [Vector3::zeros(); Segment::COUNT];
        w0[Segment::Pelvis.index()] = turn(Vector3::y(), 0.2);
        w0[Segment::RightUpperArm.index()] = turn(Vector3::x(), -0.9);
        w0[Segment::RightForearm.index()] = turn(Vector3::x(), -0.2);
        w0[Segment::LeftShin.index()] = turn(Vector3::x(), 0.4);
        start.step(&Vector3::zeros(), &w0);
        // Every pixel a data point, of weight one; without the pull towards hanging,
        // which by design bends a limb the camera hardly sees (this raised arm: 3.6 cm
        // at its worst joint with a pull of 0.1).
        let cfg = RegisterConfig {
            iterations: 30,
            interior_stride: 1,
            limb_rest_prior: 0.0,
            ..RegisterConfig::default()
        };
        let before = worst(&t, &start, &truth);
        assert!(before > 0.1, "the start is {before} m off at worst");
        // The limbs' tips where the geodesic maxima would be: the truth's.
        let posed = Posed::new(&t, &truth);
        let tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
        let mut reg = Registration::default();
        reg.prepare(&frame, &cfg);
        assert!(reg.data_len() > 1000);
        let fit = reg
            .fit(&frame, &t, &[start], &tips, &SEEN, &cfg)
            .expect("a start");
        let after = worst(&t, &fit.pose, &truth);
        assert!(after < 0.02, "worst joint {after} m off after registration");
        // The camera sees the torso and the hanging arm; the raised arm points at it, so
        // its upper part is hidden behind its own hand.
        let seen = fit.seen;
        assert!(seen[Segment::Chest.index()] > 0.8, "{seen:?}");
        assert!(seen[Segment::LeftForearm.index()] > 0.8, "{seen:?}");
        assert!(seen[Segment::RightUpperArm.index()] < 0.3, "{seen:?}");
    }

    #[test]
    fn an_arm_held_out_beside_the_silhouette_is_pulled_back_onto_it() {
        let (t, k) = scene();
        // The truth: standing, arms hanging. The start: the right arm held straight out
        // sideways at shoulder height, over the background, with no geodesic maximum
        // to follow (a T-pose's arm, the person since turned side-on and the arm
        // hidden). Only the silhouette tells it is not there, and the arm lies beside
        // the person's pixels, not above or below them.
        let truth = facing(Point3::new(0.0, 0.1, 2.6));
        let (points, mask) = render(&t, &truth, &k);
        let frame = frame_of(&points, &mask, &k);
        let mut start = truth;
        let mut w = [Vector3::zeros(); Segment::COUNT];
        w[Segment::RightUpperArm.index()] = Vector3::z() * 1.5;
        start.step(&Vector3::zeros(), &w);
        let cfg = RegisterConfig {
            interior_stride: 1,
            limb_rest_prior: 0.0,
            ..RegisterConfig::default()
        };
        let posed = Posed::new(&t, &truth);
        let mut tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
        tips[crate::config::Limb::RightArm.index()] = None;
        // How far the arm's joints project from the nearest person pixel.
        let off_silhouette = |pose: &BodyPose| {
            let skel = Posed::new(&t, pose).skeleton(&t);
            [Joint::RightElbow, Joint::RightHand].map(|j| {
                let (u, v) = k.project(&skel[j]).expect("in front of the camera");
                (0..mask.len())
                    .filter(|&i| mask[i])
                    .map(|i| {
                        let w = k.width as usize;
                        let (pu, pv) = ((i % w) as f32, (i / w) as f32);
                        ((pu - u).powi(2) + (pv - v).powi(2)).sqrt()
                    })
                    .fold(f32::INFINITY, f32::min)
            })
        };
        let before = off_silhouette(&start);
        assert!(before[1] > 20.0, "{before:?} pixels off");
        let mut reg = Registration::default();
        reg.prepare(&frame, &cfg);
        let fit = reg
            .fit(&frame, &t, &[start], &tips, &SEEN, &cfg)
            .expect("a start");
        let after = off_silhouette(&fit.pose);
        assert!(after.iter().all(|&d| d < 2.0), "{after:?} pixels off");
    }

    /// A body standing before the camera as the last frame tracked it, and each limb's
    /// own tip on it.
    fn tracked_with_own_tips() -> (BodyTemplate, BodyPose, [Option<Point3<f32>>; 5]) {
        let (t, _) = scene();
        let tracked = facing(Point3::new(0.0, 0.1, 2.6));
        let posed = Posed::new(&t, &tracked);
        let own = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
        (t, tracked, own)
    }

    #[test]
    fn a_tip_on_another_limb_of_the_tracked_body_is_dropped() {
        use crate::Limb;
        let (t, tracked, own) = tracked_with_own_tips();
        let posed = Posed::new(&t, &tracked);
        let cfg = RegisterConfig::default();
        // Every limb's own tip stays, a hanging hand beside its thigh too.
        let mut tips = own;
        drop_borrowed_tips(&t, &tracked, &mut tips, &cfg);
        assert_eq!(tips, own);
        // The right arm given a point of the left forearm (its front, halfway down).
        let c = t
            .capsules
            .iter()
            .find(|c| c.segment == Segment::LeftForearm)
            .expect("a left forearm");
        let mid = Point3::from((c.a.coords + c.b.coords) * 0.5);
        let on_left_forearm = posed.point(c.segment, &mid) - Vector3::z() * c.ra.min(c.rb);
        tips[Limb::RightArm.index()] = Some(on_left_forearm);
        drop_borrowed_tips(&t, &tracked, &mut tips, &cfg);
        assert_eq!(tips[Limb::RightArm.index()], None);
        assert_eq!(tips[Limb::LeftArm.index()], own[Limb::LeftArm.index()]);
        // Off, it stays.
        tips[Limb::RightArm.index()] = Some(on_left_forearm);
        let off = RegisterConfig {
            borrowed_tip_gap: 0.0,
            ..cfg
        };
        drop_borrowed_tips(&t, &tracked, &mut tips, &off);
        assert_eq!(tips[Limb::RightArm.index()], Some(on_left_forearm));
    }

    #[test]
    fn only_a_tip_off_the_tracked_body_makes_the_geodesic_estimate_race() {
        use crate::Limb;
        let (t, tracked, own) = tracked_with_own_tips();
        let posed = Posed::new(&t, &tracked);
        let cfg = RegisterConfig::default();
        assert!(!tips_strayed(&t, &tracked, &own, &cfg));
        // The left leg's maximum on the front of the right knee: far from the left toes,
        // but on the body.
        let shin = t
            .capsules
            .iter()
            .find(|c| c.segment == Segment::RightShin)
            .expect("a right shin");
        let knee = posed.point(shin.segment, &shin.a) - Vector3::z() * shin.ra;
        let mut tips = own;
        tips[Limb::LeftLeg.index()] = Some(knee);
        let toes = own[Limb::LeftLeg.index()].expect("toes");
        assert!((knee - toes).norm() > cfg.race_gap);
        assert!(!tips_strayed(&t, &tracked, &tips, &cfg));
        // Without the surface test it races.
        let anywhere = RegisterConfig {
            race_off_body: 0.0,
            ..cfg.clone()
        };
        assert!(tips_strayed(&t, &tracked, &tips, &anywhere));
        // A hand raised 40 cm before the chest, where the tracked body is not, races.
        let mut tips = own;
        tips[Limb::RightArm.index()] = Some(Point3::new(0.0, -0.2, 2.2));
        assert!(tips_strayed(&t, &tracked, &tips, &cfg));
    }

    #[test]
    fn only_a_bent_arm_tells_its_bones_apart() {
        // Σ over residuals of w j j for the two bones' derivatives j = (j1, j2).
        let normal = |js: &[(f64, f64, f64)]| {
            let mut l = [0.0; 5];
            for &(j1, j2, r) in js {
                l[0] += j1 * r;
                l[1] += j2 * r;
                l[2] += j1 * j1;
                l[3] += j1 * j2;
                l[4] += j2 * j2;
            }
            l
        };
        // A straight arm: every residual moves alike whichever bone grows.
        let straight: Vec<_> = (0..40).map(|i| (0.5, 0.4, 0.01 * i as f64)).collect();
        assert_eq!(bone_steps(&normal(&straight), 1.5), None);
        // Bent: some residuals move with one bone only; the steps solve for both.
        let (s1, s2) = (0.03, -0.02);
        let bent: Vec<_> = (0..40)
            .map(|i| {
                let (j1, j2) = if i % 2 == 0 { (0.4, 0.0) } else { (0.2, 0.4) };
                (j1, j2, -(j1 * s1 + j2 * s2))
            })
            .collect();
        let [a, b] = bone_steps(&normal(&bent), 1.5).expect("a bent arm");
        assert!((a as f64 - s1).abs() < 1e-6 && (b as f64 - s2).abs() < 1e-6);
    }

    #[test]
    fn the_better_start_wins_the_race() {
        let (t, k) = scene();
        let truth = facing(Point3::new(0.0, 0.1, 2.6));
        let (points, mask) = render(&t, &truth, &k);
        let frame = frame_of(&points, &mask, &k);
        // A start turned half round (back to the camera) cannot reach the truth in a
        // few steps; one a little off can.
        let mut away = truth;
        let mut w = [Vector3::zeros(); Segment::COUNT];
        w[Segment::Pelvis.index()] = Vector3::y() * 2.6;
        away.step(&Vector3::zeros(), &w);
        let mut near = truth;
        near.step(
            &Vector3::new(0.04, -0.03, 0.02),
            &[Vector3::zeros(); Segment::COUNT],
        );
        let cfg = RegisterConfig {
            interior_stride: 1,
            ..RegisterConfig::default()
        };
        let mut reg = Registration::default();
        reg.prepare(&frame, &cfg);
        let posed = Posed::new(&t, &truth);
        let tips = t.tips.map(|(s, local)| Some(posed.point(s, &local)));
        for starts in [[away, near], [near, away]] {
            let fit = reg
                .fit(&frame, &t, &starts, &tips, &SEEN, &cfg)
                .expect("starts");
            let err = worst(&t, &fit.pose, &truth);
            let (sa, sb) = (
                Posed::new(&t, &fit.pose).skeleton(&t),
                Posed::new(&t, &truth).skeleton(&t),
            );
            for j in Joint::ALL {
                eprintln!("{j:?} {:.3}", (sa[j] - sb[j]).norm());
            }
            assert!(err < 0.02, "worst joint {err} m off");
        }
    }
}
