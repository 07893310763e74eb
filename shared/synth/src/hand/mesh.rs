//! Triangles of the procedural hand's capsules, in the hand's frame.

use super::shape::{Capsule, HandShape};
use nalgebra::Vector3;

/// A closed triangle mesh per capsule, every triangle wound counter-clockwise seen
/// from outside its capsule (in the hand's right-handed frame).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct HandMesh {
    pub verts: Vec<Vector3<f32>>,
    pub tris: Vec<[u32; 3]>,
}

/// Points around each ring; rings on each rounded end.
const AROUND: usize = 12;
const CAP_RINGS: usize = 4;

impl HandMesh {
    pub fn of(shape: &HandShape) -> Self {
        let mut m = Self::default();
        for c in &shape.capsules {
            m.capsule(c);
        }
        m
    }

    fn capsule(&mut self, c: &Capsule) {
        let d = c.q - c.p;
        let len = d.norm();
        let u = if len > 1e-6 { d / len } else { Vector3::x() };
        let helper = if u.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = u.cross(&helper).normalize();
        let e2 = u.cross(&e1);
        // (axial position, radius) of each ring, from the pole at p to the pole at q.
        let mut rings = Vec::with_capacity(2 * CAP_RINGS);
        for i in 1..=CAP_RINGS {
            let th = std::f32::consts::FRAC_PI_2 * (1.0 - i as f32 / CAP_RINGS as f32);
            rings.push((-c.rp * th.sin(), c.rp * th.cos()));
        }
        for i in 0..CAP_RINGS {
            let th = std::f32::consts::FRAC_PI_2 * (i as f32 / CAP_RINGS as f32);
            rings.push((len + c.rq * th.sin(), c.rq * th.cos()));
        }
        let base = self.verts.len() as u32;
        for &(s, r) in &rings {
            for k in 0..AROUND {
                let phi = k as f32 / AROUND as f32 * std::f32::consts::TAU;
                self.verts
                    .push(c.p + u * s + (e1 * phi.cos() + e2 * phi.sin()) * r);
            }
        }
        let pole_p = self.verts.len() as u32;
        self.verts.push(c.p - u * c.rp);
        let pole_q = pole_p + 1;
        self.verts.push(c.q + u * c.rq);
        // The point of the axis nearest a triangle is inside the capsule: the
        // triangle's normal must point away from it.
        let inside = |x: &Vector3<f32>| c.p + u * (x - c.p).dot(&u).clamp(0.0, len);
        let n = AROUND as u32;
        let mut push = |verts: &[Vector3<f32>], mut t: [u32; 3]| {
            let [pa, pb, pc] = t.map(|i| verts[i as usize]);
            let normal = (pb - pa).cross(&(pc - pa));
            if normal.norm_squared() < 1e-18 {
                return;
            }
            let centroid = (pa + pb + pc) / 3.0;
            if normal.dot(&(centroid - inside(&centroid))) < 0.0 {
                t.swap(1, 2);
            }
            self.tris.push(t);
        };
        for r in 0..rings.len() as u32 - 1 {
            for k in 0..n {
                let k1 = (k + 1) % n;
                let (i00, i01) = (base + r * n + k, base + r * n + k1);
                let (i10, i11) = (base + (r + 1) * n + k, base + (r + 1) * n + k1);
                push(&self.verts, [i00, i10, i11]);
                push(&self.verts, [i00, i11, i01]);
            }
        }
        let last = base + (rings.len() as u32 - 1) * n;
        for k in 0..n {
            let k1 = (k + 1) % n;
            push(&self.verts, [pole_p, base + k1, base + k]);
            push(&self.verts, [pole_q, last + k, last + k1]);
        }
    }
}
