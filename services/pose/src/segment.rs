//! The person's pixels: depth band, floor plane removed (RANSAC), blobs split at depth
//! jumps, the largest person-shaped blob kept.

use crate::geom::Moments;
use airglyph_core::{DepthView, Intrinsics};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Settings of the segmentation (part of [`crate::PoseConfig`]); lengths in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SegmentConfig {
    /// Depth band in which a person is looked for: nearest depth.
    pub near: f32,
    /// Farthest depth.
    pub far: f32,
    /// Whether to find and remove a floor plane (RANSAC on the lower image half).
    pub remove_floor: bool,
    /// Points closer to the floor plane than this are floor.
    pub floor_margin: f32,
    /// Neighbouring pixels belong to one blob when their depths differ by less than
    /// `max(blob_jump_min, blob_jump_px * pixel footprint)`.
    pub blob_jump_min: f32,
    /// See `blob_jump_min`.
    pub blob_jump_px: f32,
    /// Physical area (m², the surface seen) a blob needs to be a person.
    pub min_person_area: f32,
    /// Largest area of a person (m²); larger blobs are walls.
    pub max_person_area: f32,
    /// Vertical extent a blob needs to be a person.
    pub min_person_height: f32,
    /// Largest horizontal extent of a person (arms spread).
    pub max_person_width: f32,
    /// What becomes of pixels between the two sides of a depth jump, taken for the
    /// sensor's mixed ("flying") pixels, before the blobs are found.
    pub flying_pixels: FlyingPixels,
}

impl Default for SegmentConfig {
    fn default() -> Self {
        Self {
            near: 0.3,
            far: 6.0,
            remove_floor: true,
            floor_margin: 0.03,
            blob_jump_min: 0.15,
            blob_jump_px: 20.0,
            min_person_area: 0.05,
            max_person_area: 2.0,
            min_person_height: 0.4,
            max_person_width: 2.4,
            flying_pixels: FlyingPixels::Keep,
        }
    }
}

/// What the segmentation does with a depth sensor's mixed ("flying") pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FlyingPixels {
    /// Left as measured.
    Keep,
    /// Left without data: no blob takes them.
    Drop,
    /// Given the nearer surface's depth: that surface's blob takes them, and they no
    /// longer bridge the jump.
    ToNearer,
}

/// A plane `n · x + d = 0` with unit normal pointing up, out of the floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// The unit normal.
    pub n: Vector3<f32>,
    /// The offset: `n · x + d = 0` on the plane.
    pub d: f32,
}

impl Plane {
    #[inline]
    /// Signed height of `p` above the plane.
    pub fn height(&self, p: &Point3<f32>) -> f32 {
        self.n.dot(&p.coords) + self.d
    }
}

/// What segmentation found in one frame.
#[derive(Debug, Clone, Default)]
pub struct Segmentation {
    /// Whether a person-shaped blob was found.
    pub found: bool,
    /// Pixel count of the person.
    pub pixels: usize,
    /// Centroid of the person's points.
    pub centroid: Point3<f32>,
    /// Bounding box of the person in the image (u0, v0, u1, v1), inclusive.
    pub bbox: (u32, u32, u32, u32),
    /// The floor found in this frame, if any.
    pub floor: Option<Plane>,
    /// Whether the person was found within the window around the last frame's
    /// ([`Segmenter::run`]), not in the whole image.
    pub windowed: bool,
}

/// The part of the image segmentation looks at: columns `u0..=u1`, rows `v0..=v1`.
///
/// A person moves a few pixels a frame, so the last frame's box with a margin holds
/// this frame's person; the wall and the floor around it, most of the image, are
/// neither back-projected nor filled. What the window cuts off was not looked at: a
/// blob that reaches one of its cut edges may go on beyond it ([`Window::cuts`]), and a
/// person found only so is looked for again in the whole image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Window {
    u0: usize,
    v0: usize,
    u1: usize,
    v1: usize,
    /// The image's size.
    w: usize,
    h: usize,
}

impl Window {
    fn whole(w: usize, h: usize) -> Self {
        Self {
            u0: 0,
            v0: 0,
            u1: w - 1,
            v1: h - 1,
            w,
            h,
        }
    }

    /// `bbox` grown by `margin` pixels on every side, within the image.
    fn around(bbox: (u32, u32, u32, u32), margin: usize, w: usize, h: usize) -> Self {
        let (u0, v0, u1, v1) = corners(bbox);
        Self {
            u0: u0.saturating_sub(margin),
            v0: v0.saturating_sub(margin),
            u1: (u1 + margin).min(w - 1),
            v1: (v1 + margin).min(h - 1),
            w,
            h,
        }
    }

    fn is_whole(&self) -> bool {
        *self == Self::whole(self.w, self.h)
    }

    /// Whether the box `bbox` reaches an edge of the window that is not the image's.
    fn cuts(&self, bbox: (u32, u32, u32, u32)) -> bool {
        let (u0, v0, u1, v1) = corners(bbox);
        (u0 <= self.u0 && self.u0 > 0)
            || (v0 <= self.v0 && self.v0 > 0)
            || (u1 >= self.u1 && self.u1 + 1 < self.w)
            || (v1 >= self.v1 && self.v1 + 1 < self.h)
    }

    /// The window's pixels of row `v`, as indices of the image.
    fn row(&self, v: usize) -> std::ops::Range<usize> {
        v * self.w + self.u0..v * self.w + self.u1 + 1
    }
}

/// A pixel box's first and last column and row, as indices.
fn corners(bbox: (u32, u32, u32, u32)) -> (usize, usize, usize, usize) {
    (
        bbox.0 as usize,
        bbox.1 as usize,
        bbox.2 as usize,
        bbox.3 as usize,
    )
}

/// Deterministic xorshift generator (the estimator must not depend on a global seed).
#[derive(Debug, Clone)]
pub struct XorShift(u64);

impl XorShift {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        (x >> 32) as u32
    }
    #[inline]
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u32() as u64 * n as u64) >> 32) as usize
    }
}

/// A run of labelled pixels in row `v`, columns `u0..=u1`, whose steps to their
/// neighbours the flood fill has yet to try.
#[derive(Debug, Clone, Copy)]
struct Span {
    v: u32,
    u0: u32,
    u1: u32,
}

/// The flood fill's rule for a step between 4-neighbours.
#[derive(Clone, Copy)]
struct Step {
    inv_f: f32,
    jump: (f32, f32),
}

impl Step {
    /// Largest depth difference of a step from a pixel at depth `z` (metres).
    #[inline]
    fn reach(&self, z: f32) -> f32 {
        (self.jump.0 * z * self.inv_f).max(self.jump.1)
    }

    /// Whether the fill may step from depth `z` onto the pixel of depth `q` and label
    /// `l`: it has data, no blob yet, and lies within reach.
    #[inline]
    fn allows(&self, z: f32, q: f32, l: u32) -> bool {
        q > 0.0 && l == u32::MAX && (q - z).abs() < self.reach(z)
    }

    /// `span` grown left and right along its row (`points` and `labels` of that row),
    /// labelling the pixels it takes; the span's first and last column.
    #[inline]
    fn widen(
        &self,
        points: &[Point3<f32>],
        labels: &mut [u32],
        span: Span,
        label: u32,
    ) -> (u32, u32) {
        let (mut u0, mut u1) = (span.u0 as usize, span.u1 as usize);
        while u0 > 0 && self.allows(points[u0].z, points[u0 - 1].z, labels[u0 - 1]) {
            u0 -= 1;
            labels[u0] = label;
        }
        while u1 + 1 < points.len() && self.allows(points[u1].z, points[u1 + 1].z, labels[u1 + 1]) {
            u1 += 1;
            labels[u1] = label;
        }
        (u0 as u32, u1 as u32)
    }

    /// Steps from the pixels `from` of a span (first column `u0`) onto the pixels `to`
    /// of the row `v` beside it: the pixels taken are labelled, and each run of them
    /// goes on `spans`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn seed(
        &self,
        points: &[Point3<f32>],
        labels: &mut [u32],
        spans: &mut Vec<Span>,
        (from, to): (std::ops::Range<usize>, std::ops::Range<usize>),
        v: u32,
        u0: u32,
        label: u32,
    ) {
        let last = u0 + (from.len() as u32).saturating_sub(1);
        let mut open: Option<u32> = None;
        let pairs = points[from]
            .iter()
            .zip(&points[to.clone()])
            .zip(&mut labels[to]);
        for (u, ((p, q), l)) in (u0..).zip(pairs) {
            if self.allows(p.z, q.z, *l) {
                *l = label;
                open.get_or_insert(u);
            } else if let Some(s) = open.take() {
                spans.push(Span {
                    v,
                    u0: s,
                    u1: u - 1,
                });
            }
        }
        if let Some(s) = open {
            spans.push(Span { v, u0: s, u1: last });
        }
    }
}

/// Pixels the window reaches beyond the last frame's person box, at 320 pixels across
/// (scaled with the image): a hand drawing at 2 m/s moves 3–4 pixels a frame there.
const WINDOW_MARGIN: usize = 16;

/// A blob is no person when more than this many tenths of its rows' ends that border
/// data border something nearer ([`Segmenter::behind_its_borders`]).
const BEHIND_SHARE_TENTHS: usize = 6;

/// A blob whose centroid lies within this of the last frame's person (metres) is the
/// tracked person.
pub const TRACKED: f32 = 0.5;

/// How far behind a forearm raised before the body the body can lie, metres.
const ARM_LENGTH: f32 = 0.75;

/// The camera-frame point of a pixel of depth `d` (millimetres) on the ray
/// (`ray_x`, `ray_y`, 1); the origin (no data) outside the depth `band` (millimetres).
#[inline]
fn ray_point(d: u16, ray_x: f32, ray_y: f32, band: (f32, f32)) -> Point3<f32> {
    let d = d as f32;
    if d > 0.0 && d >= band.0 && d <= band.1 {
        let z = d * 1e-3;
        Point3::new(ray_x * z, ray_y * z, z)
    } else {
        Point3::origin()
    }
}

/// The vertical extent of `blobs` together (metres): above the floor when there is
/// one, else in the camera's frame.
fn extent<'a>(blobs: impl IntoIterator<Item = &'a Blob>, floored: bool) -> f32 {
    let (lo, hi) = blobs.into_iter().fold((f32::MAX, f32::MIN), |(lo, hi), b| {
        if floored {
            (lo.min(b.hmin.max(0.0)), hi.max(b.hmax))
        } else {
            (lo.min(b.min.y), hi.max(b.max.y))
        }
    });
    hi - lo
}

/// A step within a surface smaller than this (metres) is noise, however small the
/// steps beside it.
const SURFACE_NOISE: f32 = 0.005;

/// The nearer neighbour's depth when the middle of five depths along a line (0: no
/// data) is a mixed ("flying") pixel: it lies between its two neighbours, which lie farther apart than the fill
/// steps, and off both their surfaces, by more than thrice the step each surface
/// takes beside it. A depth sensor's matching window cut by a jump gives a pixel such a
/// depth; the last pixel of a surface seen at a grazing angle (an arm's side before
/// the chest) lies between too, but continues its surface's curve.
#[inline]
fn mixed([a2, a, z, b, b2]: [f32; 5], step: Step) -> Option<f32> {
    let ((lo, lo2), (hi, hi2)) = if a < b {
        ((a, a2), (b, b2))
    } else {
        ((b, b2), (a, a2))
    };
    let slope = |s: f32, s2: f32| {
        if s2 > 0.0 {
            (s - s2).abs().max(SURFACE_NOISE)
        } else {
            SURFACE_NOISE
        }
    };
    (lo > 0.0
        && hi - lo >= step.reach(lo)
        && z - lo > 3.0 * slope(lo, lo2)
        && hi - z > 3.0 * slope(hi, hi2))
    .then_some(lo)
}

/// Reusable buffers of the segmentation step.
#[derive(Debug, Default)]
pub struct Segmenter {
    labels: Vec<u32>,
    spans: Vec<Span>,
    /// Every blob's spans as its fill took them, blob after blob: the shape statistics
    /// are gathered from them afterwards, and only for blobs small enough to matter.
    filled: Vec<Span>,
    samples: Vec<Point3<f32>>,
    /// The samples' x, y and z.
    coords: [Vec<f32>; 3],
    contacts: Vec<(u32, u32)>,
    /// Per image column, x / z of its pixels' rays.
    ray_x: Vec<f32>,
    /// Per blob label, whether it is the person's.
    keep: Vec<bool>,
    /// Per blob label, the mean of a part of the person's mask that lies behind the
    /// person's own blob ([`Segmenter::body_points`]).
    behind_body: Vec<Option<Point3<f32>>>,
    /// The flood fill of the holes in the person: its queue, the pixels it reached and
    /// those it has been to (over the person's box).
    queue: Vec<(u32, u32)>,
    reached: Vec<u32>,
    visited: Vec<bool>,
    /// Per row of the person's box, their first and last pixel.
    rows: Vec<(usize, usize)>,
    /// The floor's pixels [`Segmenter::drop_floor`] drops.
    floor_points: Vec<u32>,
    /// The pixels [`Segmenter::mend_flying_pixels`] mends, with their nearer
    /// neighbour's depth.
    flying: Vec<(u32, f32)>,
}

struct Blob {
    label: u32,
    /// Its spans in [`Segmenter::filled`].
    spans: std::ops::Range<usize>,
    pixels: usize,
    area: f32,
    moments: Moments,
    min: Vector3<f32>,
    max: Vector3<f32>,
    bbox: (u32, u32, u32, u32),
    hmin: f32,
    hmax: f32,
    /// It reaches a cut edge of the window ([`Window::cuts`]): its pixels and figures
    /// may be only part of it.
    cut: bool,
}

impl Blob {
    fn new(label: u32) -> Self {
        Self {
            label,
            spans: 0..0,
            pixels: 0,
            area: 0.0,
            moments: Moments::default(),
            min: Vector3::repeat(f32::MAX),
            max: Vector3::repeat(f32::MIN),
            bbox: (u32::MAX, u32::MAX, 0, 0),
            hmin: f32::MAX,
            hmax: f32::MIN,
            cut: false,
        }
    }

    /// Counts the pixels `u0..=u1` of row `v` (`points` of that row) and their area.
    fn add_span(&mut self, points: &[Point3<f32>], v: u32, u0: u32, u1: u32, inv_f: f32) {
        let span = &points[u0 as usize..=u1 as usize];
        self.pixels += span.len();
        self.bbox = (
            self.bbox.0.min(u0),
            self.bbox.1.min(v),
            self.bbox.2.max(u1),
            self.bbox.3.max(v),
        );
        for p in span {
            let fp = p.z * inv_f;
            self.area += fp * fp;
        }
    }

    /// The extent, heights above the floor and moments of the pixels `u0..=u1` of row
    /// `v` (`points` of that row).
    fn add_shape(
        &mut self,
        points: &[Point3<f32>],
        v: u32,
        u0: u32,
        u1: u32,
        floor: Option<Plane>,
    ) {
        let span = &points[u0 as usize..=u1 as usize];
        for p in span {
            self.min = self.min.inf(&p.coords);
            self.max = self.max.sup(&p.coords);
        }
        if let Some(pl) = floor {
            for p in span {
                let hh = pl.height(p);
                self.hmin = self.hmin.min(hh);
                self.hmax = self.hmax.max(hh);
            }
        }
        // Moments on a sparse subset (the pixels whose u + v is a multiple of three)
        // are enough for the shape test.
        let first = (3 - (u0 + v) % 3) % 3;
        for p in span.iter().skip(first as usize).step_by(3) {
            self.moments.add(p);
        }
    }
}

impl Segmenter {
    /// Back-projects `depth` into `points` (z = 0 where there is no data, the depth is
    /// outside the band, or segmentation did not look) and marks the person's pixels in
    /// `mask`. With `last_box`, the last frame's person box, it looks within that box
    /// and a margin around it first (the wall and floor beyond are neither
    /// back-projected nor filled), and in the whole image only when the person found
    /// there is not the tracked one or may go on beyond the window.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &mut self,
        depth: &DepthView,
        k: &Intrinsics,
        cfg: &SegmentConfig,
        prev_floor: Option<Plane>,
        prev_centroid: Option<Point3<f32>>,
        last_box: Option<(u32, u32, u32, u32)>,
        points: &mut Vec<Point3<f32>>,
        mask: &mut Vec<bool>,
    ) -> Segmentation {
        let (w, h) = (depth.width() as usize, depth.height() as usize);
        let n = w * h;
        // No clearing: every pixel of both is written below, and zeroing the megabyte
        // first only doubled the writes.
        points.resize(n, Point3::origin());
        mask.resize(n, false);
        self.labels.resize(n, u32::MAX);
        // x / z per column: no division a pixel.
        self.ray_x.clear();
        self.ray_x.extend((0..w).map(|u| (u as f32 - k.cx) / k.fx));
        let floor = if cfg.remove_floor {
            self.find_floor(depth, k, cfg, prev_floor)
        } else {
            None
        };
        let window = last_box
            .map(|b| Window::around(b, WINDOW_MARGIN * w.max(h) / 320, w, h))
            .filter(|win| !win.is_whole());
        if let (Some(win), Some(c)) = (window, prev_centroid) {
            let seg = self.look(depth, k, cfg, floor, prev_centroid, win, points, mask);
            // The tracked person, whole within the window.
            if seg.found && (seg.centroid - c).norm() < TRACKED && !win.cuts(seg.bbox) {
                return Segmentation {
                    windowed: true,
                    ..seg
                };
            }
        }
        self.look(
            depth,
            k,
            cfg,
            floor,
            prev_centroid,
            Window::whole(w, h),
            points,
            mask,
        )
    }

    /// Segmentation within `win`: the rest of `points` and `mask` is cleared. Blobs
    /// reaching the window's cut edges are never the person; one taken as a part of the
    /// person's body makes the result's box reach the cut edge, for the caller to look
    /// again.
    #[allow(clippy::too_many_arguments)]
    fn look(
        &mut self,
        depth: &DepthView,
        k: &Intrinsics,
        cfg: &SegmentConfig,
        floor: Option<Plane>,
        prev_centroid: Option<Point3<f32>>,
        win: Window,
        points: &mut [Point3<f32>],
        mask: &mut [bool],
    ) -> Segmentation {
        let (w, h) = (win.w, win.h);
        self.back_project(depth, k, cfg, &win, points);
        let step = Step {
            inv_f: 2.0 / (k.fx + k.fy),
            jump: (cfg.blob_jump_px, cfg.blob_jump_min),
        };
        if cfg.flying_pixels != FlyingPixels::Keep {
            self.mend_flying_pixels(points, &win, step, cfg.flying_pixels);
        }
        if let Some(pl) = floor {
            self.drop_floor(points, &win, &pl, cfg.floor_margin);
        }
        let mut seg = Segmentation {
            floor,
            ..Default::default()
        };

        // Connected components split at depth jumps. Every label is cleared, beyond
        // the window too: the fill does not step there, but the search for the body's
        // parts looks at a pixel's right and lower neighbours, and another frame's
        // label there would name a blob this frame does not have.
        self.labels.fill(u32::MAX);
        self.filled.clear();
        let mut blobs: Vec<Blob> = Vec::new();
        for v in win.v0..=win.v1 {
            for start in win.row(v) {
                if points[start].z <= 0.0 || self.labels[start] != u32::MAX {
                    continue;
                }
                let label = blobs.len() as u32;
                blobs.push(self.fill(points, w, h, start, label, step));
            }
        }
        // A blob larger than a person (a wall) is no person, nor part of one: its
        // shape is not needed.
        for b in &mut blobs {
            b.cut = win.cuts(b.bbox);
        }
        for b in blobs.iter_mut().filter(|b| b.area <= cfg.max_person_area) {
            for span in &self.filled[b.spans.clone()] {
                let row = span.v as usize * w;
                b.add_shape(&points[row..row + w], span.v, span.u0, span.u1, floor);
            }
        }

        // The largest blob that could be a person: the best of all, and of those that
        // stand before what borders them.
        let mut best_before: Option<(f32, usize)> = None;
        let mut best: Option<(f32, usize)> = None;
        let mut best_short: Option<(f32, usize)> = None;
        for (bi, b) in blobs.iter().enumerate() {
            if b.cut || b.area < cfg.min_person_area || b.area > cfg.max_person_area {
                continue;
            }
            // Wholly under the floor: under a table's top taken for it.
            if floor.is_some() && b.hmax < 0.0 {
                continue;
            }
            let height = extent([b], floor.is_some());
            let tracked = prev_centroid.is_some_and(|c| (b.moments.mean() - c).norm() < TRACKED);
            // A forearm raised before the face can cut a person in two, neither as tall
            // as a person: a piece of the tracked person keeps the track, and with no
            // track the largest piece stands in when no blob is tall enough; either is
            // judged with the parts it gathers below.
            let short = height < cfg.min_person_height && !tracked;
            let width = (b.max.x - b.min.x).max(0.0);
            if width > cfg.max_person_width || height > 2.6 {
                continue;
            }
            // A wall or a table top is flat; a person is not.
            if let Some(pca) = b.moments.pca() {
                let z = pca.mean.z;
                let noise = 0.004 + 0.0015 * z * z;
                if pca.std[2] < noise && pca.std[1] > 0.25 {
                    continue;
                }
            }
            // Largest in the image: of two people, the nearer one.
            let mut score = b.pixels as f32;
            if tracked {
                score *= 1.5;
            }
            if short {
                if best_short.is_none_or(|(s, _)| score > s) {
                    best_short = Some((score, bi));
                }
                continue;
            }
            if best.is_none_or(|(s, _)| score > s) {
                best = Some((score, bi));
            }
            // A person stands before the background; a piece of wall enclosed by an arm,
            // the floor and the image's border lies behind what borders it.
            let before = !self.behind_its_borders(points, w, &self.filled[b.spans.clone()], step);
            if before && best_before.is_none_or(|(s, _)| score > s) {
                best_before = Some((score, bi));
            }
        }
        // A blob behind its borders keeps the place only when it is more than twice as
        // large and within an arm's length behind the one before them: a forearm
        // raised before the chest stands before what borders it, the body behind it
        // does not, and is still the person. (The corner of a room beside a person
        // seated at a desk was as large, 1.6 m behind them.)
        let near_behind = |behind: usize, before: usize| {
            blobs[behind].moments.mean().z - blobs[before].moments.mean().z < ARM_LENGTH
        };
        let best = match (best_before, best) {
            (Some(f), Some(b)) if f.0 * 2.0 >= b.0 || !near_behind(b.1, f.1) => Some(f),
            (_, b) => b,
        }
        .or(best_short);
        mask.fill(false);
        if let Some((_, bi)) = best {
            let b = &blobs[bi];
            let limbs = self.body_parts(points, w, h, &blobs, bi, cfg);
            let whole = limbs.iter().map(|&li| &blobs[li]).chain([b]);
            if extent(whole, floor.is_some()) < cfg.min_person_height {
                return seg;
            }
            let mut pixels = b.pixels;
            let mut bbox = b.bbox;
            for &li in &limbs {
                pixels += blobs[li].pixels;
                let lb = blobs[li].bbox;
                bbox = (
                    bbox.0.min(lb.0),
                    bbox.1.min(lb.1),
                    bbox.2.max(lb.2),
                    bbox.3.max(lb.3),
                );
            }
            // Labels are blob indices; u32::MAX (no blob) is out of the table.
            self.keep.clear();
            self.keep.resize(blobs.len(), false);
            for &bi in limbs.iter().chain([&bi]) {
                self.keep[blobs[bi].label as usize] = true;
            }
            self.behind_body.clear();
            self.behind_body.resize(blobs.len(), None);
            for &li in &limbs {
                let mean = blobs[li].moments.mean();
                self.behind_body[blobs[li].label as usize] = (mean.z > b.max.z).then_some(mean);
            }
            for v in win.v0..=win.v1 {
                for (m, &l) in mask[win.row(v)].iter_mut().zip(&self.labels[win.row(v)]) {
                    *m = self.keep.get(l as usize).copied().unwrap_or(false);
                }
            }
            self.fill_holes(points, mask, w, bbox, pixels / 50);
            seg.found = true;
            seg.pixels = pixels;
            seg.centroid = b.moments.mean();
            seg.bbox = bbox;
        }
        seg
    }

    /// The person's pixels of the last frame's `mask` (as [`Segmenter::run`] left it)
    /// but for the parts of the body taken across depth jumps that lie, on average,
    /// behind the farthest point of the person's own blob and there `beyond(mean)`,
    /// into `out`. A seated person's chair back is such a part, and so is a far limb
    /// seen through a gap of the body: the caller's `beyond` tells them apart. The
    /// steps before the registration keep the whole mask: they were tuned with such
    /// parts in it, and taken out there they moved the torso.
    pub fn body_points(
        &self,
        mask: &[bool],
        out: &mut Vec<bool>,
        beyond: impl Fn(Point3<f32>) -> bool,
    ) {
        let left_out: Vec<bool> = self
            .behind_body
            .iter()
            .map(|m| m.is_some_and(&beyond))
            .collect();
        out.clear();
        out.extend(
            mask.iter()
                .zip(&self.labels)
                .map(|(&m, &l)| m && !left_out.get(l as usize).copied().unwrap_or(false)),
        );
    }

    /// Gives the person the pixels without data that their pixels enclose (each hole up
    /// to `max_area` pixels): the sensor lost them (a dark or shiny patch, an eye), the
    /// body is there. Their points stay without depth.
    fn fill_holes(
        &mut self,
        points: &[Point3<f32>],
        mask: &mut [bool],
        w: usize,
        (u0, v0, u1, v1): (u32, u32, u32, u32),
        max_area: usize,
    ) {
        let (u0, v0, u1, v1) = (u0 as usize, v0 as usize, u1 as usize, v1 as usize);
        let bw = u1 - u0 + 1;
        let hole = |i: usize, mask: &[bool]| !mask[i] && points[i].z <= 0.0;
        // A pixel's place in the box, where `visited` is kept.
        let at = |x: usize, y: usize| (y - v0) * bw + x - u0;
        // Each row's first and last pixel of the person. A hole that reaches past them
        // reaches the box's edge or data not the person's: it is not enclosed, and
        // the floor dropped beside and below the person is not flooded pixel by pixel.
        self.rows.clear();
        self.rows.extend((v0..=v1).map(|v| {
            let row = &mask[v * w + u0..=v * w + u1];
            match (row.iter().position(|&m| m), row.iter().rposition(|&m| m)) {
                (Some(a), Some(b)) => (u0 + a, u0 + b),
                _ => (1, 0),
            }
        }));
        let inside = |rows: &[(usize, usize)], x: usize, y: usize| {
            let (a, b) = rows[y - v0];
            (a..=b).contains(&x)
        };
        let edge = |x: usize, y: usize| x == u0 || x == u1 || y == v0 || y == v1;
        self.visited.clear();
        self.visited.resize(bw * (v1 - v0 + 1), false);
        for v in v0..=v1 {
            let (first, last) = self.rows[v - v0];
            for u in first..=last {
                let start = v * w + u;
                if !hole(start, mask) || self.visited[at(u, v)] {
                    continue;
                }
                // Grow the hole: no hole when it reaches the box's edge, past the
                // person's pixels of a row, or data that is not the person's.
                self.queue.clear();
                self.reached.clear();
                self.queue.push((u as u32, v as u32));
                self.visited[at(u, v)] = true;
                let mut enclosed = true;
                while let Some((x, y)) = self.queue.pop() {
                    let (x, y) = (x as usize, y as usize);
                    let i = y * w + x;
                    self.reached.push(i as u32);
                    if edge(x, y) {
                        enclosed = false;
                        continue;
                    }
                    for (j, xj, yj) in [
                        (i - 1, x - 1, y),
                        (i + 1, x + 1, y),
                        (i - w, x, y - 1),
                        (i + w, x, y + 1),
                    ] {
                        if hole(j, mask) {
                            // Tested here, not when popped: an edge pixel another
                            // flood took would otherwise not count.
                            if edge(xj, yj) || !inside(&self.rows, xj, yj) {
                                enclosed = false;
                                continue;
                            }
                            let a = at(xj, yj);
                            if !self.visited[a] {
                                self.visited[a] = true;
                                self.queue.push((xj as u32, yj as u32));
                            }
                        } else if !mask[j] {
                            enclosed = false;
                        }
                    }
                }
                if enclosed && self.reached.len() <= max_area {
                    for &j in &self.reached {
                        mask[j as usize] = true;
                    }
                }
            }
        }
    }

    /// Whether most of the left and right ends of a blob's `spans` (those with a pixel
    /// of data beyond them) border something nearer the camera across a depth jump:
    /// the blob is seen through a gap of what lies before it.
    fn behind_its_borders(
        &self,
        points: &[Point3<f32>],
        w: usize,
        spans: &[Span],
        step: Step,
    ) -> bool {
        let (mut ends, mut behind) = (0usize, 0usize);
        for s in spans {
            let row = s.v as usize * w;
            let (u0, u1) = (s.u0 as usize, s.u1 as usize);
            let beside = [
                (u0 > 0).then(|| (points[row + u0], points[row + u0 - 1])),
                (u1 + 1 < w).then(|| (points[row + u1], points[row + u1 + 1])),
            ];
            for (p, q) in beside.into_iter().flatten() {
                if q.z > 0.0 {
                    ends += 1;
                    behind += usize::from(q.z < p.z - step.reach(p.z));
                }
            }
        }
        ends > 0 && behind * 10 > ends * BEHIND_SHARE_TENTHS
    }

    /// `points` within `win` from `depth`, zero where there is no data or the depth is
    /// outside the band; zero beyond the window.
    fn back_project(
        &mut self,
        depth: &DepthView,
        k: &Intrinsics,
        cfg: &SegmentConfig,
        win: &Window,
        points: &mut [Point3<f32>],
    ) {
        let w = win.w;
        let band = (cfg.near * 1000.0, cfg.far * 1000.0);
        let rows = depth
            .pixels()
            .chunks_exact(w)
            .zip(points.chunks_exact_mut(w));
        for (v, (row, out)) in rows.enumerate() {
            if v < win.v0 || v > win.v1 {
                out.fill(Point3::origin());
                continue;
            }
            out[..win.u0].fill(Point3::origin());
            out[win.u1 + 1..].fill(Point3::origin());
            let ray_y = (v as f32 - k.cy) / k.fy;
            let cols = win.u0..win.u1 + 1;
            for ((&d, p), &ray_x) in row[cols.clone()]
                .iter()
                .zip(&mut out[cols.clone()])
                .zip(&self.ray_x[cols])
            {
                *p = ray_point(d, ray_x, ray_y, band);
            }
        }
    }

    /// Drops the points of `win` within `margin` of the floor plane `pl`, but for those
    /// of an upright surface that reaches down to it: the floor hidden by a table, the
    /// plane found is the table's top, and the belly just above it is no floor.
    fn drop_floor(&mut self, points: &mut [Point3<f32>], win: &Window, pl: &Plane, margin: f32) {
        // A neighbour two rows away this near lies on the same surface.
        const SAME_SURFACE2: f32 = 0.05 * 0.05;
        let w = win.w;
        // Along the surface from `p` to `q`, two rows up or down: across the floor it
        // runs level (within 30° of the plane), up a belly along the plane's normal;
        // None when `q` lies on another surface.
        let level = |p: &Point3<f32>, q: &Point3<f32>| {
            let d = q - p;
            let length2 = d.norm_squared();
            (q.z > 0.0 && length2 <= SAME_SURFACE2).then(|| pl.n.dot(&d).powi(2) < 0.25 * length2)
        };
        self.floor_points.clear();
        let cols = win.u0..win.u1 + 1;
        for v in win.v0..=win.v1 {
            let row_of = |r: usize| &points[r * w..][cols.clone()];
            let up = (v >= win.v0 + 2).then(|| row_of(v - 2));
            let down = (v + 2 <= win.v1).then(|| row_of(v + 2));
            for (k, p) in row_of(v).iter().enumerate() {
                if p.z <= 0.0 || pl.height(p).abs() >= margin {
                    continue;
                }
                let above = up.and_then(|r| level(p, &r[k]));
                // Most of the floor: level with the row above.
                let floor = above == Some(true)
                    || match down.and_then(|r| level(p, &r[k])) {
                        Some(level) => level,
                        None => above.is_none(),
                    };
                if floor {
                    self.floor_points.push((v * w + win.u0 + k) as u32);
                }
            }
        }
        for &i in &self.floor_points {
            points[i as usize] = Point3::origin();
        }
    }

    /// Mends the pixels of `win` the sensor mixed across a depth jump ([`mixed`]),
    /// along a row or a column, as `how` says: one of them joins a chair's back to the
    /// person sitting before it.
    fn mend_flying_pixels(
        &mut self,
        points: &mut [Point3<f32>],
        win: &Window,
        step: Step,
        how: FlyingPixels,
    ) {
        let w = win.w;
        // Depth 0 (no data) beyond the window.
        let z = |u: usize, v: usize| {
            if (win.u0..=win.u1).contains(&u) && (win.v0..=win.v1).contains(&v) {
                points[v * w + u].z
            } else {
                0.0
            }
        };
        self.flying.clear();
        for v in win.v0..=win.v1 {
            for u in win.u0..=win.u1 {
                let here = points[v * w + u].z;
                if here <= 0.0 {
                    continue;
                }
                let (l, r) = (u.wrapping_sub(1), u.wrapping_sub(2));
                let (t, b) = (v.wrapping_sub(1), v.wrapping_sub(2));
                let row = [z(r, v), z(l, v), here, z(u + 1, v), z(u + 2, v)];
                let column = [z(u, b), z(u, t), here, z(u, v + 1), z(u, v + 2)];
                let nearer = match (mixed(row, step), mixed(column, step)) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
                if let Some(near) = nearer {
                    self.flying.push(((v * w + u) as u32, near));
                }
            }
        }
        // Judged on the image as measured, mended after.
        for &(i, near) in &self.flying {
            let p = &mut points[i as usize];
            *p = match how {
                FlyingPixels::Keep => *p,
                FlyingPixels::Drop => Point3::origin(),
                // Along its ray: the camera-frame point scales with its depth.
                FlyingPixels::ToNearer => *p * (near / p.z),
            };
        }
    }

    /// The blob of pixel `start`: its pixels labelled `label` by a flood fill over
    /// 4-neighbours, a step from `p` to `q` allowed by `step`, with its pixel count, box
    /// and area
    /// (the spans it took go on [`Segmenter::filled`] for the rest).
    ///
    /// The fill works on horizontal spans, not pixels: a span's pixels are visited in
    /// one tight loop along the row, and only the spans they start in the rows above
    /// and below go on the stack (a pixel-by-pixel fill pushed and popped every pixel,
    /// which was most of the segmentation's cost). Every labelled pixel belongs to
    /// exactly one span and each of its four steps is tried once, so the blob is the
    /// pixel fill's, whatever the order.
    fn fill(
        &mut self,
        points: &[Point3<f32>],
        w: usize,
        h: usize,
        start: usize,
        label: u32,
        step: Step,
    ) -> Blob {
        let mut b = Blob::new(label);
        // Local borrows: the compiler need not reload the buffers after every store.
        let (labels, spans, filled) = (&mut self.labels[..], &mut self.spans, &mut self.filled);
        let first = filled.len();
        labels[start] = label;
        spans.clear();
        let (u, v) = ((start % w) as u32, (start / w) as u32);
        spans.push(Span { v, u0: u, u1: u });
        while let Some(span) = spans.pop() {
            let row = span.v as usize * w;
            let (u0, u1) = step.widen(
                &points[row..row + w],
                &mut labels[row..row + w],
                span,
                label,
            );
            b.add_span(&points[row..row + w], span.v, u0, u1, step.inv_f);
            filled.push(Span { v: span.v, u0, u1 });
            let from = row + u0 as usize..row + u1 as usize + 1;
            if span.v > 0 {
                let to = from.start - w..from.end - w;
                step.seed(
                    points,
                    labels,
                    spans,
                    (from.clone(), to),
                    span.v - 1,
                    u0,
                    label,
                );
            }
            if (span.v as usize) + 1 < h {
                let to = from.start + w..from.end + w;
                step.seed(points, labels, spans, (from, to), span.v + 1, u0, label);
            }
        }
        b.spans = first..filled.len();
        b
    }

    /// The other blobs of the person's body. An arm raised before the chest hides the
    /// shoulder it hangs from, and a forearm across the waist hides where the chest
    /// meets the hips: in the image such parts meet the rest only across depth jumps
    /// and form blobs of their own. Starting from the person's blob, a blob that borders
    /// the parts found so far is taken when it lies within arm's reach of the body and
    /// neither far in front of it nor behind it (walls and other people do not qualify).
    fn body_parts(
        &mut self,
        points: &[Point3<f32>],
        w: usize,
        h: usize,
        blobs: &[Blob],
        person: usize,
        cfg: &SegmentConfig,
    ) -> Vec<usize> {
        // Which blobs could be part of this body at all: within arm's reach of it,
        // neither far in front of it nor behind it (walls and other people are not).
        let p = &blobs[person];
        let centre = p.moments.mean();
        let near = |x: Vector3<f32>| (x - centre.coords).norm() < 1.4;
        let eligible: Vec<bool> = blobs
            .iter()
            .enumerate()
            .map(|(bi, b)| {
                // Of a blob the window cuts, only what its whole would fail too: its
                // depths and area grow with it, its centre and extent may go anywhere.
                let depth_and_area = b.min.z > p.min.z - 0.9
                    && b.max.z < p.max.z + 0.25
                    && b.area <= cfg.max_person_area;
                bi == person
                    || (depth_and_area
                        && (b.cut
                            || ((b.moments.mean() - centre).norm() < 1.0
                                && near(b.min)
                                && near(b.max))))
            })
            .collect();
        // Pairs of such blobs that border each other, one entry a touching pixel: both
        // pixels lie within the eligible blobs' bounding boxes.
        let mut area_of_interest = (u32::MAX, u32::MAX, 0, 0);
        for (b, _) in blobs.iter().zip(&eligible).filter(|(_, &e)| e) {
            area_of_interest = (
                area_of_interest.0.min(b.bbox.0),
                area_of_interest.1.min(b.bbox.1),
                area_of_interest.2.max(b.bbox.2),
                area_of_interest.3.max(b.bbox.3),
            );
        }
        let (u0, v0, u1, v1) = area_of_interest;
        self.contacts.clear();
        for v in v0 as usize..=v1 as usize {
            for u in u0 as usize..=u1 as usize {
                let i = v * w + u;
                let la = self.labels[i];
                if la == u32::MAX || points[i].z <= 0.0 || !eligible[la as usize] {
                    continue;
                }
                for j in [(u + 1 < w).then(|| i + 1), (v + 1 < h).then(|| i + w)]
                    .into_iter()
                    .flatten()
                {
                    let lb = self.labels[j];
                    if lb != u32::MAX && lb != la && eligible[lb as usize] {
                        self.contacts.push((la.min(lb), la.max(lb)));
                    }
                }
            }
        }
        self.contacts.sort_unstable();
        let mut area = p.area;
        let mut taken = vec![person];
        let mut frontier = vec![person];
        while let Some(cur) = frontier.pop() {
            let cur = cur as u32;
            for run in self.contacts.chunk_by(|a, b| a == b) {
                let (la, lb) = run[0];
                // One touching pixel is noise; a limb's edge runs along the body.
                if run.len() < 3 || (la != cur && lb != cur) {
                    continue;
                }
                // Labels are blob indices.
                let other = if la == cur { lb } else { la } as usize;
                if taken.contains(&other) {
                    continue;
                }
                if area + blobs[other].area <= cfg.max_person_area {
                    area += blobs[other].area;
                    taken.push(other);
                    frontier.push(other);
                }
            }
        }
        taken.remove(0);
        taken
    }

    /// RANSAC for a floor-like plane (normal within 37° of the image's up) among the
    /// points of the lower two thirds of the image.
    ///
    /// Its samples are back-projected from `depth` on their own, so the floor is the
    /// whole image's whatever the window; `self.ray_x` must be `depth`'s.
    fn find_floor(
        &mut self,
        depth: &DepthView,
        k: &Intrinsics,
        cfg: &SegmentConfig,
        prev: Option<Plane>,
    ) -> Option<Plane> {
        let (w, h) = (depth.width() as usize, depth.height() as usize);
        let band = (cfg.near * 1000.0, cfg.far * 1000.0);
        let pixels = depth.pixels();
        self.samples.clear();
        let step = (((w * h) as f32 / 4000.0).sqrt().floor() as usize).max(1);
        for v in (h / 3..h).step_by(step) {
            let ray_y = (v as f32 - k.cy) / k.fy;
            for u in (0..w).step_by(step) {
                let p = ray_point(pixels[v * w + u], self.ray_x[u], ray_y, band);
                if p.z > 0.0 {
                    self.samples.push(p);
                }
            }
        }
        let s = &self.samples;
        if s.len() < 50 {
            return None;
        }
        let tol = cfg.floor_margin.max(0.02);
        // The hypotheses' inlier counts are most of the search: over the coordinates
        // in separate arrays they vectorise.
        for (c, xs) in self.coords.iter_mut().enumerate() {
            xs.clear();
            xs.extend(s.iter().map(|p| p[c]));
        }
        let [xs, ys, zs] = &self.coords;
        let count = |pl: &Plane| -> usize {
            let (n, d) = (pl.n, pl.d);
            xs.iter()
                .zip(ys)
                .zip(zs)
                // Plane::height's sum, in its order.
                // Counted in u32, four to a vector register, not usize's two.
                .map(|((&x, &y), &z)| u32::from((n.x * x + n.y * y + n.z * z + d).abs() < tol))
                .sum::<u32>() as usize
        };
        let mut best: Option<(usize, Plane)> = prev.map(|pl| (count(&pl), pl));
        let mut rng = XorShift::new(0x9e37_79b9_7f4a_7c15);
        // Samples are in row order: the floor is most likely among the last rows, so
        // most hypotheses are drawn from there.
        let low = s.len() * 2 / 3;
        for it in 0..150 {
            let (lo, span) = if it % 3 == 2 {
                (0, s.len())
            } else {
                (low, s.len() - low)
            };
            let a = s[lo + rng.below(span)];
            let b = s[lo + rng.below(span)];
            let c = s[lo + rng.below(span)];
            let nrm = (b - a).cross(&(c - a));
            let len = nrm.norm();
            if len < 1e-6 {
                continue;
            }
            let mut nrm = nrm / len;
            // Up is −y in the camera frame.
            if nrm.y > 0.0 {
                nrm = -nrm;
            }
            if -nrm.y < 0.8 {
                continue;
            }
            let pl = Plane {
                n: nrm,
                d: -nrm.dot(&a.coords),
            };
            let c = count(&pl);
            if best.is_none_or(|(bc, _)| c > bc) {
                best = Some((c, pl));
            }
        }
        let (c, pl) = best?;
        if c < (s.len() / 20).max(40) {
            return None;
        }
        // Least-squares refinement on the inliers; a floor recedes from the camera and
        // spreads sideways, a slice through a body does not.
        let mut m = Moments::default();
        let (mut zmin, mut zmax, mut xmin, mut xmax) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for p in s.iter().filter(|p| pl.height(p).abs() < tol) {
            m.add(p);
            zmin = zmin.min(p.z);
            zmax = zmax.max(p.z);
            xmin = xmin.min(p.x);
            xmax = xmax.max(p.x);
        }
        if zmax - zmin < 0.6 || xmax - xmin < 0.6 {
            return None;
        }
        // A floor fills the bottom of the image, except where someone stands on it. A
        // table's top seen from just above it may not (a seated person's forearms
        // resting on it, the table's front edge below it), but it hides the floor and
        // holds a third of the samples: it is taken for the floor, as when it fills
        // the bottom. Left in the image, its level pixels join the forearms resting on
        // it to the whole table, which then outweighs a small person.
        let bottom = &s[s.len() * 17 / 20..];
        let on = bottom.iter().filter(|p| pl.height(p).abs() < tol).count();
        let fills_bottom = !bottom.is_empty() && on * 2 >= bottom.len();
        if !fills_bottom && c * 3 < s.len() {
            return None;
        }
        let pca = m.pca()?;
        let mut nrm: Vector3<f32> = pca.axes.column(2).into_owned();
        if nrm.y > 0.0 {
            nrm = -nrm;
        }
        if -nrm.y < 0.8 || !nrm.iter().all(|c| c.is_finite()) {
            return Some(pl);
        }
        // Most of the floor must be below the person: the plane's points lie low in
        // the image, which the sampling region already ensures.
        Some(Plane {
            n: nrm,
            d: -nrm.dot(&pca.mean.coords),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blobs of the pixel-by-pixel fill the span fill replaced: every labelled
    /// pixel tries its four steps.
    fn pixel_fill(points: &[Point3<f32>], w: usize, h: usize, step: Step) -> Vec<u32> {
        let mut labels = vec![u32::MAX; w * h];
        let mut next = 0;
        for start in 0..w * h {
            if points[start].z <= 0.0 || labels[start] != u32::MAX {
                continue;
            }
            labels[start] = next;
            let mut stack = vec![start];
            while let Some(i) = stack.pop() {
                let (u, v) = (i % w, i / w);
                let near = [
                    (u > 0).then(|| i - 1),
                    (u + 1 < w).then(|| i + 1),
                    (v > 0).then(|| i - w),
                    (v + 1 < h).then(|| i + w),
                ];
                for j in near.into_iter().flatten() {
                    if step.allows(points[i].z, points[j].z, labels[j]) {
                        labels[j] = next;
                        stack.push(j);
                    }
                }
            }
            next += 1;
        }
        labels
    }

    /// Depth patches with holes, steps and slopes: many blobs, ragged edges, and steps
    /// allowed one way and not the other (the reach grows with depth).
    fn scene(w: usize, h: usize, seed: u64) -> Vec<Point3<f32>> {
        let mut rng = XorShift::new(seed);
        let mut z = vec![0f32; w * h];
        for _ in 0..12 {
            let (u0, v0) = (rng.below(w), rng.below(h));
            let (u1, v1) = (
                (u0 + rng.below(w / 2)).min(w),
                (v0 + rng.below(h / 2)).min(h),
            );
            let base = 0.8 + rng.below(3000) as f32 * 1e-3;
            let slope = (rng.below(200) as f32 - 100.0) * 1e-3;
            for v in v0..v1 {
                for u in u0..u1 {
                    z[v * w + u] = base + slope * u as f32 + rng.below(40) as f32 * 1e-3;
                }
            }
        }
        for _ in 0..w * h / 20 {
            z[rng.below(w * h)] = 0.0;
        }
        z.iter().map(|&z| Point3::new(0.0, 0.0, z)).collect()
    }

    /// The rule `fill_holes` keeps, by whole components: a 4-connected piece of pixels
    /// without data and not the person's is given to the person when none of it lies
    /// on the box's edge, none of it borders data that is not the person's, and it is
    /// no larger than `max_area`.
    fn holes_by_components(
        mask: &[bool],
        points: &[Point3<f32>],
        w: usize,
        (u0, v0, u1, v1): (usize, usize, usize, usize),
        max_area: usize,
    ) -> Vec<bool> {
        let hole = |i: usize| !mask[i] && points[i].z <= 0.0;
        let mut out = mask.to_vec();
        let mut seen = vec![false; mask.len()];
        for v in v0..=v1 {
            for u in u0..=u1 {
                let s = v * w + u;
                if !hole(s) || seen[s] {
                    continue;
                }
                seen[s] = true;
                let (mut piece, mut stack, mut enclosed) = (Vec::new(), vec![(u, v)], true);
                while let Some((x, y)) = stack.pop() {
                    piece.push(y * w + x);
                    enclosed &= x != u0 && x != u1 && y != v0 && y != v1;
                    let near = [
                        (x > u0).then(|| (x - 1, y)),
                        (x < u1).then(|| (x + 1, y)),
                        (y > v0).then(|| (x, y - 1)),
                        (y < v1).then(|| (x, y + 1)),
                    ];
                    for (xj, yj) in near.into_iter().flatten() {
                        let j = yj * w + xj;
                        if hole(j) {
                            if !seen[j] {
                                seen[j] = true;
                                stack.push((xj, yj));
                            }
                        } else if !mask[j] {
                            enclosed = false;
                        }
                    }
                }
                if enclosed && piece.len() <= max_area {
                    for j in piece {
                        out[j] = true;
                    }
                }
            }
        }
        out
    }

    #[test]
    fn holes_are_filled_by_whole_components_of_the_box() {
        let mut rng = XorShift::new(17);
        let mut seg = Segmenter::default();
        let mut filled_some = 0;
        for case in 0..3000 {
            let (w, h) = (3 + rng.below(12), 3 + rng.below(12));
            let share = rng.below(100);
            let mask: Vec<bool> = (0..w * h).map(|_| rng.below(100) < share).collect();
            let points: Vec<Point3<f32>> = (0..w * h)
                .map(|_| Point3::new(0.0, 0.0, if rng.below(2) == 0 { 0.0 } else { 1.0 }))
                .collect();
            let on: Vec<usize> = (0..w * h).filter(|&i| mask[i]).collect();
            if on.is_empty() {
                continue;
            }
            let bbox = (
                on.iter().map(|i| i % w).min().unwrap(),
                on.iter().map(|i| i / w).min().unwrap(),
                on.iter().map(|i| i % w).max().unwrap(),
                on.iter().map(|i| i / w).max().unwrap(),
            );
            let max_area = 1 + rng.below(30);
            let want = holes_by_components(&mask, &points, w, bbox, max_area);
            let mut got = mask.clone();
            let b32 = (bbox.0 as u32, bbox.1 as u32, bbox.2 as u32, bbox.3 as u32);
            seg.fill_holes(&points, &mut got, w, b32, max_area);
            assert_eq!(got, want, "case {case}: {w}x{h}, box {bbox:?}");
            filled_some += usize::from(got != mask);
        }
        // The cases exercise the filling, not only its refusals.
        assert!(filled_some > 100, "{filled_some}");
    }

    /// Frames of the drawing person before floor and wall, with sensor noise.
    fn drawing_frames(n: usize) -> (Vec<airglyph_core::DepthImage>, Intrinsics) {
        use airglyph_synth::{Background, MotionSpec, SceneConfig, Synthesizer};
        let k = Intrinsics::default().scaled_to(320, 240);
        let mut synth = Synthesizer::new(SceneConfig {
            intrinsics: k,
            motion: MotionSpec::parse("draw:8", None, false).expect("draw spec"),
            background: Background::FloorAndWall,
            sensor_noise: true,
            ..SceneConfig::default()
        })
        .expect("scene");
        ((0..n).map(|i| synth.render(i * 3).0).collect(), k)
    }

    fn segment(
        s: &mut Segmenter,
        img: &airglyph_core::DepthImage,
        k: &Intrinsics,
        last: Option<&Segmentation>,
    ) -> (Segmentation, Vec<Point3<f32>>, Vec<bool>) {
        segment_with(
            s,
            img,
            k,
            &SegmentConfig::default(),
            last.and_then(|l| l.floor),
            last.map(|l| l.centroid),
            last.filter(|l| l.found).map(|l| l.bbox),
        )
    }

    /// [`Segmenter::run`] on `img` with `cfg`, given the last frame's floor, person's
    /// centroid and box.
    fn segment_with(
        s: &mut Segmenter,
        img: &airglyph_core::DepthImage,
        k: &Intrinsics,
        cfg: &SegmentConfig,
        floor: Option<Plane>,
        centroid: Option<Point3<f32>>,
        bbox: Option<(u32, u32, u32, u32)>,
    ) -> (Segmentation, Vec<Point3<f32>>, Vec<bool>) {
        let (mut points, mut mask) = (Vec::new(), Vec::new());
        let seg = s.run(
            &img.view(),
            k,
            cfg,
            floor,
            centroid,
            bbox,
            &mut points,
            &mut mask,
        );
        (seg, points, mask)
    }

    #[test]
    fn the_window_around_the_last_person_finds_what_the_whole_image_finds() {
        let (frames, k) = drawing_frames(12);
        let (mut tracking, mut whole) = (Segmenter::default(), Segmenter::default());
        let mut last: Option<Segmentation> = None;
        let mut windowed = 0;
        for (i, img) in frames.iter().enumerate() {
            let (a, pa, ma) = segment(&mut tracking, img, &k, last.as_ref());
            // The same floor and centroid, but never a box: always the whole image.
            let (b, _, mb) = segment(
                &mut whole,
                img,
                &k,
                last.as_ref()
                    .map(|l| Segmentation {
                        found: false,
                        ..l.clone()
                    })
                    .as_ref(),
            );
            assert!(a.found && b.found, "frame {i}");
            assert_eq!(ma, mb, "frame {i}: the person's pixels differ");
            assert_eq!(
                (a.pixels, a.bbox, a.centroid),
                (b.pixels, b.bbox, b.centroid)
            );
            // Beyond the window nothing is left of another frame.
            let person = pa.iter().zip(&ma).filter(|(p, &m)| m && p.z > 0.0).count();
            assert_eq!(person, a.pixels, "frame {i}");
            assert!(!b.windowed);
            windowed += usize::from(a.windowed);
            last = Some(a);
        }
        assert_eq!(windowed, frames.len() - 1, "the window was not used");
    }

    #[test]
    fn a_person_beyond_the_window_is_looked_for_in_the_whole_image() {
        let (frames, k) = drawing_frames(1);
        let mut s = Segmenter::default();
        let (whole, _, mask) = segment(&mut s, &frames[0], &k, None);
        // Last frame's box in the image's top left corner, where only wall is.
        let stale = Segmentation {
            bbox: (0, 0, 20, 20),
            ..whole.clone()
        };
        let (again, _, mask_again) = segment(&mut s, &frames[0], &k, Some(&stale));
        assert!(again.found && !again.windowed);
        assert_eq!(mask_again, mask);
        // Boxes whose windows cut off the feet, or the drawing arm's side: the person
        // they hold is near enough the last one, but reaches the window's edge.
        let (u0, v0, u1, v1) = whole.bbox;
        let beyond = 2 * WINDOW_MARGIN as u32;
        for bbox in [(u0, v0, u1, v1 - beyond), (u0 + beyond, v0, u1, v1)] {
            let cut = Segmentation {
                bbox,
                ..whole.clone()
            };
            let (again, _, mask_again) = segment(&mut s, &frames[0], &k, Some(&cut));
            assert!(again.found && !again.windowed, "{bbox:?}");
            assert_eq!(mask_again, mask, "{bbox:?}");
        }
    }

    /// A wide-angle camera (106° across) before a standing cylinder (the person, 0.6 m
    /// wide, 1.6 m tall, 2 m away) and a low bar 0.9 m away that runs from before the
    /// cylinder's right side to the image's right border: a blob of its own, reaching
    /// too far from the person to be a part of it, which a window around the cylinder
    /// cuts.
    fn cylinder_and_bar() -> (airglyph_core::DepthImage, Intrinsics) {
        let k = Intrinsics {
            fx: 60.0,
            fy: 60.0,
            ..Intrinsics::default().scaled_to(160, 120)
        };
        let mut img = airglyph_core::DepthImage::empty(k.width, k.height);
        for v in 0..k.height {
            for u in 0..k.width {
                let ray = k.back_project(u as f32, v as f32, 1.0);
                let (x, y) = (ray.x * 2.0, ray.y * 2.0);
                if x.abs() < 0.3 && y.abs() < 0.8 {
                    let z = 2.0 - (0.09 - x * x).max(0.0).sqrt();
                    img.set(u, v, (z * 1000.0) as u16);
                }
                if ray.x > 0.13 && ray.y.abs() < 0.08 {
                    img.set(u, v, 900);
                }
            }
        }
        (img, k)
    }

    /// A person-sized cylinder 1.2 m away before a wider board 25 cm behind it (a
    /// chair's back), with the board's pixels beside the cylinder's sides at a depth
    /// between the two, as a depth sensor's matching window gives them.
    fn person_before_a_chair_with_flying_pixels() -> (airglyph_core::DepthImage, Intrinsics) {
        let k = Intrinsics::default().scaled_to(320, 240);
        let mut img = airglyph_core::DepthImage::empty(k.width, k.height);
        let person = |u: u32, v: u32| {
            let ray = k.back_project(u as f32, v as f32, 1.0);
            let (x, y) = (ray.x * 1.2, ray.y * 1.2);
            (x.abs() < 0.18 && y.abs() < 0.6).then(|| 1.2 - (0.0324 - x * x).max(0.0).sqrt())
        };
        for v in 0..k.height {
            for u in 0..k.width {
                let ray = k.back_project(u as f32, v as f32, 1.0);
                let (x, y) = (ray.x * 1.45, ray.y * 1.45);
                let z = match person(u, v) {
                    Some(z) => z,
                    None if x.abs() < 0.3 && (-0.3..0.45).contains(&y) => {
                        let beside = [u.wrapping_sub(1), u + 1]
                            .iter()
                            .filter_map(|&n| person(n, v))
                            .next();
                        beside.map_or(1.45, |near| (near + 1.45) / 2.0)
                    }
                    None => continue,
                };
                img.set(u, v, (z * 1000.0) as u16);
            }
        }
        (img, k)
    }

    #[test]
    fn flying_pixels_do_not_join_a_chairs_back_to_the_person() {
        let (img, k) = person_before_a_chair_with_flying_pixels();
        let chair_points = |flying_pixels: FlyingPixels| {
            let cfg = SegmentConfig {
                flying_pixels,
                ..SegmentConfig::default()
            };
            let mut s = Segmenter::default();
            let (seg, points, mask) = segment_with(&mut s, &img, &k, &cfg, None, None, None);
            assert!(seg.found);
            let mut body = Vec::new();
            s.body_points(&mask, &mut body, |_| true);
            (0..mask.len())
                .filter(|&i| body[i] && points[i].z > 1.4)
                .count()
        };
        // The pixels between bridge the jump: the board is the person's own blob, and
        // nothing of it leaves the body's points.
        assert!(
            chair_points(FlyingPixels::Keep) > 1000,
            "the scene bridges the jump"
        );
        assert_eq!(chair_points(FlyingPixels::Drop), 0);
        assert_eq!(chair_points(FlyingPixels::ToNearer), 0);
    }

    #[test]
    fn a_person_cut_in_two_by_a_forearm_is_still_found() {
        // Seen from the waist up, 0.7 m of them, 1.3 m away, with a forearm held
        // across them 0.3 m nearer: neither half is as tall as a person.
        let k = Intrinsics::default().scaled_to(320, 240);
        let mut img = airglyph_core::DepthImage::empty(k.width, k.height);
        for v in 0..k.height {
            for u in 0..k.width {
                let ray = k.back_project(u as f32, v as f32, 1.0);
                let (x, y) = (ray.x * 1.3, ray.y * 1.3);
                if x.abs() < 0.2 && y.abs() < 0.35 {
                    img.set(
                        u,
                        v,
                        (1300.0 - 200.0 * (0.04 - x * x).max(0.0).sqrt()) as u16,
                    );
                }
                let (x, y) = (ray.x, ray.y);
                if x.abs() < 0.26 && y.abs() < 0.04 {
                    img.set(u, v, 1000);
                }
            }
        }
        let found = |prev_centroid: Option<Point3<f32>>| {
            let cfg = SegmentConfig::default();
            let (seg, _, mask) = segment_with(
                &mut Segmenter::default(),
                &img,
                &k,
                &cfg,
                None,
                prev_centroid,
                None,
            );
            let rows = |v: std::ops::Range<usize>| {
                v.flat_map(|v| (0..k.width as usize).map(move |u| v * k.width as usize + u))
                    .filter(|&i| mask[i])
                    .count()
            };
            let (middle, h) = (k.cy as usize, k.height as usize);
            (seg.found, rows(0..middle - 12), rows(middle + 12..h))
        };
        // With the person's last place or without, both halves and the forearm are the
        // person.
        for prev in [None, Some(Point3::new(0.0, 0.0, 1.25))] {
            let (found, above, below) = found(prev);
            assert!(found, "tracked: {}", prev.is_some());
            assert!(
                above > 1000 && below > 1000,
                "{above} pixels above, {below} below"
            );
        }
        // A box shorter than a person, alone, is none.
        let mut boxed = airglyph_core::DepthImage::empty(k.width, k.height);
        for v in 0..k.height {
            for u in 0..k.width {
                let ray = k.back_project(u as f32, v as f32, 1.0);
                if (ray.x * 1.3).abs() < 0.2 && (ray.y * 1.3).abs() < 0.15 {
                    boxed.set(u, v, 1300 + (u % 7) as u16 * 10);
                }
            }
        }
        let (seg, _, _) = segment(&mut Segmenter::default(), &boxed, &k, None);
        assert!(!seg.found);
    }

    #[test]
    fn a_belly_just_above_a_table_top_taken_for_the_floor_is_no_floor() {
        // A table top 0.4 m under the camera from 0.8 to 1.3 m away, and a belly, an
        // upright surface 1.35 m away, down to the top's level behind it.
        let (w, h, f) = (160, 160, 240.0);
        let top = Plane {
            n: Vector3::new(0.0, -1.0, 0.0),
            d: 0.4,
        };
        let points: Vec<Point3<f32>> = (0..w * h)
            .map(|i| {
                let ray = Vector3::new((i % w) as f32 - 80.0, (i / w) as f32 - 40.0, f) / f;
                let on_top = ray.y > 0.0 && (0.8..1.3).contains(&(0.4 / ray.y));
                let on_belly = ray.y * 1.35 <= 0.4 && ray.x.abs() * 1.35 < 0.2;
                match (on_top, on_belly) {
                    (true, _) => Point3::from(ray * (0.4 / ray.y)),
                    (false, true) => Point3::from(ray * 1.35),
                    _ => Point3::origin(),
                }
            })
            .collect();
        let near_top = |pts: &[Point3<f32>], belly: bool| {
            pts.iter()
                .filter(|p| p.z > 0.0 && top.height(p).abs() < 0.03 && (p.z > 1.32) == belly)
                .count()
        };
        let belly = near_top(&points, true);
        assert!(belly > 100 && near_top(&points, false) > 100);
        let mut kept = points.clone();
        Segmenter::default().drop_floor(&mut kept, &Window::whole(w, h), &top, 0.03);
        assert_eq!(
            near_top(&kept, true),
            near_top(&points, true),
            "the belly stays"
        );
        assert_eq!(near_top(&kept, false), 0, "the top goes");
    }

    #[test]
    fn labels_of_an_earlier_frame_beyond_the_window_are_not_read() {
        let (scene, k) = cylinder_and_bar();
        // Noise: thousands of one-pixel blobs, labelled all over the image.
        let mut noise = airglyph_core::DepthImage::empty(k.width, k.height);
        let mut x: u32 = 7;
        for p in noise.pixels_mut() {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *p = 500 + (x % 4500) as u16;
        }
        let mut s = Segmenter::default();
        let (whole, _, mask) = segment(&mut s, &scene, &k, None);
        assert!(whole.found);
        let bar = (0..k.width as usize)
            .filter(|&u| mask[60 * k.width as usize + u])
            .count();
        assert!(bar < 30, "the bar is no part of the person");
        segment(&mut s, &noise, &k, None);
        // The window around the cylinder cuts the bar, which touches it: the search
        // for the person's parts looks at the pixels beside the window's edge.
        let (again, _, mask_again) = segment(&mut s, &scene, &k, Some(&whole));
        assert!(again.found);
        assert_eq!(mask_again, mask);
    }

    #[test]
    fn a_chair_back_seen_between_the_arms_and_the_torso_is_no_body_point() {
        use airglyph_synth::{
            Background, Chair, MotionSpec, Placement, Posture, Prop, SceneConfig, ScriptedPose,
            Synthesizer,
        };
        let k = Intrinsics::default().scaled_to(320, 240);
        let chair = Chair::default();
        let cfg = SceneConfig {
            intrinsics: k,
            motion: MotionSpec::Pose(ScriptedPose::ArmsAtSides),
            background: Background::Room,
            props: vec![Prop::Chair(chair)],
            posture: Posture::Seated {
                seat_height_m: chair.seat_height_m,
            },
            placement: Placement {
                distance_m: 1.2,
                ..Placement::default()
            },
            ..SceneConfig::default()
        }
        .framing_upper_body()
        .expect("the body loads");
        let img = Synthesizer::new(cfg).expect("scene").render(0).0;
        let mut s = Segmenter::default();
        let (seg, points, mask) = segment(&mut s, &img, &k, None);
        assert!(seg.found);
        let mut body = Vec::new();
        s.body_points(&mask, &mut body, |_| true);
        let nearest = (0..mask.len())
            .filter(|&i| mask[i] && points[i].z > 0.0)
            .map(|i| points[i].z)
            .fold(f32::MAX, f32::min);
        let left_out: Vec<f32> = (0..mask.len())
            .filter(|&i| mask[i] && !body[i] && points[i].z > 0.0)
            .map(|i| points[i].z)
            .collect();
        // The chair's back is in the mask (the steps before the registration were
        // tuned so), out of the body's points, and it lies behind the body.
        assert!(left_out.len() > 50, "{} chair pixels", left_out.len());
        assert!(
            left_out.iter().all(|&z| z > nearest + 0.3),
            "{nearest} {left_out:?}"
        );
        // A person standing with nothing behind them keeps every pixel.
        let (frames, k) = drawing_frames(1);
        let (_, _, mask) = segment(&mut s, &frames[0], &k, None);
        s.body_points(&mask, &mut body, |_| true);
        assert_eq!(body, mask);
    }

    #[test]
    fn span_fill_finds_the_pixel_fills_blobs() {
        let (w, h) = (61, 47);
        let step = Step {
            inv_f: 1.0 / 60.0,
            jump: (20.0, 0.05),
        };
        for seed in 1..40 {
            let points = scene(w, h, seed);
            let want = pixel_fill(&points, w, h, step);
            let mut seg = Segmenter {
                labels: vec![u32::MAX; w * h],
                ..Segmenter::default()
            };
            let mut label = 0;
            for start in 0..w * h {
                if points[start].z <= 0.0 || seg.labels[start] != u32::MAX {
                    continue;
                }
                let b = seg.fill(&points, w, h, start, label, step);
                assert_eq!(b.pixels, want.iter().filter(|&&l| l == label).count());
                label += 1;
            }
            assert_eq!(seg.labels, want, "seed {seed}");
        }
    }
}
