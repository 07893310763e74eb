//! The seed's descriptor (§16.4): N points of the Bezier curve whose control points are
//! the trajectory, evaluated with de Casteljau; the direction between consecutive points
//! by atan2 over the full circle, quantized into codes of equal angle.

use crate::trajectory::Point;
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
}
