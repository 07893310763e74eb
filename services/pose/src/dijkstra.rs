//! Dijkstra's search with a radix heap (monotone integer priority queue): geodesic
//! distances in whole millimetres, `O(m + n log C)` and no comparisons of floats.

/// A monotone priority queue of `(key, node)` with `u32` keys: every key pushed must be
/// at least the last key popped, which Dijkstra guarantees for non-negative weights.
#[derive(Debug)]
pub struct RadixHeap {
    last: u32,
    len: usize,
    buckets: Vec<Vec<(u32, u32)>>,
}

impl Default for RadixHeap {
    fn default() -> Self {
        Self {
            last: 0,
            len: 0,
            buckets: (0..33).map(|_| Vec::new()).collect(),
        }
    }
}

#[inline]
fn bucket_of(key: u32, last: u32) -> usize {
    (32 - (key ^ last).leading_zeros()) as usize
}

impl RadixHeap {
    pub fn clear(&mut self) {
        self.last = 0;
        self.len = 0;
        for b in &mut self.buckets {
            b.clear();
        }
    }

    /// Pushes a key; keys below the last popped one are raised to it (cannot happen in
    /// Dijkstra, but the queue stays correct for any input).
    #[inline]
    pub fn push(&mut self, key: u32, node: u32) {
        let key = key.max(self.last);
        self.buckets[bucket_of(key, self.last)].push((key, node));
        self.len += 1;
    }

    pub fn pop(&mut self) -> Option<(u32, u32)> {
        if self.len == 0 {
            return None;
        }
        if self.buckets[0].is_empty() {
            let i = (1..33).find(|&i| !self.buckets[i].is_empty())?;
            let items = std::mem::take(&mut self.buckets[i]);
            let new_last = items.iter().map(|&(k, _)| k).min().unwrap_or(self.last);
            self.last = new_last;
            for &(k, n) in &items {
                self.buckets[bucket_of(k, new_last)].push((k, n));
            }
            // Give the emptied bucket its allocation back.
            let mut items = items;
            items.clear();
            if self.buckets[i].is_empty() {
                self.buckets[i] = items;
            }
        }
        self.len -= 1;
        self.buckets[0].pop()
    }
}

/// A graph Dijkstra can walk: the neighbours of a node with edge weights in millimetres.
pub trait Graph {
    /// How many nodes there are, numbered from 0.
    fn node_count(&self) -> usize;
    /// Calls `f(neighbour, weight)` for every edge of `node` (weights in millimetres).
    fn for_each_edge(&self, node: u32, f: impl FnMut(u32, u32));
}

/// Unreached.
pub const INF: u32 = u32::MAX;

/// Shortest-path state that can grow: more sources may be added later (a zero-weight
/// edge from the root to a new source) and the search continues from where it stopped,
/// touching only the nodes that come closer.
#[derive(Debug, Default)]
pub struct Dijkstra {
    /// Each node's distance from the nearest source ([`INF`]: unreached).
    pub dist: Vec<u32>,
    /// Each node's predecessor on its shortest path ([`INF`] for a source or unreached).
    pub pred: Vec<u32>,
    heap: RadixHeap,
}

impl Dijkstra {
    /// Forgets every source and distance, for a graph of `n` nodes.
    pub fn reset(&mut self, n: usize) {
        self.dist.clear();
        self.dist.resize(n, INF);
        self.pred.clear();
        self.pred.resize(n, INF);
        self.heap.clear();
    }

    /// Makes `node` a source at distance zero (joined to the root by a zero-weight edge).
    pub fn add_source(&mut self, node: u32) {
        self.dist[node as usize] = 0;
        self.pred[node as usize] = INF;
        // Distances of the new search start again at zero.
        self.heap.clear();
        self.heap.push(0, node);
    }

    /// Runs until every node has its final distance from the set of sources.
    pub fn run<G: Graph>(&mut self, g: &G) {
        let (dist, pred, heap) = (&mut self.dist, &mut self.pred, &mut self.heap);
        while let Some((d, u)) = heap.pop() {
            if d > dist[u as usize] {
                continue;
            }
            g.for_each_edge(u, |v, w| {
                let nd = d.saturating_add(w);
                if nd < dist[v as usize] {
                    dist[v as usize] = nd;
                    pred[v as usize] = u;
                    heap.push(nd, v);
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Grid {
        w: u32,
        h: u32,
        blocked: Vec<bool>,
    }

    impl Graph for Grid {
        fn node_count(&self) -> usize {
            (self.w * self.h) as usize
        }
        fn for_each_edge(&self, n: u32, mut f: impl FnMut(u32, u32)) {
            let (x, y) = ((n % self.w) as i32, (n / self.w) as i32);
            for (dx, dy, w) in [(1, 0, 10), (-1, 0, 10), (0, 1, 10), (0, -1, 10), (1, 1, 14)] {
                let (xx, yy) = (x + dx, y + dy);
                if xx < 0 || yy < 0 || xx >= self.w as i32 || yy >= self.h as i32 {
                    continue;
                }
                let m = (yy as u32) * self.w + xx as u32;
                if !self.blocked[m as usize] && !self.blocked[n as usize] {
                    f(m, w);
                }
            }
        }
    }

    #[test]
    fn radix_heap_pops_in_order() {
        let mut h = RadixHeap::default();
        let keys = [50u32, 3, 3, 1000, 7, 0, 64, 65, 1 << 30];
        for (i, &k) in keys.iter().enumerate() {
            h.push(k, i as u32);
        }
        let mut got = Vec::new();
        while let Some((k, _)) = h.pop() {
            got.push(k);
            if k == 7 {
                h.push(9, 99);
            }
        }
        let mut want = keys.to_vec();
        want.push(9);
        want.sort();
        assert_eq!(got, want);
    }

    #[test]
    fn grid_distances_and_a_wall() {
        let (w, h) = (10u32, 6u32);
        let mut blocked = vec![false; (w * h) as usize];
        // A wall at x = 5 with a gap at y = 5.
        for y in 0..5 {
            blocked[(y * w + 5) as usize] = true;
        }
        let g = Grid { w, h, blocked };
        let mut d = Dijkstra::default();
        d.reset(g.node_count());
        d.add_source(0);
        d.run(&g);
        assert_eq!(d.dist[9], 14 * 5 + 10 * 4 + 10 * 5); // through the gap, then up
        assert_eq!(d.dist[(5 * w + 5) as usize], 14 * 5);
        assert_eq!(d.dist[(2 * w + 5) as usize], INF);
        // Adding a second source only lowers distances, incrementally.
        let before = d.dist.clone();
        d.add_source(9);
        d.run(&g);
        assert_eq!(d.dist[9], 0);
        assert_eq!(d.dist[8], 10);
        assert!(d.dist.iter().zip(&before).all(|(a, b)| a <= b));
    }
}
