//! Points binned in cubes, for the closest points within a radius: the torso's
//! registration matches model and data points only when they lie that near, so each
//! model point looks at the 27 cubes around it instead of at every data point.

use nalgebra::Point3;

/// The cubes a cloud falls into, its points listed cube by cube; buffers are reused.
#[derive(Debug, Default)]
pub(crate) struct Cells {
    origin: Point3<f32>,
    /// 1 / the cubes' side.
    inv: f32,
    dims: [usize; 3],
    /// Where each cube's points start in `order`, and one past the last cube.
    start: Vec<u32>,
    /// Point indices, cube by cube, ascending within a cube.
    order: Vec<u32>,
}

/// At most this many cubes a point: a side tiny against the cloud (a setting far off)
/// makes larger cubes rather than a huge table. Larger cubes only look at more points.
const CUBES_A_POINT: usize = 8;

impl Cells {
    /// Bins `points` in cubes of side at least `side` (finite points only).
    pub(crate) fn build(&mut self, points: &[Point3<f32>], side: f32) {
        self.start.clear();
        self.order.clear();
        self.dims = [0; 3];
        let finite = || points.iter().filter(|p| p.iter().all(|c| c.is_finite()));
        let Some(first) = finite().next() else {
            return;
        };
        let (mut lo, mut hi) = (first.coords, first.coords);
        for p in finite() {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        let extent = hi - lo;
        let budget = (CUBES_A_POINT * points.len()).max(27) as f32;
        let volume = extent.iter().map(|e| e.max(side)).product::<f32>();
        let mut side = side.max((volume / budget).cbrt()).max(1e-6);
        // The same product as `coords`, so the farthest point falls in the last cube.
        let dims = |inv: f32| [0, 1, 2].map(|a| (extent[a] * inv) as usize + 1);
        while dims(1.0 / side).iter().product::<usize>() as f32 > budget {
            side *= 1.25;
        }
        self.origin = Point3::from(lo);
        self.inv = 1.0 / side;
        self.dims = dims(self.inv);
        let n_cells = self.dims.iter().product::<usize>();
        self.start.resize(n_cells + 1, 0);
        let cells: Vec<Option<usize>> = points.iter().map(|p| self.cell_of(p)).collect();
        for c in cells.iter().flatten() {
            self.start[c + 1] += 1;
        }
        for i in 0..n_cells {
            self.start[i + 1] += self.start[i];
        }
        self.order.resize(self.start[n_cells] as usize, 0);
        let mut next = self.start[..n_cells].to_vec();
        for (i, c) in cells.iter().enumerate() {
            if let Some(c) = *c {
                self.order[next[c] as usize] = i as u32;
                next[c] += 1;
            }
        }
    }

    fn coords(&self, p: &Point3<f32>) -> [i64; 3] {
        [0, 1, 2].map(|a| ((p[a] - self.origin[a]) * self.inv).floor() as i64)
    }

    fn cell_of(&self, p: &Point3<f32>) -> Option<usize> {
        if !p.iter().all(|c| c.is_finite()) {
            return None;
        }
        let [x, y, z] = self.coords(p);
        let [dx, dy, dz] = self.dims;
        let inside = |c: i64, d: usize| (0..d as i64).contains(&c);
        (inside(x, dx) && inside(y, dy) && inside(z, dz))
            .then(|| (z as usize * dy + y as usize) * dx + x as usize)
    }

    /// Calls `f` with every binned point that may lie within a cube's side of `p`
    /// (those of the 27 cubes around it), and perhaps some farther.
    pub(crate) fn near(&self, p: &Point3<f32>, mut f: impl FnMut(u32)) {
        if self.start.is_empty() || !p.iter().all(|c| c.is_finite()) {
            return;
        }
        let c = self.coords(p);
        let [dx, dy, dz] = self.dims.map(|d| d as i64);
        let span = |a: usize, d: i64| (c[a] - 1).max(0)..=(c[a] + 1).min(d - 1);
        for z in span(2, dz) {
            for y in span(1, dy) {
                let row = (z * dy + y) * dx;
                let xs = span(0, dx);
                if xs.is_empty() {
                    continue;
                }
                let (a, b) = ((row + xs.start()) as usize, (row + xs.end()) as usize);
                let (from, to) = (self.start[a] as usize, self.start[b + 1] as usize);
                for &i in &self.order[from..to] {
                    f(i);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point within `r` of `p`, by looking at all of them.
    fn brute(points: &[Point3<f32>], p: &Point3<f32>, r: f32) -> Vec<u32> {
        (0..points.len() as u32)
            .filter(|&i| (points[i as usize] - p).norm() < r)
            .collect()
    }

    fn cloud(n: usize, seed: u32) -> Vec<Point3<f32>> {
        // A small LCG: enough spread for the test, no dependency.
        let mut s = seed;
        let mut next = move || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1u32 << 24) as f32
        };
        (0..n)
            .map(|_| Point3::new(next() - 0.5, next() * 0.8, 1.0 + next() * 0.6))
            .collect()
    }

    #[test]
    fn every_point_within_the_side_is_offered() {
        let points = cloud(900, 7);
        let queries = cloud(200, 11);
        for side in [0.1f32, 0.05, 0.37] {
            let mut cells = Cells::default();
            cells.build(&points, side);
            for q in &queries {
                let mut got = Vec::new();
                cells.near(q, |i| got.push(i));
                for i in brute(&points, q, side) {
                    assert!(got.contains(&i), "side {side}: point {i} missed near {q}");
                }
            }
        }
    }

    #[test]
    fn a_far_setting_an_empty_cloud_and_bad_points_do_not_break_it() {
        let mut points = cloud(300, 3);
        points.push(Point3::new(f32::NAN, 0.0, 1.0));
        points.push(Point3::new(f32::INFINITY, 0.0, 1.0));
        let mut cells = Cells::default();
        // A side far below the spacing of the points: the table stays small.
        cells.build(&points, 1e-9);
        assert!(cells.start.len() <= CUBES_A_POINT * points.len() + 2);
        let q = points[5];
        let mut got = Vec::new();
        cells.near(&q, |i| got.push(i));
        assert!(got.contains(&5));
        cells.near(&Point3::new(f32::NAN, 0.0, 0.0), |_| panic!("a NaN query"));
        cells.build(&[], 0.1);
        cells.near(&q, |_| panic!("an empty cloud"));
    }
}
