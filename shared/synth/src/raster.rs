//! A z-buffer triangle rasterizer into 16-bit depth (millimetres, 0 = no data).
//!
//! Pixel (u, v) samples the scene at its centre, the point (u, v) of the camera model in
//! airglyph-core, so a rendered pixel back-projects exactly onto the surface it shows.
//! Depth is interpolated as 1/z, which is linear in the image for a planar triangle, so
//! a plane renders to its exact depth (up to the millimetre rounding).

use airglyph_core::Intrinsics;
use nalgebra::Point3;

/// The label of pixels no triangle covered.
pub const NO_LABEL: u8 = u8::MAX;

/// Closer than this (metres) a vertex is dropped: its triangle is not drawn.
pub const NEAR_M: f32 = 0.05;

/// Tolerance of the inside test (edge-function units, px²).
const EDGE_EPS: f32 = 1e-2;

/// Reusable buffers for [`Raster::rasterize`].
#[derive(Debug, Default, Clone)]
pub struct Raster {
    screen: Vec<[f32; 3]>,
}

impl Raster {
    /// A rasterizer with no buffer yet (it grows to the first frame's size).
    pub fn new() -> Self {
        Self::default()
    }

    /// Draws `tris` over `verts` (camera frame, metres) into `depth` keeping the nearest
    /// surface; `labels`, if given, receives `tri_label[t]` wherever triangle `t` won.
    /// With `cull`, triangles whose front (counter-clockwise seen from outside) faces
    /// away from the camera are skipped: right for closed, consistently wound meshes.
    #[allow(clippy::too_many_arguments)]
    pub fn rasterize(
        &mut self,
        k: &Intrinsics,
        verts: &[Point3<f32>],
        tris: &[[u32; 3]],
        tri_label: &[u8],
        cull: bool,
        depth: &mut [u16],
        mut labels: Option<&mut [u8]>,
    ) {
        let w = k.width as usize;
        let h = k.height as usize;
        debug_assert_eq!(depth.len(), w * h);
        self.screen.clear();
        self.screen.extend(verts.iter().map(|p| {
            if p.z > NEAR_M {
                let iz = 1.0 / p.z;
                [p.x * k.fx * iz + k.cx, p.y * k.fy * iz + k.cy, iz]
            } else {
                [f32::NAN, f32::NAN, -1.0]
            }
        }));
        let maxx = w as f32 - 1.0;
        let maxy = h as f32 - 1.0;
        for (ti, t) in tris.iter().enumerate() {
            let mut a = self.screen[t[0] as usize];
            let b = self.screen[t[1] as usize];
            let mut c = self.screen[t[2] as usize];
            if a[2] <= 0.0 || b[2] <= 0.0 || c[2] <= 0.0 {
                continue;
            }
            let mut area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            // Seen from the camera a front face winds clockwise in this y-down image.
            if area >= 0.0 {
                if cull || area == 0.0 {
                    continue;
                }
            } else {
                std::mem::swap(&mut a, &mut c);
                area = -area;
            }
            // (ceil/floor of non-negative values by integer conversion: the libm calls
            // were a tenth of the frame time in the profile.)
            let x0 = ceil_pos(a[0].min(b[0]).min(c[0]).max(0.0));
            let x1 = floor_pos(a[0].max(b[0]).max(c[0]).min(maxx));
            let y0 = ceil_pos(a[1].min(b[1]).min(c[1]).max(0.0));
            let y1 = floor_pos(a[1].max(b[1]).max(c[1]).min(maxy));
            if !(x0 <= x1 && y0 <= y1) {
                continue;
            }
            let inv_area = 1.0 / area;
            // Edge functions e_i(p), each the weight of the opposite vertex times area.
            let e = |p: &[f32; 3], q: &[f32; 3], x: f32, y: f32| {
                (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])
            };
            let (dx0, dy0) = (-(c[1] - b[1]), c[0] - b[0]);
            let (dx1, dy1) = (-(a[1] - c[1]), a[0] - c[0]);
            let (dx2, dy2) = (-(b[1] - a[1]), b[0] - a[0]);
            let s0 = e(&b, &c, x0, y0);
            let s1 = e(&c, &a, x0, y0);
            let s2 = e(&a, &b, x0, y0);
            // 1/z as a plane over the image: iz = r0*a + r1*b + r2*c (scaled by 1/area).
            let za = a[2] * inv_area;
            let zb = b[2] * inv_area;
            let zc = c[2] * inv_area;
            let dzx = dx0 * za + dx1 * zb + dx2 * zc;
            let label = tri_label.get(ti).copied().unwrap_or(NO_LABEL);
            let (xs, xe) = (x0 as usize, x1 as usize);
            for y in y0 as usize..=y1 as usize {
                let g = y as f32 - y0;
                let r0 = s0 + g * dy0;
                let r1 = s1 + g * dy1;
                let r2 = s2 + g * dy2;
                let iz0 = r0 * za + r1 * zb + r2 * zc;
                let row = y * w;
                for x in xs..=xe {
                    // Evaluated afresh (not accumulated) so that two triangles sharing an
                    // edge agree on it to within EDGE_EPS: no cracks between them.
                    let f = (x - xs) as f32;
                    let w0 = r0 + f * dx0;
                    let w1 = r1 + f * dx1;
                    let w2 = r2 + f * dx2;
                    if w0 >= -EDGE_EPS && w1 >= -EDGE_EPS && w2 >= -EDGE_EPS {
                        let iz = iz0 + f * dzx;
                        let mm = (1000.0 / iz + 0.5).clamp(1.0, 65535.0) as u16;
                        let cur = &mut depth[row + x];
                        if mm.wrapping_sub(1) < cur.wrapping_sub(1) {
                            *cur = mm;
                            if let Some(l) = labels.as_deref_mut() {
                                l[row + x] = label;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// `x.ceil()` for finite `x` in [0, 2²⁴).
#[inline]
fn ceil_pos(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t < x {
        t + 1.0
    } else {
        t
    }
}

/// `x.floor()` for `x` ≥ 0 (negative values, an empty range anyway, give -1).
#[inline]
fn floor_pos(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        x as i32 as f32
    }
}
