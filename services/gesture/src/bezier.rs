//! The seed's descriptor (§16.4): N points of the Bezier curve whose control points are
//! the trajectory, evaluated with de Casteljau; the direction between consecutive points
//! by atan2 over the full circle, quantized into codes of equal angle; for trajectories
//! with depth, the curve in 3-D and its directions quantized on the sphere.

use crate::trajectory::{Point, Trajectory};
use serde::{Deserialize, Serialize};
// The curve's points are shared with the viewer, which draws them: airglyph-core has them.
pub use airglyph_core::bezier::bezier_points;

/// The direction code of the step (dx, dy): atan2 over the full circle [0, 2π), split
/// into `n_dirs` sectors centred on 0, 2π/n_dirs, …  (with 8: 0 = right, 2 = down in
/// y-down coordinates, 4 = left, 6 = up). With `zero_len` > 0 a step shorter than it
/// is the resting code `n_dirs`.
pub fn direction_code(dx: f64, dy: f64, n_dirs: usize, zero_len: f64) -> usize {
    if zero_len > 0.0 && (dx * dx + dy * dy).sqrt() < zero_len {
        return n_dirs;
    }
    let mut a = dy.atan2(dx);
    if a < 0.0 {
        a += std::f64::consts::TAU;
    }
    let sector = std::f64::consts::TAU / n_dirs as f64;
    (((a + sector / 2.0) / sector).floor() as usize) % n_dirs
}

/// The seed's observation sequence: `n_points` Bezier points, then the 8-direction code
/// of each of the `n_points − 1` steps. `zero_frac` > 0 adds the resting code 8 for
/// steps shorter than that fraction of the trajectory's bounding-box diagonal.
pub fn bezier_codes(points: &[Point], n_points: usize, zero_frac: f64) -> Vec<usize> {
    let bz = bezier_points(points, n_points.max(2));
    let zero_len = if zero_frac > 0.0 {
        zero_frac * diagonal(points)
    } else {
        0.0
    };
    bz.windows(2)
        .map(|w| direction_code(w[1][0] - w[0][0], w[1][1] - w[0][1], 8, zero_len))
        .collect()
}

/// The directions the seed's codes name: 8 sectors of the circle in the body's frontal
/// plane, or 26 directions on the sphere for trajectories with depth.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Directions {
    /// 8 sectors of 45° in the x/y plane (the seed's; depth is not read).
    #[default]
    Circle8,
    /// The 26 directions from a cube's centre to its faces, edges and corners. The 8
    /// among them in the x/y plane are the circle's, so a flat trajectory gets the
    /// codes it gets on the circle (numbered otherwise), and a push towards the camera
    /// is a code of its own instead of a resting hand.
    Sphere26,
}

impl Directions {
    /// How many direction codes there are (the resting code is one more).
    pub fn count(self) -> usize {
        match self {
            Directions::Circle8 => 8,
            Directions::Sphere26 => 26,
        }
    }

    /// Whether it is the seed's circle (model files leave it out then).
    pub fn is_circle(&self) -> bool {
        *self == Directions::Circle8
    }
}

/// The 26 unit directions of [`Directions::Sphere26`], in code order.
fn sphere26() -> &'static [[f64; 3]; 26] {
    static DIRS: std::sync::OnceLock<[[f64; 3]; 26]> = std::sync::OnceLock::new();
    DIRS.get_or_init(|| {
        let mut out = [[0.0; 3]; 26];
        let mut k = 0;
        for x in -1i32..=1 {
            for y in -1i32..=1 {
                for z in -1i32..=1 {
                    if (x, y, z) == (0, 0, 0) {
                        continue;
                    }
                    let n = ((x * x + y * y + z * z) as f64).sqrt();
                    out[k] = [x as f64 / n, y as f64 / n, z as f64 / n];
                    k += 1;
                }
            }
        }
        out
    })
}

/// The code of the 3-D step `d`: the nearest of the 26 directions on the sphere (the
/// largest cosine). With `zero_len` > 0 a step shorter than it is the resting code 26.
pub fn sphere_code(d: [f64; 3], zero_len: f64) -> usize {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if zero_len > 0.0 && len < zero_len {
        return 26;
    }
    let mut best = (0, f64::NEG_INFINITY);
    for (k, u) in sphere26().iter().enumerate() {
        let c = u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
        if c > best.1 {
            best = (k, c);
        }
    }
    best.0
}

/// The seed's observation sequence of a trajectory with the directions `dirs`: on the
/// circle exactly [`bezier_codes`] of its 2-D points; on the sphere the Bezier curve of
/// its 3-D points (z = 0 without depth), each step's code on the sphere, and the
/// resting code 26 for steps shorter than `zero_frac` of its 3-D bounding box diagonal.
pub fn trajectory_codes(
    t: &Trajectory,
    n_points: usize,
    zero_frac: f64,
    dirs: Directions,
) -> Vec<usize> {
    match dirs {
        Directions::Circle8 => bezier_codes(&t.points, n_points, zero_frac),
        Directions::Sphere26 => {
            let n = n_points.max(2);
            let xy = bezier_points(&t.points, n);
            // De Casteljau works a coordinate at a time: z's curve is that of (z, 0).
            let zs: Vec<Point> = t.points3().iter().map(|p| [p[2], 0.0]).collect();
            let z = bezier_points(&zs, n);
            let zero_len = if zero_frac > 0.0 {
                zero_frac * diagonal3(&t.points3())
            } else {
                0.0
            };
            (1..n)
                .map(|i| {
                    let d = [
                        xy[i][0] - xy[i - 1][0],
                        xy[i][1] - xy[i - 1][1],
                        z[i][0] - z[i - 1][0],
                    ];
                    sphere_code(d, zero_len)
                })
                .collect()
        }
    }
}

fn diagonal3(points: &[[f32; 3]]) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] as f64);
            hi[k] = hi[k].max(p[k] as f64);
        }
    }
    (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt()
}

fn diagonal(points: &[Point]) -> f64 {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in points {
        x0 = x0.min(p[0] as f64);
        y0 = y0.min(p[1] as f64);
        x1 = x1.max(p[0] as f64);
        y1 = y1.max(p[1] as f64);
    }
    if points.is_empty() {
        0.0
    } else {
        ((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_cover_the_full_circle() {
        assert_eq!(direction_code(1.0, 0.0, 8, 0.0), 0);
        assert_eq!(direction_code(1.0, 1.0, 8, 0.0), 1);
        assert_eq!(direction_code(0.0, 1.0, 8, 0.0), 2);
        assert_eq!(direction_code(-1.0, 0.0, 8, 0.0), 4);
        assert_eq!(direction_code(0.0, -1.0, 8, 0.0), 6);
        assert_eq!(direction_code(1.0, -0.1, 8, 0.0), 0);
        assert_eq!(direction_code(0.001, 0.0, 8, 0.01), 8);
    }

    #[test]
    fn seed_descriptor_of_a_line_and_lengths() {
        let line: Vec<Point> = (0..20).map(|i| [0.0, i as f32]).collect();
        for n in [5, 10, 15, 20, 30] {
            let c = bezier_codes(&line, n, 0.0);
            assert_eq!(c.len(), n - 1);
            assert!(c.iter().all(|&k| k == 2), "{c:?}");
        }
    }

    #[test]
    fn the_circle_keeps_the_seed_codes_and_the_sphere_names_depth() {
        let zig: Vec<Point> = (0..30)
            .map(|i| [i as f32, if i % 10 < 5 { i % 5 } else { 5 - i % 5 } as f32])
            .collect();
        let flat = Trajectory::from_points(zig.clone());
        assert_eq!(
            trajectory_codes(&flat, 15, 0.0, Directions::Circle8),
            bezier_codes(&zig, 15, 0.0)
        );
        // Depth is not read on the circle.
        let deep = flat.clone().with_depth((0..30).map(|i| i as f32).collect());
        assert_eq!(
            trajectory_codes(&deep, 15, 0.0, Directions::Circle8),
            bezier_codes(&zig, 15, 0.0)
        );
        // On the sphere a flat path's codes map one to one onto the circle's.
        let circle = trajectory_codes(&flat, 15, 0.0, Directions::Sphere26);
        let seed = bezier_codes(&zig, 15, 0.0);
        let mut map = std::collections::BTreeMap::new();
        for (s, c) in seed.iter().zip(&circle) {
            assert_eq!(*map.entry(*s).or_insert(*c), *c, "{seed:?} {circle:?}");
        }
        // A push towards the camera and a pull away: two codes, neither a plane's.
        let push =
            Trajectory::from_points3(&(0..10).map(|i| [0.0, 0.0, i as f32]).collect::<Vec<_>>());
        let pull =
            Trajectory::from_points3(&(0..10).map(|i| [0.0, 0.0, -i as f32]).collect::<Vec<_>>());
        let (a, b) = (
            trajectory_codes(&push, 5, 0.0, Directions::Sphere26),
            trajectory_codes(&pull, 5, 0.0, Directions::Sphere26),
        );
        assert!(a.iter().all(|&k| k == a[0]) && b.iter().all(|&k| k == b[0]));
        assert_ne!(a[0], b[0]);
        assert!(!circle.contains(&a[0]) && !circle.contains(&b[0]));
        assert_eq!(sphere_code([0.0, 0.0, 1e-9], 1e-3), 26);
    }
}
