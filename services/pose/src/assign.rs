//! Step 5: the geodesic maxima given to the five limbs by least total cost.

use crate::body::BodyConfig;
use crate::dijkstra::Graph;
use crate::geodesic::Geodesic;
use crate::graph::{GeoGraph, NONE};
use crate::torso::{TorsoConfig, TorsoPose};
use crate::Limb;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// Settings of the assignment of geodesic maxima to limbs (part of
/// [`crate::PoseConfig`]); costs are metres of geodesic cost.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AssignConfig {
    /// Cost of leaving a limb without a maximum.
    pub unassigned_cost: f32,
    /// Extra cost, for the arms and legs, of a maximum that lies beside the geodesic
    /// path of a farther one (a bent elbow or knee beside the path to the hand or foot).
    pub dominated_cost: f32,
    /// Cost per metre a head candidate lies sideways off the torso's axis (beyond 8 cm).
    pub head_off_axis_weight: f32,
    /// An arm's geodesic path that passes its shoulder no nearer than this is taken to
    /// reach the torso some hidden way (a hand against the hip); such a candidate costs
    /// `hidden_root_cost` plus how far it lies beyond the arm's reach. 0 = off.
    pub hidden_root_gap: f32,
    /// See `hidden_root_gap`.
    pub hidden_root_cost: f32,
    /// Weight of the distance to the limb's last extremity.
    pub temporal_weight: f32,
}

impl Default for AssignConfig {
    fn default() -> Self {
        Self {
            unassigned_cost: 1.2,
            dominated_cost: 0.3,
            head_off_axis_weight: 5.0,
            hidden_root_gap: 0.12,
            hidden_root_cost: 0.3,
            temporal_weight: 0.3,
        }
    }
}

/// Half the width of the head, metres: a maximum this near the torso's axis, above its
/// centre, may be the head's.
const HEAD_HALF_WIDTH: f32 = 0.1;

/// A maximum's path back to the torso centre that comes this near a shoulder (metres)
/// came down an arm.
const SHOULDER_PASSED: f32 = 0.1;

/// The cost of giving each geodesic maximum (rows) to each limb (columns), and what the
/// chains need of each maximum's path.
#[derive(Debug, Clone, Default)]
pub struct LimbCosts {
    /// Per maximum, per limb of [`Limb::ALL`].
    pub cost: Vec<[f32; 5]>,
    /// Per maximum and limb: where the path back to the torso centre is cut (the index
    /// of its point nearest the limb's root).
    pub cuts: Vec<[usize; 5]>,
    /// Per maximum and limb: the geodesic length from the limb's root (NaN for an arm
    /// whose path misses its shoulder).
    pub lengths: Vec<[f32; 5]>,
    /// Per maximum: its path back to the torso centre, graph nodes from the maximum.
    pub paths: Vec<Vec<u32>>,
}

/// What giving each maximum to each limb costs (seed: the geodesic length against the
/// limb's, plus the priors below), and each maximum's path back to the torso centre
/// with where it is cut for each limb. `cut`: which maxima lie where the body is cut
/// from view; `roots`: the limbs' roots in the camera frame;
/// `inv`: camera frame → torso frame; `last_extremity`: each limb's extremity of the
/// last frame, torso frame; `body`: the limbs' lengths; `torso`: its key points (the
/// hips' height); `path`: a buffer.
#[allow(clippy::too_many_arguments)]
pub fn limb_costs(
    graph: &GeoGraph,
    geo: &Geodesic,
    maxima: &[u32],
    cut: &[bool],
    roots: &[Point3<f32>; 5],
    inv: &TorsoPose,
    last_extremity: &[Option<Point3<f32>>; 5],
    cfg: &AssignConfig,
    body: &BodyConfig,
    torso: &TorsoConfig,
    path: &mut Vec<u32>,
) -> LimbCosts {
    let n = graph.node_count();
    let mut cost: Vec<[f32; 5]> = Vec::with_capacity(maxima.len());
    let mut cuts: Vec<[usize; 5]> = Vec::with_capacity(maxima.len());
    let mut lengths: Vec<[f32; 5]> = Vec::with_capacity(maxima.len());
    let mut paths: Vec<Vec<u32>> = Vec::with_capacity(maxima.len());
    for (&m, &at_a_cut) in maxima.iter().zip(cut) {
        path.clear();
        let mut a = m;
        let mut guard = 0;
        while a != NONE && guard < n {
            path.push(a);
            a = geo.pred(a);
            guard += 1;
        }
        let dm = geo.dist(m) as f32 * 1e-3;
        let passes_a_shoulder = [Limb::LeftArm, Limb::RightArm].iter().any(|a| {
            let r = roots[a.index()];
            path.iter()
                .any(|&p| (graph.pos[p as usize] - r).norm() < SHOULDER_PASSED)
        });
        let mut row = [f32::INFINITY; 5];
        let mut cut = [0usize; 5];
        let mut len = [0f32; 5];
        for l in Limb::ALL {
            let r = roots[l.index()];
            // Cut the path where it passes nearest the limb root: the geodesic cost
            // from the root is the path's length beyond that point plus the gap.
            let mut near = (f32::INFINITY, 0usize);
            for (pi, &p) in path.iter().enumerate() {
                let d = (graph.pos[p as usize] - r).norm();
                if d < near.0 {
                    near = (d, pi);
                }
            }
            let p_cut = path[near.1];
            let mut best = (dm - geo.dist(p_cut) as f32 * 1e-3 + near.0, near.1);
            // The geodesic length of a limb hardly depends on how it is bent.
            let (l1, l2) = body.bones(l);
            let reach = l1 + l2 + body.extremity_extra(l);
            // A hand resting against the hip or held before the chest may reach the
            // torso by a path that never passes its shoulder: the arm's own link is
            // hidden. Its geodesic length then says nothing; it must only be within
            // the arm's reach, and its targets are the forearm's and hand's.
            let hidden = matches!(l, Limb::LeftArm | Limb::RightArm)
                && cfg.hidden_root_gap > 0.0
                && near.0 > cfg.hidden_root_gap;
            let mut c = if hidden {
                let distal = ((l2 + body.extremity_extra(l)) * 1000.0) as u32;
                let d_m = geo.dist(m);
                let end = path
                    .iter()
                    .position(|&p| d_m.saturating_sub(geo.dist(p)) >= distal)
                    .unwrap_or(path.len() - 1);
                best = (f32::NAN, end);
                let euclid = (graph.pos[m as usize] - r).norm();
                (euclid - reach).max(0.0) + cfg.hidden_root_cost
            } else {
                (best.0 - reach).abs() + (near.0 - 0.05).max(0.0)
            };
            if let Some(prev) = last_extremity[l.index()] {
                let pm = graph.pos[m as usize];
                c += cfg.temporal_weight * (inv.apply(&pm) - prev).norm();
            }
            // An extremity lies on its own side of the body.
            let local = inv.apply(&graph.pos[m as usize]);
            c += match l {
                Limb::LeftArm | Limb::LeftLeg => (-local.x).max(0.0),
                Limb::RightArm | Limb::RightLeg => local.x.max(0.0),
                // The top of the head is on the torso's axis, not out on a shoulder.
                Limb::Head => {
                    (-local.y).max(0.0) + cfg.head_off_axis_weight * (local.x.abs() - 0.08).max(0.0)
                }
            };
            // Feet stay below the hips, and never reach the chest: a maximum up there
            // is a head, a hand or an ear, and the legs may well be out of view.
            if matches!(l, Limb::LeftLeg | Limb::RightLeg) {
                c += (local.y - torso.keypoints.left_hip[1] + 0.2).max(0.0);
                if local.y > 0.0 {
                    c = f32::INFINITY;
                }
                // A path that passes a shoulder comes down an arm: a hand resting on a
                // table or the thighs lies as low as a foot, and legs hidden by the
                // table must not take it. (At a cut the maximum is no limb's end, and
                // giving it to a leg keeps it from an arm.)
                if passes_a_shoulder && !at_a_cut {
                    c = f32::INFINITY;
                }
            }
            row[l.index()] = c;
            cut[l.index()] = best.1;
            len[l.index()] = best.0;
        }
        cost.push(row);
        cuts.push(cut);
        lengths.push(len);
        paths.push(path.clone());
    }
    // The head's end is its top: of the maxima on the torso's axis above it (an ear,
    // the chin, the top), the highest. Judged by geodesic length alone, a side of the
    // head wins when the torso sits a little low, as it does close to the camera.
    let head = Limb::Head.index();
    let heights: Vec<Option<f32>> = maxima
        .iter()
        .map(|&m| {
            let local = inv.apply(&graph.pos[m as usize]);
            (local.y > 0.0 && local.x.abs() < HEAD_HALF_WIDTH).then_some(local.y)
        })
        .collect();
    if let Some(top) = heights.iter().flatten().copied().reduce(f32::max) {
        for (row, h) in cost.iter_mut().zip(&heights) {
            if let Some(h) = h {
                row[head] += top - h;
            }
        }
    }
    // A bent elbow or knee is a geodesic maximum of its own, beside the path to the
    // hand or foot beyond it. Such a maximum is no limb's end while the farther one is
    // there: it costs extra for every limb but the head.
    if cfg.dominated_cost > 0.0 {
        for (bi, &mb) in maxima.iter().enumerate() {
            let pb = graph.pos[mb as usize];
            let db = geo.dist(mb);
            let dominated = maxima.iter().enumerate().any(|(ai, &ma)| {
                ai != bi
                    && geo.dist(ma) > db + 150
                    && paths[ai]
                        .iter()
                        .any(|&p| (graph.pos[p as usize] - pb).norm() < 0.08)
            });
            if dominated {
                for c in &mut cost[bi][1..] {
                    *c += cfg.dominated_cost;
                }
            }
        }
    }
    LimbCosts {
        cost,
        cuts,
        lengths,
        paths,
    }
}

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
}
