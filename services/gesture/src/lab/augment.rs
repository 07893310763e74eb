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

/// The depth gain's range, as a log: 0.6 to 1.65 times at full strength.
const DEPTH_GAIN_LN: f32 = 0.5;

/// Depth for the augmented points: `z` scaled like the plane and then by a gain of its
/// own, the whole turned a little about the vertical axis and the horizontal one (people
/// do not draw exactly facing the camera), jittered like the plane.
///
/// The gain: people misjudge depth in the air far more than width, and one puts into a
/// push or a helix a fraction of the depth another does; a vocabulary learnt from a few
/// people has seen only their fractions.
fn turn_in_depth<R: Rng>(
    t: &mut Trajectory,
    z: &[f32],
    rng: &mut R,
    strength: f32,
    scale: f32,
    jitter: f32,
) {
    let yaw = rng.gen_range(-0.4..0.4f32) * strength;
    let pitch = rng.gen_range(-0.4..0.4f32) * strength;
    let gain = (rng.gen_range(-DEPTH_GAIN_LN..DEPTH_GAIN_LN) * strength).exp();
    let z0 = z.iter().copied().fold(f32::MAX, f32::min);
    let (cy, sy) = (yaw.cos(), yaw.sin());
    let (cp, sp) = (pitch.cos(), pitch.sin());
    let mut depth = Vec::with_capacity(z.len());
    for (p, &zi) in t.points.iter_mut().zip(z) {
        let zi = (zi - z0) * scale * gain;
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A push drawn by one person is as deep as that person pushes; the copies the
    /// networks learn from push shallower and deeper.
    #[test]
    fn copies_of_a_push_differ_in_how_deep_they_push() {
        let n = 20;
        let push = Trajectory {
            points: vec![[0.0, 0.0]; n],
            pen_up: vec![false; n],
            depth: Some((0..n).map(|i| i as f32 / (n - 1) as f32).collect()),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // How long each copy's push is: turning keeps the length, the plane's scale
        // moves it by a fifth at most, the depth's own gain by more.
        let lengths: Vec<f32> = (0..300)
            .map(|_| {
                let t = augment(&push, &mut rng, 1.0);
                let z = t.depth.as_ref().unwrap();
                let (a, b) = (t.points[0], t.points[n - 1]);
                let d = [b[0] - a[0], b[1] - a[1], z[n - 1] - z[0]];
                d.iter().map(|x| x * x).sum::<f32>().sqrt()
            })
            .collect();
        let lo = lengths.iter().copied().fold(f32::MAX, f32::min);
        let hi = lengths.iter().copied().fold(f32::MIN, f32::max);
        assert!(lo < 0.7 && hi > 1.4, "{lo} {hi}");
        // 2-D data draws no depth.
        let flat = Trajectory {
            depth: None,
            ..push
        };
        assert!(augment(&flat, &mut rng, 1.0).depth.is_none());
    }
}
