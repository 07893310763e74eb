//! The articulated body the registration (step 7, `register/`) fits to the depth data:
//! fourteen rigid segments in a tree (pelvis → abdomen → chest → head, and collars →
//! arms; pelvis → legs), each
//! carrying tapered capsules that approximate its surface, and the 16 joints as points of
//! the segments.
//!
//! Every segment's frame is, at rest, the pelvis frame (x = the person's left, y = up
//! towards the neck, z = forward out of the belly) moved to the segment's joint; at rest
//! the limbs hang straight down. A [`BodyPose`] gives each segment a rotation in the
//! camera frame; joint positions follow by forward kinematics, so bone lengths and the
//! torso's shape can never change from frame to frame.
//!
//! The template's numbers were measured on the MakeHuman body of airglyph-synth standing
//! (`examples/fit_template.rs`): the
//! radius of each limb around its bone, the torso's cross-sections in the pelvis frame,
//! the joints' places. Arm and leg lengths scale with the person's
//! (`calibrate.rs`).

use crate::Limb;
use airglyph_core::{Joint, Skeleton};
use nalgebra::{Point3, Rotation3, Unit, Vector3};
use serde::{Deserialize, Serialize};

/// The body's bone lengths, metres (part of [`crate::PoseConfig`]): measured on the
/// MakeHuman body of airglyph-synth standing still; the arms' and legs' are then learned
/// for the person in view (`calibrate.rs`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BodyConfig {
    /// Shoulder to elbow.
    pub upper_arm: f32,
    /// Elbow to palm centre.
    pub forearm: f32,
    /// Hip to knee.
    pub thigh: f32,
    /// Knee to ankle.
    pub shin: f32,
    /// Neck to the head joint (the skull's centre).
    pub neck_to_head: f32,
}

impl Default for BodyConfig {
    fn default() -> Self {
        Self {
            upper_arm: 0.227,
            forearm: 0.272,
            thigh: 0.42,
            shin: 0.382,
            neck_to_head: 0.104,
        }
    }
}

impl BodyConfig {
    /// Bone lengths (root→middle, middle→end) of a limb; the head has one bone.
    pub fn bones(&self, limb: Limb) -> (f32, f32) {
        match limb {
            Limb::Head => (self.neck_to_head, 0.0),
            Limb::LeftArm | Limb::RightArm => (self.upper_arm, self.forearm),
            Limb::LeftLeg | Limb::RightLeg => (self.thigh, self.shin),
        }
    }

    /// Geodesic length beyond the end joint: fingers past the palm centre, the foot
    /// past the ankle, the skull's top past its centre.
    pub fn extremity_extra(&self, limb: Limb) -> f32 {
        match limb {
            Limb::Head => 0.10,
            Limb::LeftArm | Limb::RightArm => 0.10,
            Limb::LeftLeg | Limb::RightLeg => 0.12,
        }
    }
}

/// A rigid part of the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Segment {
    /// The hips' segment, the tree's root.
    Pelvis,
    /// The lower back, between the pelvis and the chest: the spine bends at both ends.
    Abdomen,
    /// The ribcage, carrying the neck, the torso joint and the collarbones.
    Chest,
    /// The head, turning at the neck.
    Head,
    /// The collarbones: the shoulder joint rises and comes forward with the arm.
    LeftCollar,
    /// Shoulder to elbow.
    LeftUpperArm,
    /// Elbow to fingertips (the body model has no wrist).
    LeftForearm,
    /// See `LeftCollar`.
    RightCollar,
    /// See `LeftUpperArm`.
    RightUpperArm,
    /// See `LeftForearm`.
    RightForearm,
    /// Hip to knee.
    LeftThigh,
    /// Knee to toes.
    LeftShin,
    /// See `LeftThigh`.
    RightThigh,
    /// See `LeftShin`.
    RightShin,
}

impl Segment {
    /// How many segments there are.
    pub const COUNT: usize = 14;
    /// Every segment, each after its parent.
    pub const ALL: [Segment; Segment::COUNT] = [
        Segment::Pelvis,
        Segment::Abdomen,
        Segment::Chest,
        Segment::Head,
        Segment::LeftCollar,
        Segment::LeftUpperArm,
        Segment::LeftForearm,
        Segment::RightCollar,
        Segment::RightUpperArm,
        Segment::RightForearm,
        Segment::LeftThigh,
        Segment::LeftShin,
        Segment::RightThigh,
        Segment::RightShin,
    ];

    /// The segment's place in [`Segment::ALL`] and in per-segment arrays.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The segment it hangs from (None for the pelvis).
    pub fn parent(self) -> Option<Segment> {
        use Segment::*;
        match self {
            Pelvis => None,
            Abdomen | LeftThigh | RightThigh => Some(Pelvis),
            Chest => Some(Abdomen),
            Head | LeftCollar | RightCollar => Some(Chest),
            LeftUpperArm => Some(LeftCollar),
            RightUpperArm => Some(RightCollar),
            LeftForearm => Some(LeftUpperArm),
            RightForearm => Some(RightUpperArm),
            LeftShin => Some(LeftThigh),
            RightShin => Some(RightThigh),
        }
    }

    /// The segment and its ancestors, the pelvis last: whose joints move it.
    pub fn chain(self) -> impl Iterator<Item = Segment> {
        std::iter::successors(Some(self), |s| s.parent())
    }
}

/// A capsule whose radius changes linearly from `ra` at `a` to `rb` at `b` (segment frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// The segment carrying it.
    pub segment: Segment,
    /// One end of its axis, segment frame.
    pub a: Point3<f32>,
    /// The other end.
    pub b: Point3<f32>,
    /// Radius at `a`.
    pub ra: f32,
    /// Radius at `b`.
    pub rb: f32,
    /// The [`Shape::capsules`] entry it was made from, and whether mirrored.
    pub spec: usize,
    /// Whether it is the right side's mirror of a left-side capsule.
    pub mirrored: bool,
}

/// The body's shape and proportions.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyTemplate {
    /// Each segment's joint (its frame's origin) in its parent's frame; zero for the pelvis.
    pub origin: [Vector3<f32>; Segment::COUNT],
    /// The capsules approximating the surface.
    pub capsules: Vec<Capsule>,
    /// Each of the 16 joints: the segment carrying it and its place in that frame.
    pub joints: [(Segment, Point3<f32>); Joint::COUNT],
    /// The extremity of each limb of [`crate::Limb::ALL`] (top of the head, fingertips,
    /// toes): where its geodesic maximum lies.
    pub tips: [(Segment, Point3<f32>); 5],
    /// The top of the head in the head's frame: the head joint reported, where the
    /// template's own skeletons carry the skull's centre ([`Shape::crown`]).
    pub crown: Point3<f32>,
}

/// A capsule of a [`Shape`]: endpoints in its segment's frame, where a limb segment's y
/// is in units of its bone's length (so the capsule follows the person's limb lengths).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CapsuleSpec {
    /// The segment carrying it.
    pub segment: Segment,
    /// One end of its axis.
    pub a: [f32; 3],
    /// Radius at `a`, metres.
    pub ra: f32,
    /// The other end.
    pub b: [f32; 3],
    /// Radius at `b`, metres.
    pub rb: f32,
}

/// A body's shape: the capsules and joints of its left side and midline (the right side
/// mirrors the left), in segment frames. Limb points (upper arm, forearm, thigh, shin)
/// have their y in bone lengths; everything else is in metres.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Shape {
    /// The abdomen's joint (lower back), pelvis frame; the chest's, abdomen frame.
    pub abdomen: [f32; 3],
    /// See `abdomen`.
    pub chest: [f32; 3],
    /// Chest frame: the neck (the head's joint), the torso joint, the left collarbone's
    /// joint (at the breastbone); the left shoulder in the collarbone's frame.
    pub neck: [f32; 3],
    /// See `neck`.
    pub torso: [f32; 3],
    /// See `neck`.
    pub collar: [f32; 3],
    /// See `neck`.
    pub shoulder: [f32; 3],
    /// Pelvis frame: the left hip.
    pub hip: [f32; 3],
    /// The skull's centre, head frame: the head the registration's own skeletons carry
    /// (the seed's head chain ends there, and a start turns the head onto it).
    pub head: [f32; 3],
    /// The top of the head, head frame: the head joint reported
    /// ([`airglyph_core::Joint::Head`]).
    #[serde(default = "Shape::makehuman_crown")]
    pub crown: [f32; 3],
    /// The elbow in the upper arm's frame, the hand (palm centre) in the forearm's, the
    /// knee in the thigh's, the ankle in the shin's.
    pub elbow: [f32; 3],
    /// See `elbow`.
    pub hand: [f32; 3],
    /// See `elbow`.
    pub knee: [f32; 3],
    /// See `elbow`.
    pub ankle: [f32; 3],
    /// Tips: the top of the head, the fingertips, the toes.
    pub head_tip: [f32; 3],
    /// See `head_tip`.
    pub finger_tip: [f32; 3],
    /// See `head_tip`.
    pub toe_tip: [f32; 3],
    /// Capsules of the pelvis, chest and head (mirrored when off the midline) and of
    /// the left limbs (mirrored onto the right ones).
    pub capsules: Vec<CapsuleSpec>,
}

impl Shape {
    /// The MakeHuman body's top of the head (`crown`), for settings written before it.
    fn makehuman_crown() -> [f32; 3] {
        [0.000, 0.231, 0.084]
    }

    /// The MakeHuman body of airglyph-synth, as `examples/fit_template.rs` measures it
    /// (scripted poses and a boxing clip, not the evaluation's clips).
    pub fn makehuman() -> Self {
        use Segment::*;
        let cap = |segment, a, ra, b, rb| CapsuleSpec {
            segment,
            a,
            ra,
            b,
            rb,
        };
        Self {
            abdomen: [0.000, 0.070, -0.021],
            chest: [0.000, 0.314, 0.006],
            neck: [0.000, 0.156, 0.016],
            torso: [0.000, 0.062, 0.006],
            collar: [0.027, 0.085, 0.077],
            shoulder: [0.149, -0.014, 0.006],
            hip: [0.110, 0.000, 0.000],
            head: [0.000, 0.094, 0.101],
            crown: Self::makehuman_crown(),
            elbow: [0.000, -1.003, 0.000],
            hand: [0.027, -0.982, 0.005],
            knee: [0.000, -1.003, 0.000],
            ankle: [0.000, -0.999, 0.000],
            head_tip: [0.000, 0.240, 0.015],
            finger_tip: [0.000, -1.400, 0.000],
            toe_tip: [0.000, -1.120, 0.160],
            capsules: vec![
                cap(
                    Pelvis,
                    [0.050, -0.020, 0.008],
                    0.111,
                    [0.052, 0.100, 0.008],
                    0.108,
                ),
                cap(
                    Abdomen,
                    [0.046, 0.050, 0.049],
                    0.095,
                    [0.029, 0.220, 0.075],
                    0.095,
                ),
                cap(
                    Chest,
                    [0.302, -0.050, 0.105],
                    0.085,
                    [0.021, 0.080, 0.018],
                    0.080,
                ),
                cap(
                    Head,
                    [0.000, -0.040, -0.004],
                    0.092,
                    [0.000, 0.040, 0.016],
                    0.033,
                ),
                cap(
                    Head,
                    [0.000, 0.060, 0.072],
                    0.070,
                    [0.000, 0.150, 0.064],
                    0.090,
                ),
                cap(
                    LeftUpperArm,
                    [0.000, 0.000, -0.003],
                    0.052,
                    [0.000, -1.000, 0.006],
                    0.031,
                ),
                cap(
                    LeftForearm,
                    [0.000, 0.000, 0.004],
                    0.031,
                    [0.000, -1.300, -0.011],
                    0.031,
                ),
                cap(
                    LeftThigh,
                    [0.000, 0.000, 0.015],
                    0.093,
                    [0.000, -1.000, 0.005],
                    0.052,
                ),
                cap(
                    LeftShin,
                    [0.000, 0.000, -0.029],
                    0.059,
                    [0.000, -1.000, 0.000],
                    0.030,
                ),
                cap(
                    LeftShin,
                    [0.000, -1.090, -0.007],
                    0.038,
                    [0.000, -1.120, 0.148],
                    0.045,
                ),
            ],
        }
    }
}

impl Segment {
    /// The thigh of the leg this segment is part of (None: no leg's).
    pub fn thigh(self) -> Option<Segment> {
        use Segment::*;
        match self {
            LeftThigh | LeftShin => Some(LeftThigh),
            RightThigh | RightShin => Some(RightThigh),
            _ => None,
        }
    }

    /// The same segment on the body's other side (itself on the midline).
    pub fn mirrored(self) -> Segment {
        use Segment::*;
        match self {
            LeftCollar => RightCollar,
            RightCollar => LeftCollar,
            LeftUpperArm => RightUpperArm,
            RightUpperArm => LeftUpperArm,
            LeftForearm => RightForearm,
            RightForearm => LeftForearm,
            LeftThigh => RightThigh,
            RightThigh => LeftThigh,
            LeftShin => RightShin,
            RightShin => LeftShin,
            s => s,
        }
    }

    /// Whether the segment's frame carries mirrored copies of the left side's capsules.
    fn on_midline(self) -> bool {
        matches!(
            self,
            Segment::Pelvis | Segment::Abdomen | Segment::Chest | Segment::Head
        )
    }
}

fn v(p: [f32; 3]) -> Vector3<f32> {
    Vector3::new(p[0], p[1], p[2])
}

fn mirror(p: [f32; 3]) -> [f32; 3] {
    [-p[0], p[1], p[2]]
}

/// Bone lengths, metres: upper arm, forearm, thigh, shin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limbs {
    /// Shoulder to elbow.
    pub upper_arm: f32,
    /// Elbow to palm centre.
    pub forearm: f32,
    /// Hip to knee.
    pub thigh: f32,
    /// Knee to ankle.
    pub shin: f32,
}

impl Limbs {
    /// The configured bone lengths.
    pub fn from_config(cfg: &BodyConfig) -> Self {
        Self {
            upper_arm: cfg.upper_arm,
            forearm: cfg.forearm,
            thigh: cfg.thigh,
            shin: cfg.shin,
        }
    }

    /// The length a limb segment's y is measured in (1 for the others).
    pub fn unit(&self, s: Segment) -> f32 {
        use Segment::*;
        match s {
            LeftUpperArm | RightUpperArm => self.upper_arm,
            LeftForearm | RightForearm => self.forearm,
            LeftThigh | RightThigh => self.thigh,
            LeftShin | RightShin => self.shin,
            Pelvis | Abdomen | Chest | Head | LeftCollar | RightCollar => 1.0,
        }
    }
}

impl BodyTemplate {
    /// The configured shape ([`crate::config::RegisterConfig::shape`]) with the
    /// configured bone lengths (already scaled to the person's by the calibration when
    /// that is on). The two sections, not the whole [`crate::PoseConfig`]: the settings
    /// gather this module's [`BodyConfig`], so the body cannot depend on them.
    pub fn new(shape: &Shape, bones: &BodyConfig) -> Self {
        Self::from_shape(shape, &Limbs::from_config(bones))
    }

    /// The body of `shape` with the bone lengths `limbs`.
    pub fn from_shape(shape: &Shape, limbs: &Limbs) -> Self {
        use Segment::*;
        // A point of a segment's frame, limb y scaled by the bone length.
        let at = |s: Segment, p: [f32; 3]| Point3::new(p[0], p[1] * limbs.unit(s), p[2]);
        let both = |left: Segment, p: [f32; 3]| {
            [(left, at(left, p)), (left.mirrored(), at(left, mirror(p)))]
        };
        let mut origin = [Vector3::zeros(); Segment::COUNT];
        origin[Abdomen.index()] = v(shape.abdomen);
        origin[Chest.index()] = v(shape.chest);
        origin[Head.index()] = v(shape.neck);
        origin[LeftCollar.index()] = v(shape.collar);
        origin[RightCollar.index()] = v(mirror(shape.collar));
        origin[LeftUpperArm.index()] = v(shape.shoulder);
        origin[RightUpperArm.index()] = v(mirror(shape.shoulder));
        for (s, p) in both(LeftUpperArm, shape.elbow) {
            origin[if s == LeftUpperArm {
                LeftForearm
            } else {
                RightForearm
            }
            .index()] = p.coords;
        }
        origin[LeftThigh.index()] = v(shape.hip);
        origin[RightThigh.index()] = v(mirror(shape.hip));
        for (s, p) in both(LeftThigh, shape.knee) {
            origin[if s == LeftThigh { LeftShin } else { RightShin }.index()] = p.coords;
        }

        let mut capsules = Vec::with_capacity(2 * shape.capsules.len());
        for (spec, c) in shape.capsules.iter().enumerate() {
            let seg = c.segment;
            capsules.push(Capsule {
                segment: seg,
                a: at(seg, c.a),
                b: at(seg, c.b),
                ra: c.ra,
                rb: c.rb,
                spec,
                mirrored: false,
            });
            let off_midline = c.a[0] != 0.0 || c.b[0] != 0.0;
            if !seg.on_midline() || off_midline {
                capsules.push(Capsule {
                    segment: seg.mirrored(),
                    a: at(seg, mirror(c.a)),
                    b: at(seg, mirror(c.b)),
                    ra: c.ra,
                    rb: c.rb,
                    spec,
                    mirrored: true,
                });
            }
        }
        let p3 = |p: [f32; 3]| Point3::new(p[0], p[1], p[2]);
        let [lhand, rhand] = both(LeftForearm, shape.hand);
        let [lankle, rankle] = both(LeftShin, shape.ankle);
        let [lfinger, rfinger] = both(LeftForearm, shape.finger_tip);
        let [ltoe, rtoe] = both(LeftShin, shape.toe_tip);
        let o = Point3::origin();
        let joints = [
            (Head, p3(shape.head)),
            (Chest, p3(shape.neck)),
            (Chest, p3(shape.torso)),
            (Pelvis, o),
            (LeftCollar, p3(shape.shoulder)),
            (LeftForearm, o),
            lhand,
            (RightCollar, p3(mirror(shape.shoulder))),
            (RightForearm, o),
            rhand,
            (Pelvis, p3(shape.hip)),
            (LeftShin, o),
            lankle,
            (Pelvis, p3(mirror(shape.hip))),
            (RightShin, o),
            rankle,
        ];
        let t = Self {
            origin,
            capsules,
            joints,
            tips: [(Head, p3(shape.head_tip)), lfinger, rfinger, ltoe, rtoe],
            crown: p3(shape.crown),
        };
        debug_assert!(Joint::ALL
            .iter()
            .all(|j| t.joints[j.index()].0 == segment_of(*j)));
        t
    }
}

/// The segments of a limb of [`crate::Limb::ALL`], root first.
pub fn limb_segments(limb: crate::Limb) -> &'static [Segment] {
    use crate::Limb;
    use Segment::*;
    match limb {
        Limb::Head => &[Head],
        Limb::LeftArm => &[LeftUpperArm, LeftForearm],
        Limb::RightArm => &[RightUpperArm, RightForearm],
        Limb::LeftLeg => &[LeftThigh, LeftShin],
        Limb::RightLeg => &[RightThigh, RightShin],
    }
}

/// The segment that carries a joint.
pub fn segment_of(j: Joint) -> Segment {
    use Segment::*;
    match j {
        Joint::Head => Head,
        Joint::Neck | Joint::Torso => Chest,
        Joint::LeftShoulder => LeftCollar,
        Joint::RightShoulder => RightCollar,
        Joint::Pelvis | Joint::LeftHip | Joint::RightHip => Pelvis,
        Joint::LeftElbow | Joint::LeftHand => LeftForearm,
        Joint::RightElbow | Joint::RightHand => RightForearm,
        Joint::LeftKnee | Joint::LeftFoot => LeftShin,
        Joint::RightKnee | Joint::RightFoot => RightShin,
    }
}

/// The smallest rotation taking direction `a` to direction `b` (nalgebra's
/// `rotation_between` gives NaN for nearly parallel vectors).
pub fn shortest_turn(a: &Vector3<f32>, b: &Vector3<f32>) -> Rotation3<f32> {
    let (Some(a), Some(b)) = (a.try_normalize(1e-9), b.try_normalize(1e-9)) else {
        return Rotation3::identity();
    };
    let c = a.cross(&b);
    let (sin, cos) = (c.norm(), a.dot(&b));
    if sin < 1e-7 {
        if cos > 0.0 {
            return Rotation3::identity();
        }
        // Half a turn about any axis across `a`.
        let across = if a.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let axis = Unit::new_normalize(a.cross(&across));
        return Rotation3::from_axis_angle(&axis, std::f32::consts::PI);
    }
    Rotation3::from_axis_angle(&Unit::new_unchecked(c / sin), sin.atan2(cos))
}

/// The rotation vector of `r` (its axis times its angle, radians), as nalgebra's
/// `scaled_axis` but with the angle's cosine clamped to [−1, 1]: nalgebra takes the
/// arccosine of (trace − 1) / 2, which rounding puts past 1 for a rotation within about
/// a milliradian of none, and returns NaN. A NaN in the registration's joint priors made
/// every step of the fit NaN, and the body froze (pose NOTES, 2026-12-04 evening).
/// Wherever nalgebra's result is finite this is the same to the bit.
pub fn rotation_vector(r: &Rotation3<f32>) -> Vector3<f32> {
    let cos = ((r.matrix().trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    r.axis()
        .map_or(Vector3::zeros(), |axis| axis.into_inner() * cos.acos())
}

/// Where the body is: the pelvis joint and every segment's rotation, camera frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    /// The pelvis segment's joint, camera frame.
    pub pelvis: Point3<f32>,
    /// Each segment's rotation, segment frame → camera frame.
    pub rotation: [Rotation3<f32>; Segment::COUNT],
}

/// A posed body: every segment's joint position, for reading points off it.
#[derive(Debug, Clone, Copy)]
pub struct Posed {
    /// Each segment's joint, camera frame.
    pub joint: [Point3<f32>; Segment::COUNT],
    /// Each segment's rotation, segment frame → camera frame.
    pub rotation: [Rotation3<f32>; Segment::COUNT],
}

impl Posed {
    /// The body `t` at `pose`, by forward kinematics.
    pub fn new(t: &BodyTemplate, pose: &BodyPose) -> Self {
        let mut joint = [pose.pelvis; Segment::COUNT];
        for s in Segment::ALL {
            if let Some(p) = s.parent() {
                joint[s.index()] =
                    joint[p.index()] + pose.rotation[p.index()] * t.origin[s.index()];
            }
        }
        Self {
            joint,
            rotation: pose.rotation,
        }
    }

    /// A point of a segment's frame in the camera frame.
    pub fn point(&self, s: Segment, local: &Point3<f32>) -> Point3<f32> {
        self.joint[s.index()] + self.rotation[s.index()] * local.coords
    }

    /// The 16 joints where the posed body puts them.
    pub fn skeleton(&self, t: &BodyTemplate) -> Skeleton {
        let mut joints = [Point3::origin(); Joint::COUNT];
        for (j, (s, local)) in joints.iter_mut().zip(&t.joints) {
            *j = self.point(*s, local);
        }
        Skeleton::new(joints)
    }
}

impl BodyPose {
    /// The pose nearest a 16-joint skeleton: the pelvis frame from the hips and the
    /// neck, each limb segment turned the shortest way from its parent onto its bone.
    /// `None` for a degenerate skeleton (hips on top of each other, say).
    pub fn from_skeleton(t: &BodyTemplate, s: &Skeleton) -> Option<Self> {
        use Segment::*;
        let x = (s[Joint::LeftHip] - s[Joint::RightHip]).try_normalize(1e-6)?;
        let up = s[Joint::Neck] - s[Joint::Pelvis];
        let y = (up - x * x.dot(&up)).try_normalize(1e-6)?;
        let z = x.cross(&y);
        let pelvis_r = Rotation3::from_basis_unchecked(&[x, y, z]);
        let mut rotation = [pelvis_r; Segment::COUNT];
        let turn = |from: &Rotation3<f32>, local: Vector3<f32>, want: Vector3<f32>| {
            shortest_turn(&(from * local), &want) * from
        };
        let head_axis = t.joints[Joint::Head.index()].1.coords;
        rotation[Head.index()] = turn(&pelvis_r, head_axis, s[Joint::Head] - s[Joint::Neck]);
        for (upper, fore, j0, j1, j2) in [
            (
                LeftUpperArm,
                LeftForearm,
                Joint::LeftShoulder,
                Joint::LeftElbow,
                Joint::LeftHand,
            ),
            (
                RightUpperArm,
                RightForearm,
                Joint::RightShoulder,
                Joint::RightElbow,
                Joint::RightHand,
            ),
            (
                LeftThigh,
                LeftShin,
                Joint::LeftHip,
                Joint::LeftKnee,
                Joint::LeftFoot,
            ),
            (
                RightThigh,
                RightShin,
                Joint::RightHip,
                Joint::RightKnee,
                Joint::RightFoot,
            ),
        ] {
            // The template's own bone (its joints need not lie on the segment's axis).
            let bone_upper = t.origin[fore.index()];
            let bone_fore = t.joints[j2.index()].1.coords;
            let ru = turn(&pelvis_r, bone_upper, s[j1] - s[j0]);
            rotation[upper.index()] = ru;
            rotation[fore.index()] = turn(&ru, bone_fore, s[j2] - s[j1]);
        }
        let pose = Self {
            pelvis: s[Joint::Pelvis],
            rotation,
        };
        pose.is_finite().then_some(pose)
    }

    /// This pose with one limb's segments turned as in `other` (the limb stays attached
    /// where this pose puts its root).
    pub fn with_limb_of(&self, other: &BodyPose, limb: crate::Limb) -> BodyPose {
        let mut p = *self;
        for s in limb_segments(limb) {
            p.rotation[s.index()] = other.rotation[s.index()];
        }
        p
    }

    /// Whether every number of the pose is finite.
    pub fn is_finite(&self) -> bool {
        self.pelvis.coords.iter().all(|c| c.is_finite())
            && self
                .rotation
                .iter()
                .all(|r| r.matrix().iter().all(|c| c.is_finite()))
    }

    /// Moves the pose by a step of the registration: `dt` for the pelvis, and for each
    /// segment a small rotation `omega` (camera frame, radians) about its joint that
    /// carries everything below it along.
    pub fn step(&mut self, dt: &Vector3<f32>, omega: &[Vector3<f32>; Segment::COUNT]) {
        self.pelvis += dt;
        let mut turn = [Rotation3::identity(); Segment::COUNT];
        for s in Segment::ALL {
            let w = omega[s.index()];
            let own = Unit::try_new(w, 1e-12).map_or(Rotation3::identity(), |axis| {
                Rotation3::from_axis_angle(&axis, w.norm())
            });
            let parent = s
                .parent()
                .map_or(Rotation3::identity(), |p| turn[p.index()]);
            turn[s.index()] = own * parent;
        }
        for s in Segment::ALL {
            let r = turn[s.index()] * self.rotation[s.index()];
            // Re-orthonormalise: many small steps would otherwise drift.
            self.rotation[s.index()] = Rotation3::from_matrix_eps(r.matrix(), 1e-7, 4, r);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn standing() -> (BodyTemplate, BodyPose) {
        let t = BodyTemplate::new(&Shape::makehuman(), &BodyConfig::default());
        // Facing the camera 2.5 m away: the person's left is the camera's +x, up is -y,
        // forward is -z.
        let r = Rotation3::from_basis_unchecked(&[Vector3::x(), -Vector3::y(), -Vector3::z()]);
        let pose = BodyPose {
            pelvis: Point3::new(0.0, 0.1, 2.5),
            rotation: [r; Segment::COUNT],
        };
        (t, pose)
    }

    #[test]
    fn rotation_vectors_of_small_and_generic_turns() {
        // A small turn taken back out of a larger one, as the priors do (a segment
        // against its parent): rounding puts the trace past 3 for some of these, where
        // the arccosine of nalgebra's `scaled_axis` gives NaN.
        for i in 0..500 {
            let a = Rotation3::new(Vector3::new(0.3 + 0.01 * i as f32, -0.7, 1.1));
            let small = Vector3::new(1.0, -2.0, 0.5) * (1e-5 * (i % 9) as f32);
            let r = a.inverse() * (a * Rotation3::new(small));
            let v = rotation_vector(&r);
            assert!((v - small).norm() < 1e-3, "{v:?} against {small:?}");
        }
        for v in [
            Vector3::new(0.1, 0.0, 0.0),
            Vector3::new(0.3, -0.2, 0.9),
            Vector3::new(-1.5, 1.0, 0.5),
        ] {
            let r = Rotation3::new(v);
            assert_eq!(rotation_vector(&r), r.scaled_axis());
            assert!((rotation_vector(&r) - v).norm() < 1e-4);
        }
    }

    #[test]
    fn standing_joints_are_where_the_template_puts_them() {
        let (t, pose) = standing();
        let s = Posed::new(&t, &pose).skeleton(&t);
        // Head above the neck above the pelvis (camera y down), shoulders and hips on
        // the person's own sides (left = camera +x when facing the camera).
        assert!(s[Joint::Head].y < s[Joint::Neck].y && s[Joint::Neck].y < s[Joint::Pelvis].y);
        assert!(s[Joint::LeftShoulder].x > 0.1 && s[Joint::RightShoulder].x < -0.1);
        assert!(s[Joint::LeftHip].x > 0.05 && s[Joint::RightHip].x < -0.05);
        // Bone lengths are the configured ones, to within the shape's placing of the
        // joints (a joint may lie a little off its segment's axis).
        let cfg = BodyConfig::default();
        let ua = (s[Joint::LeftElbow] - s[Joint::LeftShoulder]).norm();
        let fa = (s[Joint::LeftHand] - s[Joint::LeftElbow]).norm();
        assert!((ua - cfg.upper_arm).abs() < 0.01 && (fa - cfg.forearm).abs() < 0.01);
        let leg = s[Joint::LeftFoot].y - s[Joint::LeftHip].y;
        assert!((leg - cfg.thigh - cfg.shin).abs() < 0.01, "{leg}");
    }

    #[test]
    fn a_pose_read_back_from_its_own_skeleton_gives_the_same_joints() {
        let (t, mut pose) = standing();
        // Bend the body: turn the chest, raise the right arm forward, bend the left knee.
        let mut w = [Vector3::zeros(); Segment::COUNT];
        w[Segment::Chest.index()] = Vector3::new(0.0, 0.3, 0.1);
        w[Segment::RightUpperArm.index()] = Vector3::new(1.2, 0.0, 0.0);
        w[Segment::RightForearm.index()] = Vector3::new(0.6, 0.2, 0.0);
        w[Segment::LeftShin.index()] = Vector3::new(-0.9, 0.0, 0.0);
        pose.step(&Vector3::new(0.1, 0.0, 0.2), &w);
        let s = Posed::new(&t, &pose).skeleton(&t);
        eprintln!("{:?} {:?}", s, pose);
        let back = BodyPose::from_skeleton(&t, &s).expect("a skeleton with hips apart");
        let s2 = Posed::new(&t, &back).skeleton(&t);
        for j in Joint::ALL {
            // The chest's turn relative to the pelvis is not in the hips and neck alone:
            // joints on the chest may differ by that turn; limbs keep their bones.
            let tol = match segment_of(j) {
                Segment::Pelvis => 1e-4,
                _ => 0.12,
            };
            assert!(
                (s[j] - s2[j]).norm() < tol,
                "{j:?}: {:?} vs {:?}",
                s[j],
                s2[j]
            );
        }
        // Bone directions are kept exactly, whatever the chest did.
        for (a, b) in [
            (Joint::RightElbow, Joint::RightHand),
            (Joint::LeftKnee, Joint::LeftFoot),
        ] {
            let d1 = (s[b] - s[a]).normalize();
            let d2 = (s2[b] - s2[a]).normalize();
            assert!(d1.dot(&d2) > 0.9999, "{a:?}→{b:?}");
        }
    }

    #[test]
    fn a_step_moves_points_as_its_jacobian_says() {
        // The registration's Jacobian: a point of segment s moves by
        // dt + Σ_{j in chain(s)} ω_j × (x − p_j) for a small step.
        let (t, pose) = standing();
        let before = Posed::new(&t, &pose);
        let local = Point3::new(0.01, -0.2, 0.03);
        let x = before.point(Segment::LeftForearm, &local);
        let mut w = [Vector3::zeros(); Segment::COUNT];
        for (i, wi) in w.iter_mut().enumerate() {
            *wi = Vector3::new(0.3, -0.2, 0.1 * i as f32) * 1e-4;
        }
        let dt = Vector3::new(1e-4, -2e-4, 3e-4);
        let mut after = pose;
        after.step(&dt, &w);
        let moved = Posed::new(&t, &after).point(Segment::LeftForearm, &local) - x;
        let mut predicted = dt;
        for s in Segment::LeftForearm.chain() {
            predicted += w[s.index()].cross(&(x - before.joint[s.index()]));
        }
        assert!(
            (moved - predicted).norm() < 1e-6,
            "{moved:?} vs {predicted:?}"
        );
    }
}
