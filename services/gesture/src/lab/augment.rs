//! Writer variation for training: a trajectory a little rotated, sheared, stretched and
//! jittered; one with depth also turned a little out of its plane.

use crate::features::bbox;
use crate::trajectory::Trajectory;
use rand::Rng;

/// Random distortion for training (writer variation): rotation, shear, anisotropic
/// scale and jitter, applied to the raw trajectory.
pub fn augment<R: Rng>(t: &Trajectory, rng: &mut R, strength: f32) -> Trajectory {
    let rot = rng.gen_range(-0.2..0.2f32) * strength;
    let shear = rng.gen_range(-0.3..0.3f32) * strength;
    let sx = 1.0 + rng.gen_range(-0.2..0.2f32) * strength;
    let sy = 1.0 + rng.gen_range(-0.2..0.2f32) * strength;
    let (c, s) = (rot.cos(), rot.sin());
    let (x0, y0, x1, y1) = bbox(&t.points);
    let size = (x1 - x0).max(y1 - y0).max(1e-6);
    let jitter = 0.006 * size * strength;
    let points = t
        .points
        .iter()
        .map(|p| {
            let (x, y) = (p[0] - x0, p[1] - y0);
            let x = x + shear * y;
            let (x, y) = (x * sx, y * sy);
            let (x, y) = (c * x - s * y, s * x + c * y);
            let jx = if jitter > 0.0 {
                rng.gen_range(-jitter..jitter)
            } else {
                0.0
            };
            let jy = if jitter > 0.0 {
                rng.gen_range(-jitter..jitter)
            } else {
                0.0
            };
            [x + jx, y + jy]
        })
        .collect();
    let mut out = Trajectory {
        points,
        pen_up: t.pen_up.clone(),
        depth: None,
    };
    if let Some(z) = &t.depth {
        // After the 2-D draws, so that 2-D data draws what it drew before depth.
        turn_in_depth(&mut out, z, rng, strength, (sx + sy) / 2.0, jitter);
    }
    out
}

/// Depth for the augmented points: `z` scaled like the plane, the whole turned a little
/// about the vertical axis and the horizontal one (people do not draw exactly facing
/// the camera), jittered like the plane.
fn turn_in_depth<R: Rng>(
    t: &mut Trajectory,
    z: &[f32],
    rng: &mut R,
    strength: f32,
    scale: f32,
    jitter: f32,
) {
    let yaw = rng.gen_range(-0.25..0.25f32) * strength;
    let pitch = rng.gen_range(-0.25..0.25f32) * strength;
    let z0 = z.iter().copied().fold(f32::MAX, f32::min);
    let (cy, sy) = (yaw.cos(), yaw.sin());
    let (cp, sp) = (pitch.cos(), pitch.sin());
    let mut depth = Vec::with_capacity(z.len());
    for (p, &zi) in t.points.iter_mut().zip(z) {
        let zi = (zi - z0) * scale;
        let (x, zi) = (cy * p[0] - sy * zi, sy * p[0] + cy * zi);
        let (y, zi) = (cp * p[1] - sp * zi, sp * p[1] + cp * zi);
        let jz = if jitter > 0.0 {
            rng.gen_range(-jitter..jitter)
        } else {
            0.0
        };
        *p = [x, y];
        depth.push(zi + jz);
    }
    t.depth = Some(depth);
}
