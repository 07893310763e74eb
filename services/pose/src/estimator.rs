//! The estimator: the steps of one frame in order ([`PoseEstimator::estimate_at`]), what
//! is carried from frame to frame ([`Tracking`]), the person's learned size, and the
//! steps' buffers ([`Scratch`]).

use crate::assign::{assign, limb_costs, LimbCosts};
use crate::body::{segment_of, BodyConfig, BodyPose, BodyTemplate, Posed, Segment};
use crate::calibrate::{arms_reaching, BodyCalibration};
use crate::chains::{limb_chain, LimbState, TargetMarks};
use crate::config::PoseConfig;
use crate::debug::{Debug, StepTimes};
use crate::dijkstra::Graph;
use crate::geodesic::Geodesic;
use crate::graph::{GeoGraph, NONE};
use crate::hands::{hands_at_fingertips, hands_at_their_points};
use crate::head_top::head_top_at_its_points;
use crate::legs_seen::{leg_seen, LegEnd};
use crate::neck::{head_top_maximum, neck_base, NeckBase};
use crate::register::{
    drop_borrowed_tips, hidden_limbs, place, starts, tips_strayed, Fit, Frame, OfferedStart,
    Registration,
};
use crate::segment::{Plane, Segmentation, Segmenter, TRACKED};
use crate::smooth::Smoother;
use crate::torso::{
    anchored_at_head_top, facing, facing_from_feet, head_top_of_mask, keypoints, TorsoEstimator,
    TorsoFit, TorsoPoints, TorsoPose, TorsoStart, FACING_COS,
};
use crate::view::ChairBehind;
use crate::Limb;
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use nalgebra::{Point3, Vector3};
use std::time::Instant;

/// What [`PoseEstimator::estimate`] returns for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseResult {
    /// Whether a person was found. When false, `skeleton` holds zeros with confidence 0.
    pub person_found: bool,
    /// 16 joints, metres, in the camera frame (x right, y down, z forward, as
    /// airglyph-core's back-projection gives them); a confidence in [0, 1] each.
    /// Always finite.
    pub skeleton: Skeleton,
}

/// What is carried from one frame to the next about the person tracked: losing track
/// is `Tracking::default()`. The person's learned size is not in it (a person lost for
/// a frame is most likely the same one when found again).
#[derive(Debug, Default)]
struct Tracking {
    /// Step 1: the floor found, the person's centroid and image box, where the next
    /// frame's segmentation starts.
    floor: Option<Plane>,
    centroid: Option<Point3<f32>>,
    bbox: Option<(u32, u32, u32, u32)>,
    /// Step 2: the last torso pose and its offset from the torso region's PCA centre
    /// (torso frame), where the seed's torso registration starts.
    torso: Option<TorsoPose>,
    torso_offset: Option<Vector3<f32>>,
    /// Frames since the seed's torso step last ran in full.
    frames_tracked: usize,
    /// Frames since a foot was last seen (a leg's maximum well below the neck), if
    /// one was since tracking began.
    since_foot: Option<usize>,
    /// Step 6: each limb's last chain (the assignment's temporal cost reads its
    /// extremity).
    limbs: [Option<LimbState>; 5],
    /// Step 7: the last registered body, and how hidden each of its limbs was.
    body: Option<BodyPose>,
    hidden: [f32; Segment::COUNT],
    /// The joints' filters.
    smoother: Smoother,
}

impl Tracking {
    /// Whether a foot was seen lately: the person was seen whole, not cut short by the
    /// image's edge or a table.
    fn seen_whole(&self) -> bool {
        self.since_foot.is_some_and(|n| n < FEET_MEMORY)
    }

    /// Where this frame's torso step starts, and whether it runs in full (detecting):
    /// while the registration tracks the body, its torso needs no registration of its
    /// own; every [`crate::config::RaceConfig::redetect_every`] frames the seed's
    /// torso step runs in full, so the geodesic start stays independent of the
    /// tracking.
    fn torso_start(&mut self, cfg: &PoseConfig) -> (TorsoStart, bool) {
        // A tracked body not seen whole lately (cut short of its feet by the image's
        // edge or a table) that has turned its back to the camera is taken to have
        // turned round by mistake: depth alone hardly tells a back from a front, a
        // person at a device faces it, and a registration that swapped left and right
        // explains the frame as well as the right one and keeps it. (A whole person
        // may well turn round, and its feet tell: CMU 01_03, side-on, was 0.3 cm
        // worse when whole bodies were lost so too.)
        let turned_away =
            !self.seen_whole() && self.torso.is_some_and(|p| facing(&p) < TURNED_AWAY_COS);
        if turned_away {
            *self = Tracking {
                floor: self.floor,
                centroid: self.centroid,
                bbox: self.bbox,
                ..Tracking::default()
            };
        }
        self.frames_tracked += 1;
        let redetect = self.frames_tracked >= cfg.register.race.redetect_every.max(1);
        let tracked = (!redetect)
            .then(|| {
                self.body.and_then(|b| {
                    let tpl = BodyTemplate::new(&cfg.register.shape, &cfg.body);
                    crate::torso::of_body(&b, &tpl, &cfg.torso)
                })
            })
            .flatten();
        let start = match (tracked, self.torso.zip(self.torso_offset)) {
            (Some(pose), _) => TorsoStart::Known(pose),
            // A redetection keeps the tracked torso's turn but starts it at the torso
            // region's centre: a body that drifted off would otherwise take the seed's
            // estimate with it (from scratch, front and back could swap).
            (None, Some((pose, _))) if redetect && cfg.register.enabled => {
                TorsoStart::Track(pose, Vector3::zeros())
            }
            (None, Some((pose, offset))) => TorsoStart::Track(pose, offset),
            (None, None) => TorsoStart::Fresh,
        };
        if tracked.is_none() {
            self.frames_tracked = 0;
        }
        (start, tracked.is_none())
    }
}

/// The steps' buffers, reused from frame to frame: nothing in them is read before a
/// frame writes it.
#[derive(Debug)]
struct Scratch {
    /// The frame reduced to the work width.
    small: Vec<u16>,
    /// The work image back-projected (zero where segmentation did not look) and the
    /// person's pixels.
    points: Vec<Point3<f32>>,
    mask: Vec<bool>,
    /// The mask's pixels the registration explains ([`Segmenter::body_points`]).
    body_mask: Vec<bool>,
    segmenter: Segmenter,
    torso: TorsoEstimator,
    graph: GeoGraph,
    geodesic: Geodesic,
    /// A maximum's path back to the torso centre.
    path: Vec<u32>,
    marks: TargetMarks,
    registration: Registration,
}

/// Estimates a 16-joint skeleton from each depth frame (seed §16.3). Keeps state from
/// frame to frame (the torso registration, the last fit of each limb, the registered
/// body, the person's size), so feed it the frames of one camera in order;
/// [`PoseEstimator::reset`] forgets it.
pub struct PoseEstimator {
    k: Intrinsics,
    cfg: PoseConfig,
    tracking: Tracking,
    /// The person's limb lengths, learned as they move; kept when the person is lost
    /// for a moment.
    calib: BodyCalibration,
    scratch: Scratch,
    /// The time of the last frame, seconds.
    clock: Option<f64>,
    times: StepTimes,
    debug: Debug,
    offered: Option<OfferedStart>,
}

impl PoseEstimator {
    /// An estimator for frames of the camera `intrinsics` describes. Frames of another
    /// size are handled by scaling the intrinsics to them.
    pub fn new(intrinsics: Intrinsics, config: PoseConfig) -> Self {
        Self {
            k: intrinsics,
            scratch: Scratch {
                small: Vec::new(),
                points: Vec::new(),
                mask: Vec::new(),
                body_mask: Vec::new(),
                segmenter: Segmenter::default(),
                torso: TorsoEstimator::new(&config.torso),
                graph: GeoGraph::default(),
                geodesic: Geodesic::default(),
                path: Vec::new(),
                marks: TargetMarks::default(),
                registration: Registration::default(),
            },
            cfg: config,
            tracking: Tracking::default(),
            calib: BodyCalibration::default(),
            clock: None,
            times: StepTimes::default(),
            debug: Debug::default(),
            offered: None,
        }
    }

    /// Offers the next frame's registration a start of its own (see [`OfferedStart`]).
    /// A skeleton the body cannot be posed from (hips on top of each other) is ignored.
    pub fn offer_start(&mut self, start: OfferedStart) {
        self.offered = Some(start);
    }

    /// The settings it was made with.
    pub fn config(&self) -> &PoseConfig {
        &self.cfg
    }

    /// The camera it was made for.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.k
    }

    /// Forgets everything learned from earlier frames, the person's size included.
    pub fn reset(&mut self) {
        self.tracking = Tracking::default();
        self.calib.reset();
    }

    /// The ratios of the person's arm and leg lengths to the configured body's, as
    /// learned so far (1 until enough has been seen).
    pub fn body_ratios(&self) -> (f32, f32) {
        (self.calib.arm_ratio(), self.calib.leg_ratio())
    }

    /// Time of each step in the last frame.
    pub fn step_times(&self) -> StepTimes {
        self.times
    }

    /// Intermediate results of the last frame.
    pub fn debug(&self) -> &Debug {
        &self.debug
    }

    /// The person mask of the last frame (row-major over the work image, one flag a
    /// pixel).
    pub fn mask(&self) -> &[bool] {
        &self.scratch.mask
    }

    /// The skeleton of one depth frame, taken to follow the last one by a frame period
    /// of [`PoseConfig::nominal_fps`]. Never panics and never returns NaN.
    pub fn estimate(&mut self, depth: DepthView) -> PoseResult {
        let t = self
            .clock
            .map_or(0.0, |c| c + 1.0 / self.cfg.nominal_fps.max(1.0));
        self.estimate_at(depth, t)
    }

    /// The skeleton of one depth frame captured at `time_s` seconds (any origin; not
    /// decreasing), which paces the joints' smoothing. Never panics, never NaN.
    pub fn estimate_at(&mut self, depth: DepthView, time_s: f64) -> PoseResult {
        self.clock = Some(time_s);
        let k = if (depth.width(), depth.height()) == (self.k.width, self.k.height) {
            self.k
        } else {
            self.k.scaled_to(depth.width(), depth.height())
        };
        let estimated = self.work_image(depth);
        // An offer is for one frame, taken or not (a frame without a person never
        // reaches the registration).
        self.offered = None;
        match estimated {
            Some(s) if s.is_finite() => {
                let mut skeleton = self
                    .tracking
                    .smoother
                    .smooth(s, time_s, &self.cfg.smoothing);
                // Smoothing may carry a joint seen at the image's edge past it.
                for j in 0..Joint::COUNT {
                    if !inside(&k, &skeleton.joints[j]) {
                        skeleton.visible[j] = false;
                        skeleton.confidence[j] = 0.0;
                    }
                }
                PoseResult {
                    person_found: true,
                    skeleton,
                }
            }
            _ => {
                self.tracking = Tracking::default();
                PoseResult {
                    person_found: false,
                    skeleton: Skeleton {
                        joints: [Point3::origin(); Joint::COUNT],
                        confidence: [0.0; Joint::COUNT],
                        visible: [false; Joint::COUNT],
                    },
                }
            }
        }
    }

    /// The frame reduced to the work width (each output pixel the nearest depth of its
    /// block, so 640×480 costs what 320×240 does), then the steps on it.
    fn work_image(&mut self, depth: DepthView) -> Option<Skeleton> {
        if depth.width() < 8 || depth.height() < 8 {
            return None;
        }
        let k_full = if depth.width() != self.k.width || depth.height() != self.k.height {
            self.k.scaled_to(depth.width(), depth.height())
        } else {
            self.k
        };
        let work_width = self.cfg.work_width;
        let factor = if work_width > 0 && depth.width() > work_width {
            depth.width().div_ceil(work_width)
        } else {
            1
        };
        let mut small = std::mem::take(&mut self.scratch.small);
        let r = if factor > 1 {
            match reduce(&depth, factor, &mut small) {
                Some(view) => {
                    let k = k_full.scaled_to(view.width(), view.height());
                    self.estimate_frame(view, k)
                }
                None => None,
            }
        } else {
            self.estimate_frame(depth, k_full)
        };
        self.scratch.small = small;
        r
    }

    /// The steps of one frame on the work image `depth` of camera `k`: the skeleton, or
    /// None when no person is found.
    fn estimate_frame(&mut self, depth: DepthView, k: Intrinsics) -> Option<Skeleton> {
        let size = (depth.width() as usize, depth.height() as usize);
        if k.validate().is_err() {
            return None;
        }
        // The settings with the person's limb lengths as learned so far.
        let mut cfg = self.cfg.clone();
        if self.cfg.calibrate.enabled {
            self.calib.apply(&mut cfg.body, &mut cfg.register.priors);
        }
        let cfg = &cfg;
        self.debug = Debug {
            work_size: (depth.width(), depth.height()),
            ..Debug::default()
        };
        let (s, t, d) = (&mut self.scratch, &mut self.tracking, &mut self.debug);
        let mut lap = Lap(Instant::now());

        // 1. The person's pixels.
        let seg = segment(s, t, &depth, &k, cfg, d);
        self.times.segment = lap.lap();
        if !seg.found {
            return None;
        }
        // 2. The torso.
        let mut torso = torso(s, t, &seg, size, cfg, d)?;
        self.times.torso = lap.lap();
        // 3. The geodesic graph, rooted at the torso joint.
        let root = graph(s, &k, size, &torso, cfg, d)?;
        self.times.graph = lap.lap();
        // 4. The geodesic maxima, and which of them lie where the body is cut from view
        // (there the limb goes on: it passes the maximum, it does not end at it).
        let maxima = s.geodesic.maxima(&s.graph, root, &cfg.geodesic);
        let frame = Frame {
            points: &s.points,
            mask: &s.mask,
            width: size.0,
            height: size.1,
            k: &k,
            floor: seg.floor,
        };
        let cut: Vec<bool> = maxima
            .iter()
            .map(|&m| frame.at_a_cut(s.graph.pixel_of_node[m as usize] as usize))
            .collect();
        let pixel = |m: &u32| s.graph.pixel_of_node[*m as usize];
        d.maxima = maxima.iter().map(pixel).collect();
        d.cut_maxima = maxima
            .iter()
            .zip(&cut)
            .filter(|(_, c)| **c)
            .map(|(m, _)| pixel(m))
            .collect();
        self.times.geodesic = lap.lap();
        let whole: Vec<u32> = maxima
            .iter()
            .zip(&cut)
            .filter(|(_, c)| !**c)
            .map(|(m, _)| *m)
            .collect();
        turn_to_the_feet(s, t, &mut torso, &whole, cfg);
        // 5. The maxima given to the limbs (the head's holding the torso's height), and
        // the limbs' tips checked against the tracked body.
        let tpl = BodyTemplate::new(&cfg.register.shape, &cfg.body);
        // A limb whose root the camera cannot see (hips below the image's border or
        // behind a table) shows no end in view either.
        let rooted = Limb::ALL.map(|l| frame.sees(torso.keypoints.root_of(l)));
        let assigned = assign_limbs(s, t, &maxima, &cut, rooted, &mut torso, size, &tpl, cfg, d);
        // The neck's base as the person's outline shows it, below the head's maximum,
        // to hold the height of a body the image or a table cuts short of its feet: a
        // foot in view holds it better. (A leg's tip near the torso is no foot: a
        // hand's maximum taken for a leg's.)
        let up = torso.pose.r * Vector3::y();
        let foot_seen = [Limb::LeftLeg, Limb::RightLeg].iter().any(|l| {
            assigned.tips[l.index()]
                .is_some_and(|tip| (torso.keypoints.neck - tip).dot(&up) >= FOOT_BELOW_NECK)
        });
        let neck = assigned.limb[Limb::Head.index()]
            .filter(|&mi| !cut[mi] && !foot_seen)
            .and_then(|mi| {
                let head = s.graph.pos[maxima[mi] as usize];
                let base =
                    |top: &Point3<f32>| neck_base(&s.points, &s.mask, &torso.pose, top, 1.0 / k.fx);
                base(&head).or_else(|| {
                    head_top_maximum(&head, &torso.pose, &whole, &s.graph.pos)
                        .and_then(|top| base(&top))
                })
            });
        d.neck_base = neck.clone();
        t.since_foot = if foot_seen {
            Some(0)
        } else {
            t.since_foot.map(|n| n.saturating_add(1))
        };
        // Without registration, the limbs' geodesic lengths measure the person.
        if !cfg.register.enabled {
            for l in Limb::ALL {
                if let Some(mi) = assigned.limb[l.index()] {
                    let length = assigned.lengths[mi][l.index()];
                    self.calib
                        .measure(&self.cfg.calibrate, &self.cfg.body, l, length);
                }
            }
        }
        // 6. The seed's skeleton: the torso's key points and, when it races the tracked
        // body, a chain per limb.
        let seed = chains(s, t, &torso, &maxima, &assigned, &k, cfg, d);
        self.times.limbs = lap.lap();
        // 7. The whole body registered to the frame, from the last frame's body and
        // from the seed's estimate when it races, whichever explains the frame better.
        // What lies behind the torso's back of a body facing the camera, cut short of
        // its feet and not seen whole lately, by more than the sensor's noise: the
        // chair's, for the registration's points and for which legs show a foot.
        let facing_cut = facing(&torso.pose) > FACING_COS && !foot_seen;
        let chair = (facing_cut && !t.seen_whole())
            .then(|| ChairBehind::of(&torso.pose, cfg.torso.half_depth + CHAIR_BEHIND_BACK));
        let mut skeleton = if cfg.register.enabled {
            // A seated person's chair back shows between the arms and the torso and
            // around the body; taken into the mask across its depth jumps, it pulled
            // hanging forearms back into it. Left out of the points the registration
            // explains: the mask's parts behind the torso's back, of a torso facing
            // the camera (side-on, its back lies along the rays and a far limb behind
            // it) and cut short of its feet (a far leg seen through a gap of a whole
            // body was taken for one).
            let mask = if facing_cut {
                let inv = torso.pose.inverse();
                let back = cfg.torso.half_depth;
                s.segmenter
                    .body_points(&s.mask, &mut s.body_mask, |p| inv.apply(&p).z < -back);
                // Where the person leans on the chair's back, back and chair meet
                // with no depth jump and the chair is one part with the body: its
                // points are then left out one by one (`chair`). Not for a body seen
                // whole lately: a boxer's elbow drawn back, a leg stepping back, lie
                // there too.
                if let Some(chair) = &chair {
                    for (m, p) in s.body_mask.iter_mut().zip(&s.points) {
                        *m &= p.z <= 0.0 || !chair.holds(p);
                    }
                }
                &s.body_mask
            } else {
                &s.mask
            };
            let frame = Frame {
                points: &s.points,
                mask,
                width: size.0,
                height: size.1,
                k: &k,
                floor: seg.floor,
            };
            let side_on = torso.side_on.then_some(seg.centroid);
            let offered = self.offered.take();
            let calib = self.cfg.calibrate.enabled.then_some(&mut self.calib);
            let upright = (torso.detecting && cfg.register.race.upright_rest)
                .then(|| upright_torso(&seed.skeleton, &torso.fit.pose, torso.up_hint, &tpl, cfg))
                .flatten();
            let body = Body {
                template: tpl,
                side_on,
                offered,
                upright,
                neck,
            };
            let reg = &mut s.registration;
            register_body(reg, &frame, t, &seed, &torso.pose, body, calib, cfg, d)?
        } else {
            seed.reported()
        };
        self.times.register = lap.lap();
        // 8. Which joints the camera could see: a joint out of view is reported so,
        // with confidence 0, its place only a guess.
        let frame = Frame {
            points: &s.points,
            mask: &s.mask,
            width: size.0,
            height: size.1,
            k: &k,
            floor: seg.floor,
        };
        for j in 0..Joint::COUNT {
            skeleton.visible[j] = frame.shows(&skeleton.joints[j]);
        }
        // The hips of a body not seen whole lately (no foot in view, this frame or
        // lately), whose pelvis the camera mostly does not see where the fit puts it:
        // the fit holds them just above a table's edge or the image's, the segment
        // behind it. (With a foot in view the legs hold the pelvis, and a standing
        // body's pelvis half hidden by a forearm, or by its own leg side-on, is seen.)
        if !t.seen_whole() {
            for j in [Joint::Pelvis, Joint::LeftHip, Joint::RightHip] {
                if skeleton.confidence[j.index()] < PELVIS_SEEN {
                    skeleton.visible[j.index()] = false;
                }
            }
        }
        // A leg's knee and foot: only what its end in view shows (`legs_seen.rs`).
        for l in [Limb::LeftLeg, Limb::RightLeg] {
            let (hip, knee, foot) = l.joints();
            let end = assigned.limb[l.index()].map(|mi| LegEnd {
                at: s.graph.pos[maxima[mi] as usize],
                cut: cut[mi],
                reach: assigned.lengths[mi][l.index()],
            });
            let rooted = rooted[l.index()] && skeleton.visible[hip.index()];
            let seen = leg_seen(l, &skeleton, end, rooted, &up, &frame, chair.as_ref());
            if let Some(knee) = knee {
                skeleton.visible[knee.index()] = seen.knee;
            }
            skeleton.visible[foot.index()] = seen.foot;
        }
        for j in 0..Joint::COUNT {
            if !skeleton.visible[j] {
                skeleton.confidence[j] = 0.0;
            }
        }

        // The paths are done with: hand their buffers to the overlay as pixels.
        let mut paths = assigned.paths;
        for path in &mut paths {
            for a in path.iter_mut() {
                *a = s.graph.pixel_of_node[*a as usize];
            }
        }
        d.paths = paths;
        Some(skeleton)
    }
}

/// How far below the top of the head the mask shows a head's maximum may lie and still
/// hold the torso's height, metres: about a third of a head.
const BELOW_THE_HEADS_TOP: f32 = 0.05;

/// How far below the neck a leg's tip must lie to be a foot, metres: a seated child's
/// feet lie farther.
const FOOT_BELOW_NECK: f32 = 0.8;

/// The share of the pelvis the camera must see where the fit puts it, in a body cut
/// short of its feet, for its hips to be reported visible.
const PELVIS_SEEN: f32 = 0.5;

/// A tracked torso turned further than this from facing the camera (120°) is lost
/// ([`Tracking::torso_start`])...
const TURNED_AWAY_COS: f32 = -0.5;

/// ...unless a foot was seen within this many frames (2 s at 30 frames/s).
const FEET_MEMORY: usize = 60;

/// How far behind the torso's back a point of a body cut short of its feet is taken
/// for the chair's, metres: beyond the sensor's noise there.
const CHAIR_BEHIND_BACK: f32 = 0.05;

/// Whether `p` projects inside the image of camera `k`.
fn inside(k: &Intrinsics, p: &Point3<f32>) -> bool {
    k.project(p).is_some_and(|(u, v)| {
        u >= 0.0 && v >= 0.0 && u <= k.width as f32 - 1.0 && v <= k.height as f32 - 1.0
    })
}

/// Seconds between laps.
struct Lap(Instant);

impl Lap {
    /// Seconds since the last lap (or the start).
    fn lap(&mut self) -> f64 {
        let now = Instant::now();
        let dt = (now - self.0).as_secs_f64();
        self.0 = now;
        dt
    }
}

/// Step 1: the person's pixels (into `s.points` and `s.mask`). A person found far from
/// the last frame's is not the one tracked (or the camera lost them for long): the
/// torso, limbs and body tracked belong elsewhere, and starting from them would lose
/// this one, so tracking starts afresh.
fn segment(
    s: &mut Scratch,
    t: &mut Tracking,
    depth: &DepthView,
    k: &Intrinsics,
    cfg: &PoseConfig,
    d: &mut Debug,
) -> Segmentation {
    let seg = s.segmenter.run(
        depth,
        k,
        &cfg.segment,
        t.floor,
        t.centroid,
        t.bbox,
        &mut s.points,
        &mut s.mask,
    );
    if seg.found
        && t.centroid
            .is_some_and(|c| (seg.centroid - c).norm() > TRACKED)
    {
        *t = Tracking::default();
    }
    t.floor = seg.floor;
    d.floor = seg.floor;
    d.windowed = seg.windowed;
    t.bbox = seg.found.then_some(seg.bbox);
    if seg.found {
        t.centroid = Some(seg.centroid);
    }
    seg
}

/// The torso of this frame, as the later steps move it.
struct Torso {
    /// The torso step's fit.
    fit: TorsoFit,
    /// The torso frame now (turned to the feet, held at the head's height).
    pose: TorsoPose,
    /// Its key points, camera frame.
    keypoints: TorsoPoints<Point3<f32>>,
    /// The torso key points' confidence.
    confidence: f32,
    /// Whether the seed's torso step ran in full (no tracked body to take it from).
    detecting: bool,
    /// Found afresh with a narrow torso core: perhaps side-on, which the seed's torso
    /// step takes for a frontal chest (see `register::starts`).
    side_on: bool,
    /// Which way is up: the floor's normal, or the camera's up.
    up_hint: Vector3<f32>,
}

impl Torso {
    fn set_pose(&mut self, pose: TorsoPose, cfg: &PoseConfig) {
        self.pose = pose;
        self.keypoints = keypoints(&pose, &cfg.torso);
    }
}

/// Step 2: the torso, by distance transform, PCA and model registration, or the
/// tracked body's.
fn torso(
    s: &mut Scratch,
    t: &mut Tracking,
    seg: &Segmentation,
    (w, h): (usize, usize),
    cfg: &PoseConfig,
    d: &mut Debug,
) -> Option<Torso> {
    let up_hint = seg.floor.map(|p| p.n).unwrap_or(-Vector3::y());
    let (start, detecting) = t.torso_start(cfg);
    let fit = s
        .torso
        .fit(&s.points, &s.mask, w, h, &cfg.torso, start, up_hint)?;
    let side_on = t.body.is_none()
        && fit
            .core_half_width
            .is_some_and(|w| w < cfg.torso.side_on_half_width);
    d.torso_residual = fit.residual;
    d.torso_reinit = fit.reinitialised;
    let confidence = if fit.residual.is_finite() {
        (1.0 - fit.residual / (2.0 * cfg.torso.icp_reinit_residual)).clamp(0.2, 1.0)
    } else {
        0.2
    };
    // The torso model slides along its axis; when it is found afresh, the top of the
    // head holds it. Not while tracking (the tracked body holds it better), nor at a
    // re-detection of a body whose feet were seen lately: the feet hold its height,
    // and at a walker's re-detections the head's top moved the torso, and a hand was
    // fitted off its arm for the frames that followed.
    let mut pose = fit.pose;
    if detecting && cfg.torso.head_top_height > 0.0 && !t.seen_whole() {
        if let Some(top) = head_top_of_mask(&s.points, &s.mask, w, &pose) {
            let dy = top - cfg.torso.head_top_height;
            if dy.abs() < 0.3 {
                pose.t += pose.r * Vector3::new(0.0, dy, 0.0);
            }
        }
    }
    t.torso = Some(pose);
    d.torso_pose = Some(pose);
    Some(Torso {
        fit,
        pose,
        keypoints: keypoints(&pose, &cfg.torso),
        confidence,
        detecting,
        side_on,
        up_hint,
    })
}

/// Step 3: the geodesic graph over the person's pixels, and its node at the torso joint
/// (the root).
fn graph(
    s: &mut Scratch,
    k: &Intrinsics,
    (w, h): (usize, usize),
    torso: &Torso,
    cfg: &PoseConfig,
    d: &mut Debug,
) -> Option<u32> {
    s.graph.build(&s.points, &s.mask, w, h, k, &cfg.graph);
    d.nodes = s.graph.node_count();
    d.bridges = s.graph.bridges.len();
    d.joins = s.graph.joins.len();
    if let Some(a) = s.graph.nearest_node(k, &Point3::from(torso.pose.t), 24) {
        return Some(a);
    }
    // A known torso came without the distance transform's core pixel: the rare frame
    // whose torso lies off the graph pays for it here.
    let core = torso.fit.core_pixel.or_else(|| {
        let init = s
            .torso
            .initial_pose(&s.points, &s.mask, w, h, &cfg.torso, torso.up_hint);
        init.map(|(_, core)| core)
    })?;
    let a = s.graph.node_of_pixel[core];
    (a != NONE && s.graph.comp[a as usize] != NONE).then_some(a)
}

/// The torso model cannot tell front from back, nor well a quarter turn; the feet can:
/// toes point where the person faces. The torso is turned when they say so.
fn turn_to_the_feet(
    s: &Scratch,
    t: &mut Tracking,
    torso: &mut Torso,
    maxima: &[u32],
    cfg: &PoseConfig,
) {
    if !cfg.torso.feet_facing {
        return;
    }
    if let Some(turned) = facing_from_feet(&torso.pose, maxima, &s.graph, &s.geodesic) {
        torso.set_pose(turned, cfg);
        t.torso = Some(turned);
    }
}

/// Step 5's result.
struct Assigned {
    /// Per limb, the maximum given to it (index into the maxima).
    limb: [Option<usize>; 5],
    /// Per maximum and limb: where its path is cut for the limb, and the geodesic
    /// length from the limb's root ([`LimbCosts`]).
    cuts: Vec<[usize; 5]>,
    lengths: Vec<[f32; 5]>,
    /// Per maximum, its path back to the torso joint.
    paths: Vec<Vec<u32>>,
    /// Per limb, its tip: the maximum given to it, unless it lies on another limb of
    /// the tracked body.
    tips: [Option<Point3<f32>>; 5],
    /// Per limb, the maximum given to it, at a cut or not: if it is the limb's, the limb
    /// reaches at least that far.
    ends: [Option<Point3<f32>>; 5],
    /// Whether the seed's estimate races the tracked body: when detecting, when nothing
    /// is tracked, or when a limb tip lies far from the tracked body's and off its
    /// surface; otherwise the registration alone follows the body from the last frame.
    race: bool,
}

/// Step 5: the maxima given to the limbs by least total cost; the torso held at the
/// head's height; the limbs' tips, and whether the seed's estimate races the tracked
/// body.
#[allow(clippy::too_many_arguments)]
fn assign_limbs(
    s: &mut Scratch,
    t: &mut Tracking,
    maxima: &[u32],
    cut: &[bool],
    rooted: [bool; 5],
    torso: &mut Torso,
    (w, h): (usize, usize),
    tpl: &BodyTemplate,
    cfg: &PoseConfig,
    d: &mut Debug,
) -> Assigned {
    let tracked_torso = torso.pose;
    let inv = torso.pose.inverse();
    let LimbCosts {
        cost,
        cuts,
        lengths,
        paths,
    } = limb_costs(
        &s.graph,
        &s.geodesic,
        maxima,
        cut,
        &Limb::ALL.map(|l| *torso.keypoints.root_of(l)),
        &inv,
        &t.limbs.map(|l| l.and_then(|l| l.extremity)),
        &cfg.assign,
        &cfg.body,
        &cfg.torso,
        &mut s.path,
    );
    let mut cost = cost;
    for row in &mut cost {
        for (c, _) in row.iter_mut().zip(rooted).filter(|(_, seen)| !seen) {
            *c = f32::INFINITY;
        }
    }
    let limb = assign(&cost, cfg.assign.unassigned_cost);
    d.cost = cost;
    d.maxima_dist = maxima
        .iter()
        .map(|&m| s.geodesic.dist(m) as f32 * 1e-3)
        .collect();
    d.assignment = limb;
    // The head's top holds the torso's height (the next frame's torso step starts from
    // the torso before this).
    if let (Some(mi), true) = (limb[Limb::Head.index()], cfg.torso.head_top_height > 0.0) {
        let top = maxima[mi] as usize;
        let px = s.graph.pixel_of_node[top] as usize;
        let mut pose = torso.pose;
        let head_top = &s.graph.pos[top];
        // Where the torso step held the torso at the top of the head the mask shows, a
        // maximum well below it is no top: a forearm folded back against the head
        // closes a loop through it, and the head's maximum is then a point of its side
        // where the two ways round meet.
        let below_the_top = torso.detecting
            && !t.seen_whole()
            && head_top_of_mask(&s.points, &s.mask, w, &pose)
                .is_some_and(|top| inv.apply(head_top).y < top - BELOW_THE_HEADS_TOP);
        if !below_the_top {
            anchored_at_head_top(
                &mut pose,
                &inv,
                head_top,
                (px % w, px / w),
                (w, h),
                &cfg.torso,
            );
        }
        d.torso_pose = Some(pose);
        torso.set_pose(pose, cfg);
    }
    // The registered torso may have slid along its axis, which closest points do not
    // pin; the next frame starts no farther from the torso region's centre than a torso
    // can be, or the slide would be carried on for good. A known torso measured no
    // region this frame: the last offset measured stands.
    if let Some(pca) = torso.fit.pca {
        let mut offset = tracked_torso.r.inverse() * (tracked_torso.t - pca.t);
        let lim = cfg.torso.max_offset;
        if lim > 0.0 {
            offset.y = offset.y.clamp(-lim, lim);
        }
        t.torso_offset = Some(offset);
    }
    let ends = limb.map(|mi| mi.map(|mi| s.graph.pos[maxima[mi] as usize]));
    // A limb given a maximum at a cut goes on beyond it: it has no tip to pull to.
    let mut tips = [None; 5];
    for l in Limb::ALL {
        if let Some(mi) = limb[l.index()].filter(|&mi| !cut[mi]) {
            tips[l.index()] = Some(s.graph.pos[maxima[mi] as usize]);
        }
    }
    if let (Some(prev), true) = (t.body, cfg.register.enabled) {
        drop_borrowed_tips(tpl, &prev, &mut tips, &cfg.register.race);
    }
    let race = !cfg.register.enabled
        || torso.detecting
        || t.body
            .is_none_or(|prev| tips_strayed(tpl, &prev, &tips, &cfg.register.race));
    d.raced = race;
    Assigned {
        limb,
        cuts,
        lengths,
        paths,
        tips,
        ends,
        race,
    }
}

/// Step 6's result: the seed's estimate.
struct Seed {
    /// The torso's key points and, when racing, the chains' joints.
    skeleton: Skeleton,
    /// The limbs' tips ([`Assigned::tips`]).
    tips: [Option<Point3<f32>>; 5],
    /// The limbs' maxima, at a cut or not ([`Assigned::ends`]).
    ends: [Option<Point3<f32>>; 5],
    /// Whether it races the tracked body ([`Assigned::race`]).
    race: bool,
}

impl Seed {
    /// The skeleton as reported: the head chain ends at the skull's centre, which the
    /// registration's starts are turned onto; the head reported is the top of the head,
    /// where its geodesic maximum lies (when one was assigned).
    fn reported(&self) -> Skeleton {
        let mut s = self.skeleton;
        if let Some(top) = self.tips[Limb::Head.index()] {
            s.set(Joint::Head, top);
        }
        s
    }
}

/// Step 6: the seed's skeleton: the torso's key points and, when racing, a two-joint
/// chain per limb fitted to its target points.
#[allow(clippy::too_many_arguments)]
fn chains(
    s: &mut Scratch,
    t: &mut Tracking,
    torso: &Torso,
    maxima: &[u32],
    assigned: &Assigned,
    k: &Intrinsics,
    cfg: &PoseConfig,
    d: &mut Debug,
) -> Seed {
    let mut skel = Skeleton::new([Point3::origin(); Joint::COUNT]);
    for (j, p) in TorsoPoints::<()>::JOINTS
        .into_iter()
        .zip(torso.keypoints.to_array())
    {
        skel.set(j, p);
        skel.confidence[j.index()] = torso.confidence;
    }
    let f = 0.5 * (k.fx + k.fy);
    for l in Limb::ALL.into_iter().filter(|_| assigned.race) {
        let li = l.index();
        let (_, jm, je) = l.joints();
        let found = assigned.limb[li].map(|mi| {
            let path = &assigned.paths[mi];
            (
                &path[..=assigned.cuts[mi][li].min(path.len() - 1)],
                maxima[mi],
            )
        });
        let root = *torso.keypoints.root_of(l);
        let (graph, geo, marks) = (&s.graph, &s.geodesic, &mut s.marks);
        let prev = t.limbs[li];
        let limb = limb_chain(
            l,
            root,
            found,
            &torso.pose,
            prev,
            &cfg.chains,
            &cfg.body,
            cfg.hands.behind_tip,
            f,
            graph,
            geo,
            marks,
        );
        t.limbs[li] = Some(limb.state);
        if let Some(targets) = limb.targets {
            d.targets[li] = targets;
        }
        if let Some(jm) = jm {
            skel.set(jm, limb.chain.mid);
            skel.confidence[jm.index()] = limb.confidence;
        }
        skel.set(je, limb.chain.end);
        skel.confidence[je.index()] = limb.confidence;
    }
    Seed {
        skeleton: skel,
        tips: assigned.tips,
        ends: assigned.ends,
        race: assigned.race,
    }
}

/// The seed's skeleton `seed` on the torso step's own torso `pose` (before the head's
/// top and the feet moved it) turned upright (its axis along `up`), each limb carried
/// with its root (the head with the neck), as a body. Close up, the limbs merged into
/// the torso's silhouette tilt the torso model; people mostly sit and stand upright.
fn upright_torso(
    seed: &Skeleton,
    pose: &TorsoPose,
    up: Vector3<f32>,
    tpl: &BodyTemplate,
    cfg: &PoseConfig,
) -> Option<BodyPose> {
    use Joint::*;
    let mut pose = *pose;
    pose.r = nalgebra::Rotation3::rotation_between(&(pose.r * Vector3::y()), &up)? * pose.r;
    let p = keypoints(&pose, &cfg.torso);
    let mut s = *seed;
    for (root, to, carried) in [
        (Neck, p.neck, &[Head][..]),
        (LeftShoulder, p.left_shoulder, &[LeftElbow, LeftHand]),
        (RightShoulder, p.right_shoulder, &[RightElbow, RightHand]),
        (LeftHip, p.left_hip, &[LeftKnee, LeftFoot]),
        (RightHip, p.right_hip, &[RightKnee, RightFoot]),
        (Pelvis, p.pelvis, &[]),
        (Torso, p.torso, &[]),
    ] {
        let by = to - seed[root];
        s.set(root, to);
        for &j in carried {
            s.set(j, seed[j] + by);
        }
    }
    BodyPose::from_skeleton(tpl, &s)
}

/// What step 7 fits besides the frame and the seed's estimate.
struct Body {
    /// This frame's body template (the person's limb lengths).
    template: BodyTemplate,
    /// The person's centroid, when perhaps side-on.
    side_on: Option<Point3<f32>>,
    /// A start offered from outside.
    offered: Option<OfferedStart>,
    /// At a detection, the seed's estimate on the torso step's own torso turned
    /// upright ([`upright_torso`]).
    upright: Option<BodyPose>,
    /// The neck's base the person's outline shows ([`neck_base`]).
    neck: Option<NeckBase>,
}

/// Step 7: the whole body registered to the frame; its skeleton, with the hands placed
/// on their points. The tracked body and the limbs' states follow the fit (when the
/// chains were skipped), the person's size learns from it (`calib`). None when the frame
/// is lost: no chains this frame and no registered body either.
#[allow(clippy::too_many_arguments)]
fn register_body(
    reg: &mut Registration,
    frame: &Frame,
    t: &mut Tracking,
    seed: &Seed,
    torso: &TorsoPose,
    body: Body,
    calib: Option<&mut BodyCalibration>,
    cfg: &PoseConfig,
    d: &mut Debug,
) -> Option<Skeleton> {
    let mut tpl = body.template;
    reg.prepare(frame, &cfg.register.sampling);
    let geodesic = seed
        .race
        .then(|| BodyPose::from_skeleton(&tpl, &seed.skeleton))
        .flatten();
    let starts = starts(
        &tpl,
        t.body,
        geodesic,
        geodesic.and(body.upright),
        &seed.tips,
        body.side_on,
        body.offered,
        body.neck.clone(),
        &cfg.register,
    );
    // A person found afresh has their arms searched for too. (While tracking, a
    // searched arm won frames it should not: an arm hidden behind the body, which
    // nothing contradicts, searched into the open.)
    let afresh = seed.race && t.body.is_none();
    let mut best = reg.fit(frame, &tpl, &starts, &t.hidden, afresh);
    if seed.race {
        d.geodesic = Some(seed.skeleton);
    }
    let mut placed = None;
    let mut calib = calib;
    if let (Some(b), Some(calib), true) = (&mut best, calib.as_deref_mut(), afresh) {
        if let Some(longer) =
            arms_to_their_tips(reg, frame, &tpl, b, seed, body.neck, t, calib, cfg)
        {
            (tpl, *b) = longer;
        }
    }
    if let Some(b) = best {
        if let Some(calib) = calib {
            calib.learn(&b, &cfg.register.lengths);
        }
        placed = fitted_joints(&b, &tpl, &seed.tips, frame, cfg);
        if placed.is_some() {
            t.body = Some(b.pose);
            t.hidden = hidden_limbs(&b.seen);
            d.register_passes = b.passes;
            let points = reg.data_len();
            d.register_energy = b.energy / points.max(1) as f32;
            d.register_points = points;
            d.body = Some((b.pose, tpl));
        }
    }
    let Some(Fitted {
        skeleton: mut skel,
        hands,
        head_top,
    }) = placed
    else {
        if seed.race {
            return Some(seed.reported());
        }
        // Neither chains nor a registered body: the frame is lost.
        t.body = None;
        return None;
    };
    // The chains were skipped: their state (the limbs' last fits, in the torso frame)
    // follows the registered body, its hands as fitted.
    if !seed.race {
        t.limbs = crate::chains::following(&skel, &seed.tips, torso);
    }
    for (j, h) in [Joint::LeftHand, Joint::RightHand].into_iter().zip(hands) {
        if let Some(h) = h {
            skel.set(j, h);
        }
    }
    // The template's skeleton carries the skull's centre, which the chains' state
    // follows; the head reported is the top of the head.
    skel.set(Joint::Head, head_top);
    Some(skel)
}

/// The least lengthening of the arms worth fitting the body again for: the tip lies on
/// the surface, and the sensor's noise moves it.
const ARMS_LONGER: f32 = 1.05;

/// A person found afresh whose arms' tips lie beyond the reach of the arms fitted in `b`
/// ([`arms_reaching`]): the body fitted again from `b` with arms long enough, and its
/// template; the person's arms are held at least that long from now on (`calib`). None
/// when the arms reach their tips.
#[allow(clippy::too_many_arguments)]
fn arms_to_their_tips(
    reg: &mut Registration,
    frame: &Frame,
    tpl: &BodyTemplate,
    b: &Fit,
    seed: &Seed,
    neck: Option<NeckBase>,
    t: &Tracking,
    calib: &mut BodyCalibration,
    cfg: &PoseConfig,
) -> Option<(BodyTemplate, Fit)> {
    let k = arms_reaching(tpl, &b.pose, &seed.ends).filter(|&k| k >= ARMS_LONGER)?;
    let ratio = calib.arm_ratio();
    calib.arms_at_least(ratio * k);
    // The factor as the calibration bounds it: none left when the arms are already
    // as long as it allows.
    let k = calib.arm_ratio() / ratio;
    if k <= 1.0 {
        return None;
    }
    let bones = BodyConfig {
        upper_arm: cfg.body.upper_arm * k,
        forearm: cfg.body.forearm * k,
        ..cfg.body.clone()
    };
    let longer = BodyTemplate::new(&cfg.register.shape, &bones);
    let starts = starts(
        &longer,
        Some(b.pose),
        None,
        None,
        &seed.tips,
        None,
        None,
        neck,
        &cfg.register,
    );
    let fit = reg.fit(frame, &longer, &starts, &t.hidden, false)?;
    Some((longer, fit))
}

/// `depth` reduced by `factor`, each pixel the nearest depth of its block (into
/// `small`); None when the reduced image is no image.
fn reduce<'a>(depth: &DepthView, factor: u32, small: &'a mut Vec<u16>) -> Option<DepthView<'a>> {
    let (sw, sh) = (depth.width() / factor, depth.height() / factor);
    small.clear();
    small.resize((sw * sh) as usize, 0);
    let src = depth.pixels();
    let fw = depth.width() as usize;
    for v in 0..sh as usize {
        for u in 0..sw as usize {
            let mut best = u16::MAX;
            for dv in 0..factor as usize {
                let row = (v * factor as usize + dv) * fw + u * factor as usize;
                for &d in &src[row..row + factor as usize] {
                    if d > 0 && d < best {
                        best = d;
                    }
                }
            }
            small[v * sw as usize + u] = if best == u16::MAX { 0 } else { best };
        }
    }
    DepthView::new(sw, sh, small).ok()
}

/// The skeleton of a registered body: its joints, each confident as much as the camera
/// sees of its segment where the body puts it, the hands behind the fingertips seen;
/// and where each hand (left, right) lies among its own points, if it moves. None when
/// the body gives no finite joints.
fn fitted_joints(
    b: &Fit,
    tpl: &BodyTemplate,
    tips: &[Option<Point3<f32>>; 5],
    frame: &Frame,
    cfg: &PoseConfig,
) -> Option<Fitted> {
    let posed = Posed::new(tpl, &b.pose);
    let mut skel = posed.skeleton(tpl);
    if !skel.is_finite() {
        return None;
    }
    for j in Joint::ALL {
        let seen = b.seen[segment_of(j).index()];
        skel.confidence[j.index()] = (0.1 + 0.9 * seen).clamp(0.0, 1.0);
    }
    hands_at_fingertips(&mut skel, &posed, tpl, tips, &cfg.hands, &cfg.chains);
    // The capsules where the body puts them, placed once for both steps.
    let placed = place(tpl, &posed);
    let hands = hands_at_their_points(&skel, frame, &placed, &cfg.hands);
    let head_top = head_top_at_its_points(frame, tpl, &posed, &placed, &cfg.head)
        .unwrap_or_else(|| posed.point(Segment::Head, &tpl.crown));
    Some(Fitted {
        skeleton: skel,
        hands,
        head_top,
    })
}

/// A registered body's joints ([`fitted_joints`]).
struct Fitted {
    /// The template's skeleton (its head the skull's centre), the hands at their tips.
    skeleton: Skeleton,
    /// Where each hand (left, right) lies among its points, if it was placed.
    hands: [Option<Point3<f32>>; 2],
    /// The top of the head: the head joint reported.
    head_top: Point3<f32>,
}
