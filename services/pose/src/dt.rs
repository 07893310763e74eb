//! Exact Euclidean distance transform of a binary mask (Felzenszwalb & Huttenlocher's
//! lower envelope of parabolas, one pass over the columns and one over the rows).

/// Squared distance, in pixels², from each pixel inside `mask` to the nearest pixel
/// outside it (pixels beyond the image border count as outside). Zero outside the mask.
/// `scratch` buffers are reused between calls.
#[derive(Debug, Default)]
pub struct DistanceTransform {
    f: Vec<f32>,
    d: Vec<f32>,
    v: Vec<usize>,
    z: Vec<f32>,
    col: Vec<f32>,
}

const INF: f32 = 1e20;

/// Which sides of the image the mask continues beyond.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Open {
    pub left: bool,
    pub right: bool,
    pub top: bool,
    pub bottom: bool,
}

impl DistanceTransform {
    /// The squared distance (pixels²) of each pixel of a `width`×`height` mask to the
    /// nearest pixel outside it, into `out`.
    pub fn compute(&mut self, mask: &[bool], width: usize, height: usize, out: &mut Vec<f32>) {
        self.compute_open(mask, width, height, Open::default(), out);
    }

    /// [`DistanceTransform::compute`] with the sides in `open` continuing the mask
    /// beyond the border (a body cut by the image's edge is no narrower there).
    pub fn compute_open(
        &mut self,
        mask: &[bool],
        width: usize,
        height: usize,
        open: Open,
        out: &mut Vec<f32>,
    ) {
        out.clear();
        out.resize(width * height, 0.0);
        if width == 0 || height == 0 {
            return;
        }
        // Each 1-D problem is padded at both ends: zero where the border counts as
        // background, infinity where the mask goes on.
        let pad = |on: bool| if on { INF } else { 0.0 };
        let n = width.max(height) + 2;
        self.f.resize(n, 0.0);
        self.d.resize(n, 0.0);
        self.v.resize(n, 0);
        self.z.resize(n + 1, 0.0);
        self.col.resize(n, 0.0);
        // Columns first.
        for x in 0..width {
            self.f[0] = pad(open.top);
            for y in 0..height {
                self.f[y + 1] = if mask[y * width + x] { INF } else { 0.0 };
            }
            self.f[height + 1] = pad(open.bottom);
            self.pass(height + 2);
            for y in 0..height {
                out[y * width + x] = self.d[y + 1];
            }
        }
        // Then rows.
        for y in 0..height {
            self.f[0] = pad(open.left);
            self.f[1..width + 1].copy_from_slice(&out[y * width..(y + 1) * width]);
            self.f[width + 1] = pad(open.right);
            self.pass(width + 2);
            for x in 0..width {
                out[y * width + x] = if mask[y * width + x] {
                    self.d[x + 1]
                } else {
                    0.0
                };
            }
        }
    }

    /// 1-D squared distance transform of `f[..n]` into `d[..n]`.
    fn pass(&mut self, n: usize) {
        let (f, d, v, z) = (&self.f, &mut self.d, &mut self.v, &mut self.z);
        let mut k = 0usize;
        v[0] = 0;
        z[0] = -INF;
        z[1] = INF;
        for q in 1..n {
            let fq = f[q] + (q * q) as f32;
            loop {
                let p = v[k];
                let s = (fq - (f[p] + (p * p) as f32)) / (2.0 * (q as f32 - p as f32));
                if s <= z[k] && k > 0 {
                    k -= 1;
                    continue;
                }
                if s <= z[k] {
                    // k == 0: replace the first parabola.
                    v[0] = q;
                    z[0] = -INF;
                    z[1] = INF;
                    break;
                }
                k += 1;
                v[k] = q;
                z[k] = s;
                z[k + 1] = INF;
                break;
            }
        }
        k = 0;
        for (q, dq) in d.iter_mut().enumerate().take(n) {
            while z[k + 1] < q as f32 {
                k += 1;
            }
            let p = v[k];
            let dx = q as f32 - p as f32;
            *dq = dx * dx + f[p];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(mask: &[bool], w: usize, h: usize) -> Vec<f32> {
        let mut out = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                if !mask[y * w + x] {
                    continue;
                }
                let mut best = f32::MAX;
                for yy in -1..=h as i64 {
                    for xx in -1..=w as i64 {
                        let inside = xx >= 0
                            && yy >= 0
                            && (xx as usize) < w
                            && (yy as usize) < h
                            && mask[yy as usize * w + xx as usize];
                        if !inside {
                            let d = (xx - x as i64).pow(2) + (yy - y as i64).pow(2);
                            best = best.min(d as f32);
                        }
                    }
                }
                out[y * w + x] = best;
            }
        }
        out
    }

    #[test]
    fn rectangle_distances_are_exact() {
        let (w, h) = (20, 12);
        let mut mask = vec![false; w * h];
        for y in 2..10 {
            for x in 3..17 {
                mask[y * w + x] = true;
            }
        }
        let mut dt = DistanceTransform::default();
        let mut out = Vec::new();
        dt.compute(&mask, w, h, &mut out);
        assert_eq!(out, brute(&mask, w, h));
        // The centre of an 8-row band is 4 pixels from the edge.
        assert_eq!(out[5 * w + 10], 16.0);
        assert_eq!(out[0], 0.0);
    }

    #[test]
    fn a_mask_cut_by_an_open_side_is_no_narrower_there() {
        // A band 8 pixels wide running off the bottom: near the bottom its centre is
        // 4 pixels from the sides, not 1 from the border.
        let (w, h) = (20, 12);
        let mut mask = vec![false; w * h];
        for y in 2..h {
            for x in 6..14 {
                mask[y * w + x] = true;
            }
        }
        let mut dt = DistanceTransform::default();
        let mut out = Vec::new();
        let open = Open {
            bottom: true,
            ..Open::default()
        };
        dt.compute_open(&mask, w, h, open, &mut out);
        assert_eq!(out[(h - 1) * w + 10], 16.0);
        assert_eq!(out[(h - 1) * w + 6], 1.0);
        dt.compute(&mask, w, h, &mut out);
        assert_eq!(out[(h - 1) * w + 10], 1.0);
    }

    #[test]
    fn irregular_mask_matches_brute_force_including_the_border() {
        let (w, h) = (17, 13);
        let mask: Vec<bool> = (0..w * h)
            .map(|i| ((i * 7919) % 11) != 0 || i % 5 == 0)
            .collect();
        let mut dt = DistanceTransform::default();
        let mut out = Vec::new();
        dt.compute(&mask, w, h, &mut out);
        assert_eq!(out, brute(&mask, w, h));
    }
}
