//! A Kinect-v1-like sensor model and the floor-and-wall background.
//!
//! Kinect v1 measures disparity against a projector 7.5 cm beside the IR camera in
//! steps of 1/8 pixel, so depth is quantized ever more coarsely with distance (about
//! 2 cm steps at 2.7 m), with noise σ_z ≈ 1.4·10⁻³ z² (Khoshelham & Elberink 2012);
//! pixels at depth discontinuities are often lost, and the projector's shadow leaves a
//! band without data on the left of every foreground edge.

use airglyph_core::Intrinsics;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The projector–camera baseline, metres.
pub const BASELINE_M: f32 = 0.075;
/// Disparity is measured in steps of this many pixels.
pub const DISPARITY_STEP_PX: f32 = 0.125;
/// Noise of the disparity, pixels (σ_z = σ_d z² / (f b) ≈ 1.4e-3 z² at f = 575.8).
pub const DISPARITY_SIGMA_PX: f32 = 0.06;
/// The sensor's range, metres: nothing nearer or farther is measured.
pub const RANGE_M: (f32, f32) = (0.5, 5.0);
/// Chance that a pixel at a depth discontinuity is lost.
pub const EDGE_DROP: f64 = 0.5;

/// Applies the sensor model to a rendered depth image in place; deterministic given
/// `seed` and `frame`.
pub fn apply(k: &Intrinsics, depth: &mut [u16], seed: u64, frame: usize) {
    let w = k.width as usize;
    let h = k.height as usize;
    let fb = k.fx * BASELINE_M;
    let mut rng =
        ChaCha8Rng::seed_from_u64(seed ^ (frame as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    // Projector shadow: background to the left of a nearer surface loses its data.
    for y in 0..h {
        let row = &mut depth[y * w..(y + 1) * w];
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
    // Lost pixels at discontinuities (decided on the clean image, applied after).
    let mut lost = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let d = depth[y * w + x];
            if d == 0 {
                continue;
            }
            let mut edge = false;
            for (dx, dy) in [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                if nx < 0 || ny < 0 || nx >= w as i32 || ny >= h as i32 {
                    continue;
                }
                let n = depth[ny as usize * w + nx as usize];
                if n == 0 || (n as i32 - d as i32).unsigned_abs() > 60 {
                    edge = true;
                    break;
                }
            }
            if edge && rng.gen_bool(EDGE_DROP) {
                lost.push(y * w + x);
            }
        }
    }
    for i in lost {
        depth[i] = 0;
    }
    // Disparity noise and quantization.
    for d in depth.iter_mut() {
        if *d == 0 {
            continue;
        }
        let z = *d as f32 * 1e-3;
        if !(RANGE_M.0..=RANGE_M.1).contains(&z) {
            *d = 0;
            continue;
        }
        let disp = fb / z + gaussian(&mut rng) * DISPARITY_SIGMA_PX;
        let q = (disp / DISPARITY_STEP_PX).round() * DISPARITY_STEP_PX;
        *d = if q > 0.0 {
            (fb / q * 1000.0).round().clamp(0.0, 65535.0) as u16
        } else {
            0
        };
    }
}

/// A standard normal sample (Box–Muller).
pub(crate) fn gaussian(rng: &mut impl Rng) -> f32 {
    let u1: f32 = rng.gen_range(f32::EPSILON..1.0);
    let u2: f32 = rng.gen::<f32>();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}
