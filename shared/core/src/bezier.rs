//! Points of the Bezier curve whose control points are a trajectory: the seed's gesture
//! descriptor (§16.4) samples it, and the viewer draws the same points over the path the
//! gesture stage followed. Here, beside the other shared geometry, so that both use one
//! computation without one stage depending on another.

/// The Bezier curve with control points `ctrl` at parameter `t` in [0, 1], by de
/// Casteljau's algorithm (stable at any degree, unlike the power basis). `scratch` is
/// reused between calls; the origin for no control point.
pub fn de_casteljau(ctrl: &[[f32; 2]], t: f64, scratch: &mut Vec<[f64; 2]>) -> [f64; 2] {
    scratch.clear();
    scratch.extend(ctrl.iter().map(|p| [p[0] as f64, p[1] as f64]));
    let n = scratch.len();
    if n == 0 {
        return [0.0, 0.0];
    }
    let u = 1.0 - t;
    for r in 1..n {
        for i in 0..n - r {
            let a = scratch[i];
            let b = scratch[i + 1];
            scratch[i] = [u * a[0] + t * b[0], u * a[1] + t * b[1]];
        }
    }
    scratch[0]
}

/// `n` points of the Bezier curve with control points `ctrl`, at equally spaced
/// parameters t = 0, 1/(n−1), …, 1.
pub fn bezier_points(ctrl: &[[f32; 2]], n: usize) -> Vec<[f64; 2]> {
    let mut scratch = Vec::with_capacity(ctrl.len());
    (0..n)
        .map(|i| {
            let t = if n > 1 {
                i as f64 / (n - 1) as f64
            } else {
                0.0
            };
            de_casteljau(ctrl, t, &mut scratch)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn de_casteljau_matches_bernstein_for_a_cubic() {
        let c = [[0.0, 0.0], [1.0, 2.0], [3.0, 3.0], [4.0, 0.0]];
        let mut s = Vec::new();
        for i in 0..=10 {
            let t = i as f64 / 10.0;
            let u = 1.0 - t;
            let w = [u * u * u, 3.0 * u * u * t, 3.0 * u * t * t, t * t * t];
            let x: f64 = (0..4).map(|k| w[k] * c[k][0] as f64).sum();
            let y: f64 = (0..4).map(|k| w[k] * c[k][1] as f64).sum();
            let p = de_casteljau(&c, t, &mut s);
            assert!((p[0] - x).abs() < 1e-12 && (p[1] - y).abs() < 1e-12);
        }
    }

    #[test]
    fn endpoints_are_interpolated_and_high_degree_is_stable() {
        let ctrl: Vec<[f32; 2]> = (0..400)
            .map(|i| {
                let a = i as f32 / 400.0 * std::f32::consts::TAU;
                [1000.0 * a.cos(), 1000.0 * a.sin()]
            })
            .collect();
        let b = bezier_points(&ctrl, 15);
        assert_eq!(b.len(), 15);
        assert!((b[0][0] - 1000.0).abs() < 1e-6);
        assert!((b[14][0] - ctrl[399][0] as f64).abs() < 1e-3);
        assert!(b
            .iter()
            .all(|p| p[0].is_finite() && p[0].abs() <= 1000.0 + 1e-6));
    }

    #[test]
    fn no_control_point_and_no_point_asked_do_not_panic() {
        assert_eq!(bezier_points(&[], 3), vec![[0.0, 0.0]; 3]);
        assert!(bezier_points(&[[1.0, 2.0]], 0).is_empty());
        assert_eq!(bezier_points(&[[1.0, 2.0]], 1), vec![[1.0, 2.0]]);
    }
}
