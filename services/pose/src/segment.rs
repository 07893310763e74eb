//! The person's pixels: depth band, floor plane removed (RANSAC), blobs split at depth
//! jumps, the largest person-shaped blob kept.

use crate::config::PoseConfig;
use crate::geom::Moments;
use airglyph_core::{DepthView, Intrinsics};
use nalgebra::{Point3, Vector3};

/// A plane `n · x + d = 0` with unit normal pointing up, out of the floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub n: Vector3<f32>,
    pub d: f32,
}

impl Plane {
    #[inline]
    pub fn height(&self, p: &Point3<f32>) -> f32 {
        self.n.dot(&p.coords) + self.d
    }
}

/// What segmentation found in one frame.
#[derive(Debug, Clone, Default)]
pub struct Segmentation {
    /// Whether a person-shaped blob was found.
    pub found: bool,
    /// Pixel count of the person.
    pub pixels: usize,
    /// Centroid of the person's points.
    pub centroid: Point3<f32>,
    /// Bounding box of the person in the image (u0, v0, u1, v1), inclusive.
    pub bbox: (u32, u32, u32, u32),
    /// The floor found in this frame, if any.
    pub floor: Option<Plane>,
}

/// Deterministic xorshift generator (the estimator must not depend on a global seed).
#[derive(Debug, Clone)]
pub struct XorShift(u64);

impl XorShift {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        (x >> 32) as u32
    }
    #[inline]
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u32() as u64 * n as u64) >> 32) as usize
    }
}

/// Pixel (u, v) as one word for the flood fill's stack (images are narrower than 2¹⁶).
#[inline]
fn pack(u: usize, v: usize) -> u32 {
    (v << 16 | u) as u32
}

/// Reusable buffers of the segmentation step.
#[derive(Debug, Default)]
pub struct Segmenter {
    labels: Vec<u32>,
    stack: Vec<u32>,
    samples: Vec<Point3<f32>>,
    /// The samples' x, y and z.
    coords: [Vec<f32>; 3],
    contacts: Vec<(u32, u32)>,
    /// Per image column, x / z of its pixels' rays.
    ray_x: Vec<f32>,
    /// Per blob label, whether it is the person's.
    keep: Vec<bool>,
}

struct Blob {
    label: u32,
    pixels: usize,
    area: f32,
    moments: Moments,
    min: Vector3<f32>,
    max: Vector3<f32>,
    bbox: (u32, u32, u32, u32),
    hmin: f32,
    hmax: f32,
}

impl Segmenter {
    /// Back-projects `depth` into `points` (z = 0 where there is no data or the depth is
    /// outside the band) and marks the person's pixels in `mask`.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &mut self,
        depth: &DepthView,
        k: &Intrinsics,
        cfg: &PoseConfig,
        prev_floor: Option<Plane>,
        prev_centroid: Option<Point3<f32>>,
        points: &mut Vec<Point3<f32>>,
        mask: &mut Vec<bool>,
    ) -> Segmentation {
        let (w, h) = (depth.width() as usize, depth.height() as usize);
        let n = w * h;
        if w > 0xffff || h > 0xffff {
            // Beyond what the flood fill's packed pixel coordinates hold.
            return Segmentation::default();
        }
        points.clear();
        points.resize(n, Point3::origin());
        mask.clear();
        mask.resize(n, false);
        self.back_project(depth, k, cfg, points);
        let floor = if cfg.remove_floor {
            self.find_floor(points, w, h, cfg, prev_floor)
        } else {
            None
        };
        if let Some(pl) = floor {
            for p in points.iter_mut() {
                if p.z > 0.0 && pl.height(p).abs() < cfg.floor_margin {
                    *p = Point3::origin();
                }
            }
        }
        let mut seg = Segmentation {
            floor,
            ..Default::default()
        };

        // Connected components split at depth jumps.
        self.labels.clear();
        self.labels.resize(n, u32::MAX);
        let mut blobs: Vec<Blob> = Vec::new();
        let inv_f = 2.0 / (k.fx + k.fy);
        for start in 0..n {
            if points[start].z <= 0.0 || self.labels[start] != u32::MAX {
                continue;
            }
            let label = blobs.len() as u32;
            let jump = (cfg.blob_jump_px, cfg.blob_jump_min);
            blobs.push(self.fill(points, w, h, start, label, floor, inv_f, jump));
        }

        // The largest blob that could be a person.
        let mut best: Option<(f32, usize)> = None;
        for (bi, b) in blobs.iter().enumerate() {
            if b.area < cfg.min_person_area || b.area > cfg.max_person_area {
                continue;
            }
            let height = if floor.is_some() {
                b.hmax - b.hmin.max(0.0)
            } else {
                b.max.y - b.min.y
            };
            if height < cfg.min_person_height {
                continue;
            }
            let width = (b.max.x - b.min.x).max(0.0);
            if width > cfg.max_person_width || height > 2.6 {
                continue;
            }
            // A wall or a table top is flat; a person is not.
            if let Some(pca) = b.moments.pca() {
                let z = pca.mean.z;
                let noise = 0.004 + 0.0015 * z * z;
                if pca.std[2] < noise && pca.std[1] > 0.25 {
                    continue;
                }
            }
            // Largest in the image: of two people, the nearer one.
            let mut score = b.pixels as f32;
            if let Some(c) = prev_centroid {
                if (b.moments.mean() - c).norm() < 0.5 {
                    score *= 1.5;
                }
            }
            if best.is_none_or(|(s, _)| score > s) {
                best = Some((score, bi));
            }
        }
        if let Some((_, bi)) = best {
            let b = &blobs[bi];
            let limbs = self.body_parts(points, w, h, &blobs, bi, cfg);
            let mut pixels = b.pixels;
            let mut bbox = b.bbox;
            for &li in &limbs {
                pixels += blobs[li].pixels;
                let lb = blobs[li].bbox;
                bbox = (
                    bbox.0.min(lb.0),
                    bbox.1.min(lb.1),
                    bbox.2.max(lb.2),
                    bbox.3.max(lb.3),
                );
            }
            // Labels are blob indices; u32::MAX (no blob) is out of the table.
            self.keep.clear();
            self.keep.resize(blobs.len(), false);
            for &bi in limbs.iter().chain([&bi]) {
                self.keep[blobs[bi].label as usize] = true;
            }
            for (m, &l) in mask.iter_mut().zip(&self.labels) {
                *m = self.keep.get(l as usize).copied().unwrap_or(false);
            }
            seg.found = true;
            seg.pixels = pixels;
            seg.centroid = b.moments.mean();
            seg.bbox = bbox;
        }
        seg
    }

    /// `points` (of the image's size, zeroed) from `depth`, left zero where there is no
    /// data or the depth is outside the band.
    fn back_project(
        &mut self,
        depth: &DepthView,
        k: &Intrinsics,
        cfg: &PoseConfig,
        points: &mut [Point3<f32>],
    ) {
        let w = depth.width() as usize;
        // x / z and y / z per column and row: no division a pixel.
        self.ray_x.clear();
        self.ray_x.extend((0..w).map(|u| (u as f32 - k.cx) / k.fx));
        let (near_mm, far_mm) = (cfg.near * 1000.0, cfg.far * 1000.0);
        let rows = depth
            .pixels()
            .chunks_exact(w)
            .zip(points.chunks_exact_mut(w));
        for (v, (row, out)) in rows.enumerate() {
            let ray_y = (v as f32 - k.cy) / k.fy;
            for ((&d, p), &ray_x) in row.iter().zip(out).zip(&self.ray_x) {
                let d = d as f32;
                if d > 0.0 && d >= near_mm && d <= far_mm {
                    let z = d * 1e-3;
                    *p = Point3::new(ray_x * z, ray_y * z, z);
                }
            }
        }
    }

    /// The blob of pixel `start`: its pixels labelled `label` by a depth-first flood
    /// fill over 4-neighbours whose depth differs by less than
    /// `max(jump.0 × footprint, jump.1)`, and its statistics.
    #[allow(clippy::too_many_arguments)]
    // Out of line: inlined into `run`, its loop keeps less in registers (about 5 % more
    // instructions, by callgrind).
    #[inline(never)]
    fn fill(
        &mut self,
        points: &[Point3<f32>],
        w: usize,
        h: usize,
        start: usize,
        label: u32,
        floor: Option<Plane>,
        inv_f: f32,
        jump: (f32, f32),
    ) -> Blob {
        let mut b = Blob {
            label,
            pixels: 0,
            area: 0.0,
            moments: Moments::default(),
            min: Vector3::repeat(f32::MAX),
            max: Vector3::repeat(f32::MIN),
            bbox: (u32::MAX, u32::MAX, 0, 0),
            hmin: f32::MAX,
            hmax: f32::MIN,
        };
        // Local borrows: the compiler need not reload the buffers after every store.
        let (labels, stack) = (&mut self.labels[..], &mut self.stack);
        labels[start] = label;
        stack.clear();
        stack.push(pack(start % w, start / w));
        while let Some(uv) = stack.pop() {
            // Pixels go on the stack as (u, v): a division per pixel costs more than
            // the rest of its visit.
            let (u, v) = (uv & 0xffff, uv >> 16);
            let i = v as usize * w + u as usize;
            let p = points[i];
            b.pixels += 1;
            let fp = p.z * inv_f;
            b.area += fp * fp;
            // Moments on a sparse subset are enough for the shape test.
            if (u + v) % 3 == 0 {
                b.moments.add(&p);
            }
            b.min = b.min.inf(&p.coords);
            b.max = b.max.sup(&p.coords);
            b.bbox = (
                b.bbox.0.min(u),
                b.bbox.1.min(v),
                b.bbox.2.max(u),
                b.bbox.3.max(v),
            );
            if let Some(pl) = floor {
                let hh = pl.height(&p);
                b.hmin = b.hmin.min(hh);
                b.hmax = b.hmax.max(hh);
            }
            let jump = (jump.0 * fp).max(jump.1);
            let mut visit = |j: usize, uv: u32| {
                let q = points[j].z;
                if q > 0.0 && labels[j] == u32::MAX && (q - p.z).abs() < jump {
                    labels[j] = label;
                    stack.push(uv);
                }
            };
            if u > 0 {
                visit(i - 1, uv - 1);
            }
            if (u as usize) + 1 < w {
                visit(i + 1, uv + 1);
            }
            if v > 0 {
                visit(i - w, uv - (1 << 16));
            }
            if (v as usize) + 1 < h {
                visit(i + w, uv + (1 << 16));
            }
        }
        b
    }

    /// The other blobs of the person's body. An arm raised before the chest hides the
    /// shoulder it hangs from, and a forearm across the waist hides where the chest
    /// meets the hips: in the image such parts meet the rest only across depth jumps
    /// and form blobs of their own. Starting from the person's blob, a blob that borders
    /// the parts found so far is taken when it lies within arm's reach of the body and
    /// neither far in front of it nor behind it (walls and other people do not qualify).
    fn body_parts(
        &mut self,
        points: &[Point3<f32>],
        w: usize,
        h: usize,
        blobs: &[Blob],
        person: usize,
        cfg: &PoseConfig,
    ) -> Vec<usize> {
        // Which blobs could be part of this body at all: within arm's reach of it,
        // neither far in front of it nor behind it (walls and other people are not).
        let p = &blobs[person];
        let centre = p.moments.mean();
        let near = |x: Vector3<f32>| (x - centre.coords).norm() < 1.4;
        let eligible: Vec<bool> = blobs
            .iter()
            .enumerate()
            .map(|(bi, b)| {
                bi == person
                    || ((b.moments.mean() - centre).norm() < 1.0
                        && near(b.min)
                        && near(b.max)
                        && b.min.z > p.min.z - 0.9
                        && b.max.z < p.max.z + 0.25
                        && b.area <= cfg.max_person_area)
            })
            .collect();
        // Pairs of such blobs that border each other, one entry a touching pixel.
        self.contacts.clear();
        for v in 0..h {
            for u in 0..w {
                let i = v * w + u;
                let la = self.labels[i];
                if la == u32::MAX || points[i].z <= 0.0 || !eligible[la as usize] {
                    continue;
                }
                for j in [(u + 1 < w).then(|| i + 1), (v + 1 < h).then(|| i + w)]
                    .into_iter()
                    .flatten()
                {
                    let lb = self.labels[j];
                    if lb != u32::MAX && lb != la && eligible[lb as usize] {
                        self.contacts.push((la.min(lb), la.max(lb)));
                    }
                }
            }
        }
        self.contacts.sort_unstable();
        let mut area = p.area;
        let mut taken = vec![person];
        let mut frontier = vec![person];
        while let Some(cur) = frontier.pop() {
            let cur = cur as u32;
            for run in self.contacts.chunk_by(|a, b| a == b) {
                let (la, lb) = run[0];
                // One touching pixel is noise; a limb's edge runs along the body.
                if run.len() < 3 || (la != cur && lb != cur) {
                    continue;
                }
                // Labels are blob indices.
                let other = if la == cur { lb } else { la } as usize;
                if taken.contains(&other) {
                    continue;
                }
                if area + blobs[other].area <= cfg.max_person_area {
                    area += blobs[other].area;
                    taken.push(other);
                    frontier.push(other);
                }
            }
        }
        taken.remove(0);
        taken
    }

    /// RANSAC for a floor-like plane (normal within 37° of the image's up) among the
    /// points of the lower two thirds of the image.
    fn find_floor(
        &mut self,
        points: &[Point3<f32>],
        w: usize,
        h: usize,
        cfg: &PoseConfig,
        prev: Option<Plane>,
    ) -> Option<Plane> {
        self.samples.clear();
        let step = (((w * h) as f32 / 4000.0).sqrt().floor() as usize).max(1);
        for v in (h / 3..h).step_by(step) {
            for u in (0..w).step_by(step) {
                let p = points[v * w + u];
                if p.z > 0.0 {
                    self.samples.push(p);
                }
            }
        }
        let s = &self.samples;
        if s.len() < 50 {
            return None;
        }
        let tol = cfg.floor_margin.max(0.02);
        // The hypotheses' inlier counts are most of the search: over the coordinates
        // in separate arrays they vectorise.
        for (c, xs) in self.coords.iter_mut().enumerate() {
            xs.clear();
            xs.extend(s.iter().map(|p| p[c]));
        }
        let [xs, ys, zs] = &self.coords;
        let count = |pl: &Plane| -> usize {
            let (n, d) = (pl.n, pl.d);
            xs.iter()
                .zip(ys)
                .zip(zs)
                // Plane::height's sum, in its order.
                .map(|((&x, &y), &z)| usize::from((n.x * x + n.y * y + n.z * z + d).abs() < tol))
                .sum()
        };
        let mut best: Option<(usize, Plane)> = prev.map(|pl| (count(&pl), pl));
        let mut rng = XorShift::new(0x9e37_79b9_7f4a_7c15);
        // Samples are in row order: the floor is most likely among the last rows, so
        // most hypotheses are drawn from there.
        let low = s.len() * 2 / 3;
        for it in 0..150 {
            let (lo, span) = if it % 3 == 2 {
                (0, s.len())
            } else {
                (low, s.len() - low)
            };
            let a = s[lo + rng.below(span)];
            let b = s[lo + rng.below(span)];
            let c = s[lo + rng.below(span)];
            let nrm = (b - a).cross(&(c - a));
            let len = nrm.norm();
            if len < 1e-6 {
                continue;
            }
            let mut nrm = nrm / len;
            // Up is −y in the camera frame.
            if nrm.y > 0.0 {
                nrm = -nrm;
            }
            if -nrm.y < 0.8 {
                continue;
            }
            let pl = Plane {
                n: nrm,
                d: -nrm.dot(&a.coords),
            };
            let c = count(&pl);
            if best.is_none_or(|(bc, _)| c > bc) {
                best = Some((c, pl));
            }
        }
        let (c, pl) = best?;
        if c < (s.len() / 20).max(40) {
            return None;
        }
        // Least-squares refinement on the inliers; a floor recedes from the camera and
        // spreads sideways, a slice through a body does not.
        let mut m = Moments::default();
        let (mut zmin, mut zmax, mut xmin, mut xmax) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for p in s.iter().filter(|p| pl.height(p).abs() < tol) {
            m.add(p);
            zmin = zmin.min(p.z);
            zmax = zmax.max(p.z);
            xmin = xmin.min(p.x);
            xmax = xmax.max(p.x);
        }
        if zmax - zmin < 0.6 || xmax - xmin < 0.6 {
            return None;
        }
        // A floor fills the bottom of the image, except where someone stands on it.
        let bottom = &s[s.len() * 17 / 20..];
        let on = bottom.iter().filter(|p| pl.height(p).abs() < tol).count();
        if bottom.is_empty() || on * 2 < bottom.len() {
            return None;
        }
        let pca = m.pca()?;
        let mut nrm: Vector3<f32> = pca.axes.column(2).into_owned();
        if nrm.y > 0.0 {
            nrm = -nrm;
        }
        if -nrm.y < 0.8 || !nrm.iter().all(|c| c.is_finite()) {
            return Some(pl);
        }
        // Most of the floor must be below the person: the plane's points lie low in
        // the image, which the sampling region already ensures.
        Some(Plane {
            n: nrm,
            d: -nrm.dot(&pca.mean.coords),
        })
    }
}
