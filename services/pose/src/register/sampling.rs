//! What the registration reads of a frame: the person's points sampled (every one near
//! the silhouette's edge, a grid inside) and, for the silhouette term, a map of the
//! nearest person pixel.

use super::{Frame, Registration};

/// Which person points the registration's data term takes (part of
/// [`super::RegisterConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct SamplingConfig {
    /// Every person point within this many pixels of the silhouette's edge (thin parts:
    /// a forearm is two or three pixels wide)...
    pub thin_px: f32,
    /// ...and the others on a grid of this stride.
    pub interior_stride: usize,
}

impl Default for SamplingConfig {
    fn default() -> Self {
        Self {
            thin_px: 2.0,
            interior_stride: 3,
        }
    }
}

/// How far around the person's bounding box the nearest-person-pixel map reaches,
/// pixels (a limb of the body farther out is pulled towards the box's edge first).
pub(super) const NEAREST_MARGIN: usize = 24;

/// For every block of 2×2 pixels of the person's bounding box (and a margin), a person
/// pixel of the nearest block that has one, by two passes of nearest-seed propagation
/// over 8-neighbours: within a few pixels of the exact answer, enough to pull a limb
/// back onto the silhouette, at a quarter of the cost of a full-resolution map.
#[derive(Debug, Default)]
pub(super) struct NearestPixel {
    /// The box in blocks: first block column and row, size.
    pub(super) bu0: usize,
    pub(super) bv0: usize,
    pub(super) w: usize,
    pub(super) h: usize,
    /// Per block: a person pixel (image coordinates) of the nearest block with one,
    /// `u16::MAX` for none, and the squared distance in blocks.
    pub(super) seed: Vec<(u16, u16)>,
    pub(super) d2: Vec<u32>,
}

/// Pixels a block of [`NearestPixel`] covers along each axis.
pub(super) const BLOCK: usize = 2;

impl NearestPixel {
    /// `bbox`: the person pixels' first and last column and row.
    pub(super) fn build(
        &mut self,
        f: &Frame,
        bbox: Option<(usize, usize, usize, usize)>,
        margin: usize,
    ) {
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
    pub(super) fn get(&self, u: usize, v: usize) -> Option<(u16, u16)> {
        if self.w == 0 {
            return None;
        }
        let bu = (u / BLOCK).clamp(self.bu0, self.bu0 + self.w - 1) - self.bu0;
        let bv = (v / BLOCK).clamp(self.bv0, self.bv0 + self.h - 1) - self.bv0;
        let q = self.seed[bv * self.w + bu];
        (q.0 != u16::MAX).then_some(q)
    }
}

/// Whether a person pixel lies within a radius of the silhouette's edge: of a pixel
/// outside the mask, or of the image's border. The exact answer of the squared distance
/// transform's `d² ≤ r²`, from the few pixels within the radius, for the registration's
/// sampling alone (which needs no more than that of the transform).
pub(super) struct EdgeTest {
    /// The offsets (du, dv) within the radius, nearest first (most edge pixels have a
    /// neighbour outside).
    pub(super) offsets: Vec<(i32, i32)>,
}

impl EdgeTest {
    pub(super) fn new(radius: f32) -> Self {
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
    pub(super) fn near(&self, f: &Frame, u: usize, v: usize) -> bool {
        let (w, h) = (f.width as i32, f.height as i32);
        self.offsets.iter().any(|&(du, dv)| {
            let (x, y) = (u as i32 + du, v as i32 + dv);
            x < 0 || y < 0 || x >= w || y >= h || !f.mask[(y * w + x) as usize]
        })
    }
}

impl Registration {
    /// Samples the person's points and builds the nearest-person-pixel map.
    ///
    /// Thin parts (limbs, within [`SamplingConfig::thin_px`] of the silhouette's edge)
    /// keep every pixel: a forearm is two or three pixels wide. The thick interior is
    /// taken on a grid of [`SamplingConfig::interior_stride`].
    pub fn prepare(&mut self, f: &Frame, cfg: &SamplingConfig) {
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
}
