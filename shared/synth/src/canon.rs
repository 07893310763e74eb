//! The canonical skeleton every motion source drives: 19 bones in a T-pose, and the
//! [`Pose`] that motion produces and bodies consume.
//!
//! Body frame: metres, y up, the person faces +z, +x is the person's left, the floor is
//! y = 0. In the canonical T-pose the arms are straight along ±x with palms down, the
//! legs straight down, spine and head straight up, feet pointing forward.

use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};

/// A bone of the canonical skeleton; the discriminant indexes [`Pose::rot`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Bone {
    /// The pelvis, root of the hierarchy.
    Hips,
    /// The lower spine.
    Spine,
    /// The upper spine.
    Chest,
    /// The neck.
    Neck,
    /// The head.
    Head,
    /// The left clavicle.
    LeftCollar,
    /// The left upper arm.
    LeftUpperArm,
    /// The left forearm.
    LeftForearm,
    /// The left hand.
    LeftHand,
    /// The right clavicle.
    RightCollar,
    /// The right upper arm.
    RightUpperArm,
    /// The right forearm.
    RightForearm,
    /// The right hand.
    RightHand,
    /// The left thigh.
    LeftThigh,
    /// The left shin.
    LeftShin,
    /// The left foot.
    LeftFoot,
    /// The right thigh.
    RightThigh,
    /// The right shin.
    RightShin,
    /// The right foot.
    RightFoot,
}

impl Bone {
    /// How many canonical bones there are.
    pub const COUNT: usize = 19;
    /// Every bone, parents before children.
    pub const ALL: [Bone; Bone::COUNT] = [
        Bone::Hips,
        Bone::Spine,
        Bone::Chest,
        Bone::Neck,
        Bone::Head,
        Bone::LeftCollar,
        Bone::LeftUpperArm,
        Bone::LeftForearm,
        Bone::LeftHand,
        Bone::RightCollar,
        Bone::RightUpperArm,
        Bone::RightForearm,
        Bone::RightHand,
        Bone::LeftThigh,
        Bone::LeftShin,
        Bone::LeftFoot,
        Bone::RightThigh,
        Bone::RightShin,
        Bone::RightFoot,
    ];

    /// The bone's index in [`Bone::ALL`] and in every per-bone array.
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    /// The bone it hangs from; None for the hips.
    pub fn parent(self) -> Option<Bone> {
        use Bone::*;
        Some(match self {
            Hips => return None,
            Spine => Hips,
            Chest => Spine,
            Neck => Chest,
            Head => Neck,
            LeftCollar | RightCollar => Chest,
            LeftUpperArm => LeftCollar,
            LeftForearm => LeftUpperArm,
            LeftHand => LeftForearm,
            RightUpperArm => RightCollar,
            RightForearm => RightUpperArm,
            RightHand => RightForearm,
            LeftThigh | RightThigh => Hips,
            LeftShin => LeftThigh,
            LeftFoot => LeftShin,
            RightShin => RightThigh,
            RightFoot => RightShin,
        })
    }

    /// The bone whose head is this bone's tail, if any (the chain continues there).
    pub fn child(self) -> Option<Bone> {
        use Bone::*;
        Some(match self {
            Hips => Spine,
            Spine => Chest,
            Chest => Neck,
            Neck => Head,
            LeftCollar => LeftUpperArm,
            LeftUpperArm => LeftForearm,
            LeftForearm => LeftHand,
            RightCollar => RightUpperArm,
            RightUpperArm => RightForearm,
            RightForearm => RightHand,
            LeftThigh => LeftShin,
            LeftShin => LeftFoot,
            RightThigh => RightShin,
            RightShin => RightFoot,
            Head | LeftHand | RightHand | LeftFoot | RightFoot => return None,
        })
    }

    /// The bone's direction (head to tail) in the canonical T-pose.
    pub fn tpose_dir(self) -> Vector3<f32> {
        use Bone::*;
        match self {
            Hips | Spine | Chest | Neck | Head => Vector3::y(),
            LeftCollar | LeftUpperArm | LeftForearm | LeftHand => Vector3::x(),
            RightCollar | RightUpperArm | RightForearm | RightHand => -Vector3::x(),
            LeftThigh | LeftShin | RightThigh | RightShin => -Vector3::y(),
            LeftFoot | RightFoot => Vector3::new(0.0, -0.35, 1.0).normalize(),
        }
    }

    /// The mirror-image bone (left <-> right); central bones are their own mirror.
    pub fn mirror(self) -> Bone {
        use Bone::*;
        match self {
            LeftCollar => RightCollar,
            LeftUpperArm => RightUpperArm,
            LeftForearm => RightForearm,
            LeftHand => RightHand,
            RightCollar => LeftCollar,
            RightUpperArm => LeftUpperArm,
            RightForearm => LeftForearm,
            RightHand => LeftHand,
            LeftThigh => RightThigh,
            LeftShin => RightShin,
            LeftFoot => RightFoot,
            RightThigh => LeftThigh,
            RightShin => LeftShin,
            RightFoot => LeftFoot,
            b => b,
        }
    }

    /// The bone's name in scripts and logs.
    pub fn name(self) -> &'static str {
        use Bone::*;
        match self {
            Hips => "hips",
            Spine => "spine",
            Chest => "chest",
            Neck => "neck",
            Head => "head",
            LeftCollar => "left_collar",
            LeftUpperArm => "left_upper_arm",
            LeftForearm => "left_forearm",
            LeftHand => "left_hand",
            RightCollar => "right_collar",
            RightUpperArm => "right_upper_arm",
            RightForearm => "right_forearm",
            RightHand => "right_hand",
            LeftThigh => "left_thigh",
            LeftShin => "left_shin",
            LeftFoot => "left_foot",
            RightThigh => "right_thigh",
            RightShin => "right_shin",
            RightFoot => "right_foot",
        }
    }
}

/// One frame of motion on the canonical skeleton.
///
/// `rot[b]` is bone `b`'s rotation in the body frame relative to the canonical T-pose
/// (world, not parent-relative: a child's rotation already contains its parents'), and
/// `root` is where the hips joint (the head of [`Bone::Hips`]) is, in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Where the hips joint is, body frame, metres.
    pub root: Point3<f32>,
    /// Each bone's rotation from the T-pose, body frame, in [`Bone::ALL`] order.
    pub rot: [UnitQuaternion<f32>; Bone::COUNT],
}

impl Pose {
    /// The T-pose with the hips at `root`.
    pub fn tpose(root: Point3<f32>) -> Self {
        Self {
            root,
            rot: [UnitQuaternion::identity(); Bone::COUNT],
        }
    }

    /// A bone's rotation.
    #[inline]
    pub fn get(&self, b: Bone) -> UnitQuaternion<f32> {
        self.rot[b.index()]
    }

    /// Sets a bone's rotation.
    #[inline]
    pub fn set(&mut self, b: Bone, q: UnitQuaternion<f32>) {
        self.rot[b.index()] = q;
    }

    /// The rotation of `b` relative to its parent (identity in the T-pose).
    pub fn local(&self, b: Bone) -> UnitQuaternion<f32> {
        match b.parent() {
            Some(p) => self.get(p).inverse() * self.get(b),
            None => self.get(b),
        }
    }

    /// Turns the whole body by `q` about the vertical line through the origin of the body
    /// frame (e.g. a yaw to show the person sideways).
    pub fn rotate_all(&mut self, q: UnitQuaternion<f32>) {
        self.root = q * self.root;
        for r in &mut self.rot {
            *r = q * *r;
        }
    }

    /// Blends two poses (`t` = 0 gives `self`), bone by bone along the shortest arc.
    pub fn lerp(&self, other: &Pose, t: f32) -> Pose {
        let mut out = *self;
        out.root = self.root + (other.root - self.root) * t;
        for (o, (a, b)) in out
            .rot
            .iter_mut()
            .zip(self.rot.iter().zip(other.rot.iter()))
        {
            let b = if a.coords.dot(&b.coords) < 0.0 {
                UnitQuaternion::new_unchecked(-b.into_inner())
            } else {
                *b
            };
            *o = a.nlerp(&b, t);
        }
        out
    }
}

/// Where the canonical bones are in a body's T-pose: head and tail of each bone and the
/// 16 ground-truth joints, in the body frame. Motion generators read lengths from here so
/// the same script fits a short or a tall body.
#[derive(Debug, Clone, PartialEq)]
pub struct TposeSkeleton {
    /// Where each bone starts, in [`Bone::ALL`] order.
    pub head: [Point3<f32>; Bone::COUNT],
    /// Where each bone ends, in [`Bone::ALL`] order.
    pub tail: [Point3<f32>; Bone::COUNT],
    /// Ground-truth joints (airglyph-core's [`airglyph_core::Joint`] order) in the T-pose.
    pub joints: [Point3<f32>; airglyph_core::Joint::COUNT],
    /// The skull's centre in the T-pose: where motions put a hand by the face (the
    /// head joint is the top of the head).
    pub skull: Point3<f32>,
}

impl TposeSkeleton {
    /// Where bone `b` starts.
    pub fn head(&self, b: Bone) -> Point3<f32> {
        self.head[b.index()]
    }

    /// Where bone `b` ends.
    pub fn tail(&self, b: Bone) -> Point3<f32> {
        self.tail[b.index()]
    }

    /// Where ground-truth joint `j` is in the T-pose.
    pub fn joint(&self, j: airglyph_core::Joint) -> Point3<f32> {
        self.joints[j.index()]
    }

    /// Forward kinematics: where the head of each bone is under `pose`.
    pub fn posed_heads(&self, pose: &Pose) -> [Point3<f32>; Bone::COUNT] {
        let mut out = [Point3::origin(); Bone::COUNT];
        for b in Bone::ALL {
            out[b.index()] = match b.parent() {
                None => pose.root,
                Some(p) => out[p.index()] + pose.get(p) * (self.head(b) - self.head(p)),
            };
        }
        out
    }

    /// Where a point rigidly attached to bone `b` (given in the T-pose) goes under `pose`.
    pub fn posed_point(
        &self,
        heads: &[Point3<f32>; Bone::COUNT],
        pose: &Pose,
        b: Bone,
        p: Point3<f32>,
    ) -> Point3<f32> {
        heads[b.index()] + pose.get(b) * (p - self.head(b))
    }
}

/// The shortest-arc rotation taking unit vector `from` to `to` (a half turn about a
/// perpendicular axis when they are opposite).
pub fn shortest_arc(from: &Vector3<f32>, to: &Vector3<f32>) -> UnitQuaternion<f32> {
    let f = from.normalize();
    let t = to.normalize();
    UnitQuaternion::rotation_between(&f, &t).unwrap_or_else(|| {
        let axis = if f.x.abs() < 0.9 {
            f.cross(&Vector3::x())
        } else {
            f.cross(&Vector3::y())
        };
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), std::f32::consts::PI)
    })
}

/// The rotation taking the orthonormal frame (a1, a2) to (b1, b2): b1 = R a1 and b2 lies
/// in the plane of R a2 and R a1. Vectors need not be exactly orthogonal.
pub fn frame_to_frame(
    a1: &Vector3<f32>,
    a2: &Vector3<f32>,
    b1: &Vector3<f32>,
    b2: &Vector3<f32>,
) -> UnitQuaternion<f32> {
    let basis = |u: &Vector3<f32>, v: &Vector3<f32>| {
        let e1 = u.normalize();
        let e2 = (v - e1 * e1.dot(v)).normalize();
        let e3 = e1.cross(&e2);
        Matrix3::from_columns(&[e1, e2, e3])
    };
    let a = basis(a1, a2);
    let b = basis(b1, b2);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(b * a.transpose()))
}
