//! What the camera can see of the person: where the image ends and what stands before
//! them. A body seen from the waist up, or behind a table, continues where the camera
//! cannot look; nothing there is evidence of where it is, and the estimate must neither
//! take the cut for a limb's end nor report what it could not see.

use airglyph_core::Intrinsics;
use nalgebra::Point3;

/// A surface this much nearer than a point of the body hides it, metres: a table before
/// the legs, a chair's arm before a hand. Nearer than this the surface may be what the
/// body touches (the floor under a foot, a table under a hand).
pub(crate) const OCCLUDER_GAP: f32 = 0.12;

/// How close to the image's edge (work pixels) the body counts as cut by it: the graph
/// leaves out the last pixels of a noisy edge, so a maximum stops short of it.
const BORDER_PX: usize = 4;

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
}

impl Frame<'_> {
    /// Whether the pixel shows something that is not the person, nearer than `z` by
    /// [`OCCLUDER_GAP`]: the body at depth `z` there would be hidden behind it.
    pub(crate) fn occluded(&self, idx: usize, z: f32) -> bool {
        let q = self.points[idx];
        !self.mask[idx] && q.z > 0.0 && q.z < z - OCCLUDER_GAP
    }

    /// Whether the person's pixel `idx` lies where the body is cut from view: at the
    /// image's edge, or beside something nearer that hides what continues (a geodesic
    /// maximum there is the end of what the camera sees, not of a limb).
    pub(crate) fn at_a_cut(&self, idx: usize) -> bool {
        let (u, v) = (idx % self.width, idx / self.width);
        if u < BORDER_PX
            || v < BORDER_PX
            || u + BORDER_PX >= self.width
            || v + BORDER_PX >= self.height
        {
            return true;
        }
        let z = self.points[idx].z;
        let r = BORDER_PX as isize + 1;
        (-r..=r).any(|dv| {
            (-r..=r).any(|du| {
                let (x, y) = (u as isize + du, v as isize + dv);
                let j = y as usize * self.width + x as usize;
                x >= 0
                    && y >= 0
                    && (x as usize) < self.width
                    && (y as usize) < self.height
                    && self.occluded(j, z)
            })
        })
    }

    /// Whether the camera could see any of `points`.
    pub(crate) fn sees_any(&self, points: impl IntoIterator<Item = Point3<f32>>) -> bool {
        points.into_iter().any(|p| self.sees(&p))
    }

    /// Whether a joint at `p` (camera frame) is in the camera's view: it projects inside
    /// the image and nothing that is not the person stands before it there. A joint
    /// hidden only by the person's own body is in view.
    pub(crate) fn sees(&self, p: &Point3<f32>) -> bool {
        let Some((u, v)) = self.k.project(p) else {
            return false;
        };
        let (u, v) = (u.round(), v.round());
        if u < 0.0 || v < 0.0 || u >= self.width as f32 || v >= self.height as f32 {
            return false;
        }
        !self.occluded(v as usize * self.width + u as usize, p.z)
    }
}
