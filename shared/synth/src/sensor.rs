//! A Kinect-v1-like sensor model.
//!
//! Kinect v1 measures disparity against a projector 7.5 cm beside the IR camera in
//! steps of 1/8 pixel, so depth is quantized ever more coarsely with distance (about
//! 2 cm steps at 2.7 m, 7 cm at 5 m), with a random error growing with the square of the
//! distance (Khoshelham & Elberink 2012: about 1.5 mm at 1 m, 4 cm at 5 m). What it
//! cannot match it leaves empty: the projector's shadow, a band on the left of every
//! nearer surface; surfaces seen at a grazing angle (the sides of arms and torso); a
//! pixel at a depth jump now and then; small blobs where the pattern is lost (dark or
//! shiny patches, hair). Where a depth jump cuts its matching window, a pixel may take a
//! depth between the two surfaces (a "flying pixel"). What it does not model: the noise
//! is drawn per pixel, while the real sensor's is correlated over its matching window,
//! and lateral edges are not blurred. The pose README compares it with the literature.

use airglyph_core::Intrinsics;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The artefacts of one sensor; [`SensorModel::default`] is Kinect v1's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorModel {
    /// The projector–camera baseline, metres.
    pub baseline_m: f32,
    /// Disparity is measured in steps of this many pixels.
    pub disparity_step_px: f32,
    /// Noise of the disparity before its quantization, pixels (σ_z = σ_d z² / (f b)).
    pub disparity_sigma_px: f32,
    /// The range, metres: nothing nearer or farther is measured.
    pub range_m: (f32, f32),
    /// Chance that a pixel at a depth discontinuity is lost.
    pub edge_drop: f64,
    /// Chance that a pixel on the far side of a depth jump takes a depth in between.
    pub flying_pixels: f64,
    /// Beyond this angle between the viewing ray and the surface's normal (degrees)
    /// pixels start to be lost, all but a fifth of them by 85°.
    pub grazing_deg: f32,
    /// Share of the image lost in small blobs.
    pub holes: f32,
}

impl Default for SensorModel {
    fn default() -> Self {
        Self {
            baseline_m: 0.075,
            disparity_step_px: 0.125,
            disparity_sigma_px: 0.06,
            range_m: (0.5, 5.0),
            edge_drop: 0.5,
            flying_pixels: 0.15,
            grazing_deg: 72.0,
            holes: 0.002,
        }
    }
}

/// Depth steps larger than this (millimetres) are discontinuities.
const JUMP_MM: i32 = 60;

impl SensorModel {
    /// Applies the model to a rendered depth image in place; deterministic given `seed`
    /// and `frame`.
    pub fn apply(&self, k: &Intrinsics, depth: &mut [u16], seed: u64, frame: usize) {
        let w = k.width as usize;
        let h = k.height as usize;
        let mut rng =
            ChaCha8Rng::seed_from_u64(seed ^ (frame as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        self.shadow(k, depth);
        // Decided on the image as rendered (with its shadows), applied after.
        let mut changes: Vec<(usize, u16)> = Vec::new();
        let (tan_lo, tan_hi) = (
            self.grazing_deg.to_radians().tan(),
            85f32.to_radians().tan(),
        );
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let d = depth[i];
                if d == 0 {
                    continue;
                }
                let neighbour = |dx: i32, dy: i32| {
                    let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                    (nx >= 0 && ny >= 0 && nx < w as i32 && ny < h as i32)
                        .then(|| depth[ny as usize * w + nx as usize])
                };
                let mut nearer = None;
                let mut edge = false;
                let mut slope = 0f32;
                for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                    let Some(n) = neighbour(dx, dy) else {
                        continue;
                    };
                    let step = n as i32 - d as i32;
                    if n == 0 || step.abs() > JUMP_MM {
                        edge = true;
                        if n != 0 && step < 0 {
                            nearer = Some(nearer.map_or(n, |m: u16| m.min(n)));
                        }
                    } else {
                        // Depth change across one pixel's footprint: the surface's tilt.
                        let footprint = d as f32 / if dx != 0 { k.fx } else { k.fy };
                        slope = slope.max(step.unsigned_abs() as f32 / footprint);
                    }
                }
                if let Some(near) = nearer.filter(|_| rng.gen_bool(self.flying_pixels)) {
                    let t: f32 = rng.gen_range(0.15..0.85);
                    changes.push((i, (near as f32 + t * (d - near) as f32).round() as u16));
                } else if edge && rng.gen_bool(self.edge_drop) {
                    changes.push((i, 0));
                } else if slope > tan_lo {
                    let p = ((slope - tan_lo) / (tan_hi - tan_lo)).min(1.0) * 0.8;
                    if rng.gen_bool(p as f64) {
                        changes.push((i, 0));
                    }
                }
            }
        }
        for (i, v) in changes {
            depth[i] = v;
        }
        self.blobs(k, depth, &mut rng);
        self.quantize(k, depth, &mut rng);
    }

    /// The projector's shadow: background to the left of a nearer surface loses its data.
    fn shadow(&self, k: &Intrinsics, depth: &mut [u16]) {
        let w = k.width as usize;
        let fb = k.fx * self.baseline_m;
        for row in depth.chunks_exact_mut(w) {
            for x in (1..w).rev() {
                let near = row[x];
                let far = row[x - 1];
                if near != 0 && far > near && far - near > 50 {
                    let zn = near as f32 * 1e-3;
                    let zf = far as f32 * 1e-3;
                    let band = (fb * (1.0 / zn - 1.0 / zf)).round() as usize;
                    for px in &mut row[x.saturating_sub(band)..x] {
                        if *px > near {
                            *px = 0;
                        }
                    }
                }
            }
        }
    }

    /// Small round holes, 1.5–5 pixels across at 640 pixels a row, covering `holes` of
    /// the image.
    fn blobs(&self, k: &Intrinsics, depth: &mut [u16], rng: &mut ChaCha8Rng) {
        let (w, h) = (k.width as i32, k.height as i32);
        let scale = w as f32 / 640.0;
        let mean_area = std::f32::consts::PI * (1.6 * scale).powi(2);
        let count = (self.holes * (w * h) as f32 / mean_area).round() as usize;
        for _ in 0..count {
            let (cx, cy) = (rng.gen_range(0..w), rng.gen_range(0..h));
            let r: f32 = rng.gen_range(0.75..2.5) * scale;
            let ri = r.ceil() as i32;
            for y in (cy - ri).max(0)..=(cy + ri).min(h - 1) {
                for x in (cx - ri).max(0)..=(cx + ri).min(w - 1) {
                    if ((x - cx).pow(2) + (y - cy).pow(2)) as f32 <= r * r {
                        depth[(y * w + x) as usize] = 0;
                    }
                }
            }
        }
    }

    /// Disparity noise, then quantization to the disparity step; out of range is lost.
    fn quantize(&self, k: &Intrinsics, depth: &mut [u16], rng: &mut ChaCha8Rng) {
        let fb = k.fx * self.baseline_m;
        for d in depth.iter_mut() {
            if *d == 0 {
                continue;
            }
            let z = *d as f32 * 1e-3;
            if !(self.range_m.0..=self.range_m.1).contains(&z) {
                *d = 0;
                continue;
            }
            let disp = fb / z + gaussian(rng) * self.disparity_sigma_px;
            let q = (disp / self.disparity_step_px).round() * self.disparity_step_px;
            *d = if q > 0.0 {
                (fb / q * 1000.0).round().clamp(0.0, 65535.0) as u16
            } else {
                0
            };
        }
    }
}

/// A standard normal sample (Box–Muller).
pub(crate) fn gaussian(rng: &mut impl Rng) -> f32 {
    let u1: f32 = rng.gen_range(f32::EPSILON..1.0);
    let u2: f32 = rng.gen::<f32>();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}
