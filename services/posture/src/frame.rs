//! The hand's own frame from its points: the principal axes of the 3-D points (the
//! longest along the fingers, the shortest out of the palm) and the main axis of the
//! mask in the image, each signed so that the same hand gets the same frame.

use crate::segment::HandRegion;
use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};

/// The hand's principal axes, camera frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandFrame {
    /// The mean of the hand's points.
    pub centroid: Point3<f32>,
    /// The longest axis, signed away from the elbow: along the fingers of a flat hand.
    pub finger_dir: Vector3<f32>,
    /// The shortest axis, signed towards the camera: out of whichever side of the palm
    /// the camera sees (a depth image cannot tell the palm from the back by itself).
    pub palm_normal: Vector3<f32>,
    /// The spread of the points along finger direction, across the palm and along
    /// the normal (square roots of the eigenvalues, metres), largest first.
    pub spread_m: [f32; 3],
    /// The angle of the mask's main axis in the image, radians, signed so that it
    /// points away from the elbow's side (x right, y down).
    pub image_angle: f32,
}

/// The frame of a segmented hand.
pub fn hand_frame(region: &HandRegion) -> HandFrame {
    let pts = region.pixels();
    let n = pts.len().max(1) as f32;
    let centroid = Point3::from(pts.iter().map(|h| h.p.coords).sum::<Vector3<f32>>() / n);
    let mut cov = Matrix3::zeros();
    for h in pts {
        let d = h.p - centroid;
        cov += d * d.transpose();
    }
    cov /= n;
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let axis = |i: usize| eig.eigenvectors.column(order[i]).into_owned();
    let forearm = region.forearm_dir();
    let mut finger_dir = axis(0);
    if finger_dir.dot(&forearm) < 0.0 {
        finger_dir = -finger_dir;
    }
    let mut palm_normal = axis(2);
    if palm_normal.dot(&centroid.coords) > 0.0 {
        palm_normal = -palm_normal;
    }
    let spread_m = [0, 1, 2].map(|i| eig.eigenvalues[order[i]].max(0.0).sqrt());

    // The mask's main axis in the image, from the second moments of its pixels.
    let (mut su, mut sv) = (0.0f64, 0.0f64);
    for h in pts {
        su += h.u as f64;
        sv += h.v as f64;
    }
    let (mu, mv) = (su / n as f64, sv / n as f64);
    let (mut cuu, mut cvv, mut cuv) = (0.0f64, 0.0f64, 0.0f64);
    for h in pts {
        let (du, dv) = (h.u as f64 - mu, h.v as f64 - mv);
        cuu += du * du;
        cvv += dv * dv;
        cuv += du * dv;
    }
    let mut angle = 0.5 * (2.0 * cuv).atan2(cuu - cvv);
    // The forearm's direction seen in the image picks which way the axis points.
    let (fx, fy) = (forearm.x as f64, forearm.y as f64);
    let (ax, ay) = (angle.cos(), angle.sin());
    if ax * fx + ay * fy < 0.0 {
        angle += std::f64::consts::PI;
    }
    HandFrame {
        centroid,
        finger_dir,
        palm_normal,
        spread_m,
        image_angle: angle as f32,
    }
}
