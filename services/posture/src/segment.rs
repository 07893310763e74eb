//! The hand's pixels around a hand joint: a window sized from the joint's depth, a
//! seed on the surface nearest the joint, and a region grown from it over pixels whose
//! depth changes smoothly, that stay within a depth band of the seed, within reach of
//! the joint and beyond the wrist (the forearm is cut off by the plane through the
//! wrist across the forearm).

use crate::geometry::{back_project, pixel_at};
use crate::mask::{fill_holes, largest_circle};
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use nalgebra::{Point3, Vector3};
use std::collections::VecDeque;
use std::fmt;

/// Which of the person's hands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The person's left hand.
    Left,
    /// The person's right hand.
    Right,
}

/// The two joints that place a hand: the hand joint (the palm's centre as the pose
/// stage estimates it) and the elbow, which gives the forearm's direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmJoints {
    /// The hand joint, camera frame, metres.
    pub hand: Point3<f32>,
    /// The elbow of the same arm, camera frame, metres.
    pub elbow: Point3<f32>,
}

impl ArmJoints {
    /// The hand and elbow of one side of a skeleton.
    pub fn from_skeleton(sk: &Skeleton, side: Side) -> Self {
        let (hand, elbow) = match side {
            Side::Left => (Joint::LeftHand, Joint::LeftElbow),
            Side::Right => (Joint::RightHand, Joint::RightElbow),
        };
        Self {
            hand: sk.get(hand),
            elbow: sk.get(elbow),
        }
    }
}

/// Why no hand was found: every way the input can fail is one of these, never a panic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoHand {
    /// A joint is not a finite point, the hand is not in front of the camera, or the
    /// elbow sits on the hand (no forearm direction).
    BadJoints,
    /// The depth image is not the size the intrinsics say.
    SizeMismatch,
    /// The hand joint projects outside the image.
    OutsideImage,
    /// No depth within reach of the hand joint near its pixel.
    NoDepth,
    /// What was found is too small to be a hand at its depth.
    TooSmall {
        /// Pixels found.
        pixels: usize,
        /// Pixels a hand at least covers there.
        needed: usize,
    },
}

impl fmt::Display for NoHand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NoHand::BadJoints => write!(f, "no hand: the joints do not place a hand"),
            NoHand::SizeMismatch => write!(f, "no hand: the depth image and camera differ"),
            NoHand::OutsideImage => write!(f, "no hand: the hand joint is outside the image"),
            NoHand::NoDepth => write!(f, "no hand: no depth near the hand joint"),
            NoHand::TooSmall { pixels, needed } => {
                write!(f, "no hand: {pixels} pixels, a hand needs {needed}")
            }
        }
    }
}

impl std::error::Error for NoHand {}

/// How the hand is cut out. Lengths in metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SegmentParams {
    /// The side of the square window searched around the hand joint, at its depth.
    pub window_m: f32,
    /// How far a hand pixel may be from the hand joint: a hand is about 0.19 m long
    /// and its joint near the middle, plus the pose estimate's error.
    pub reach_m: f32,
    /// How far in depth a hand pixel may be from the seed (a hand turned edge-on to
    /// the camera spans its length in depth).
    pub band_m: f32,
    /// How far from the joint's pixel (at its depth) the seed is looked for.
    pub seed_radius_m: f32,
    /// The wrist lies this fraction of the elbow–hand distance back from the hand
    /// joint towards the elbow (the palm's centre is about a fifth of the forearm's
    /// length beyond the wrist).
    pub wrist_back: f32,
    /// The least area of a hand, square metres (a fist seen edge-on is about 0.004).
    pub min_area_m2: f32,
    /// Points farther back towards the elbow than this fraction of the elbow–hand
    /// distance from the palm's centre (the largest circle in the mask) are the
    /// forearm's: a second cut, from the hand's own shape, for what the wrist
    /// estimated from the joints left on. The palm's radius in the image would be
    /// the natural unit, but a hand seen edge-on is thin in the image.
    pub palm_back: f32,
}

impl Default for SegmentParams {
    fn default() -> Self {
        Self {
            window_m: 0.44,
            reach_m: 0.19,
            band_m: 0.15,
            seed_radius_m: 0.05,
            wrist_back: 0.25,
            min_area_m2: 0.0012,
            palm_back: 0.15,
        }
    }
}

/// One pixel of the hand and the point it sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandPixel {
    /// Column in the image.
    pub u: u32,
    /// Row in the image.
    pub v: u32,
    /// The point seen, camera frame, metres.
    pub p: Point3<f32>,
}

/// The hand cut out of one depth image: its pixels (never empty), the window they lie
/// in, and where the cut was made.
#[derive(Debug, Clone, PartialEq)]
pub struct HandRegion {
    window: Window,
    mask: Vec<bool>,
    pixels: Vec<HandPixel>,
    palm: Palm,
    wrist: Point3<f32>,
    forearm: Vector3<f32>,
    focal: f32,
}

/// The largest circle inside the hand's mask: the palm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Palm {
    /// Its centre's column in the image (fractional).
    pub u: f32,
    /// Its centre's row in the image (fractional).
    pub v: f32,
    /// Its radius, pixels.
    pub radius_px: f32,
    /// The hand's point nearest its centre, camera frame, metres.
    pub centre: Point3<f32>,
}

/// A rectangle of the image: the first column and row, and its size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First column.
    pub u0: u32,
    /// First row.
    pub v0: u32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

impl Window {
    fn index(&self, u: u32, v: u32) -> Option<usize> {
        let (x, y) = (u.checked_sub(self.u0)?, v.checked_sub(self.v0)?);
        (x < self.width && y < self.height).then(|| (y * self.width + x) as usize)
    }
}

impl HandRegion {
    /// The window around the hand joint that was searched.
    pub fn window(&self) -> Window {
        self.window
    }

    /// Whether image pixel (`u`, `v`) is the hand's.
    pub fn contains(&self, u: u32, v: u32) -> bool {
        self.window.index(u, v).is_some_and(|i| self.mask[i])
    }

    /// The hand's pixels.
    pub fn pixels(&self) -> &[HandPixel] {
        &self.pixels
    }

    /// The mask over the window, row-major: what the contour and region features read.
    pub fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// The palm: the largest circle inside the mask.
    pub fn palm(&self) -> Palm {
        self.palm
    }

    /// Where the forearm was cut off.
    pub fn wrist(&self) -> Point3<f32> {
        self.wrist
    }

    /// From the elbow towards the hand (unit).
    pub fn forearm_dir(&self) -> Vector3<f32> {
        self.forearm
    }

    /// The camera's focal length in pixels (its mean of fx and fy): converts the
    /// image's pixels to metres at a depth.
    pub fn focal_px(&self) -> f32 {
        self.focal
    }
}

/// Cuts the hand of `arm` out of `depth` (millimetres, 0 = no data).
pub fn segment(
    depth: DepthView<'_>,
    k: &Intrinsics,
    arm: ArmJoints,
    params: &SegmentParams,
) -> Result<HandRegion, NoHand> {
    if depth.width() != k.width || depth.height() != k.height {
        return Err(NoHand::SizeMismatch);
    }
    let finite = |p: &Point3<f32>| p.iter().all(|c| c.is_finite());
    if !finite(&arm.hand) || !finite(&arm.elbow) || arm.hand.z < 0.2 {
        return Err(NoHand::BadJoints);
    }
    let along = arm.hand - arm.elbow;
    let forearm_len = along.norm();
    if !forearm_len.is_finite() || forearm_len <= 0.05 {
        return Err(NoHand::BadJoints);
    }
    let forearm = along / forearm_len;
    let (cu, cv) = k.project(&arm.hand).ok_or(NoHand::BadJoints)?;
    let inside = |u: f32, v: f32| u >= 0.0 && v >= 0.0 && u < k.width as f32 && v < k.height as f32;
    if !inside(cu, cv) {
        return Err(NoHand::OutsideImage);
    }
    let focal = 0.5 * (k.fx + k.fy);
    let px_per_m = focal / arm.hand.z;
    let half = (0.5 * params.window_m * px_per_m).ceil().max(2.0);
    let clamp_u = |x: f32| x.clamp(0.0, (k.width - 1) as f32) as u32;
    let clamp_v = |y: f32| y.clamp(0.0, (k.height - 1) as f32) as u32;
    let (u0, u1) = (clamp_u(cu - half), clamp_u(cu + half));
    let (v0, v1) = (clamp_v(cv - half), clamp_v(cv + half));
    let window = Window {
        u0,
        v0,
        width: u1 - u0 + 1,
        height: v1 - v0 + 1,
    };
    let wrist = arm.hand - forearm * (params.wrist_back * forearm_len).clamp(0.03, 0.12);
    let point = |u: u32, v: u32| pixel_at(depth, u, v).map(|z| back_project(k, u, v, z));
    // A pixel may be the hand's when it is within reach of the joint and beyond the
    // wrist: the forearm and what lies far behind or beside the hand never are.
    let may_be_hand =
        |p: &Point3<f32>| (p - arm.hand).norm() < params.reach_m && (p - wrist).dot(&forearm) > 0.0;

    // Seeds: the pixels near the joint's that may be the hand's, nearest the joint
    // first. A seed on a speck (a fingertip cut off by the reach, a flying pixel of
    // the sensor) grows too little; the next seed outside what was grown is tried.
    let seed_px = (params.seed_radius_m * px_per_m).ceil().max(1.0);
    let mut seeds: Vec<(f32, u32, u32, Point3<f32>)> = Vec::new();
    for v in clamp_v(cv - seed_px)..=clamp_v(cv + seed_px) {
        for u in clamp_u(cu - seed_px)..=clamp_u(cu + seed_px) {
            if let Some(p) = point(u, v).filter(|p| may_be_hand(p)) {
                seeds.push(((p - arm.hand).norm(), u, v, p));
            }
        }
    }
    if seeds.is_empty() {
        return Err(NoHand::NoDepth);
    }
    seeds.sort_by(|a, b| a.0.total_cmp(&b.0));
    let needed = ((params.min_area_m2 * px_per_m * px_per_m).ceil() as usize).max(12);
    let mut tried = vec![false; (window.width * window.height) as usize];
    let mut best: Option<(Vec<bool>, Vec<HandPixel>)> = None;
    for &(_, su, sv, sp) in seeds.iter() {
        let Some(i) = window.index(su, sv) else {
            continue;
        };
        if tried[i] {
            continue;
        }
        let (mask, pixels) = grow(&window, (su, sv, sp), &point, &may_be_hand, params.band_m);
        for (t, m) in tried.iter_mut().zip(&mask) {
            *t |= *m;
        }
        let found = pixels.len();
        if best.as_ref().is_none_or(|b| found > b.1.len()) {
            best = Some((mask, pixels));
        }
        if found >= needed {
            break;
        }
    }
    let found = best.as_ref().map_or(0, |b| b.1.len());
    let Some((mask, pixels)) = best.filter(|_| found >= needed) else {
        return Err(NoHand::TooSmall {
            pixels: found,
            needed,
        });
    };
    let (mask, pixels) = trim_forearm(
        &window,
        mask,
        pixels,
        forearm,
        params.palm_back * forearm_len,
    );
    if pixels.len() < needed {
        return Err(NoHand::TooSmall {
            pixels: pixels.len(),
            needed,
        });
    }
    let palm = palm_of(&window, &mask, &pixels);
    Ok(HandRegion {
        window,
        mask,
        pixels,
        palm,
        wrist,
        forearm,
        focal,
    })
}

/// The region grown from `seed` over 4-neighbours whose depth differs by less than a
/// step that grows with the sensor's depth resolution (about 2.85e-3 z² m for a
/// Kinect v1), within `band_m` of the seed's depth, that may be the hand's.
fn grow(
    window: &Window,
    (su, sv, sp): (u32, u32, Point3<f32>),
    point: &impl Fn(u32, u32) -> Option<Point3<f32>>,
    may_be_hand: &impl Fn(&Point3<f32>) -> bool,
    band_m: f32,
) -> (Vec<bool>, Vec<HandPixel>) {
    let step = 0.02 + 4.0e-3 * sp.z * sp.z;
    let mut mask = vec![false; (window.width * window.height) as usize];
    let mut pixels = Vec::new();
    let mut queue = VecDeque::new();
    if let Some(i) = window.index(su, sv) {
        mask[i] = true;
        pixels.push(HandPixel {
            u: su,
            v: sv,
            p: sp,
        });
        queue.push_back((su, sv, sp.z));
    }
    while let Some((u, v, z)) = queue.pop_front() {
        for (du, dv) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
            let (nu, nv) = (u as i64 + du, v as i64 + dv);
            if nu < 0 || nv < 0 {
                continue;
            }
            let (nu, nv) = (nu as u32, nv as u32);
            let Some(i) = window.index(nu, nv) else {
                continue;
            };
            if mask[i] {
                continue;
            }
            let Some(p) = point(nu, nv) else { continue };
            if (p.z - z).abs() < step && (p.z - sp.z).abs() < band_m && may_be_hand(&p) {
                mask[i] = true;
                pixels.push(HandPixel { u: nu, v: nv, p });
                queue.push_back((nu, nv, p.z));
            }
        }
    }
    (mask, pixels)
}

/// The palm of a region.
fn palm_of(window: &Window, mask: &[bool], pixels: &[HandPixel]) -> Palm {
    let (w, h) = (window.width as usize, window.height as usize);
    let (x, y, r) = largest_circle(&fill_holes(mask, w, h), w, h);
    let (u, v) = (x + window.u0 as f32, y + window.v0 as f32);
    let centre = pixels
        .iter()
        .min_by(|a, b| {
            let da = (a.u as f32 - u).powi(2) + (a.v as f32 - v).powi(2);
            let db = (b.u as f32 - u).powi(2) + (b.v as f32 - v).powi(2);
            da.total_cmp(&db)
        })
        .map_or(Point3::origin(), |h| h.p);
    Palm {
        u,
        v,
        radius_px: r,
        centre,
    }
}

/// Drops the points more than `back_m` behind the palm's centre along the forearm:
/// the wrist guessed from the joints is a few centimetres off, and a forearm's stub
/// changes a fist's outline more than any posture.
fn trim_forearm(
    window: &Window,
    mut mask: Vec<bool>,
    pixels: Vec<HandPixel>,
    forearm: Vector3<f32>,
    back_m: f32,
) -> (Vec<bool>, Vec<HandPixel>) {
    let palm = palm_of(window, &mask, &pixels);
    let limit = -back_m;
    let (keep, drop): (Vec<HandPixel>, Vec<HandPixel>) = pixels
        .into_iter()
        .partition(|h| (h.p - palm.centre).dot(&forearm) >= limit);
    for h in &drop {
        if let Some(i) = window.index(h.u, h.v) {
            mask[i] = false;
        }
    }
    (mask, keep)
}
