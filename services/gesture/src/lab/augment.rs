//! Writer variation for training: a trajectory a little rotated, sheared, stretched and
//! jittered.

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
    Trajectory {
        points,
        pen_up: t.pen_up.clone(),
    }
}
