//! Whether the camera showed a leg's knee and foot. A joint that projects into view was
//! not yet seen: the fit puts a leg's knee and foot somewhere even when nothing of the
//! leg's end was in the frame (legs below the image's edge, under a table, a seated
//! person's thighs pointing at the camera). A leg shows its foot only when its end in
//! view could be a foot, and its knee only when the leg has an end and a hip in view and
//! its end is no cut nearer the hip than the knee.

use crate::view::{ChairBehind, Frame};
use crate::Limb;
use airglyph_core::{Joint, Skeleton};
use nalgebra::{Point3, Vector3};

/// The share of the fitted leg's length within which a leg's end in view, near the
/// hip's height, is no foot: a seated thigh is about half the leg, a foot a whole
/// leg's geodesic reach (more, over the surface).
const SHORT_REACH: f32 = 0.75;

/// How near the fitted foot must lie to the point where the image's edge (or a table)
/// cuts its leg, metres, for the cut to take only its toes: a foot's length.
const FOOT_BY_ITS_CUT: f32 = 0.2;

/// The end of a leg the frame showed: the geodesic maximum assigned to it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LegEnd {
    /// Where it lies, camera frame.
    pub at: Point3<f32>,
    /// Whether it lies where the body is cut from view (the image's edge, a table).
    pub cut: bool,
    /// Its geodesic distance from the leg's root, metres.
    pub reach: f32,
}

/// Which of its own joints a leg showed the camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LegSeen {
    /// The knee.
    pub knee: bool,
    /// The foot.
    pub foot: bool,
}

/// What the camera showed of the leg `leg` of the fitted `skeleton`: its end in view
/// (`None`: the leg got no geodesic maximum), whether its hip is in view (`rooted`),
/// the torso's `up` (camera frame), and where a chair stands behind the person, if it
/// may. Only knee and foot are judged; the hip is the torso's.
pub(crate) fn leg_seen(
    leg: Limb,
    skeleton: &Skeleton,
    end: Option<LegEnd>,
    rooted: bool,
    up: &Vector3<f32>,
    frame: &Frame,
    chair: Option<&ChairBehind>,
) -> LegSeen {
    let (hip_joint, knee_joint, foot_joint) = leg.joints();
    let joint = |j: Joint| skeleton.joints[j.index()];
    let (hip, foot) = (joint(hip_joint), joint(foot_joint));
    let thigh = knee_joint.map_or(0.0, |knee| (joint(knee) - hip).norm());
    let length = knee_joint.map_or(0.0, |knee| thigh + (foot - joint(knee)).norm());
    // A leg with no maximum of its own showed the camera no end at all: its foot and
    // knee are where the fit put them (a thigh bent back into the image to take an
    // arm's points), not where anything was seen. Nor does a leg whose hip lies where
    // the camera cannot look show anything of its own: its knee and foot are the
    // template's guess. (Not so for an arm: the geodesic length of an arm hanging
    // beside the torso says too little of where along it the image's edge cuts it.)
    let Some(end) = end.filter(|_| rooted) else {
        return LegSeen {
            knee: false,
            foot: false,
        };
    };
    // A leg cut from view (the image's edge, a table) nearer its hip than the fitted
    // thigh is long did not show its knee: a seated person's thigh, pointing at the
    // camera, cut by the image's lower edge, with the knee the fit put inside it. (In
    // a straight line: the geodesic reach runs over the belly and the thigh's curve.)
    let knee_cut_off = end.cut && (end.at - hip).norm() < thigh;
    LegSeen {
        knee: knee_joint.is_some_and(|k| skeleton.visible[k.index()]) && !knee_cut_off,
        foot: skeleton.visible[foot_joint.index()]
            && foot_seen(&end, &hip, &foot, length, up, frame, chair),
    }
}

/// Whether the leg's `end` in view is its foot, fitted at `foot`.
fn foot_seen(
    end: &LegEnd,
    hip: &Point3<f32>,
    foot: &Point3<f32>,
    length: f32,
    up: &Vector3<f32>,
    frame: &Frame,
    chair: Option<&ChairBehind>,
) -> bool {
    let below_hip = |p: &Point3<f32>| (hip - p).dot(up);
    let near_hip_height = below_hip(&end.at) < 0.5 * length;
    if end.cut {
        // A leg whose farthest point lies where the body is cut from view goes on
        // beyond the cut: its foot was not seen, wherever the fit put it; unless the
        // cut lies farther along the body than the fitted leg is long, most of a leg
        // below the hip, and the fitted foot beside it, when only the toes are cut. (A
        // cut beside the hip reached the long way round, through the torso, is another
        // limb's.)
        return end.reach >= length
            && (foot - end.at).norm() <= FOOT_BY_ITS_CUT
            && !near_hip_height;
    }
    if !near_hip_height {
        return true;
    }
    // An end in view near the hip's height is a foot only in a kick, a whole leg's
    // reach away, on its own pixels. Within a thigh's reach it is a seated person's
    // knee, or a hand hanging beside the hip or lying in the lap taken for the leg: a
    // foot the fit put behind the person there, or near the hip's height itself (on
    // the thighs), was not seen. Nor was one the camera sees through (past it to
    // something farther, or nothing at all), nor the end of one that lies behind the
    // torso's back (the chair's, as the registration took it).
    let short = end.reach < SHORT_REACH * length;
    let unseen = short && (frame.behind_the_person(foot) || below_hip(foot) < 0.5 * length)
        || frame.sees_through(foot)
        || chair.is_some_and(|c| c.holds(&end.at));
    !unseen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Rigid;
    use crate::view::testing::{columns, frame_of};
    use airglyph_core::Intrinsics;
    use nalgebra::{Rotation3, Vector3};

    /// A 320×240 frame whose columns 100–219 are the person's surface 1 m away, the
    /// rest a wall 3 m away: its points and mask.
    fn person_before_a_wall() -> (Vec<Point3<f32>>, Vec<bool>, Intrinsics) {
        columns(|u| (100..220).contains(&u), 1.0, 3.0)
    }

    /// A left leg standing down from its hip at (0.1, 0, 1) m (camera frame, y down),
    /// its knee 0.4 m below, its foot at `foot`; every joint in view.
    fn left_leg(foot: Point3<f32>) -> Skeleton {
        let mut s = Skeleton::new([Point3::origin(); Joint::COUNT]);
        s.set(Joint::LeftHip, Point3::new(0.1, 0.0, 1.0));
        s.set(Joint::LeftKnee, Point3::new(0.1, 0.4, 1.0));
        s.set(Joint::LeftFoot, foot);
        s
    }

    const UP: Vector3<f32> = Vector3::new(0.0, -1.0, 0.0);

    fn end(at: [f32; 3], cut: bool, reach: f32) -> Option<LegEnd> {
        Some(LegEnd {
            at: Point3::new(at[0], at[1], at[2]),
            cut,
            reach,
        })
    }

    #[test]
    fn a_foot_at_the_legs_end_below_the_hip_is_seen_and_a_leg_without_end_or_hip_is_not() {
        let (points, mask, k) = person_before_a_wall();
        let frame = frame_of(&points, &mask, &k);
        let s = left_leg(Point3::new(0.1, 0.8, 1.0));
        let seen = |end, rooted| leg_seen(Limb::LeftLeg, &s, end, rooted, &UP, &frame, None);
        let both = LegSeen {
            knee: true,
            foot: true,
        };
        let neither = LegSeen {
            knee: false,
            foot: false,
        };
        assert_eq!(seen(end([0.1, 0.82, 1.0], false, 0.9), true), both);
        assert_eq!(seen(None, true), neither);
        assert_eq!(seen(end([0.1, 0.82, 1.0], false, 0.9), false), neither);
    }

    #[test]
    fn a_leg_cut_from_view_shows_its_foot_only_when_the_cut_takes_the_toes() {
        let (points, mask, k) = person_before_a_wall();
        let frame = frame_of(&points, &mask, &k);
        let s = left_leg(Point3::new(0.1, 0.8, 1.0));
        let foot = |end| leg_seen(Limb::LeftLeg, &s, end, true, &UP, &frame, None).foot;
        // Cut at the toes, beside the fitted foot, a whole leg along the body.
        assert!(foot(end([0.1, 0.85, 1.0], true, 0.9)));
        // Cut at the thigh: the foot beyond it is the fit's guess.
        assert!(!foot(end([0.1, 0.3, 1.0], true, 0.3)));
        // Cut beside the hip, reached the long way round: another limb's.
        assert!(!foot(end([0.3, 0.05, 1.0], true, 0.9)));
    }

    #[test]
    fn a_leg_cut_from_view_shows_its_knee_only_when_the_cut_lies_past_it() {
        let (points, mask, k) = person_before_a_wall();
        let frame = frame_of(&points, &mask, &k);
        let s = left_leg(Point3::new(0.1, 0.8, 1.0));
        let knee = |end| leg_seen(Limb::LeftLeg, &s, end, true, &UP, &frame, None).knee;
        // Cut at the shin, past the knee 0.4 m below the hip.
        assert!(knee(end([0.1, 0.6, 1.0], true, 0.6)));
        // Cut at the thigh: the knee in view is the fit's guess. The geodesic reach
        // over the belly is no measure of where along the leg the cut lies.
        assert!(!knee(end([0.1, 0.25, 1.0], true, 0.5)));
        // An end not at a cut: the knee in view is judged by the view alone.
        assert!(knee(end([0.1, 0.25, 1.0], false, 0.5)));
    }

    #[test]
    fn an_end_at_the_hips_height_is_no_foot_where_nothing_shows_one() {
        let (points, mask, k) = person_before_a_wall();
        let frame = frame_of(&points, &mask, &k);
        let foot = |foot: [f32; 3], reach| {
            let s = left_leg(Point3::new(foot[0], foot[1], foot[2]));
            // The leg's end beside the hip, at its height: a hand hanging there.
            let end = end([0.25, 0.02, 1.0], false, reach);
            leg_seen(Limb::LeftLeg, &s, end, true, &UP, &frame, None).foot
        };
        // Fitted behind the person, within a thigh's reach: not seen; a whole leg's
        // reach away (a kick), the rule does not judge it.
        assert!(!foot([0.1, 0.45, 1.4], 0.3));
        assert!(foot([0.1, 0.45, 1.4], 1.0));
        // Fitted on the thighs, at the hip's height, before the person's surface.
        assert!(!foot([0.1, 0.05, 0.8], 0.3));
        assert!(foot([0.1, 0.05, 0.8], 1.0));
        // Fitted where the camera sees the wall: not seen at any reach.
        assert!(!foot([-0.5, 0.45, 1.2], 1.0));
    }

    #[test]
    fn an_end_at_the_hips_height_behind_the_torsos_back_is_the_chairs() {
        let (points, mask, k) = person_before_a_wall();
        let frame = frame_of(&points, &mask, &k);
        let s = left_leg(Point3::new(0.1, 0.45, 1.0));
        // A torso 1 m away facing the camera (its z towards it), its back 0.15 m
        // behind its origin.
        let torso = Rigid {
            r: Rotation3::from_axis_angle(&Vector3::y_axis(), std::f32::consts::PI),
            t: Vector3::new(0.0, 0.0, 1.0),
        };
        let chair = ChairBehind::of(&torso, 0.15);
        let foot = |at, chair: Option<&ChairBehind>| {
            let end = end(at, false, 1.2);
            leg_seen(Limb::LeftLeg, &s, end, true, &UP, &frame, chair).foot
        };
        assert!(!foot([0.25, 0.0, 1.3], Some(&chair)));
        // Not behind the back, or no chair where the person may be seen whole.
        assert!(foot([0.25, 0.0, 1.1], Some(&chair)));
        assert!(foot([0.25, 0.0, 1.3], None));
    }
}
