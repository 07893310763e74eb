//! Closed-form geometry: Horn's quaternion solution for rotations and rigid motions,
//! and principal component analysis of a point set.

use nalgebra::{Matrix3, Matrix4, Point3, Rotation3, SymmetricEigen, UnitQuaternion, Vector3};

/// A rigid motion `x ↦ R x + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rigid {
    /// The rotation.
    pub r: Rotation3<f32>,
    /// The translation, applied after the rotation.
    pub t: Vector3<f32>,
}

impl Default for Rigid {
    fn default() -> Self {
        Self {
            r: Rotation3::identity(),
            t: Vector3::zeros(),
        }
    }
}

impl Rigid {
    #[inline]
    /// The motion applied to a point.
    pub fn apply(&self, p: &Point3<f32>) -> Point3<f32> {
        self.r * p + self.t
    }

    #[inline]
    /// The motion applied to a direction (the rotation alone).
    pub fn apply_vec(&self, v: &Vector3<f32>) -> Vector3<f32> {
        self.r * v
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Rigid) -> Rigid {
        Rigid {
            r: self.r * other.r,
            t: self.r * other.t + self.t,
        }
    }

    /// The motion that undoes this one.
    pub fn inverse(&self) -> Rigid {
        let ri = self.r.inverse();
        Rigid {
            r: ri,
            t: -(ri * self.t),
        }
    }

    /// Whether every number is finite.
    pub fn is_finite(&self) -> bool {
        self.r.matrix().iter().all(|c| c.is_finite()) && self.t.iter().all(|c| c.is_finite())
    }
}

/// The rotation `R` minimising `Σ wᵢ ‖R aᵢ − bᵢ‖²` (Horn 1987, unit quaternions): the
/// eigenvector of the largest eigenvalue of Horn's symmetric 4×4 matrix built from the
/// weighted cross-covariance `Σ wᵢ aᵢ bᵢᵀ`. Identity when the data say nothing.
pub fn horn_rotation_from_covariance(s: &Matrix3<f64>) -> Rotation3<f32> {
    let (sxx, sxy, sxz) = (s[(0, 0)], s[(0, 1)], s[(0, 2)]);
    let (syx, syy, syz) = (s[(1, 0)], s[(1, 1)], s[(1, 2)]);
    let (szx, szy, szz) = (s[(2, 0)], s[(2, 1)], s[(2, 2)]);
    let n = Matrix4::new(
        sxx + syy + szz,
        syz - szy,
        szx - sxz,
        sxy - syx,
        syz - szy,
        sxx - syy - szz,
        sxy + syx,
        szx + sxz,
        szx - sxz,
        sxy + syx,
        -sxx + syy - szz,
        syz + szy,
        sxy - syx,
        szx + sxz,
        syz + szy,
        -sxx - syy + szz,
    );
    if !n.iter().all(|c| c.is_finite()) || n.norm() < 1e-18 {
        return Rotation3::identity();
    }
    let eig = SymmetricEigen::new(n);
    let mut best = 0;
    for i in 1..4 {
        if eig.eigenvalues[i] > eig.eigenvalues[best] {
            best = i;
        }
    }
    let q = eig.eigenvectors.column(best);
    let quat = nalgebra::Quaternion::new(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32);
    if !quat.coords.iter().all(|c| c.is_finite()) || quat.norm() < 1e-6 {
        return Rotation3::identity();
    }
    UnitQuaternion::from_quaternion(quat).to_rotation_matrix()
}

/// Accumulates weighted vector pairs for [`horn_rotation_from_covariance`].
#[derive(Debug, Clone, Default)]
pub struct RotationAccumulator {
    s: Matrix3<f64>,
    w: f64,
}

impl RotationAccumulator {
    #[inline]
    pub fn add(&mut self, a: &Vector3<f32>, b: &Vector3<f32>, w: f32) {
        let a = a.cast::<f64>();
        let b = b.cast::<f64>();
        self.s += (a * b.transpose()) * w as f64;
        self.w += w as f64;
    }

    pub fn weight(&self) -> f64 {
        self.w
    }

    pub fn rotation(&self) -> Rotation3<f32> {
        if self.w <= 0.0 {
            return Rotation3::identity();
        }
        horn_rotation_from_covariance(&self.s)
    }
}

/// The rotation about the origin taking the weighted vectors `a` onto `b`.
#[cfg(test)]
pub fn weighted_rotation(a: &[Vector3<f32>], b: &[Vector3<f32>], w: &[f32]) -> Rotation3<f32> {
    let mut acc = RotationAccumulator::default();
    for ((a, b), &w) in a.iter().zip(b).zip(w) {
        acc.add(a, b, w);
    }
    acc.rotation()
}

/// The rigid motion minimising `Σ ‖R aᵢ + t − bᵢ‖²` over point pairs (Horn's closed form:
/// centroids, then the quaternion of the centred cross-covariance).
pub fn horn_rigid(a: &[Point3<f32>], b: &[Point3<f32>]) -> Rigid {
    let n = a.len().min(b.len());
    if n == 0 {
        return Rigid::default();
    }
    let mut ca = Vector3::<f64>::zeros();
    let mut cb = Vector3::<f64>::zeros();
    for i in 0..n {
        ca += a[i].coords.cast::<f64>();
        cb += b[i].coords.cast::<f64>();
    }
    ca /= n as f64;
    cb /= n as f64;
    let mut s = Matrix3::<f64>::zeros();
    for i in 0..n {
        let da = a[i].coords.cast::<f64>() - ca;
        let db = b[i].coords.cast::<f64>() - cb;
        s += da * db.transpose();
    }
    let r = horn_rotation_from_covariance(&s);
    let t = cb.cast::<f32>() - r * ca.cast::<f32>();
    Rigid { r, t }
}

/// Mean and principal axes of a point set: `axes` columns sorted by decreasing variance,
/// `std` the standard deviation along each.
#[derive(Debug, Clone, Copy)]
pub struct Pca {
    pub mean: Point3<f32>,
    pub axes: Matrix3<f32>,
    pub std: Vector3<f32>,
}

/// Streaming moments of a point set for [`Pca`].
#[derive(Debug, Clone, Default)]
pub struct Moments {
    pub n: f64,
    s: Vector3<f64>,
    ss: Matrix3<f64>,
}

impl Moments {
    #[inline]
    pub fn add(&mut self, p: &Point3<f32>) {
        let v = p.coords.cast::<f64>();
        self.n += 1.0;
        self.s += v;
        self.ss += v * v.transpose();
    }

    pub fn mean(&self) -> Point3<f32> {
        if self.n <= 0.0 {
            return Point3::origin();
        }
        Point3::from((self.s / self.n).cast::<f32>())
    }

    pub fn pca(&self) -> Option<Pca> {
        if self.n < 3.0 {
            return None;
        }
        let m = self.s / self.n;
        let cov = self.ss / self.n - m * m.transpose();
        if !cov.iter().all(|c| c.is_finite()) {
            return None;
        }
        let eig = SymmetricEigen::new(cov);
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let mut axes = Matrix3::<f32>::zeros();
        let mut std = Vector3::<f32>::zeros();
        for (k, &i) in idx.iter().enumerate() {
            let col: Vector3<f64> = eig.eigenvectors.column(i).into_owned();
            axes.set_column(k, &col.cast::<f32>());
            std[k] = eig.eigenvalues[i].max(0.0).sqrt() as f32;
        }
        Some(Pca {
            mean: Point3::from(m.cast::<f32>()),
            axes,
            std,
        })
    }
}

/// The closest point to `p` on the segment `a`–`b`.
#[inline]
pub fn closest_on_segment(p: &Point3<f32>, a: &Point3<f32>, b: &Point3<f32>) -> Point3<f32> {
    let ab = b - a;
    let l2 = ab.norm_squared();
    if l2 < 1e-12 {
        return *a;
    }
    let t = ((p - a).dot(&ab) / l2).clamp(0.0, 1.0);
    a + ab * t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot(axis: Vector3<f32>, angle: f32) -> Rotation3<f32> {
        Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle)
    }

    #[test]
    fn horn_recovers_a_known_rigid_motion() {
        let r = rot(Vector3::new(0.3, -1.0, 0.5), 0.9);
        let t = Vector3::new(0.1, -0.4, 2.0);
        let a: Vec<Point3<f32>> = (0..20)
            .map(|i| {
                let f = i as f32;
                Point3::new((f * 0.37).sin(), (f * 0.91).cos(), f * 0.05 - 0.5)
            })
            .collect();
        let b: Vec<Point3<f32>> = a.iter().map(|p| r * p + t).collect();
        let m = horn_rigid(&a, &b);
        assert!((m.r.matrix() - r.matrix()).norm() < 1e-4);
        assert!((m.t - t).norm() < 1e-4);
        for (p, q) in a.iter().zip(&b) {
            assert!((m.apply(p) - q).norm() < 1e-4);
        }
    }

    #[test]
    fn weighted_rotation_follows_the_heavy_pairs() {
        let r = rot(Vector3::z(), 0.5);
        let a = vec![Vector3::x(), Vector3::y(), Vector3::new(1.0, 1.0, 0.0)];
        let mut b: Vec<_> = a.iter().map(|v| r * v).collect();
        // A light outlier hardly moves the answer.
        b[2] = rot(Vector3::z(), -1.0) * a[2];
        let got = weighted_rotation(&a, &b, &[1.0, 1.0, 0.01]);
        assert!(got.angle_to(&r) < 0.02, "{}", got.angle_to(&r));
    }

    #[test]
    fn empty_input_gives_identity() {
        assert_eq!(weighted_rotation(&[], &[], &[]), Rotation3::identity());
        let m = horn_rigid(&[], &[]);
        assert!(m.is_finite());
    }

    #[test]
    fn pca_finds_the_long_axis() {
        let mut m = Moments::default();
        for i in 0..100 {
            let f = i as f32 / 100.0;
            m.add(&Point3::new(
                0.1 * (f * 31.0).sin(),
                2.0 * f,
                0.01 * (f * 17.0).cos(),
            ));
        }
        let p = m.pca().unwrap();
        assert!(p.axes.column(0).y.abs() > 0.99);
        assert!(p.axes.column(2).z.abs() > 0.9);
        assert!(p.std[0] > p.std[1] && p.std[1] > p.std[2]);
    }
}
