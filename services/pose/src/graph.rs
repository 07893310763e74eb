//! The geodesic graph over the person's organized point cloud: 8-neighbours closer than
//! a threshold that grows with the pixel footprint, edges that bridge occluding
//! foreground, and stray components joined to the one holding the root.

use crate::dijkstra::Graph;
use airglyph_core::Intrinsics;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Settings of the geodesic graph (part of [`crate::PoseConfig`]); lengths in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GraphConfig {
    /// 8-neighbours are joined when closer than `max(edge_min, edge_px * footprint)`
    /// (times √2 for diagonals).
    pub edge_min: f32,
    /// See `edge_min`.
    pub edge_px: f32,
    /// Longest bridge over occluding foreground.
    pub bridge_max: f32,
    /// How much nearer the camera than a bridge's ends its occluder must be.
    pub bridge_occluder: f32,
    /// Components smaller than this many nodes are dropped rather than joined.
    pub min_component: usize,
}

impl Default for GraphConfig {
    fn default() -> Self {
        Self {
            edge_min: 0.012,
            edge_px: 3.0,
            bridge_max: 0.35,
            bridge_occluder: 0.05,
            min_component: 20,
        }
    }
}

/// No neighbour in this slot / no node at this pixel.
pub const NONE: u32 = u32::MAX;

/// Neighbour offsets; slot `7 - k` is the opposite of slot `k`.
const DIRS: [(i32, i32); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// A length in whole millimetres, at least 1. `d` is a distance (≥ 0): a half added
/// and truncated rounds it without `f32::round`, a libm call on x86-64's baseline,
/// made for every edge of every frame.
#[inline]
fn mm(d: f32) -> u32 {
    ((d * 1000.0 + 0.5) as u32).max(1)
}

/// Consecutive samples of a component (neighbours in raster order, so near each other)
/// and their bounding box: the closest-pair search skips a run whose box lies farther
/// than the best pair so far.
struct SampleBox {
    range: std::ops::Range<usize>,
    lo: Vector3<f32>,
    hi: Vector3<f32>,
}

impl SampleBox {
    const RUN: usize = 32;

    fn cover(pos: &[Point3<f32>], samples: &[u32]) -> Vec<Self> {
        (0..samples.len())
            .step_by(Self::RUN)
            .map(|start| Self::of(pos, samples, start..(start + Self::RUN).min(samples.len())))
            .collect()
    }

    /// The samples `range` of `samples` in one box.
    fn of(pos: &[Point3<f32>], samples: &[u32], range: std::ops::Range<usize>) -> Self {
        let (mut lo, mut hi) = (Vector3::repeat(f32::MAX), Vector3::repeat(f32::MIN));
        for &q in &samples[range.clone()] {
            lo = lo.inf(&pos[q as usize].coords);
            hi = hi.sup(&pos[q as usize].coords);
        }
        Self { range, lo, hi }
    }

    /// One box around `runs` (a component's [`SampleBox::cover`]), without going over
    /// the samples again.
    fn hull(runs: &[SampleBox]) -> Self {
        let (mut lo, mut hi) = (Vector3::repeat(f32::MAX), Vector3::repeat(f32::MIN));
        for r in runs {
            lo = lo.inf(&r.lo);
            hi = hi.sup(&r.hi);
        }
        let end = runs.last().map_or(0, |r| r.range.end);
        Self {
            range: 0..end,
            lo,
            hi,
        }
    }

    /// Whether every point of this box is at least `d2` (squared) from every point of
    /// `other`, with [`SampleBox::beyond`]'s margin.
    #[inline]
    fn apart(&self, other: &SampleBox, d2: f32) -> bool {
        let gap = (self.lo - other.hi)
            .sup(&(other.lo - self.hi))
            .sup(&Vector3::zeros());
        gap.norm_squared() > d2 * (1.0 + 1e-4)
    }

    /// Whether every sample of the run is at least `d2` (squared) from `p`. The margin
    /// covers rounding: a run is skipped only when no sample in it can beat `d2`, so
    /// the search finds the very pair the exhaustive one does.
    #[inline]
    fn beyond(&self, p: &Point3<f32>, d2: f32) -> bool {
        let gap = (self.lo - p.coords)
            .sup(&(p.coords - self.hi))
            .sup(&Vector3::zeros());
        gap.norm_squared() > d2 * (1.0 + 1e-4)
    }
}

/// The graph of one frame; buffers are reused.
#[derive(Debug, Default)]
pub struct GeoGraph {
    /// Size of the image the graph was built on.
    pub width: usize,
    /// See `width`.
    pub height: usize,
    /// Node of each pixel, or [`NONE`].
    pub node_of_pixel: Vec<u32>,
    /// Each node's pixel (row-major index).
    pub pixel_of_node: Vec<u32>,
    /// Each node's point, camera frame.
    pub pos: Vec<Point3<f32>>,
    /// Eight neighbour slots a node: (node, weight in mm).
    slots: Vec<[(u32, u32); 8]>,
    /// Bridging and joining edges in compressed rows.
    extra_off: Vec<u32>,
    extra: Vec<(u32, u32)>,
    /// Bridges and joins found this frame (both directions go into `extra`).
    pub bridges: Vec<(u32, u32, u32)>,
    /// Edges joining stray components to the rest: (node, node, weight in millimetres).
    pub joins: Vec<(u32, u32, u32)>,
    /// Component of each node after joining (0 = the root's), or [`NONE`] for dropped
    /// fragments.
    pub comp: Vec<u32>,
    uf: Vec<u32>,
    scratch: Vec<u32>,
}

fn find(uf: &mut [u32], mut x: u32) -> u32 {
    while uf[x as usize] != x {
        let p = uf[x as usize];
        uf[x as usize] = uf[p as usize];
        x = p;
    }
    x
}

impl Graph for GeoGraph {
    fn node_count(&self) -> usize {
        self.pos.len()
    }

    #[inline]
    fn for_each_edge(&self, node: u32, mut f: impl FnMut(u32, u32)) {
        for &(m, w) in &self.slots[node as usize] {
            if m != NONE {
                f(m, w);
            }
        }
        let (a, b) = (
            self.extra_off[node as usize] as usize,
            self.extra_off[node as usize + 1] as usize,
        );
        for &(m, w) in &self.extra[a..b] {
            f(m, w);
        }
    }
}

impl GeoGraph {
    /// Builds the graph over the pixels of `mask`. `root_pixel` names the pixel whose
    /// component every other component is joined to.
    pub fn build(
        &mut self,
        points: &[Point3<f32>],
        mask: &[bool],
        width: usize,
        height: usize,
        k: &Intrinsics,
        cfg: &GraphConfig,
    ) {
        self.width = width;
        self.height = height;
        let n_px = width * height;
        self.node_of_pixel.clear();
        self.node_of_pixel.resize(n_px, NONE);
        self.pixel_of_node.clear();
        self.pos.clear();
        for i in 0..n_px {
            // The person's pixels without depth (holes the sensor left) are no nodes.
            if mask[i] && points[i].z > 0.0 {
                self.node_of_pixel[i] = self.pos.len() as u32;
                self.pixel_of_node.push(i as u32);
                self.pos.push(points[i]);
            }
        }
        let n = self.pos.len();
        let f = 0.5 * (k.fx + k.fy);
        self.slots.clear();
        self.slots.resize(n, [(NONE, 0); 8]);
        // Neighbour edges: the four forward directions, both slots filled at once.
        for a in 0..n {
            let i = self.pixel_of_node[a] as usize;
            let (u, v) = ((i % width) as i32, (i / width) as i32);
            let p = self.pos[a];
            for (s, &(du, dv)) in DIRS.iter().enumerate().skip(4) {
                let (uu, vv) = (u + du, v + dv);
                if uu < 0 || vv < 0 || uu >= width as i32 || vv >= height as i32 {
                    continue;
                }
                let b = self.node_of_pixel[vv as usize * width + uu as usize];
                if b == NONE {
                    continue;
                }
                let q = self.pos[b as usize];
                let z = 0.5 * (p.z + q.z);
                let diag = if du != 0 && dv != 0 {
                    std::f32::consts::SQRT_2
                } else {
                    1.0
                };
                let thr = (cfg.edge_px * z / f).max(cfg.edge_min) * diag;
                let d = (q - p).norm();
                if d < thr {
                    let w = mm(d);
                    self.slots[a][s] = (b, w);
                    self.slots[b as usize][7 - s] = (a as u32, w);
                }
            }
        }
        self.find_bridges(points, cfg, f);
        self.join_components(cfg);
        // Extra edges in compressed rows.
        self.extra_off.clear();
        self.extra_off.resize(n + 1, 0);
        for &(a, b, _) in self.bridges.iter().chain(&self.joins) {
            self.extra_off[a as usize + 1] += 1;
            self.extra_off[b as usize + 1] += 1;
        }
        for i in 0..n {
            self.extra_off[i + 1] += self.extra_off[i];
        }
        self.extra.clear();
        self.extra.resize(self.extra_off[n] as usize, (NONE, 0));
        self.scratch.clear();
        self.scratch.extend_from_slice(&self.extra_off[..n]);
        for &(a, b, w) in self.bridges.iter().chain(&self.joins) {
            let ia = self.scratch[a as usize] as usize;
            self.extra[ia] = (b, w);
            self.scratch[a as usize] += 1;
            let ib = self.scratch[b as usize] as usize;
            self.extra[ib] = (a, w);
            self.scratch[b as usize] += 1;
        }
    }

    /// Edges over occluding foreground: along rows and columns, from a node whose next
    /// pixel is much nearer the camera, across a run of such nearer pixels, to the first
    /// node at about the first one's depth.
    fn find_bridges(&mut self, points: &[Point3<f32>], cfg: &GraphConfig, f: f32) {
        self.bridges.clear();
        let (w, h) = (self.width, self.height);
        for a in 0..self.pos.len() {
            let i = self.pixel_of_node[a] as usize;
            let (u, v) = (i % w, i / w);
            let p = self.pos[a];
            let max_px = ((cfg.bridge_max * f / p.z).ceil() as usize).max(2);
            let front = p.z - cfg.bridge_occluder;
            for (du, dv) in [(1usize, 0usize), (0, 1)] {
                let mut steps = 1;
                let mut bridged = None;
                loop {
                    let (uu, vv) = (u + du * steps, v + dv * steps);
                    if uu >= w || vv >= h || steps > max_px {
                        break;
                    }
                    let j = vv * w + uu;
                    let q = points[j];
                    if q.z > 0.0 && q.z < front {
                        steps += 1;
                        continue;
                    }
                    if steps > 1 && q.z > 0.0 {
                        let b = self.node_of_pixel[j];
                        if b != NONE && (q.z - p.z).abs() < cfg.bridge_occluder {
                            let d = (q - p).norm();
                            if d < cfg.bridge_max {
                                bridged = Some((b, d));
                            }
                        }
                    }
                    break;
                }
                if let Some((b, d)) = bridged {
                    self.bridges.push((a as u32, b, mm(d)));
                }
            }
        }
    }

    /// Labels components and joins every one of at least `min_component` nodes to the
    /// growing set that holds the largest, nearest first (Prim's order), by an edge
    /// between their closest sampled nodes.
    fn join_components(&mut self, cfg: &GraphConfig) {
        self.joins.clear();
        let n = self.pos.len();
        self.uf.clear();
        self.uf.extend(0..n as u32);
        for a in 0..n {
            for s in 4..8 {
                let (b, _) = self.slots[a][s];
                if b != NONE {
                    let (ra, rb) = (find(&mut self.uf, a as u32), find(&mut self.uf, b));
                    if ra != rb {
                        self.uf[ra as usize] = rb;
                    }
                }
            }
        }
        for &(a, b, _) in &self.bridges {
            let (ra, rb) = (find(&mut self.uf, a), find(&mut self.uf, b));
            if ra != rb {
                self.uf[ra as usize] = rb;
            }
        }
        // Component sizes, by root.
        self.scratch.clear();
        self.scratch.resize(n, 0);
        for a in 0..n {
            let r = find(&mut self.uf, a as u32);
            self.scratch[r as usize] += 1;
        }
        let mut comps: Vec<(u32, u32)> = (0..n as u32)
            .filter(|&a| {
                self.uf[a as usize] == a
                    && self.scratch[a as usize] as usize >= cfg.min_component.max(1)
            })
            .map(|a| (self.scratch[a as usize], a))
            .collect();
        comps.sort_by(|a, b| b.cmp(a));
        comps.truncate(48);
        self.comp.clear();
        self.comp.resize(n, NONE);
        if comps.is_empty() {
            return;
        }
        // Union-find roots to component indices (0 = largest), in `scratch`: the sizes
        // are read.
        self.scratch.fill(NONE);
        for (ci, &(_, r)) in comps.iter().enumerate() {
            self.scratch[r as usize] = ci as u32;
        }
        let mut members: Vec<Vec<u32>> = comps
            .iter()
            .map(|&(size, _)| Vec::with_capacity(size as usize))
            .collect();
        for a in 0..n {
            let ci = self.scratch[find(&mut self.uf, a as u32) as usize];
            if ci != NONE {
                self.comp[a] = ci;
                members[ci as usize].push(a as u32);
            }
        }
        if comps.len() == 1 {
            for c in self.comp.iter_mut() {
                if *c != NONE {
                    *c = 0;
                }
            }
            return;
        }
        // Samples (≤ 1500) and probes (≤ 40) of each component.
        let sample = |m: &Vec<u32>, cap: usize| -> Vec<u32> {
            let step = m.len().div_ceil(cap).max(1);
            m.iter().step_by(step).copied().collect()
        };
        let samples: Vec<Vec<u32>> = members.iter().map(|m| sample(m, 1500)).collect();
        let probes: Vec<Vec<u32>> = members.iter().map(|m| sample(m, 40)).collect();
        let pos = &self.pos;
        let boxes: Vec<Vec<SampleBox>> = samples.iter().map(|s| SampleBox::cover(pos, s)).collect();
        // Each component's samples in one box, and its probes in another: most pairs of
        // components lie farther apart than the best join found so far, and are
        // skipped whole.
        let whole: Vec<SampleBox> = boxes.iter().map(|b| SampleBox::hull(b)).collect();
        let probe_box: Vec<SampleBox> = probes
            .iter()
            .map(|s| SampleBox::of(pos, s, 0..s.len()))
            .collect();
        // The closest (probe of `c`, sample of `target`) pair nearer than `bound`
        // (squared), the first in probe and sample order of equally near ones.
        let closest = |c: usize, target: usize, bound: f32| -> (f32, u32, u32) {
            let mut best = (bound, NONE, NONE);
            if whole[target].apart(&probe_box[c], bound) {
                return best;
            }
            for &p in &probes[c] {
                let pp = pos[p as usize];
                if whole[target].beyond(&pp, best.0) {
                    continue;
                }
                for b in &boxes[target] {
                    if b.beyond(&pp, best.0) {
                        continue;
                    }
                    for &q in &samples[target][b.range.clone()] {
                        let d = (pos[q as usize] - pp).norm_squared();
                        if d < best.0 {
                            best = (d, p, q);
                        }
                    }
                }
            }
            best
        };
        let k = comps.len();
        let mut joined = vec![false; k];
        joined[0] = true;
        let mut best: Vec<(f32, u32, u32)> = (0..k).map(|c| closest(c, 0, f32::INFINITY)).collect();
        for _ in 1..k {
            let Some(c) = (0..k)
                .filter(|&c| !joined[c])
                .min_by(|&a, &b| best[a].0.total_cmp(&best[b].0))
            else {
                break;
            };
            let (d2, p, q) = best[c];
            if p == NONE {
                break;
            }
            joined[c] = true;
            self.joins.push((p, q, mm(d2.sqrt())));
            for c2 in 0..k {
                if !joined[c2] {
                    let cand = closest(c2, c, best[c2].0);
                    if cand.1 != NONE {
                        best[c2] = cand;
                    }
                }
            }
        }
        // Everything kept is now one component.
        for c in self.comp.iter_mut() {
            if *c != NONE {
                *c = 0;
            }
        }
    }

    /// The node nearest to `p` among those within `radius_px` pixels of its projection.
    pub fn nearest_node(&self, k: &Intrinsics, p: &Point3<f32>, radius_px: i32) -> Option<u32> {
        let (u, v) = k.project(p)?;
        let (u, v) = (u.round() as i32, v.round() as i32);
        let mut best: Option<(f32, u32)> = None;
        for r in 0..=radius_px {
            for vv in (v - r)..=(v + r) {
                for uu in (u - r)..=(u + r) {
                    let on_ring = (vv - v).abs() == r || (uu - u).abs() == r;
                    if !on_ring
                        || uu < 0
                        || vv < 0
                        || uu >= self.width as i32
                        || vv >= self.height as i32
                    {
                        continue;
                    }
                    let a = self.node_of_pixel[vv as usize * self.width + uu as usize];
                    if a == NONE || self.comp[a as usize] == NONE {
                        continue;
                    }
                    let d = (self.pos[a as usize] - p).norm_squared();
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, a));
                    }
                }
            }
            // Once something near is found, one more ring cannot hold a much nearer
            // pixel. Something far is no answer yet: a forearm held before the chest
            // hides the torso around the torso centre's projection.
            if best.is_some_and(|(d, _)| d < 0.15 * 0.15) && r >= 2 {
                break;
            }
        }
        best.map(|(_, a)| a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dijkstra::{Dijkstra, INF};

    fn flat(w: usize, h: usize, z: f32, k: &Intrinsics) -> Vec<Point3<f32>> {
        (0..w * h)
            .map(|i| k.back_project((i % w) as f32, (i / w) as f32, z))
            .collect()
    }

    #[test]
    fn a_flat_patch_is_one_component_with_metric_distances() {
        let k = Intrinsics::new(40, 30, 100.0, 100.0, 20.0, 15.0);
        let pts = flat(40, 30, 2.0, &k);
        let mask = vec![true; 40 * 30];
        let mut g = GeoGraph::default();
        g.build(&pts, &mask, 40, 30, &k, &GraphConfig::default());
        assert!(g.joins.is_empty() && g.bridges.is_empty());
        let mut d = Dijkstra::default();
        d.reset(g.node_count());
        d.add_source(g.node_of_pixel[0]);
        d.run(&g);
        // 39 px along a row at 2 m with f = 100: 0.78 m.
        let far = d.dist[g.node_of_pixel[39] as usize];
        assert!((far as i32 - 780).abs() <= 20, "{far}");
    }

    #[test]
    fn an_occluding_bar_is_bridged_and_a_stray_piece_is_joined() {
        let (w, h) = (40usize, 30usize);
        let k = Intrinsics::new(w as u32, h as u32, 100.0, 100.0, 20.0, 15.0);
        let mut pts = flat(w, h, 2.0, &k);
        let mut mask = vec![true; w * h];
        // A vertical bar 0.5 m in front splits the patch; it is not part of the person.
        for v in 0..h {
            for u in 18..22 {
                pts[v * w + u] = k.back_project(u as f32, v as f32, 1.5);
                mask[v * w + u] = false;
            }
        }
        // A separate small piece, far from the rest in depth.
        for v in 0..5 {
            for u in 0..5 {
                pts[v * w + u] = k.back_project(u as f32, v as f32, 2.6);
            }
        }
        let mut g = GeoGraph::default();
        g.build(&pts, &mask, w, h, &k, &GraphConfig::default());
        assert!(!g.bridges.is_empty());
        assert_eq!(g.joins.len(), 1);
        let mut d = Dijkstra::default();
        d.reset(g.node_count());
        d.add_source(g.node_of_pixel[15 * w + 30]);
        d.run(&g);
        assert!(d.dist.iter().all(|&x| x != INF));
        // Across the bar the distance is about the straight line.
        let across = d.dist[g.node_of_pixel[15 * w + 10] as usize];
        assert!((across as i32 - 400).abs() < 40, "{across}");
    }
}
