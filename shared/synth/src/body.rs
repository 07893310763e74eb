//! Bodies: a triangle mesh in its rest pose, a rig of bones, skin weights (linear blend
//! skinning, up to 4 bones a vertex) and the ground-truth joints attached to bones.
//!
//! Two bodies exist: [`Body::procedural`], built from ellipsoids and tapered capsules
//! with no external file, and MakeHuman's ([`crate::makehuman::load`]).

use crate::canon::{shortest_arc, Bone, Pose, TposeSkeleton};
use crate::error::SynthError;
use airglyph_core::Joint;
use nalgebra::{Matrix3, Point3, UnitQuaternion, Vector3};

/// The parameters of the built-in procedural person.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProceduralBody {
    /// Standing height in metres (1.2 – 2.2).
    pub height_m: f32,
    /// Girth relative to an average adult: 0.8 slim, 1.0 average, 1.3 heavy (0.6 – 1.6).
    pub build: f32,
}

impl Default for ProceduralBody {
    fn default() -> Self {
        Self {
            height_m: 1.75,
            build: 1.0,
        }
    }
}

/// One bone of a body's own rig. Rest positions are in the body frame (see `canon.rs`).
#[derive(Debug, Clone, PartialEq)]
pub struct RigBone {
    /// The bone's name in the rig's file.
    pub name: String,
    /// Index of the parent; parents always come before their children.
    pub parent: Option<usize>,
    /// Where the bone starts at rest.
    pub head: Point3<f32>,
    /// Where the bone ends at rest.
    pub tail: Point3<f32>,
    /// The canonical bone that drives this one; `None` follows its parent rigidly.
    pub canon: Option<Bone>,
    /// Rotation from this bone's rest direction to its canonical T-pose direction.
    pub align: UnitQuaternion<f32>,
}

/// An affine bone transform: x ↦ m·x + t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// The linear part.
    pub m: Matrix3<f32>,
    /// The translation.
    pub t: Vector3<f32>,
}

impl Affine {
    /// The transform that moves nothing.
    pub const IDENTITY: Affine = Affine {
        m: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        t: Vector3::new(0.0, 0.0, 0.0),
    };

    /// `m·p + t`.
    #[inline]
    pub fn apply(&self, p: &Point3<f32>) -> Point3<f32> {
        Point3::from(self.m * p.coords + self.t)
    }

    /// `self ∘ other`.
    pub fn then(&self, other: &Affine) -> Affine {
        Affine {
            m: other.m * self.m,
            t: other.m * self.t + other.t,
        }
    }
}

/// A skinned body ready to be posed.
#[derive(Debug, Clone)]
pub struct Body {
    pub(crate) name: String,
    pub(crate) verts: Vec<Point3<f32>>,
    pub(crate) tris: Vec<[u32; 3]>,
    /// The canonical bone each triangle belongs to (for occlusion labels).
    pub(crate) tri_label: Vec<u8>,
    /// Up to 4 (rig bone, weight) a vertex; unused slots have weight 0.
    pub(crate) weights: Vec<[(u16, f32); 4]>,
    pub(crate) bones: Vec<RigBone>,
    /// Ground-truth joints: (rig bone, rest position).
    pub(crate) joints: [(usize, Point3<f32>); Joint::COUNT],
    pub(crate) tpose: TposeSkeleton,
}

impl Body {
    /// The body's name, as scenes and recordings name it.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Vertices of its mesh.
    pub fn vertex_count(&self) -> usize {
        self.verts.len()
    }

    /// Triangles of its mesh.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Its rig, parents before children.
    pub fn bones(&self) -> &[RigBone] {
        &self.bones
    }

    /// Its mesh's vertices at rest (body frame: metres, y up, floor y = 0).
    pub fn rest_vertices(&self) -> &[Point3<f32>] {
        &self.verts
    }

    /// Its ground-truth joints at rest, in [`Joint::ALL`]'s order (body frame).
    pub fn rest_joints(&self) -> [Point3<f32>; Joint::COUNT] {
        self.joints.map(|(_, p)| p)
    }

    /// The canonical skeleton of this body in the T-pose (lengths for motion scripts).
    pub fn tpose(&self) -> &TposeSkeleton {
        &self.tpose
    }

    /// Per rig bone, the transform from rest to `pose` (body frame).
    pub fn bone_transforms(&self, pose: &Pose, out: &mut Vec<Affine>) {
        out.clear();
        let mut rots: Vec<UnitQuaternion<f32>> = Vec::with_capacity(self.bones.len());
        let mut heads: Vec<Point3<f32>> = Vec::with_capacity(self.bones.len());
        for b in &self.bones {
            let parent_rot = b
                .parent
                .map(|p| rots[p])
                .unwrap_or_else(UnitQuaternion::identity);
            let rot = match b.canon {
                Some(c) => pose.get(c) * b.align,
                None => parent_rot,
            };
            let head = match b.parent {
                Some(p) => heads[p] + parent_rot * (b.head - self.bones[p].head),
                None => pose.root + rot * (b.head - self.tpose_root_rest()),
            };
            let m = *rot.to_rotation_matrix().matrix();
            out.push(Affine {
                m,
                t: head.coords - m * b.head.coords,
            });
            rots.push(rot);
            heads.push(head);
        }
    }

    /// The rest position of the canonical hips joint (the root's head).
    fn tpose_root_rest(&self) -> Point3<f32> {
        self.bones[0].head
    }

    /// Ground-truth joints under the given bone transforms.
    pub fn joints_from(&self, xf: &[Affine]) -> [Point3<f32>; Joint::COUNT] {
        let mut out = [Point3::origin(); Joint::COUNT];
        for (o, (b, p)) in out.iter_mut().zip(self.joints.iter()) {
            *o = xf[*b].apply(p);
        }
        out
    }

    /// Linear blend skinning of every vertex into `out`.
    pub fn skin(&self, xf: &[Affine], out: &mut Vec<Point3<f32>>) {
        out.clear();
        out.reserve(self.verts.len());
        for (v, w) in self.verts.iter().zip(self.weights.iter()) {
            let mut acc = Vector3::zeros();
            for &(b, wt) in w {
                if wt != 0.0 {
                    let a = &xf[b as usize];
                    acc += (a.m * v.coords + a.t) * wt;
                }
            }
            out.push(Point3::from(acc));
        }
    }

    /// Builds the bookkeeping shared by every body: checks the rig, computes the
    /// canonical alignment of each mapped bone and the T-pose skeleton.
    pub(crate) fn finish(
        name: String,
        verts: Vec<Point3<f32>>,
        tris: Vec<[u32; 3]>,
        weights: Vec<[(u16, f32); 4]>,
        mut bones: Vec<RigBone>,
        joints: [(usize, Point3<f32>); Joint::COUNT],
        skull: (usize, Point3<f32>),
    ) -> Result<Body, SynthError> {
        for c in Bone::ALL {
            let n = bones.iter().filter(|b| b.canon == Some(c)).count();
            if n != 1 {
                return Err(SynthError::Config(format!(
                    "rig must drive canonical bone {} from exactly one bone, found {n}",
                    c.name()
                )));
            }
        }
        if bones.first().and_then(|b| b.canon) != Some(Bone::Hips) || bones[0].parent.is_some() {
            return Err(SynthError::Config(
                "the rig's first bone must be the root, driven by the hips".into(),
            ));
        }
        for (i, b) in bones.iter().enumerate() {
            if b.parent.is_some_and(|p| p >= i) {
                return Err(SynthError::Config(format!(
                    "rig bone {} comes before its parent",
                    b.name
                )));
            }
        }
        for b in &mut bones {
            if let Some(c) = b.canon {
                let dir = b.tail - b.head;
                b.align = if dir.norm() > 1e-6 {
                    shortest_arc(&dir, &c.tpose_dir())
                } else {
                    UnitQuaternion::identity()
                };
            }
        }
        let mut body = Body {
            name,
            verts,
            tris,
            tri_label: Vec::new(),
            weights,
            bones,
            joints,
            tpose: TposeSkeleton {
                head: [Point3::origin(); Bone::COUNT],
                tail: [Point3::origin(); Bone::COUNT],
                joints: [Point3::origin(); Joint::COUNT],
                skull: Point3::origin(),
            },
        };
        // The T-pose: every canonical rotation identity.
        let root = body.bones[0].head;
        let mut xf = Vec::new();
        body.bone_transforms(&Pose::tpose(root), &mut xf);
        for (i, b) in body.bones.iter().enumerate() {
            if let Some(c) = b.canon {
                body.tpose.head[c.index()] = xf[i].apply(&b.head);
                body.tpose.tail[c.index()] = xf[i].apply(&b.tail);
            }
        }
        for c in Bone::ALL {
            if let Some(ch) = c.child() {
                body.tpose.tail[c.index()] = body.tpose.head[ch.index()];
            }
        }
        body.tpose.joints = body.joints_from(&xf);
        body.tpose.skull = xf[skull.0].apply(&skull.1);
        // Labels: each triangle takes the canonical bone of its first vertex's heaviest
        // influence (or of that bone's nearest driven ancestor).
        let canon_of: Vec<u8> = (0..body.bones.len())
            .map(|mut i| loop {
                if let Some(c) = body.bones[i].canon {
                    break c as u8;
                }
                match body.bones[i].parent {
                    Some(p) => i = p,
                    None => break 0,
                }
            })
            .collect();
        body.tri_label = body
            .tris
            .iter()
            .map(|t| {
                let w = &body.weights[t[0] as usize];
                let best = w
                    .iter()
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .map(|x| x.0)
                    .unwrap_or(0);
                canon_of[best as usize]
            })
            .collect();
        Ok(body)
    }

    /// The built-in procedural person: ellipsoids and tapered capsules rigidly bound to
    /// the 19 canonical bones (single-bone skinning), proportioned after standard
    /// anthropometric tables (segment lengths as fractions of height).
    pub fn procedural(p: &ProceduralBody) -> Result<Body, SynthError> {
        if !(p.height_m.is_finite() && (1.2..=2.2).contains(&p.height_m)) {
            return Err(SynthError::Config(format!(
                "procedural body height {} m must be between 1.2 and 2.2",
                p.height_m
            )));
        }
        if !(p.build.is_finite() && (0.6..=1.6).contains(&p.build)) {
            return Err(SynthError::Config(format!(
                "procedural body build {} must be between 0.6 and 1.6",
                p.build
            )));
        }
        build_procedural(p)
    }
}

struct MeshBuilder {
    verts: Vec<Point3<f32>>,
    tris: Vec<[u32; 3]>,
    bone: Vec<u16>,
}

impl MeshBuilder {
    /// Adds triangles oriented so their normal points away from `centre_of(tri)`.
    fn push_tri(&mut self, mut t: [u32; 3], inside: impl Fn(&Point3<f32>) -> Point3<f32>) {
        let a = self.verts[t[0] as usize];
        let b = self.verts[t[1] as usize];
        let c = self.verts[t[2] as usize];
        let n = (b - a).cross(&(c - a));
        if n.norm_squared() < 1e-14 {
            return;
        }
        let centroid = Point3::from((a.coords + b.coords + c.coords) / 3.0);
        if n.dot(&(centroid - inside(&centroid))) < 0.0 {
            t.swap(1, 2);
        }
        self.tris.push(t);
    }

    /// A triangulated surface of revolution: `rings` of (axial position, radius) around
    /// `axis` starting at `origin`, closed by a pole at each end.
    #[allow(clippy::too_many_arguments)]
    fn revolve(
        &mut self,
        origin: Point3<f32>,
        axis: Vector3<f32>,
        ref_dir: Vector3<f32>,
        scale_ref: f32,
        rings: &[(f32, f32)],
        poles: (f32, f32),
        around: usize,
        bone: Bone,
    ) {
        let ax = axis.normalize();
        let e1 = (ref_dir - ax * ax.dot(&ref_dir)).normalize();
        let e2 = ax.cross(&e1);
        let base = self.verts.len() as u32;
        let b = bone as u16;
        for &(a, r) in rings {
            for k in 0..around {
                let phi = k as f32 / around as f32 * std::f32::consts::TAU;
                let p = origin + ax * a + e1 * (r * scale_ref * phi.cos()) + e2 * (r * phi.sin());
                self.verts.push(p);
                self.bone.push(b);
            }
        }
        let pole0 = self.verts.len() as u32;
        self.verts.push(origin + ax * poles.0);
        self.bone.push(b);
        let pole1 = self.verts.len() as u32;
        self.verts.push(origin + ax * poles.1);
        self.bone.push(b);
        let inside = |p: &Point3<f32>| {
            let s = (p - origin).dot(&ax).clamp(poles.0, poles.1);
            origin + ax * s
        };
        let n = around as u32;
        for r in 0..rings.len() as u32 - 1 {
            for k in 0..n {
                let k1 = (k + 1) % n;
                let i00 = base + r * n + k;
                let i01 = base + r * n + k1;
                let i10 = base + (r + 1) * n + k;
                let i11 = base + (r + 1) * n + k1;
                self.push_tri([i00, i10, i11], inside);
                self.push_tri([i00, i11, i01], inside);
            }
        }
        let last = base + (rings.len() as u32 - 1) * n;
        for k in 0..n {
            let k1 = (k + 1) % n;
            self.push_tri([pole0, base + k1, base + k], inside);
            self.push_tri([pole1, last + k, last + k1], inside);
        }
    }

    /// An axis-aligned ellipsoid (semi-axes along x, y, z of the body frame), revolved
    /// about `axis_dim` (0 = x, 1 = y, 2 = z).
    fn ellipsoid(&mut self, c: Point3<f32>, semi: Vector3<f32>, axis_dim: usize, bone: Bone) {
        let (ax, rd, rl, r1, r2) = match axis_dim {
            0 => (Vector3::x(), Vector3::y(), semi.x, semi.y, semi.z),
            1 => (Vector3::y(), Vector3::z(), semi.y, semi.z, semi.x),
            _ => (Vector3::z(), Vector3::x(), semi.z, semi.x, semi.y),
        };
        // ring radius along e2 is r2; along e1 (ref dir) it is r1 = r2 * (r1/r2)
        let nv = 14;
        let rings: Vec<(f32, f32)> = (1..nv)
            .map(|i| {
                let th = i as f32 / nv as f32 * std::f32::consts::PI;
                (-rl * th.cos(), r2 * th.sin())
            })
            .collect();
        self.revolve(c, ax, rd, r1 / r2, &rings, (-rl, rl), 24, bone);
    }

    /// A tapered capsule from `a` (radius `ra`) to `b` (radius `rb`) with round ends.
    fn capsule(&mut self, a: Point3<f32>, b: Point3<f32>, ra: f32, rb: f32, bone: Bone) {
        let d = b - a;
        let len = d.norm();
        let ax = d / len;
        let rd = if ax.y.abs() < 0.9 {
            Vector3::y()
        } else {
            Vector3::z()
        };
        let cap = 5;
        let mut rings = Vec::new();
        for i in 1..=cap {
            let th = std::f32::consts::FRAC_PI_2 * (1.0 - i as f32 / cap as f32);
            rings.push((-ra * th.sin(), ra * th.cos()));
        }
        for i in 1..4 {
            let t = i as f32 / 4.0;
            rings.push((len * t, ra + (rb - ra) * t));
        }
        for i in 0..cap {
            let th = std::f32::consts::FRAC_PI_2 * (i as f32 / cap as f32);
            rings.push((len + rb * th.sin(), rb * th.cos()));
        }
        rings.retain(|r| r.1 > 1e-5);
        self.revolve(a, ax, rd, 1.0, &rings, (-ra, len + rb), 16, bone);
    }
}

fn build_procedural(p: &ProceduralBody) -> Result<Body, SynthError> {
    let h = p.height_m;
    let g = p.build;
    let pt = |x: f32, y: f32, z: f32| Point3::new(x * h, y * h, z * h);
    // Joint centres as fractions of height (Drillis & Contini style tables).
    let hip_y = 0.52;
    let hip_x = 0.052;
    let knee_y = 0.285;
    let ankle_y = 0.042;
    let sh_y = 0.805;
    let sh_x = 0.105;
    let (ua, fa, hand) = (0.172, 0.150, 0.108);
    let hips = pt(0.0, hip_y, 0.0);
    let spine = pt(0.0, 0.60, -0.004);
    let chest = pt(0.0, 0.69, -0.004);
    let neck = pt(0.0, 0.815, -0.006);
    let headj = pt(0.0, 0.872, 0.0);
    let head_top = pt(0.0, 1.0, 0.0);
    let collar = |s: f32| pt(s * 0.018, 0.80, 0.004);
    let shoulder = |s: f32| pt(s * sh_x, sh_y, 0.0);
    let elbow = |s: f32| pt(s * (sh_x + ua), sh_y, 0.0);
    let wrist = |s: f32| pt(s * (sh_x + ua + fa), sh_y, 0.0);
    let fingertip = |s: f32| pt(s * (sh_x + ua + fa + hand), sh_y, 0.0);
    let hipj = |s: f32| pt(s * hip_x, hip_y, 0.0);
    let knee = |s: f32| pt(s * (hip_x + 0.004), knee_y, 0.004);
    let ankle = |s: f32| pt(s * (hip_x + 0.006), ankle_y, 0.0);
    let toe = |s: f32| pt(s * (hip_x + 0.012), 0.012, 0.11);

    let mut mb = MeshBuilder {
        verts: Vec::new(),
        tris: Vec::new(),
        bone: Vec::new(),
    };
    let v = |x: f32, y: f32, z: f32| Vector3::new(x * h, y * h, z * h);
    // Trunk.
    mb.ellipsoid(
        pt(0.0, hip_y + 0.015, -0.006),
        v(0.098 * g, 0.062, 0.063 * g),
        0,
        Bone::Hips,
    );
    mb.ellipsoid(
        pt(0.0, 0.645, -0.004),
        v(0.083 * g, 0.08, 0.058 * g),
        1,
        Bone::Spine,
    );
    mb.ellipsoid(
        pt(0.0, 0.735, -0.002),
        v(0.095 * g, 0.088, 0.064 * g),
        1,
        Bone::Chest,
    );
    // Neck and head.
    mb.capsule(
        neck,
        pt(0.0, 0.885, 0.004),
        0.03 * h * g.sqrt(),
        0.028 * h * g.sqrt(),
        Bone::Neck,
    );
    let skull = pt(0.0, 0.935, 0.008);
    let skull_radii = v(0.044, 0.064, 0.054);
    mb.ellipsoid(skull, skull_radii, 1, Bone::Head);
    // Arms.
    for (s, c, u, f, hb) in [
        (
            1.0,
            Bone::LeftCollar,
            Bone::LeftUpperArm,
            Bone::LeftForearm,
            Bone::LeftHand,
        ),
        (
            -1.0,
            Bone::RightCollar,
            Bone::RightUpperArm,
            Bone::RightForearm,
            Bone::RightHand,
        ),
    ] {
        mb.capsule(collar(s), shoulder(s), 0.03 * h * g, 0.031 * h * g, c);
        mb.capsule(shoulder(s), elbow(s), 0.028 * h * g, 0.021 * h * g, u);
        mb.capsule(elbow(s), wrist(s), 0.02 * h * g, 0.0145 * h * g, f);
        let hc = Point3::from((wrist(s).coords + fingertip(s).coords) / 2.0);
        mb.ellipsoid(hc, v(0.054, 0.0115 * g.sqrt(), 0.026 * g.sqrt()), 0, hb);
    }
    // Legs.
    for (s, t, sh, fo) in [
        (1.0, Bone::LeftThigh, Bone::LeftShin, Bone::LeftFoot),
        (-1.0, Bone::RightThigh, Bone::RightShin, Bone::RightFoot),
    ] {
        mb.capsule(hipj(s), knee(s), 0.05 * h * g, 0.031 * h * g, t);
        mb.capsule(knee(s), ankle(s), 0.031 * h * g, 0.019 * h * g, sh);
        let fc = Point3::new(ankle(s).x, 0.022 * h, 0.035 * h);
        mb.ellipsoid(fc, v(0.029 * g.sqrt(), 0.021, 0.075), 2, fo);
    }

    let bone = |c: Bone, head: Point3<f32>, tail: Point3<f32>| RigBone {
        name: c.name().to_owned(),
        parent: c.parent().map(|p| p.index()),
        head,
        tail,
        canon: Some(c),
        align: UnitQuaternion::identity(),
    };
    use Bone::*;
    let bones = vec![
        bone(Hips, hips, spine),
        bone(Spine, spine, chest),
        bone(Chest, chest, neck),
        bone(Neck, neck, headj),
        bone(Head, headj, head_top),
        bone(LeftCollar, collar(1.0), shoulder(1.0)),
        bone(LeftUpperArm, shoulder(1.0), elbow(1.0)),
        bone(LeftForearm, elbow(1.0), wrist(1.0)),
        bone(LeftHand, wrist(1.0), fingertip(1.0)),
        bone(RightCollar, collar(-1.0), shoulder(-1.0)),
        bone(RightUpperArm, shoulder(-1.0), elbow(-1.0)),
        bone(RightForearm, elbow(-1.0), wrist(-1.0)),
        bone(RightHand, wrist(-1.0), fingertip(-1.0)),
        bone(LeftThigh, hipj(1.0), knee(1.0)),
        bone(LeftShin, knee(1.0), ankle(1.0)),
        bone(LeftFoot, ankle(1.0), toe(1.0)),
        bone(RightThigh, hipj(-1.0), knee(-1.0)),
        bone(RightShin, knee(-1.0), ankle(-1.0)),
        bone(RightFoot, ankle(-1.0), toe(-1.0)),
    ];
    let palm = |s: f32| pt(s * (sh_x + ua + fa + 0.42 * hand), sh_y, 0.0);
    let crown = skull + Vector3::y() * skull_radii.y;
    let joints = [
        (Head.index(), crown),
        (Neck.index(), neck),
        (Chest.index(), pt(0.0, 0.735, -0.004)),
        (Hips.index(), hips),
        (LeftUpperArm.index(), shoulder(1.0)),
        (LeftForearm.index(), elbow(1.0)),
        (LeftHand.index(), palm(1.0)),
        (RightUpperArm.index(), shoulder(-1.0)),
        (RightForearm.index(), elbow(-1.0)),
        (RightHand.index(), palm(-1.0)),
        (LeftThigh.index(), hipj(1.0)),
        (LeftShin.index(), knee(1.0)),
        (LeftFoot.index(), ankle(1.0)),
        (RightThigh.index(), hipj(-1.0)),
        (RightShin.index(), knee(-1.0)),
        (RightFoot.index(), ankle(-1.0)),
    ];
    let weights = mb
        .bone
        .iter()
        .map(|&b| [(b, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)])
        .collect();
    Body::finish(
        format!("procedural {:.2} m, build {:.2}", h, g),
        mb.verts,
        mb.tris,
        weights,
        bones,
        joints,
        (Head.index(), skull),
    )
}
