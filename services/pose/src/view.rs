//! What the camera can see of the person: where the image ends and what stands before
//! them. A body seen from the waist up, or behind a table, continues where the camera
//! cannot look; nothing there is evidence of where it is, and the estimate must neither
//! take the cut for a limb's end nor report what it could not see.

use crate::geom::Rigid;
use crate::segment::Plane;
use airglyph_core::Intrinsics;
use nalgebra::{Point3, Vector3};

/// A surface this much nearer than a point of the body hides it, metres: a table before
/// the legs, a chair's arm before a hand. Nearer than this the surface may be what the
/// body touches (the floor under a foot, a table under a hand).
pub(crate) const OCCLUDER_GAP: f32 = 0.12;

/// A point this far under the floor the segmentation removed (a table top it took for
/// the floor) is hidden by it, metres; nearer, it is what rests on it.
const UNDER_THE_FLOOR: f32 = 0.05;

/// How close to the image's edge (work pixels) the body counts as cut by it: the graph
/// leaves out the last pixels of a noisy edge, so a maximum stops short of it.
const BORDER_PX: usize = 4;

/// A table top the segmentation took for the floor, over a leg whose hip is under it
/// ([`Frame::table_top_over`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TableTop(Plane);

impl TableTop {
    /// How far a leg's surface of radius `radius` around its axis point `x` rises into
    /// the top, metres (at most 0: under it, with room to spare).
    pub(crate) fn rise(&self, x: &Point3<f32>, radius: f32) -> f32 {
        self.0.height(x) + radius + UNDER_THE_FLOOR
    }

    /// The top's upward normal, camera frame.
    pub(crate) fn up(&self) -> Vector3<f32> {
        self.0.n
    }
}

/// What lies behind the torso's back of a body facing the camera and cut short of its
/// feet: the chair's, not the person's.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ChairBehind {
    /// Camera frame to torso frame (z forward).
    into_torso: Rigid,
    /// How far behind the torso's origin the chair begins, metres.
    back: f32,
}

impl ChairBehind {
    /// Behind the back of the torso at `torso` (torso frame to camera frame), `back`
    /// metres behind its origin.
    pub(crate) fn of(torso: &Rigid, back: f32) -> Self {
        Self {
            into_torso: torso.inverse(),
            back,
        }
    }

    /// Whether `p` (camera frame) lies there.
    pub(crate) fn holds(&self, p: &Point3<f32>) -> bool {
        self.into_torso.apply(p).z < -self.back
    }
}

/// The frame the steps work on: the work image's organized point cloud (z = 0: no
/// data) and the person's mask.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    /// Every pixel's point, camera frame.
    pub points: &'a [Point3<f32>],
    /// Whether each pixel is the person's.
    pub mask: &'a [bool],
    /// The work image's size.
    pub width: usize,
    /// The work image's size.
    pub height: usize,
    /// The camera, at the work image's size.
    pub k: &'a Intrinsics,
    /// The floor the segmentation took out of `points` (or a table top it took for
    /// the floor): its pixels have no point, but the surface is there.
    pub floor: Option<Plane>,
}

impl Frame<'_> {
    /// Whether the pixel shows something that is not the person, nearer than `z` by
    /// [`OCCLUDER_GAP`]: the body at depth `z` there would be hidden behind it.
    pub(crate) fn occluded(&self, idx: usize, z: f32) -> bool {
        if self.mask[idx] {
            return false;
        }
        let q = self.points[idx];
        if q.z > 0.0 {
            return q.z < z - OCCLUDER_GAP;
        }
        // No point: perhaps the floor the segmentation removed, or a table top taken
        // for it. Legs under a table are hidden by its top, not missing from the
        // frame; a foot on the floor is not under it.
        self.floor.is_some_and(|pl| {
            let (u, v) = ((idx % self.width) as f32, (idx / self.width) as f32);
            pl.d > 0.0 && pl.height(&self.k.back_project(u, v, z)) < -UNDER_THE_FLOOR
        })
    }

    /// Whether the person's pixel `idx` lies where the body is cut from view: at the
    /// image's edge, or beside something nearer that hides what continues (a geodesic
    /// maximum there is the end of what the camera sees, not of a limb).
    pub(crate) fn at_a_cut(&self, idx: usize) -> bool {
        if self.at_the_edge(idx) {
            return true;
        }
        let (u, v) = (idx % self.width, idx / self.width);
        let z = self.points[idx].z;
        let r = BORDER_PX as isize + 1;
        (-r..=r).any(|dv| {
            (-r..=r).any(|du| {
                let (x, y) = (u as isize + du, v as isize + dv);
                x >= 0
                    && y >= 0
                    && (x as usize) < self.width
                    && (y as usize) < self.height
                    && self.occluded(y as usize * self.width + x as usize, z)
            })
        })
    }

    /// The person's pixels whose points lie within `reach` of `at`, searched in the
    /// image box its sphere projects into.
    pub(crate) fn pixels_near<'f>(
        &'f self,
        at: &Point3<f32>,
        reach: f32,
    ) -> impl Iterator<Item = usize> + 'f {
        let (w, h) = (self.width, self.height);
        let window = self.k.project(at).filter(|_| at.z > reach).map(|(u, v)| {
            let r = (reach * self.k.fx.max(self.k.fy) / (at.z - reach)).ceil();
            let clamp = |x: f32, hi: usize| (x.max(0.0) as usize).min(hi);
            (
                clamp(u - r, w),
                clamp(u + r + 1.0, w),
                clamp(v - r, h),
                clamp(v + r + 1.0, h),
            )
        });
        let (u0, u1, v0, v1) = window.unwrap_or((0, 0, 0, 0));
        let at = *at;
        (v0..v1)
            .flat_map(move |v| (u0..u1).map(move |u| v * w + u))
            .filter(move |&i| {
                let p = self.points[i];
                self.mask[i] && p.z > 0.0 && (p - at).norm_squared() < reach * reach
            })
    }

    /// Whether pixel `idx` lies in the image's last [`BORDER_PX`] pixels.
    pub(crate) fn at_the_edge(&self, idx: usize) -> bool {
        let (u, v) = (idx % self.width, idx / self.width);
        u < BORDER_PX
            || v < BORDER_PX
            || u + BORDER_PX >= self.width
            || v + BORDER_PX >= self.height
    }

    /// The table top the segmentation took for the floor, if the hip at `hip` lies
    /// under it (None: no such top, or the hip is not under it). A seated person's
    /// knees stay under the table their hips are under; with nothing else holding a leg
    /// out of view, it would fold up through the top to explain the forearms lying on
    /// it.
    pub(crate) fn table_top_over(&self, hip: &Point3<f32>) -> Option<TableTop> {
        let top = self.floor.filter(|pl| pl.d > 0.0)?;
        (top.height(hip) < -UNDER_THE_FLOOR).then_some(TableTop(top))
    }

    /// Whether the camera could see any of `points`.
    pub(crate) fn sees_any(&self, points: impl IntoIterator<Item = Point3<f32>>) -> bool {
        points.into_iter().any(|p| self.sees(&p))
    }

    /// The pixel `p` (camera frame) projects onto, if inside the image.
    fn pixel_of(&self, p: &Point3<f32>) -> Option<usize> {
        let (u, v) = self.k.project(p)?;
        let (u, v) = (u.round(), v.round());
        let inside = u >= 0.0 && v >= 0.0 && u < self.width as f32 && v < self.height as f32;
        inside.then(|| v as usize * self.width + u as usize)
    }

    /// Whether a joint at `p` (camera frame) is shown to the camera: it sees it, and
    /// not in the image's last pixels, which the graph leaves out of a noisy edge (a
    /// joint fitted there is where the body runs out of the image, not where it was
    /// seen).
    pub(crate) fn shows(&self, p: &Point3<f32>) -> bool {
        self.pixel_of(p)
            .is_some_and(|idx| !self.at_the_edge(idx) && !self.occluded(idx, p.z))
    }

    /// Whether `p` (camera frame) projects onto the person's own pixels with their
    /// surface nearer than it by [`OCCLUDER_GAP`]: a joint the body itself hides.
    pub(crate) fn behind_the_person(&self, p: &Point3<f32>) -> bool {
        self.pixel_of(p).is_some_and(|idx| {
            let q = self.points[idx];
            self.mask[idx] && q.z > 0.0 && q.z < p.z - OCCLUDER_GAP
        })
    }

    /// Whether the camera sees through `p` (camera frame): where it projects, nothing
    /// of the person, or no depth at all. A body part at `p` would have shown there.
    pub(crate) fn sees_through(&self, p: &Point3<f32>) -> bool {
        self.pixel_of(p).is_some_and(|idx| {
            let q = self.points[idx];
            q.z <= 0.0 || !self.mask[idx] && q.z > p.z
        })
    }

    /// Whether a joint at `p` (camera frame) is in the camera's view: it projects inside
    /// the image and nothing that is not the person stands before it there. A joint
    /// hidden only by the person's own body is in view.
    pub(crate) fn sees(&self, p: &Point3<f32>) -> bool {
        self.pixel_of(p).is_some_and(|idx| !self.occluded(idx, p.z))
    }
}

#[cfg(test)]
pub(crate) mod testing {
    //! Frames for the steps' unit tests.
    use super::Frame;
    use crate::body::{BodyPose, BodyTemplate, Posed, Segment};
    use airglyph_core::Intrinsics;
    use nalgebra::{Point3, Rotation3, Vector3};

    /// A frame of 320×240 whose columns are the person's where `person` says so, at
    /// `person_z` metres, and elsewhere something at `other_z`: its points and mask.
    pub(crate) fn columns(
        person: impl Fn(usize) -> bool,
        person_z: f32,
        other_z: f32,
    ) -> (Vec<Point3<f32>>, Vec<bool>, Intrinsics) {
        let k = Intrinsics::default().scaled_to(320, 240);
        let (w, h) = (k.width as usize, k.height as usize);
        let mut points = vec![Point3::origin(); w * h];
        let mut mask = vec![false; w * h];
        for v in 0..h {
            for u in 0..w {
                let z = if person(u) { person_z } else { other_z };
                points[v * w + u] = k.back_project(u as f32, v as f32, z);
                mask[v * w + u] = person(u);
            }
        }
        (points, mask, k)
    }

    /// The template's own surface seen by the camera `k` at `pose`: dense points on every
    /// capsule splatted into a z-buffer.
    pub(crate) fn rendered(
        t: &BodyTemplate,
        pose: &BodyPose,
        k: &Intrinsics,
    ) -> (Vec<Point3<f32>>, Vec<bool>) {
        let (w, h) = (k.width as usize, k.height as usize);
        let mut points = vec![Point3::origin(); w * h];
        let mut mask = vec![false; w * h];
        let posed = Posed::new(t, pose);
        for c in &t.capsules {
            let a = posed.point(c.segment, &c.a);
            let b = posed.point(c.segment, &c.b);
            let axis = b - a;
            let len = axis.norm();
            let along = axis / len.max(1e-6);
            let side = along
                .cross(&Vector3::z())
                .try_normalize(1e-6)
                .unwrap_or(Vector3::x());
            let up = along.cross(&side);
            // Rings 4 mm apart, the caps too: past both ends by a radius.
            let reach = c.ra.max(c.rb);
            let rings = ((len + 2.0 * reach) / 0.004).ceil() as usize;
            for i in 0..=rings {
                let s = i as f32 * 0.004 - reach;
                for j in 0..120 {
                    let th = std::f32::consts::TAU * j as f32 / 120.0;
                    let tt = (s / len.max(1e-6)).clamp(0.0, 1.0);
                    let r = c.ra + (c.rb - c.ra) * tt;
                    let dir = side * th.cos() + up * th.sin();
                    // Past the ends, the cap's sphere.
                    let beyond = s - tt * len;
                    if beyond.abs() > r {
                        continue;
                    }
                    let rr = (r * r - beyond * beyond).sqrt();
                    let p = a + along * s + dir * rr;
                    let Some((u, v)) = k.project(&p) else {
                        continue;
                    };
                    let (u, v) = (u.round() as i64, v.round() as i64);
                    if u < 0 || v < 0 || u >= w as i64 || v >= h as i64 {
                        continue;
                    }
                    let i = v as usize * w + u as usize;
                    if !mask[i] || p.z < points[i].z {
                        points[i] = p;
                        mask[i] = true;
                    }
                }
            }
        }
        (points, mask)
    }

    /// A body standing facing the camera, arms hanging, its pelvis at `pelvis`.
    pub(crate) fn facing(pelvis: Point3<f32>) -> BodyPose {
        let r = Rotation3::from_basis_unchecked(&[Vector3::x(), -Vector3::y(), -Vector3::z()]);
        BodyPose {
            pelvis,
            rotation: [r; Segment::COUNT],
        }
    }

    /// The frame of `points` and `mask` seen by `k`, no floor taken out.
    pub(crate) fn frame_of<'a>(
        points: &'a [Point3<f32>],
        mask: &'a [bool],
        k: &'a Intrinsics,
    ) -> Frame<'a> {
        Frame {
            points,
            mask,
            width: k.width as usize,
            height: k.height as usize,
            k,
            floor: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::testing::{columns, frame_of};
    use super::*;
    use nalgebra::Vector3;

    /// A table top 0.3 m below the camera, taken out of the frame as its floor: every
    /// pixel has no point and none is the person's.
    fn under_a_table_top() -> (Vec<Point3<f32>>, Vec<bool>, Intrinsics, Plane) {
        let k = Intrinsics::default().scaled_to(320, 240);
        let n = (k.width * k.height) as usize;
        // Up is −y in the camera frame; the plane y = 0.3.
        let top = Plane {
            n: -Vector3::y(),
            d: 0.3,
        };
        (vec![Point3::origin(); n], vec![false; n], k, top)
    }

    #[test]
    fn what_lies_under_the_floor_taken_out_is_hidden_and_what_rests_on_it_is_not() {
        let (points, mask, k, top) = under_a_table_top();
        let frame = |floor| Frame {
            floor,
            ..frame_of(&points, &mask, &k)
        };
        // A knee 0.15 m under the top, 1.6 m away; a hand on it; a head above it.
        let knee = Point3::new(0.1, 0.45, 1.6);
        let hand = Point3::new(0.1, 0.28, 1.0);
        let head = Point3::new(0.0, -0.3, 1.4);
        let f = frame(Some(top));
        assert!(!f.sees(&knee));
        assert!(f.sees(&hand));
        assert!(f.sees(&head));
        // Without the floor, a pixel without a point hides nothing.
        assert!(frame(None).sees(&knee));
        // A camera under the plane (a ceiling, not a floor) is not looking at its top.
        let ceiling = Plane { n: top.n, d: -0.3 };
        assert!(frame(Some(ceiling)).sees(&Point3::new(0.0, -0.4, 1.6)));
    }

    #[test]
    fn a_joint_behind_the_persons_own_surface_is_told_from_one_on_it() {
        // The person's surface 1 m away over the image's middle; the wall 3 m behind.
        let (points, mask, k) = columns(|u| (100..220).contains(&u), 1.0, 3.0);
        let f = frame_of(&points, &mask, &k);
        let at = |u: f32, z: f32| k.back_project(u, 120.0, z);
        assert!(f.behind_the_person(&at(160.0, 1.4)));
        // On the surface, or nearer than the gap behind it: the joint's own pixels.
        assert!(!f.behind_the_person(&at(160.0, 1.05)));
        // Behind the wall's pixels, not the person's; outside the image.
        assert!(!f.behind_the_person(&at(40.0, 3.5)));
        assert!(!f.behind_the_person(&Point3::new(5.0, 0.0, 1.4)));
    }

    #[test]
    fn a_joint_the_camera_sees_through_is_told_from_one_on_or_behind_the_person() {
        // The person's surface 1 m away over the image's middle, but a hole without
        // depth in it; the wall 3 m behind.
        let (mut points, mask, k) = columns(|u| (100..220).contains(&u), 1.0, 3.0);
        points[120 * k.width as usize + 200] = Point3::origin();
        let f = frame_of(&points, &mask, &k);
        let at = |u: f32, z: f32| k.back_project(u, 120.0, z);
        // Beside the person, before the wall: the wall shows where it would be.
        assert!(f.sees_through(&at(40.0, 1.2)));
        // Where the person shows no depth.
        assert!(f.sees_through(&at(200.0, 1.2)));
        // On the person's surface, or hidden behind it.
        assert!(!f.sees_through(&at(160.0, 1.05)));
        assert!(!f.sees_through(&at(160.0, 1.4)));
        // Behind the wall: hidden by it, not seen through; outside the image.
        assert!(!f.sees_through(&at(40.0, 3.5)));
        assert!(!f.sees_through(&Point3::new(5.0, 0.0, 1.4)));
    }

    #[test]
    fn a_joint_in_the_images_last_pixels_is_not_shown() {
        // The person 1 m away over the whole image.
        let (points, mask, k) = columns(|_| true, 1.0, 3.0);
        let f = frame_of(&points, &mask, &k);
        let at = |u: f32, v: f32| k.back_project(u, v, 1.05);
        let last = (f.height - 1) as f32;
        assert!(f.shows(&at(160.0, 120.0)));
        assert!(f.shows(&at(160.0, last - BORDER_PX as f32 - 1.0)));
        // Seen, but where the body runs out of the image.
        assert!(f.sees(&at(160.0, last - 1.0)));
        assert!(!f.shows(&at(160.0, last - 1.0)));
        assert!(!f.shows(&at(1.0, 120.0)));
        assert!(!f.shows(&at(160.0, last + 3.0)));
    }

    #[test]
    fn a_cut_is_looked_for_up_to_the_images_edge() {
        // The person 1 m away over the whole image but its first columns, where
        // something nearer stands: pixels just inside the border are beside it, and
        // the neighbourhood searched around them reaches past the image's first column.
        let (points, mask, k) = columns(|u| u >= 2, 1.0, 0.6);
        let f = frame_of(&points, &mask, &k);
        let (w, h) = (f.width, f.height);
        for v in [BORDER_PX, h / 2, h - BORDER_PX - 1] {
            assert!(
                f.at_a_cut(v * w + BORDER_PX),
                "row {v}, by the nearer thing"
            );
        }
        assert!(!f.at_a_cut(h / 2 * w + w / 2), "the middle of the person");
    }

    #[test]
    fn a_leg_whose_hip_is_under_the_table_top_stays_under_it() {
        let (points, mask, k, top) = under_a_table_top();
        let f = Frame {
            floor: Some(top),
            ..frame_of(&points, &mask, &k)
        };
        let r = 0.06;
        // Seated: the hip 0.2 m under the top (y = 0.5).
        let hip = Point3::new(0.1, 0.5, 1.5);
        // A knee under the top with room for its surface: nothing to undo.
        let top = f.table_top_over(&hip).expect("the hip is under the top");
        let under = top.rise(&Point3::new(0.1, 0.45, 1.1), r);
        assert!(under < 0.0, "{under:?}");
        // A knee folded up onto the top, as if to explain a forearm lying on it: its
        // surface is inside the top by its radius, the margin and 2 cm above it.
        let through = top.rise(&Point3::new(0.1, 0.28, 1.1), r);
        assert!(
            (through - (0.02 + r + UNDER_THE_FLOOR)).abs() < 1e-5,
            "{through}"
        );
        // Standing behind a low table, the hip above it: the legs are not held.
        let standing = Point3::new(0.1, 0.25, 1.5);
        assert!(f.table_top_over(&standing).is_none());
        // No floor or table top taken out: nothing holds the legs.
        let bare = Frame { floor: None, ..f };
        assert!(bare.table_top_over(&hip).is_none());
    }
}
