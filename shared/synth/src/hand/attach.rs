//! Where a hand is in a frame: the hand's frame hung from the body's hand bone, the
//! scene's turn of the wrist, and the hand's ground truth.

use super::shape::palm_centre;
use super::{HandPosture, HandSpec, HandTruth, Hands, SIDES};
use crate::body::Affine;
use crate::canon::Pose;
use crate::poses::Side;
use nalgebra::{Matrix3, Point3, Rotation3, Unit, UnitQuaternion, Vector3};

/// The hand frame's axes (columns `a`, `b`, `c`; see `shape`) in the body frame of the
/// canonical T-pose, palms down, thumbs forward: a rotation for the left hand, a
/// reflection for the right, whose hand is the left's mirror image.
pub(crate) fn tpose_axes(side: Side) -> Matrix3<f32> {
    let along = side.bones().2.tpose_dir();
    Matrix3::from_columns(&[along, Vector3::z(), -Vector3::y()])
}

/// The scene's turn of one wrist as a rotation of the hand bone in the T-pose's body
/// frame. Defined in the hand's frame, so that the same angles turn either hand the
/// mirror way: roll first (about the fingers' axis, as the forearm turns), then pitch
/// about the axis across the palm.
fn wrist_turn(side: Side, spec: &HandSpec) -> UnitQuaternion<f32> {
    let roll = Rotation3::from_axis_angle(&-Vector3::x_axis(), spec.roll_deg.to_radians());
    let pitch = Rotation3::from_axis_angle(&-Vector3::y_axis(), spec.pitch_deg.to_radians());
    let b = tpose_axes(side);
    // b is orthogonal (a rotation or a reflection): b·R·bᵀ is a rotation either way.
    let m = b * (roll * pitch).matrix() * b.transpose();
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

/// Turns each hand bone of `pose` by the scene's roll and pitch; a hand with neither is
/// left exactly as it was.
pub(crate) fn turn_wrists(pose: &mut Pose, hands: &Hands<HandSpec>) {
    for side in SIDES {
        let spec = hands.get(side);
        if spec.turns_wrist() {
            let bone = side.bones().2;
            pose.set(bone, pose.get(bone) * wrist_turn(side, spec));
        }
    }
}

/// A hand's frame in the camera frame for one frame: the wrist and the axes `a`, `b`,
/// `c` of the hand's frame as columns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Placed {
    pub wrist: Point3<f32>,
    pub axes: Matrix3<f32>,
}

impl Placed {
    /// The hand of `side` at `wrist` (camera frame), turned as the pose turns its hand
    /// bone, seen through `camera` (body to camera frame).
    pub fn new(side: Side, pose: &Pose, camera: &Affine, wrist: Point3<f32>) -> Self {
        let rot = pose.get(side.bones().2).to_rotation_matrix();
        Self {
            wrist,
            axes: camera.m * rot.matrix() * tpose_axes(side),
        }
    }

    /// A point of the hand's frame in the camera frame.
    #[inline]
    pub fn point(&self, local: &Vector3<f32>) -> Point3<f32> {
        self.wrist + self.axes * local
    }

    /// The hand's truth, with the fingertips of the procedural hand if it is drawn.
    pub fn truth(
        &self,
        posture: Option<HandPosture>,
        length_m: f32,
        fingertips: Option<&[Vector3<f32>; 5]>,
    ) -> HandTruth {
        let unit = |v: Vector3<f32>| Unit::new_normalize(v).into_inner();
        HandTruth {
            posture,
            wrist: self.wrist,
            palm_centre: self.point(&palm_centre(length_m)),
            palm_normal: unit(self.axes.column(2).into()),
            finger_dir: unit(self.axes.column(0).into()),
            thumb_side: unit(self.axes.column(1).into()),
            length_m,
            fingertips: fingertips.map(|f| f.map(|p| self.point(&p))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positive roll turns the palm towards the thumb, positive pitch the fingers
    /// towards the palm, on either hand.
    #[test]
    fn the_wrist_turns_the_same_way_on_either_hand() {
        for side in SIDES {
            let b = tpose_axes(side);
            let (a, t, c) = (b.column(0), b.column(1), b.column(2));
            let roll = wrist_turn(
                side,
                &HandSpec {
                    roll_deg: 90.0,
                    ..HandSpec::default()
                },
            );
            assert!((roll * c - t).norm() < 1e-5, "{side:?} roll");
            let pitch = wrist_turn(
                side,
                &HandSpec {
                    pitch_deg: 90.0,
                    ..HandSpec::default()
                },
            );
            assert!((pitch * a - c).norm() < 1e-5, "{side:?} pitch");
        }
    }
}
