//! The energy's terms, linearised into the normal equations in one pass over the data:
//! the data term (each point on its nearest capsule), the silhouette and free-space
//! terms (the body's front surface as the camera sees it), the tips' term.

use super::capsules::Placed;
use super::capsules::{nearest_capsule, place, Gaps};
use super::solver::Accumulator;
use super::{Pass, Problem, Registration};
use crate::body::{Posed, Segment};
use airglyph_core::Joint;
use nalgebra::{Point3, Vector3};

/// Weights and scales of the energy's terms (part of [`super::RegisterConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct EnergyConfig {
    /// Scale of the data term's Cauchy weight, metres.
    pub sigma: f32,
    /// Weight of a silhouette residual against one data point's.
    pub silhouette_weight: f32,
    /// Weight of a free-space residual against one data point's.
    pub free_space_weight: f32,
    /// The silhouette's weight, as a share, where something nearer hides the body.
    pub occluded_weight: f32,

    /// Beyond this (metres) the silhouette and free-space terms pull linearly (Huber).
    pub silhouette_scale: f32,
    /// How far the body's front may lie before the surface seen, metres.
    pub free_space_margin: f32,
    /// Weight of a leg's point above the table top its hip is under (a point every 4 cm).
    pub table_top_weight: f32,
    /// Weight of a limb tip's distance to its geodesic maximum...
    pub tip_weight: f32,
    /// ...and its Cauchy scale, metres.
    pub tip_sigma: f32,
    /// Weight of the neck's height against the neck's base the outline shows, as the
    /// area of the person's surface whose data points weigh as much, m² (0: off)...
    pub neck_weight: f32,
    /// ...and its Huber scale, metres.
    pub neck_scale: f32,
}

impl Default for EnergyConfig {
    fn default() -> Self {
        Self {
            sigma: 0.03,
            silhouette_weight: 3.0,
            free_space_weight: 4.0,
            occluded_weight: 0.3,

            silhouette_scale: 0.05,
            free_space_margin: 0.03,
            table_top_weight: 4.0,
            tip_weight: 10.0,
            tip_sigma: 0.1,
            neck_weight: 0.02,
            neck_scale: 0.02,
        }
    }
}

/// Cauchy's weight and cost for residual `r` at scale `s`.
#[inline]
pub(super) fn cauchy(r: f32, s: f32) -> (f32, f32) {
    (cauchy_weight(r, s), cauchy_cost(r, s))
}

/// Huber's weight and cost at scale `s`: quadratic near, linear far. For the body
/// outside the silhouette or before a seen surface, which is wrong however far it is
/// (a data point far from the body may be something else; a limb in empty space is
/// not), so its pull must not fade with distance.
#[inline]
pub(super) fn huber(r: f32, s: f32) -> (f32, f32) {
    let a = r.abs();
    if a <= s {
        (1.0, 0.5 * r * r)
    } else {
        (s / a, s * (a - 0.5 * s))
    }
}

#[inline]
pub(super) fn cauchy_weight(r: f32, s: f32) -> f32 {
    let q = (r / s) * (r / s);
    1.0 / (1.0 + q)
}

#[inline]
pub(super) fn cauchy_cost(r: f32, s: f32) -> f32 {
    let q = (r / s) * (r / s);
    0.5 * s * s * q.ln_1p()
}

impl Registration {
    pub(super) fn accumulate(
        &self,
        p: &Problem,
        posed: &Posed,
        pass: Pass,
        assign: &mut [u16],
    ) -> (Accumulator, [f32; Segment::COUNT]) {
        let (f, t, tips, cfg) = (p.frame, p.body, p.tips, p.cfg);
        let mut placed = place(t, posed);
        for c in &mut placed {
            c.in_view = f.sees_any(front_surface(c));
        }
        let gaps = pass.search.then(|| Gaps::new(&placed));
        let mut acc = Accumulator::new(posed, cfg.lengths.bone_evidence.is_some());

        // Data: each point on its nearest capsule's surface.
        for ((p, area), ci) in self.data.iter().zip(assign.iter_mut()) {
            let (q, d) = if let Some(gaps) = &gaps {
                let (c, q, d) = nearest_capsule(&placed, gaps, p, usize::from(*ci));
                *ci = c as u16;
                (q, d)
            } else {
                let c = &placed[*ci as usize];
                if !c.in_view {
                    continue;
                }
                let (q, _, d) = c.nearest(p);
                (q, d)
            };
            let off = p - q;
            let len = off.norm();
            if len < 1e-6 || !d.is_finite() {
                continue;
            }
            let n = off / len;
            let w = cauchy_weight(d, cfg.energy.sigma);
            if pass.energy {
                acc.energy += (area * cauchy_cost(d, cfg.energy.sigma)) as f64;
            }
            acc.add(placed[*ci as usize].segment, &q, &(-n), d, area * w);
        }

        // Silhouette and free space: the body's front surface as the camera sees it.
        let mut seen_n = [0u32; Segment::COUNT];
        let mut all_n = [0u32; Segment::COUNT];
        let (w, h) = (f.width as i32, f.height as i32);
        for c in &placed {
            for s in front_surface(c) {
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
                    if gap > cfg.energy.free_space_margin {
                        // The camera sees past the body's front: the body is not there.
                        let res = cfg.energy.free_space_margin - gap;
                        let (wc, cost) = huber(res, cfg.energy.silhouette_scale);
                        acc.energy += (cfg.energy.free_space_weight * cost) as f64;
                        acc.add(
                            c.segment,
                            &s,
                            &Vector3::z(),
                            res,
                            cfg.energy.free_space_weight * wc,
                        );
                    } else if gap > -0.05 {
                        seen_n[c.segment.index()] += 1;
                    }
                } else if f.mask[idx] {
                    // A hole the sensor left in the person: no evidence either way.
                } else if c.in_view {
                    self.outside(p, &mut acc, c, &s, (u, v), cfg.energy.silhouette_weight);
                }
            }
        }

        // Legs under a table top stay under it (their points may rise to just under it).
        for c in &placed {
            let Some(top) = c
                .segment
                .thigh()
                .and_then(|thigh| f.table_top_over(&posed.joint[thigh.index()]))
            else {
                continue;
            };
            for (x, radius) in axis_points(c) {
                let r = top.rise(&x, radius);
                if r <= 0.0 {
                    continue;
                }
                let (wc, cost) = huber(r, cfg.energy.silhouette_scale);
                acc.energy += (cfg.energy.table_top_weight * cost) as f64;
                acc.add(
                    c.segment,
                    &x,
                    &top.up(),
                    r,
                    cfg.energy.table_top_weight * wc,
                );
            }
        }

        // Tips near their geodesic maxima.
        for (tip, target) in t.tips.iter().zip(tips) {
            let Some(m) = target else { continue };
            let x = posed.point(tip.0, &tip.1);
            let e = x - m;
            let (wc, cost) = cauchy(e.norm(), cfg.energy.tip_sigma);
            acc.energy += (cfg.energy.tip_weight * cost) as f64;
            acc.guide_energy += (cfg.energy.tip_weight * cost) as f64;
            let wt = cfg.energy.tip_weight * wc;
            acc.add(tip.0, &x, &Vector3::x(), e.x, wt);
            acc.add(tip.0, &x, &Vector3::y(), e.y, wt);
            acc.add(tip.0, &x, &Vector3::z(), e.z, wt);
        }
        // The neck's base the person's outline shows holds the torso's height, along
        // the torso's up: cut by the image at the waist, the torso slides along its
        // axis under the data term, and the head's and shoulders' tops then hold it
        // where the template's shape, not the person's, puts them.
        if let Some(nb) = p.neck.filter(|_| cfg.energy.neck_weight > 0.0) {
            let (seg, local) = t.joints[Joint::Neck.index()];
            let x = posed.point(seg, &local);
            let r = (x - nb.point).dot(&nb.up);
            // A data point weighs its pixel: the same area of the body weighs less
            // the farther it is.
            let px = f.k.fx / nb.point.z.max(0.1);
            let weight = cfg.energy.neck_weight * px * px;
            let (wc, cost) = huber(r, cfg.energy.neck_scale);
            acc.energy += (weight * cost) as f64;
            acc.guide_energy += (weight * cost) as f64;
            acc.add(seg, &x, &nb.up, r, weight * wc);
        }
        // A segment without a surface of its own (a collarbone) is seen as its parent;
        // one whose surface lies all outside the image is not seen.
        let mut surface = [false; Segment::COUNT];
        for c in &placed {
            surface[c.segment.index()] = true;
        }
        let mut seen = [0.0; Segment::COUNT];
        for s in Segment::ALL {
            let i = s.index();
            seen[i] = if all_n[i] > 0 {
                seen_n[i] as f32 / all_n[i] as f32
            } else if surface[i] {
                0.0
            } else {
                s.parent().map_or(0.0, |p| seen[p.index()])
            };
        }
        (acc, seen)
    }
}

impl Registration {
    /// A point `s` of capsule `c` seen at pixel `(u, v)` outside the person's mask:
    /// pulled in the image to the nearest person pixel, at its depth.
    #[inline]
    fn outside(
        &self,
        p: &Problem,
        acc: &mut Accumulator,
        c: &Placed,
        s: &Point3<f32>,
        (u, v): (i32, i32),
        weight: f32,
    ) {
        let (f, cfg) = (p.frame, p.cfg);
        let Some((qu, qv)) = self.nearest.get(u as usize, v as usize) else {
            return;
        };
        // Behind something nearer (a table) the camera could not have seen the body,
        // but a limb partly in view is more likely above the table than through it: a
        // weaker pull. A capsule wholly out of view (legs under the table) the caller
        // leave alone.
        let idx = v as usize * f.width + u as usize;
        let weight = if f.occluded(idx, s.z) {
            cfg.energy.occluded_weight
        } else {
            1.0
        } * weight;
        let target = f.k.back_project(qu as f32, qv as f32, s.z);
        let e = s - target;
        let (wc, cost) = huber(e.norm(), cfg.energy.silhouette_scale);
        acc.energy += (weight * cost) as f64;
        let ws = weight * wc;
        // Both image axes: pulled only up or down, an arm held out beside the
        // silhouette (a T-pose's arm, the person since turned side-on) stayed in the air.
        acc.add(c.segment, s, &Vector3::x(), e.x, ws);
        acc.add(c.segment, s, &Vector3::y(), e.y, ws);
    }
}

/// Points of a capsule's axis every 4 cm, with its radius there.
fn axis_points(c: &Placed) -> impl Iterator<Item = (Point3<f32>, f32)> + '_ {
    let k = ((c.len2.sqrt() / 0.04).ceil() as usize + 1).max(2);
    (0..k).map(move |i| {
        let t = i as f32 / (k - 1) as f32;
        (c.a + c.ab * t, c.ra + (c.rb - c.ra) * t)
    })
}

/// Points of a capsule's front as the camera sees it: along its axis every 4 cm, each
/// moved a radius towards the camera.
pub(super) fn front_surface(c: &Placed) -> impl Iterator<Item = Point3<f32>> + '_ {
    let len = c.len2.sqrt();
    let k = ((len / 0.04).ceil() as usize + 1).max(2);
    (0..k).filter_map(move |i| {
        let tt = i as f32 / (k - 1) as f32;
        let axis = c.a + c.ab * tt;
        let r = c.ra + (c.rb - c.ra) * tt;
        let ray = axis.coords.try_normalize(1e-6)?;
        Some(axis - ray * r)
    })
}
