//! Step 4: geodesic distances from the torso centre and the geodesic maxima, the
//! candidates for the limbs' ends.

use crate::dijkstra::{Dijkstra, Graph, INF};
use crate::graph::{GeoGraph, NONE};
use serde::{Deserialize, Serialize};

/// Settings of the geodesic maxima (part of [`crate::PoseConfig`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GeodesicConfig {
    /// A geodesic maximum must be at least this far (geodesically, metres) from every
    /// source found before it.
    pub min_extremity: f32,
    /// How many geodesic maxima to look for: the seed's five, plus spares, since the
    /// middle of a long leg can lie geodesically farther from every source than the top
    /// of the head; the assignment leaves the spares out.
    pub max_maxima: usize,
}

impl Default for GeodesicConfig {
    fn default() -> Self {
        Self {
            min_extremity: 0.12,
            max_maxima: 8,
        }
    }
}

/// The geodesic step's buffers, reused frame to frame, and its result of the last
/// frame: the distances and predecessors of the first search, from the torso centre
/// alone (the maxima's paths back to it).
#[derive(Debug, Default)]
pub struct Geodesic {
    dij: Dijkstra,
    dist: Vec<u32>,
    pred: Vec<u32>,
}

impl Geodesic {
    /// Dijkstra from the graph's `root` (the torso centre), then up to
    /// [`GeodesicConfig::max_maxima`] geodesic maxima, each joined to the sources by a
    /// zero-weight edge before the next search (the search goes on from where it was,
    /// not from scratch). The maxima, graph nodes in the order found.
    pub fn maxima(&mut self, graph: &GeoGraph, root: u32, cfg: &GeodesicConfig) -> Vec<u32> {
        let n = graph.node_count();
        self.dij.reset(n);
        self.dij.add_source(root);
        self.dij.run(graph);
        self.dist.clear();
        self.dist.extend_from_slice(&self.dij.dist);
        self.pred.clear();
        self.pred.extend_from_slice(&self.dij.pred);
        let min_ext = (cfg.min_extremity * 1000.0) as u32;
        let mut maxima: Vec<u32> = Vec::with_capacity(5);
        for _ in 0..cfg.max_maxima {
            let mut best = (0u32, NONE);
            for (a, &d) in self.dij.dist.iter().enumerate() {
                if d != INF && d > best.0 {
                    best = (d, a as u32);
                }
            }
            if best.1 == NONE || best.0 < min_ext {
                break;
            }
            maxima.push(best.1);
            self.dij.add_source(best.1);
            self.dij.run(graph);
        }
        maxima
    }

    /// A node's geodesic distance from the torso centre, millimetres ([`INF`] when
    /// unreached).
    #[inline]
    pub fn dist(&self, node: u32) -> u32 {
        self.dist[node as usize]
    }

    /// The next node on a node's shortest path back to the torso centre ([`NONE`] at
    /// the centre or when unreached).
    #[inline]
    pub fn pred(&self, node: u32) -> u32 {
        self.pred[node as usize]
    }
}
