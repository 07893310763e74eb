//! Where the head joint (the top of the head) goes once the body is registered: the
//! template's top of the head, moved along the line from the neck's base to it, to the
//! height of the head's own highest points ([`head_top_at_its_points`]).
//!
//! The template's top of the head is MakeHuman's, a fixed distance above the neck. A
//! longer head or neck, or hair, puts the person's top higher; a shorter one lower. The
//! head's points say where it is: the highest of those the fitted body gives to its
//! head, measured along the line from the neck's base to the template's top, which
//! turns with the head (a bowed head is no different); along the head segment's own
//! axis the top came out about 2 cm low on every body (pose NOTES). Only the height is
//! taken from them: across the head and in depth the camera sees the front of the
//! head's top, and the template's midline is nearer the truth there.
//!
//! Like the hands' step, this moves only the published joint: the tracked body and the
//! next frame's start are the fit's.

use crate::body::{BodyTemplate, Posed, Segment};
use crate::register::{nearest_is, Placed};
use crate::view::Frame;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// Settings of where the head joint goes (part of [`crate::PoseConfig`]); metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HeadConfig {
    /// The head's points are looked for within this distance of the template's top of
    /// the head; 0 = the template's top is reported as it is.
    pub reach: f32,
    /// The top seen farther than this from the template's, along that line, is
    /// not the head's (a raised hand the fit gave to it, hair of no head's shape): the
    /// template's stays.
    pub max_shift: f32,
}

impl Default for HeadConfig {
    fn default() -> Self {
        Self {
            reach: 0.15,
            max_shift: 0.08,
        }
    }
}

/// The head's points needed to say where its top is: fewer, and the head is mostly out
/// of view or hidden.
const MIN_POINTS: usize = 30;
/// The top is the height of this many points from the highest (0 the highest): one
/// stray pixel above the head (a flying pixel at its edge) does not lift it.
const TOP_RANK: usize = 4;
/// Work pixels above the top that must not be the person's: a hand or an arm there
/// hides the head's top.
const CLEAR_ABOVE: usize = 3;

/// The top of the head of the body `posed` (its capsules `placed`) registered to
/// `frame`: the template's, moved along the line from the neck's base to the head's own
/// highest points where the camera sees them clearly. None where the template's stays:
/// too few points, the top cut by the image's edge or hidden by another part of the
/// person, or farther than [`HeadConfig::max_shift`].
pub fn head_top_at_its_points(
    frame: &Frame,
    template: &BodyTemplate,
    posed: &Posed,
    placed: &[Placed],
    cfg: &HeadConfig,
) -> Option<Point3<f32>> {
    if cfg.reach <= 0.0 {
        return None;
    }
    let crown = posed.point(Segment::Head, &template.crown);
    let neck = posed.joint[Segment::Head.index()];
    let up = (crown - neck).try_normalize(1e-6)?;
    let mut heights: Vec<(f32, usize)> = frame
        .pixels_near(&crown, cfg.reach)
        .filter(|&i| nearest_is(placed, &frame.points[i], Segment::Head))
        .map(|i| ((frame.points[i] - crown).dot(&up), i))
        .collect();
    if heights.len() < MIN_POINTS {
        return None;
    }
    let (_, top, _) = heights.select_nth_unstable_by(TOP_RANK, |a, b| b.0.total_cmp(&a.0));
    let (shift, idx) = *top;
    let hidden = frame.at_the_edge(idx) || covered_above(frame, placed, idx);
    (!hidden && shift.abs() <= cfg.max_shift).then(|| crown + up * shift)
}

/// Whether a pixel of the person's that the fitted body does not give to the head
/// lies in the [`CLEAR_ABOVE`] rows above pixel `idx` (or a pixel either side): a hand
/// or an arm over the head.
fn covered_above(frame: &Frame, placed: &[Placed], idx: usize) -> bool {
    let (u, v) = (idx % frame.width, idx / frame.width);
    (v.saturating_sub(CLEAR_ABOVE)..v).any(|y| {
        (u.saturating_sub(1)..(u + 2).min(frame.width)).any(|x| {
            let i = y * frame.width + x;
            frame.mask[i] && !nearest_is(placed, &frame.points[i], Segment::Head)
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::{BodyConfig, BodyPose, Limbs, Shape};
    use crate::register::place;
    use crate::view::testing::{facing, frame_of, rendered};
    use airglyph_core::Intrinsics;
    use nalgebra::{Rotation3, Vector3};

    /// The MakeHuman template with its head `lift` metres higher on its neck.
    fn template(lift: f32) -> BodyTemplate {
        let mut shape = Shape::makehuman();
        for c in shape
            .capsules
            .iter_mut()
            .filter(|c| c.segment == Segment::Head)
        {
            c.a[1] += lift;
            c.b[1] += lift;
        }
        BodyTemplate::from_shape(&shape, &Limbs::from_config(&BodyConfig::default()))
    }

    /// The top of the head reported for a body of `seen` drawn at `pose`, registered as
    /// the plain template at that pose; and the template's own top there.
    fn top_of(seen: &BodyTemplate, pose: &BodyPose) -> (Option<Point3<f32>>, Point3<f32>) {
        let k = Intrinsics::default().scaled_to(320, 240);
        let (points, mask) = rendered(seen, pose, &k);
        let fitted = template(0.0);
        let posed = Posed::new(&fitted, pose);
        let top = head_top_at_its_points(
            &frame_of(&points, &mask, &k),
            &fitted,
            &posed,
            &place(&fitted, &posed),
            &HeadConfig::default(),
        );
        (top, posed.point(Segment::Head, &fitted.crown))
    }

    #[test]
    fn a_head_higher_or_lower_on_its_neck_moves_the_top_by_as_much() {
        let pose = facing(Point3::new(0.0, 0.45, 1.2));
        let (level, crown) = top_of(&template(0.0), &pose);
        let level = level.expect("the head's top is in view");
        // The template's own head reaches its top within a centimetre.
        assert!((level - crown).norm() < 0.01, "{level:?} against {crown:?}");
        for lift in [-0.03, 0.04] {
            let (top, _) = top_of(&template(lift), &pose);
            let moved = top.expect("the head's top is in view") - level;
            // Up is the camera's -y; one work pixel is 4 mm at 1.2 m.
            assert!(
                (-moved.y - lift).abs() < 0.006 && moved.x.abs() < 1e-3,
                "lifted {lift}: moved {moved:?}"
            );
        }
        // Farther than the settings allow: not the head's shape, the template's top.
        assert_eq!(top_of(&template(0.10), &pose).0, None);
    }

    #[test]
    fn a_head_cut_by_the_image_s_edge_keeps_the_template_s_top() {
        // The template's top 2 cm beyond the image's top row, the person's 6 cm.
        let k = Intrinsics::default().scaled_to(320, 240);
        let (_, crown) = top_of(&template(0.0), &facing(Point3::new(0.0, 0.0, 1.2)));
        let edge = k.back_project(0.0, 0.0, crown.z).y;
        let pose = facing(Point3::new(0.0, edge - 0.02 - crown.y, 1.2));
        let (top, crown) = top_of(&template(0.04), &pose);
        assert!(k.project(&crown).is_some_and(|(_, v)| v < -4.0));
        assert_eq!(top, None);
    }

    #[test]
    fn a_forearm_laid_on_the_head_keeps_the_template_s_top() {
        let mut pose = facing(Point3::new(0.0, 0.45, 1.2));
        assert!(top_of(&template(0.0), &pose).0.is_some());
        // The left upper arm raised 20° off the vertical, the forearm from the elbow
        // across the top of the head.
        let r = pose.rotation[Segment::Chest.index()];
        let about_z = |deg: f32| Rotation3::from_axis_angle(&Vector3::z_axis(), deg.to_radians());
        pose.rotation[Segment::LeftUpperArm.index()] = about_z(-160.0) * r;
        pose.rotation[Segment::LeftForearm.index()] = about_z(119.0) * r;
        let (top, crown) = top_of(&template(0.0), &pose);
        let t = template(0.0);
        let posed = Posed::new(&t, &pose);
        let elbow = posed.skeleton(&t)[airglyph_core::Joint::LeftElbow];
        let over = elbow + (posed.rotation[Segment::LeftForearm.index()] * -Vector3::y()) * 0.29;
        // The forearm's axis a radius above the top of the head.
        assert!(
            over.x.abs() < 0.01 && (crown.y - over.y - 0.035).abs() < 0.01,
            "{over:?}"
        );
        assert_eq!(top, None);
    }
}
