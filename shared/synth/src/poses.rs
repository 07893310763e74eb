//! Scripted poses within joint limits, and the two-bone arm IK they (and air-drawing)
//! are built with. Everything works on a body's [`TposeSkeleton`], so the same script
//! fits any body.

use crate::canon::{frame_to_frame, Bone, Pose, TposeSkeleton};
use airglyph_core::Joint;
use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

/// The scripted poses, including the hard cases of the seed paper's evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScriptedPose {
    /// Standing, arms hanging with elbows slightly bent.
    Neutral,
    /// Arms straight out to the sides.
    TPose,
    /// The right arm straight toward the camera (foreshortened to a point).
    PointAtCamera,
    /// The right hand on the left shoulder: the forearm lies across the torso.
    ArmAcrossTorso,
    /// Both hands in front of the face.
    HandsNearFace,
    /// Turned 90° to the left, arms hanging: one side of the body hides the other.
    Sideways,
    /// The right hand raised beside the head.
    Wave,
    /// Both arms forward and down, the hands in front of the belly.
    HandsInFront,
    /// At rest: the arms hanging straight against the body's sides.
    ArmsAtSides,
    /// At rest: the palms on the thighs (on top of them when seated, on their front
    /// when standing).
    HandsOnThighs,
    /// At rest: the hands on a table of the usual height
    /// ([`crate::room::TABLE_HEIGHT_M`]) in front of the person.
    HandsOnTable,
    /// At rest: the hands together in the lap (or before the hips, standing).
    HandsInLap,
    /// At rest: the forearms crossed before the chest.
    ArmsCrossed,
}

impl ScriptedPose {
    /// The hard cases of the seed paper's evaluation, which the `poses` motion cycles
    /// through.
    pub const HARD_CASES: [ScriptedPose; 8] = [
        ScriptedPose::Neutral,
        ScriptedPose::TPose,
        ScriptedPose::PointAtCamera,
        ScriptedPose::ArmAcrossTorso,
        ScriptedPose::HandsNearFace,
        ScriptedPose::Sideways,
        ScriptedPose::Wave,
        ScriptedPose::HandsInFront,
    ];

    /// Where arms rest between gestures, which the `rest` motion moves between.
    pub const AT_REST: [ScriptedPose; 6] = [
        ScriptedPose::Neutral,
        ScriptedPose::ArmsAtSides,
        ScriptedPose::HandsOnThighs,
        ScriptedPose::HandsOnTable,
        ScriptedPose::HandsInLap,
        ScriptedPose::ArmsCrossed,
    ];

    /// Every scripted pose, in the order `--help` lists them.
    pub const ALL: [ScriptedPose; 13] = [
        ScriptedPose::Neutral,
        ScriptedPose::TPose,
        ScriptedPose::PointAtCamera,
        ScriptedPose::ArmAcrossTorso,
        ScriptedPose::HandsNearFace,
        ScriptedPose::Sideways,
        ScriptedPose::Wave,
        ScriptedPose::HandsInFront,
        ScriptedPose::ArmsAtSides,
        ScriptedPose::HandsOnThighs,
        ScriptedPose::HandsOnTable,
        ScriptedPose::HandsInLap,
        ScriptedPose::ArmsCrossed,
    ];

    /// The pose's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ScriptedPose::Neutral => "neutral",
            ScriptedPose::TPose => "t-pose",
            ScriptedPose::PointAtCamera => "point-at-camera",
            ScriptedPose::ArmAcrossTorso => "arm-across-torso",
            ScriptedPose::HandsNearFace => "hands-near-face",
            ScriptedPose::Sideways => "sideways",
            ScriptedPose::Wave => "wave",
            ScriptedPose::HandsInFront => "hands-in-front",
            ScriptedPose::ArmsAtSides => "arms-at-sides",
            ScriptedPose::HandsOnThighs => "hands-on-thighs",
            ScriptedPose::HandsOnTable => "hands-on-table",
            ScriptedPose::HandsInLap => "hands-in-lap",
            ScriptedPose::ArmsCrossed => "arms-crossed",
        }
    }

    /// The pose named `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The pose on the given body, standing (facing +z of the body frame, i.e. the
    /// camera).
    pub fn pose(self, sk: &TposeSkeleton) -> Pose {
        self.pose_in(sk, Posture::Standing)
    }

    /// The pose on the given body in a posture: the legs and hips as the posture puts
    /// them, the arms reaching for what is where in it (thighs, lap, table).
    pub fn pose_in(self, sk: &TposeSkeleton, posture: Posture) -> Pose {
        let mut p = neutral(sk);
        posture.apply(sk, &mut p);
        let lift = p.root - sk.head(Bone::Hips);
        let h = height(sk);
        let head = sk.skull + lift;
        match self {
            ScriptedPose::Neutral => {}
            ScriptedPose::TPose => {
                for b in Bone::ALL {
                    if matches!(
                        b,
                        Bone::LeftUpperArm
                            | Bone::LeftForearm
                            | Bone::LeftHand
                            | Bone::RightUpperArm
                            | Bone::RightForearm
                            | Bone::RightHand
                    ) {
                        p.set(b, UnitQuaternion::identity());
                    }
                }
            }
            ScriptedPose::PointAtCamera => {
                set_arm(
                    &mut p,
                    Side::Right,
                    &Vector3::z(),
                    &Vector3::z(),
                    &Vector3::y(),
                );
            }
            ScriptedPose::ArmAcrossTorso => {
                let target =
                    sk.joint(Joint::LeftShoulder) + lift + Vector3::new(-0.01, -0.07, 0.085) * h;
                arm_ik(
                    sk,
                    &mut p,
                    Side::Right,
                    target,
                    &Vector3::new(-0.6, -1.0, -0.2),
                );
            }
            ScriptedPose::HandsNearFace => {
                for (s, side) in [(1.0, Side::Left), (-1.0, Side::Right)] {
                    let target = head + Vector3::new(s * 0.045, -0.02, 0.095) * h;
                    arm_ik(sk, &mut p, side, target, &Vector3::new(s * 0.7, -1.0, -0.2));
                }
            }
            ScriptedPose::Sideways => {
                p.rotate_all(yaw(std::f32::consts::FRAC_PI_2));
            }
            ScriptedPose::Wave => {
                let target = head + Vector3::new(-0.14, 0.06, 0.02) * h;
                arm_ik(
                    sk,
                    &mut p,
                    Side::Right,
                    target,
                    &Vector3::new(-1.0, -0.8, -0.3),
                );
            }
            ScriptedPose::HandsInFront => {
                for (s, side) in [(1.0, Side::Left), (-1.0, Side::Right)] {
                    let target =
                        sk.joint(Joint::Pelvis) + lift + Vector3::new(s * 0.05, 0.11, 0.16) * h;
                    arm_ik(sk, &mut p, side, target, &Vector3::new(s * 0.5, -1.0, -0.3));
                }
            }
            ScriptedPose::ArmsAtSides => {
                for (s, side) in [(1.0f32, Side::Left), (-1.0, Side::Right)] {
                    let a = 4f32.to_radians();
                    let up = Vector3::new(s * a.sin(), -a.cos(), 0.0);
                    let b = 6f32.to_radians();
                    let fore = Vector3::new(s * a.sin(), -b.cos(), b.sin());
                    set_arm(&mut p, side, &up, &fore, &Vector3::new(s * 0.3, 0.0, -1.0));
                }
            }
            ScriptedPose::HandsOnThighs => {
                let heads = sk.posed_heads(&p);
                for (s, side, thigh, shin) in [
                    (1.0f32, Side::Left, Bone::LeftThigh, Bone::LeftShin),
                    (-1.0, Side::Right, Bone::RightThigh, Bone::RightShin),
                ] {
                    // Halfway down the thigh, a hand's thickness off its surface: on top
                    // of it seated, before it standing.
                    let mid =
                        heads[thigh.index()] + (heads[shin.index()] - heads[thigh.index()]) * 0.55;
                    let out = match posture {
                        Posture::Standing => Vector3::new(s * 0.01, 0.0, 0.075) * h / 1.75,
                        Posture::Seated { .. } => Vector3::new(s * 0.01, 0.085, 0.0) * h / 1.75,
                    };
                    arm_ik(
                        sk,
                        &mut p,
                        side,
                        mid + out,
                        &Vector3::new(s * 0.6, -0.3, -1.0),
                    );
                }
            }
            ScriptedPose::HandsOnTable => {
                for (s, side) in [(1.0f32, Side::Left), (-1.0, Side::Right)] {
                    let target = Point3::new(
                        s * 0.17 * h / 1.75,
                        crate::room::TABLE_HEIGHT_M + 0.03,
                        p.root.z + 0.38 * h / 1.75,
                    );
                    arm_ik(sk, &mut p, side, target, &Vector3::new(s * 0.8, -1.0, -0.4));
                }
            }
            ScriptedPose::HandsInLap => {
                let pelvis = sk.joint(Joint::Pelvis) + lift;
                let ahead = match posture {
                    Posture::Standing => Vector3::new(0.0, -0.08, 0.12),
                    Posture::Seated { .. } => Vector3::new(0.0, 0.03, 0.17),
                };
                for (s, side) in [(1.0f32, Side::Left), (-1.0, Side::Right)] {
                    let target = pelvis + (ahead + Vector3::new(s * 0.03, 0.0, 0.0)) * h / 1.75;
                    arm_ik(sk, &mut p, side, target, &Vector3::new(s * 0.5, -1.0, -0.3));
                }
            }
            ScriptedPose::ArmsCrossed => {
                // Each hand on the other arm's upper arm, the right forearm in front.
                let heads = sk.posed_heads(&p);
                for (side, other, depth) in [
                    (Side::Left, Bone::RightUpperArm, 0.07f32),
                    (Side::Right, Bone::LeftUpperArm, 0.12),
                ] {
                    let s = if side == Side::Left { 1.0 } else { -1.0 };
                    let shoulder = heads[other.index()];
                    let target = shoulder + Vector3::new(s * 0.045, -0.17, depth) * h / 1.75;
                    arm_ik(sk, &mut p, side, target, &Vector3::new(s * 0.6, -1.0, -0.2));
                }
            }
        }
        p
    }
}

/// How the person holds their legs and hips.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Posture {
    /// Standing on the floor, as the motion has it.
    #[default]
    Standing,
    /// Sitting upright on a seat this high above the floor (metres): thighs forward,
    /// shins down, feet on the floor; the upper body moves as the motion has it.
    Seated {
        /// The seat's height above the floor, metres.
        seat_height_m: f32,
    },
}

impl Posture {
    /// Puts the legs and hips of `p` in this posture, keeping its heading and its upper
    /// body's rotations.
    pub fn apply(self, sk: &TposeSkeleton, p: &mut Pose) {
        let Posture::Seated { seat_height_m } = self else {
            return;
        };
        let fwd = p.get(Bone::Hips) * Vector3::z();
        let heading = yaw(fwd.x.atan2(fwd.z));
        let down_to_forward =
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -90f32.to_radians());
        let shin_tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -6f32.to_radians());
        for (s, thigh, shin, foot) in [
            (1.0f32, Bone::LeftThigh, Bone::LeftShin, Bone::LeftFoot),
            (-1.0, Bone::RightThigh, Bone::RightShin, Bone::RightFoot),
        ] {
            let splay = yaw(s * 7f32.to_radians());
            p.set(thigh, heading * splay * down_to_forward);
            p.set(shin, heading * splay * shin_tilt);
            p.set(foot, heading * splay);
        }
        // The hips joint above the seat by the thigh's half thickness and the hip
        // joints' drop below it.
        let h = height(sk);
        let drop = sk.head(Bone::Hips).y - sk.head(Bone::LeftThigh).y;
        p.root.y = seat_height_m + 0.075 * h / 1.75 + drop;
    }
}

/// Which arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The person's left arm.
    Left,
    /// The person's right arm.
    Right,
}

impl Side {
    /// The side's name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }

    pub(crate) fn bones(self) -> (Bone, Bone, Bone) {
        match self {
            Side::Left => (Bone::LeftUpperArm, Bone::LeftForearm, Bone::LeftHand),
            Side::Right => (Bone::RightUpperArm, Bone::RightForearm, Bone::RightHand),
        }
    }

    pub(crate) fn hand_joint(self) -> Joint {
        match self {
            Side::Left => Joint::LeftHand,
            Side::Right => Joint::RightHand,
        }
    }
}

/// A rotation about the vertical axis (positive turns the person to their left).
pub fn yaw(angle: f32) -> UnitQuaternion<f32> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), angle)
}

/// The body's standing height, from the T-pose skeleton (top of the head ≈ tail of the
/// head bone).
pub fn height(sk: &TposeSkeleton) -> f32 {
    sk.tail(Bone::Head).y.max(0.5)
}

/// Standing, arms hanging 12° out from the body, elbows bent 15°.
pub fn neutral(sk: &TposeSkeleton) -> Pose {
    let mut p = Pose::tpose(sk.head(Bone::Hips));
    for (s, side) in [(1.0f32, Side::Left), (-1.0, Side::Right)] {
        let a = 12f32.to_radians();
        let up = Vector3::new(s * a.sin(), -a.cos(), 0.02).normalize();
        let b = 15f32.to_radians();
        let fore = Vector3::new(s * a.sin() * 0.9, -b.cos(), b.sin()).normalize();
        set_arm(&mut p, side, &up, &fore, &Vector3::new(s * 0.3, 0.0, -1.0));
    }
    p
}

/// Points an arm: the upper arm along `upper`, the forearm and hand along `fore`; the
/// elbow bends in the plane of the two, toward the forearm. When the arm is straight,
/// `pole` says where the elbow points (its back).
pub fn set_arm(
    p: &mut Pose,
    side: Side,
    upper: &Vector3<f32>,
    fore: &Vector3<f32>,
    pole: &Vector3<f32>,
) {
    let (ub, fb, hb) = side.bones();
    let c = ub.tpose_dir();
    let u = upper.normalize();
    let f = fore.normalize();
    let mut bend = f - u * u.dot(&f);
    if bend.norm() < 1e-3 {
        bend = -(pole - u * u.dot(pole));
        if bend.norm() < 1e-3 {
            bend = Vector3::z() - u * u.z;
            if bend.norm() < 1e-3 {
                bend = Vector3::y() - u * u.y;
            }
        }
    }
    let w1 = frame_to_frame(&c, &Vector3::z(), &u, &bend);
    let angle = u.dot(&f).clamp(-1.0, 1.0).acos();
    let axis = u.cross(&bend.normalize());
    let w2 = match Unit::try_new(axis, 1e-6) {
        Some(ax) => UnitQuaternion::from_axis_angle(&ax, angle) * w1,
        None => w1,
    };
    p.set(ub, w1);
    p.set(fb, w2);
    p.set(hb, w2);
}

/// Two-bone IK: bends the arm so the palm centre reaches `target` (body frame), or
/// points it straight at the target when out of reach. The elbow points toward `pole`.
pub fn arm_ik(
    sk: &TposeSkeleton,
    p: &mut Pose,
    side: Side,
    target: Point3<f32>,
    pole: &Vector3<f32>,
) {
    let (ub, fb, _) = side.bones();
    let heads = sk.posed_heads(p);
    let s = heads[ub.index()];
    let l1 = (sk.head(fb) - sk.head(ub)).norm();
    let l2 = (sk.joint(side.hand_joint()) - sk.head(fb)).norm();
    let to = target - s;
    let d = to.norm().clamp((l1 - l2).abs() + 1e-4, l1 + l2 - 1e-4);
    let dir = if to.norm() > 1e-6 {
        to / to.norm()
    } else {
        -Vector3::y()
    };
    let a = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d);
    let hgt = (l1 * l1 - a * a).max(0.0).sqrt();
    let mut perp = pole - dir * dir.dot(pole);
    if perp.norm() < 1e-4 {
        perp = -Vector3::y() - dir * dir.dot(&-Vector3::y());
        if perp.norm() < 1e-4 {
            perp = Vector3::z() - dir * dir.z;
        }
    }
    let perp = perp.normalize();
    let elbow = s + dir * a + perp * hgt;
    let hand = s + dir * d;
    set_arm(p, side, &(elbow - s), &(hand - elbow), pole);
}
