//! The whole estimator: segmentation → torso → graph → geodesic maxima → limbs.

use crate::body::{BodyPose, BodyTemplate, Posed};
use crate::calibrate::BodyCalibration;
use crate::config::{Limb, PoseConfig};
use crate::dijkstra::{Dijkstra, Graph, INF};
use crate::graph::{GeoGraph, NONE};
use crate::limbs::{assign, fit_chain, Chain};
use crate::register::{Frame, Registration};
use crate::segment::{Plane, Segmenter};
use crate::torso::{keypoints, TorsoEstimator, TorsoPose, TorsoStart};
use airglyph_core::filter::OneEuro;
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use nalgebra::{Point3, Vector3};
use std::time::Instant;

/// What [`PoseEstimator::estimate`] returns for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseResult {
    /// Whether a person was found. When false, `skeleton` holds zeros with confidence 0.
    pub person_found: bool,
    /// 16 joints, metres, camera frame of DESIGN.md; a confidence in [0, 1] each.
    /// Always finite.
    pub skeleton: Skeleton,
}

/// Time spent in each step of the last frame, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepTimes {
    pub segment: f64,
    pub torso: f64,
    pub graph: f64,
    pub geodesic: f64,
    pub limbs: f64,
    /// The articulated registration ([`crate::register`]).
    pub register: f64,
}

/// Intermediate results of the last frame, for overlays and diagnostics.
#[derive(Debug, Clone, Default)]
pub struct Debug {
    /// Pixels of the geodesic maxima, in the order found.
    pub maxima: Vec<u32>,
    /// For each limb, the maximum assigned to it (index into `maxima`).
    pub assignment: [Option<usize>; 5],
    /// Target points of each limb.
    pub targets: [Vec<Point3<f32>>; 5],
    /// Nodes of the graph, components joined, bridges.
    pub nodes: usize,
    pub bridges: usize,
    pub joins: usize,
    /// Torso registration residual (m) and whether it was re-initialised.
    pub torso_residual: f32,
    pub torso_reinit: bool,
    pub floor: Option<Plane>,
    /// Whether segmentation found the person around the last frame's, without looking
    /// at the whole image ([`crate::segment::Segmentation::windowed`]).
    pub windowed: bool,
    /// Assignment cost of each maximum (rows) for each limb (columns).
    pub cost: Vec<[f32; 5]>,
    /// Geodesic distance of each maximum from the torso centre, metres.
    pub maxima_dist: Vec<f32>,
    /// The registered torso frame (torso frame → camera frame).
    pub torso_pose: Option<TorsoPose>,
    /// Pixels of each maximum's geodesic path back to the torso centre.
    pub paths: Vec<Vec<u32>>,
    /// Size of the image the steps worked on (after reduction), and its intrinsics.
    pub work_size: (u32, u32),
    /// The registered body and its template, when registration ran.
    pub body: Option<(BodyPose, BodyTemplate)>,
    /// The skeleton of the geodesic steps alone, before registration.
    pub geodesic: Option<Skeleton>,
    /// Person points and passes over them the registration took.
    pub register_points: usize,
    pub register_passes: usize,
    /// The registration's energy per data point.
    pub register_energy: f32,
    /// Whether the geodesic estimate raced the tracked body this frame.
    pub raced: bool,
}

#[derive(Debug, Clone, Copy)]
struct LimbState {
    /// Middle and end joint, and the extremity, in the torso frame.
    mid: Point3<f32>,
    end: Point3<f32>,
    extremity: Option<Point3<f32>>,
    confidence: f32,
}

/// Estimates a 16-joint skeleton from each depth frame (seed §16.3). Keeps state from
/// frame to frame (the torso registration, the last fit of each limb), so feed it the
/// frames of one camera in order; [`PoseEstimator::reset`] forgets it.
pub struct PoseEstimator {
    k: Intrinsics,
    cfg: PoseConfig,
    seg: Segmenter,
    torso: TorsoEstimator,
    graph: GeoGraph,
    dij: Dijkstra,
    dist0: Vec<u32>,
    pred0: Vec<u32>,
    points: Vec<Point3<f32>>,
    mask: Vec<bool>,
    stamp: Vec<u32>,
    stamp_now: u32,
    path: Vec<u32>,
    small: Vec<u16>,
    prev_torso: Option<TorsoPose>,
    /// The torso origin's offset from the torso region's PCA centre, in the torso frame.
    prev_offset: Option<Vector3<f32>>,
    prev_floor: Option<Plane>,
    prev_centroid: Option<Point3<f32>>,
    /// The last frame's person box in the image, where segmentation looks first.
    prev_box: Option<(u32, u32, u32, u32)>,
    limbs: [Option<LimbState>; 5],
    reg: Registration,
    /// The last frame's registered body, and frames since the torso was last
    /// registered on its own.
    prev_body: Option<BodyPose>,
    /// How hidden its limbs were ([`crate::register::hidden_limbs`]).
    prev_hidden: [f32; crate::body::Segment::COUNT],
    frames_tracked: usize,
    /// The person's limb lengths, learned as they move; kept when the person is lost
    /// for a moment.
    calib: BodyCalibration,
    /// One filter per joint coordinate, and the time of the last frame (seconds).
    smooth: Vec<[OneEuro; 3]>,
    clock: Option<f64>,
    times: StepTimes,
    debug: Debug,
    offered: Option<OfferedStart>,
}

/// A pose offered to the next frame's registration from outside, for experiments
/// that ask whether finding the pose or the energy limits the error (the truth of a
/// synthetic frame, say: `examples/devloop.rs oracle`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OfferedStart {
    /// Raced beside the estimator's own starts.
    Also(Skeleton),
    /// The only start.
    Only(Skeleton),
}

/// The cost of giving each geodesic maximum (rows) to each limb (columns), and what the
/// chains need of each maximum's path.
struct LimbCosts {
    cost: Vec<[f32; 5]>,
    /// Per maximum and limb: where the path back to the torso centre is cut (the index
    /// of its point nearest the limb's root).
    cuts: Vec<[usize; 5]>,
    /// Per maximum and limb: the geodesic length from the limb's root (NaN for an arm
    /// whose path misses its shoulder).
    lengths: Vec<[f32; 5]>,
    /// Per maximum: its path back to the torso centre, graph nodes from the maximum.
    paths: Vec<Vec<u32>>,
}

impl PoseEstimator {
    /// An estimator for frames of the camera `intrinsics` describes. Frames of another
    /// size are handled by scaling the intrinsics to them.
    pub fn new(intrinsics: Intrinsics, config: PoseConfig) -> Self {
        Self {
            k: intrinsics,
            torso: TorsoEstimator::new(&config),
            cfg: config,
            seg: Segmenter::default(),
            graph: GeoGraph::default(),
            dij: Dijkstra::default(),
            dist0: Vec::new(),
            pred0: Vec::new(),
            points: Vec::new(),
            mask: Vec::new(),
            stamp: Vec::new(),
            stamp_now: 0,
            path: Vec::new(),
            small: Vec::new(),
            prev_torso: None,
            prev_offset: None,
            prev_floor: None,
            prev_centroid: None,
            prev_box: None,
            limbs: [None; 5],
            reg: Registration::default(),
            prev_body: None,
            prev_hidden: [0.0; crate::body::Segment::COUNT],
            frames_tracked: 0,
            calib: BodyCalibration::default(),
            smooth: Vec::new(),
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

    pub fn config(&self) -> &PoseConfig {
        &self.cfg
    }

    pub fn intrinsics(&self) -> &Intrinsics {
        &self.k
    }

    /// Forgets everything learned from earlier frames, the person's size included.
    pub fn reset(&mut self) {
        self.lose_track();
        self.calib.reset();
    }

    /// The ratios of the person's arm and leg lengths to the configured body's, as
    /// learned so far (1 until enough has been seen).
    pub fn body_ratios(&self) -> (f32, f32) {
        (self.calib.arm_ratio(), self.calib.leg_ratio())
    }

    /// Forgets the tracking state (torso pose, limb fits), not the person's size: a
    /// person lost for a frame is most likely the same one when found again.
    fn lose_track(&mut self) {
        self.prev_torso = None;
        self.smooth.clear();
        self.prev_offset = None;
        self.prev_floor = None;
        self.prev_centroid = None;
        self.prev_box = None;
        self.limbs = [None; 5];
        self.prev_body = None;
        self.prev_hidden = [0.0; crate::body::Segment::COUNT];
        self.frames_tracked = 0;
    }

    /// Time of each step in the last frame.
    pub fn step_times(&self) -> StepTimes {
        self.times
    }

    /// Intermediate results of the last frame.
    pub fn debug(&self) -> &Debug {
        &self.debug
    }

    /// The person mask of the last frame (row-major, one flag a pixel).
    pub fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// The torso frame of the seed's steps (key points of [`PoseConfig::torso_keypoints`])
    /// that fits the last frame's registered body best.
    fn prev_body_torso(&self, cfg: &PoseConfig) -> Option<TorsoPose> {
        let body = self.prev_body?;
        let tpl = BodyTemplate::new(cfg);
        let s = Posed::new(&tpl, &body).skeleton(&tpl);
        let model: Vec<Point3<f32>> = cfg
            .torso_keypoints
            .iter()
            .map(|&[x, y, z]| Point3::new(x, y, z))
            .collect();
        let seen: Vec<Point3<f32>> = [
            Joint::Neck,
            Joint::Pelvis,
            Joint::LeftShoulder,
            Joint::RightShoulder,
            Joint::LeftHip,
            Joint::RightHip,
            Joint::Torso,
        ]
        .iter()
        .map(|&j| s[j])
        .collect();
        let pose = crate::geom::horn_rigid(&model, &seen);
        pose.is_finite().then_some(pose)
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
        let lost = PoseResult {
            person_found: false,
            skeleton: Skeleton {
                joints: [Point3::origin(); Joint::COUNT],
                confidence: [0.0; Joint::COUNT],
                visible: [false; Joint::COUNT],
            },
        };
        let estimated = self.estimate_inner(depth);
        // An offer is for one frame, taken or not (a frame without a person never
        // reaches the registration).
        self.offered = None;
        match estimated {
            Some(s) if s.is_finite() => PoseResult {
                person_found: true,
                skeleton: self.smoothed(s, time_s),
            },
            _ => {
                self.lose_track();
                lost
            }
        }
    }

    fn estimate_inner(&mut self, depth: DepthView) -> Option<Skeleton> {
        if depth.width() < 8 || depth.height() < 8 {
            return None;
        }
        let k_full = if depth.width() != self.k.width || depth.height() != self.k.height {
            self.k.scaled_to(depth.width(), depth.height())
        } else {
            self.k
        };
        // Reduce wide frames: each output pixel is the nearest depth of its block.
        let factor = if self.cfg.work_width > 0 && depth.width() > self.cfg.work_width {
            depth.width().div_ceil(self.cfg.work_width)
        } else {
            1
        };
        let mut small = std::mem::take(&mut self.small);
        let (depth, k) = if factor > 1 {
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
            let view = DepthView::new(sw, sh, &small).ok();
            match view {
                Some(v) => (v, k_full.scaled_to(sw, sh)),
                None => {
                    self.small = small;
                    return None;
                }
            }
        } else {
            (depth, k_full)
        };
        let r = self.estimate_with(depth, k);
        self.small = small;
        r
    }

    fn estimate_with(&mut self, depth: DepthView, k: Intrinsics) -> Option<Skeleton> {
        let (w, h) = (depth.width() as usize, depth.height() as usize);
        if k.validate().is_err() {
            return None;
        }
        let cfg_owned = if self.cfg.calibrate_body {
            self.calib.apply(&self.cfg)
        } else {
            self.cfg.clone()
        };
        let cfg = &cfg_owned;
        self.debug = Debug {
            work_size: (depth.width(), depth.height()),
            ..Debug::default()
        };
        let t0 = Instant::now();

        // 1. The person's pixels.
        let seg = self.seg.run(
            &depth,
            &k,
            cfg,
            self.prev_floor,
            self.prev_centroid,
            self.prev_box,
            &mut self.points,
            &mut self.mask,
        );
        // Someone found far from the last frame's person is not the one tracked (or
        // the camera lost them for long): the torso, limbs and body tracked belong
        // elsewhere, and starting from them would lose this one.
        if seg.found
            && self
                .prev_centroid
                .is_some_and(|c| (seg.centroid - c).norm() > crate::segment::TRACKED)
        {
            self.lose_track();
        }
        self.prev_floor = seg.floor;
        self.debug.floor = seg.floor;
        self.debug.windowed = seg.windowed;
        let t1 = Instant::now();
        self.times.segment = (t1 - t0).as_secs_f64();
        self.prev_box = seg.found.then_some(seg.bbox);
        if !seg.found {
            return None;
        }
        self.prev_centroid = Some(seg.centroid);

        // 2. Torso: distance transform + PCA, then model registration.
        let up_hint = seg.floor.map(|p| p.n).unwrap_or(-Vector3::y());
        // While the registration tracks the body, its torso needs no registration of
        // its own; every `redetect_every` frames the seed's torso step runs in full, so
        // the geodesic start stays independent of the tracking.
        self.frames_tracked += 1;
        let redetect = self.frames_tracked >= cfg.register.redetect_every.max(1);
        let tracked = (!redetect).then(|| self.prev_body_torso(cfg)).flatten();
        let start = match (tracked, self.prev_torso.zip(self.prev_offset)) {
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
        let fit = self
            .torso
            .fit(&self.points, &self.mask, w, h, cfg, start, up_hint)?;
        let detecting = tracked.is_none();
        // Found afresh with a narrow torso core: perhaps side-on, which the seed's torso
        // step takes for a frontal chest (see `side_on_starts`).
        let side_on = self.prev_body.is_none()
            && fit
                .core_half_width
                .is_some_and(|w| w < cfg.side_on_half_width);
        let mut torso = fit.pose;
        self.debug.torso_residual = fit.residual;
        self.debug.torso_reinit = fit.reinitialised;
        // A new registration means the old limb fits are in an unrelated frame.
        let torso_conf = if fit.residual.is_finite() {
            (1.0 - fit.residual / (2.0 * cfg.icp_reinit_residual)).clamp(0.2, 1.0)
        } else {
            0.2
        };
        self.prev_torso = Some(torso);
        self.debug.torso_pose = Some(torso);
        let mut kp = keypoints(&torso, cfg);
        let t2 = Instant::now();
        self.times.torso = (t2 - t1).as_secs_f64();

        // 3. The geodesic graph.
        self.graph.build(&self.points, &self.mask, w, h, &k, cfg);
        self.debug.nodes = self.graph.node_count();
        self.debug.bridges = self.graph.bridges.len();
        self.debug.joins = self.graph.joins.len();
        let mut centre = kp[6];
        let root = match self.graph.nearest_node(&k, &Point3::from(torso.t), 24) {
            Some(a) => a,
            None => {
                // A known torso came without the distance transform's core pixel: the
                // rare frame whose torso lies off the graph pays for it here.
                let core = fit.core_pixel.or_else(|| {
                    let (p, m) = (&self.points, &self.mask);
                    let init = self.torso.initial_pose(p, m, w, h, cfg, up_hint);
                    init.map(|(_, core)| core)
                })?;
                let a = self.graph.node_of_pixel[core];
                (a != NONE && self.graph.comp[a as usize] != NONE).then_some(a)?
            }
        };
        let t3 = Instant::now();
        self.times.graph = (t3 - t2).as_secs_f64();

        // 4. Dijkstra from the torso centre, then five maxima, each made a source.
        let maxima = self.geodesic_maxima(root, cfg);
        let t4 = Instant::now();
        self.times.geodesic = (t4 - t3).as_secs_f64();

        // The torso model cannot tell front from back, nor well a quarter turn; the feet
        // can: toes point where the person faces.
        if cfg.feet_facing {
            if let Some(turned) = self.facing_from_feet(&torso, &maxima) {
                torso = turned;
                self.prev_torso = Some(torso);
                kp = keypoints(&torso, cfg);
                centre = kp[6];
            }
        }
        let reg_pose = torso;

        // 5. Maxima to limbs by least total cost.
        let mut roots = [kp[0], kp[2], kp[3], kp[4], kp[5]];
        let inv = torso.inverse();
        let LimbCosts {
            cost,
            cuts,
            lengths,
            mut paths,
        } = self.limb_costs(&maxima, &roots, &inv, cfg);
        let assignment = assign(&cost, cfg.unassigned_cost);
        self.debug.cost = cost.clone();
        self.debug.maxima_dist = maxima
            .iter()
            .map(|&m| self.dist0[m as usize] as f32 * 1e-3)
            .collect();
        self.debug.assignment = assignment;
        // Without registration, the limbs' geodesic lengths measure the person.
        if !cfg.register.enabled {
            for l in Limb::ALL {
                if let Some(mi) = assignment[l.index()] {
                    self.calib.measure(&self.cfg, l, lengths[mi][l.index()]);
                }
            }
        }

        // The torso model slides along its own axis (a cylinder's surface does not pin
        // it); the top of the head does: hold it at `head_top_height` above the torso
        // frame's origin.
        if let (Some(mi), true) = (assignment[Limb::Head.index()], cfg.head_top_height > 0.0) {
            let top = inv.apply(&self.graph.pos[maxima[mi] as usize]);
            let dy = top.y - cfg.head_top_height;
            // Only a head top straight above the torso, not far off, is trusted; the
            // registration of the next frame starts from the unanchored pose.
            // A head cut by the image border has its top out of sight.
            let px = self.graph.pixel_of_node[maxima[mi] as usize] as usize;
            let (pu, pv) = (px % w, px / w);
            let inside = pu > 2 && pv > 2 && pu + 3 < w && pv + 3 < h;
            if inside && dy.abs() < 0.15 && top.x.abs() < 0.12 && top.z.abs() < 0.2 {
                torso.t += torso.r * nalgebra::Vector3::new(0.0, dy, 0.0);
            }
            self.debug.torso_pose = Some(torso);
            kp = keypoints(&torso, cfg);
            centre = kp[6];
            roots = [kp[0], kp[2], kp[3], kp[4], kp[5]];
        }

        // The registered torso may have slid along its axis, which closest points do
        // not pin; the next frame starts no farther from the torso region's centre
        // than a torso can be, or the slide would be carried on for good.
        // A known torso measured no region this frame: the last offset measured stands.
        if let Some(pca) = fit.pca {
            let mut offset = reg_pose.r.inverse() * (reg_pose.t - pca.t);
            let lim = cfg.max_torso_offset;
            if lim > 0.0 {
                offset.y = offset.y.clamp(-lim, lim);
            }
            self.prev_offset = Some(offset);
        }

        // The limbs' tips, and whether the seed's chains are needed this frame: the
        // geodesic estimate races the tracked body when detecting, when nothing is
        // tracked, or when a limb tip lies far from the tracked body's and off its
        // surface; otherwise the registration alone follows the body from the last frame.
        let tpl = BodyTemplate::new(cfg);
        let mut tips = [None; 5];
        for l in Limb::ALL {
            if let Some(mi) = assignment[l.index()] {
                tips[l.index()] = Some(self.graph.pos[maxima[mi] as usize]);
            }
        }
        if let (Some(prev), true) = (self.prev_body, cfg.register.enabled) {
            crate::register::drop_borrowed_tips(&tpl, &prev, &mut tips, &cfg.register);
        }
        let race = !cfg.register.enabled
            || detecting
            || self.prev_body.is_none_or(|prev| {
                crate::register::tips_strayed(&tpl, &prev, &tips, &cfg.register)
            });
        self.debug.raced = race;

        // 6. Target points and chain fitting per limb.
        let mut skel = Skeleton::new([Point3::origin(); Joint::COUNT]);
        skel.set(Joint::Torso, centre);
        skel.set(Joint::Neck, kp[0]);
        skel.set(Joint::Pelvis, kp[1]);
        skel.set(Joint::LeftShoulder, kp[2]);
        skel.set(Joint::RightShoulder, kp[3]);
        skel.set(Joint::LeftHip, kp[4]);
        skel.set(Joint::RightHip, kp[5]);
        for j in [
            Joint::Torso,
            Joint::Neck,
            Joint::Pelvis,
            Joint::LeftShoulder,
            Joint::RightShoulder,
            Joint::LeftHip,
            Joint::RightHip,
        ] {
            skel.confidence[j.index()] = torso_conf;
        }
        let f = 0.5 * (k.fx + k.fy);
        for l in Limb::ALL.into_iter().filter(|_| race) {
            let li = l.index();
            let (_, jm, je) = l.joints();
            let found = assignment[li].map(|mi| {
                let path = &paths[mi];
                (&path[..=cuts[mi][li].min(path.len() - 1)], maxima[mi])
            });
            let (c, conf) = self.limb_chain(l, roots[li], found, &torso, cfg, f);
            if let Some(jm) = jm {
                skel.set(jm, c.mid);
                skel.confidence[jm.index()] = conf;
            }
            skel.set(je, c.end);
            skel.confidence[je.index()] = conf;
        }
        let t5 = Instant::now();
        self.times.limbs = (t5 - t4).as_secs_f64();

        // 7. The whole body registered to the frame, from this estimate and from the
        // last frame's registration, whichever explains the frame better.
        if cfg.register.enabled {
            let scene = Scene {
                k: &k,
                width: w,
                height: h,
                template: tpl,
                torso: &torso,
            };
            let side_on = side_on.then_some(seg.centroid);
            if !self.register_body(&mut skel, scene, cfg, &tips, race, side_on) {
                return None;
            }
        }
        self.times.register = t5.elapsed().as_secs_f64();

        // The paths are done with: hand their buffers to the overlay as pixels.
        for path in &mut paths {
            for a in path.iter_mut() {
                *a = self.graph.pixel_of_node[*a as usize];
            }
        }
        self.debug.paths = paths;
        Some(skel)
    }

    /// Dijkstra from the graph's `root` (the torso centre), then up to
    /// [`PoseConfig::max_maxima`] geodesic maxima, each joined to the sources by a
    /// zero-weight edge before the next search (the search goes on from where it was,
    /// not from scratch). The first search's distances and predecessors stay in
    /// `dist0` and `pred0`: the paths back to the torso centre.
    fn geodesic_maxima(&mut self, root: u32, cfg: &PoseConfig) -> Vec<u32> {
        let n = self.graph.node_count();
        self.dij.reset(n);
        self.dij.add_source(root);
        self.dij.run(&self.graph);
        self.dist0.clear();
        self.dist0.extend_from_slice(&self.dij.dist);
        self.pred0.clear();
        self.pred0.extend_from_slice(&self.dij.pred);
        let min_ext = (cfg.min_extremity * 1000.0) as u32;
        let mut maxima: Vec<u32> = Vec::with_capacity(5);
        for _ in 0..cfg.max_maxima {
            let mut best = (0u32, NONE);
            for (a, &d) in self.dij.dist.iter().enumerate() {
                if d != INF && d > best.0 {
                    best = (d, a as u32);
                }
            }
            if best.1 == NONE || best.0 < min_ext {
                break;
            }
            maxima.push(best.1);
            self.dij.add_source(best.1);
            self.dij.run(&self.graph);
        }
        self.debug.maxima = maxima
            .iter()
            .map(|&m| self.graph.pixel_of_node[m as usize])
            .collect();
        maxima
    }

    /// What giving each maximum to each limb costs (seed: the geodesic length against the
    /// limb's, plus the priors below), and each maximum's path back to the torso centre
    /// with where it is cut for each limb. `roots`: the limbs' roots in the camera
    /// frame; `inv`: camera frame → torso frame.
    fn limb_costs(
        &mut self,
        maxima: &[u32],
        roots: &[Point3<f32>; 5],
        inv: &TorsoPose,
        cfg: &PoseConfig,
    ) -> LimbCosts {
        let n = self.graph.node_count();
        let mut cost: Vec<[f32; 5]> = Vec::with_capacity(maxima.len());
        let mut cuts: Vec<[usize; 5]> = Vec::with_capacity(maxima.len());
        let mut lengths: Vec<[f32; 5]> = Vec::with_capacity(maxima.len());
        let mut paths: Vec<Vec<u32>> = Vec::with_capacity(maxima.len());
        for &m in maxima {
            self.path.clear();
            let mut a = m;
            let mut guard = 0;
            while a != NONE && guard < n {
                self.path.push(a);
                a = self.pred0[a as usize];
                guard += 1;
            }
            let dm = self.dist0[m as usize] as f32 * 1e-3;
            let mut row = [f32::INFINITY; 5];
            let mut cut = [0usize; 5];
            let mut len = [0f32; 5];
            for l in Limb::ALL {
                let r = roots[l.index()];
                // Cut the path where it passes nearest the limb root: the geodesic cost
                // from the root is the path's length beyond that point plus the gap.
                let mut near = (f32::INFINITY, 0usize);
                for (pi, &p) in self.path.iter().enumerate() {
                    let d = (self.graph.pos[p as usize] - r).norm();
                    if d < near.0 {
                        near = (d, pi);
                    }
                }
                let p_cut = self.path[near.1];
                let mut best = (
                    dm - self.dist0[p_cut as usize] as f32 * 1e-3 + near.0,
                    near.1,
                );
                // The geodesic length of a limb hardly depends on how it is bent.
                let (l1, l2) = cfg.bones(l);
                let reach = l1 + l2 + cfg.extremity_extra(l);
                // A hand resting against the hip or held before the chest may reach the
                // torso by a path that never passes its shoulder: the arm's own link is
                // hidden. Its geodesic length then says nothing; it must only be within
                // the arm's reach, and its targets are the forearm's and hand's.
                let hidden = matches!(l, Limb::LeftArm | Limb::RightArm)
                    && cfg.hidden_root_gap > 0.0
                    && near.0 > cfg.hidden_root_gap;
                let mut c = if hidden {
                    let distal = ((l2 + cfg.extremity_extra(l)) * 1000.0) as u32;
                    let d_m = self.dist0[m as usize];
                    let end = self
                        .path
                        .iter()
                        .position(|&p| d_m.saturating_sub(self.dist0[p as usize]) >= distal)
                        .unwrap_or(self.path.len() - 1);
                    best = (f32::NAN, end);
                    let euclid = (self.graph.pos[m as usize] - r).norm();
                    (euclid - reach).max(0.0) + cfg.hidden_root_cost
                } else {
                    (best.0 - reach).abs() + (near.0 - 0.05).max(0.0)
                };
                if let Some(prev) = self.limbs[l.index()].and_then(|s| s.extremity) {
                    let pm = self.graph.pos[m as usize];
                    c += cfg.temporal_weight * (inv.apply(&pm) - prev).norm();
                }
                // An extremity lies on its own side of the body.
                let local = inv.apply(&self.graph.pos[m as usize]);
                c += match l {
                    Limb::LeftArm | Limb::LeftLeg => (-local.x).max(0.0),
                    Limb::RightArm | Limb::RightLeg => local.x.max(0.0),
                    // The top of the head is on the torso's axis, not out on a shoulder.
                    Limb::Head => {
                        (-local.y).max(0.0)
                            + cfg.head_off_axis_weight * (local.x.abs() - 0.08).max(0.0)
                    }
                };
                // Feet stay below the hips.
                if matches!(l, Limb::LeftLeg | Limb::RightLeg) {
                    c += (local.y - cfg.torso_keypoints[4][1] + 0.2).max(0.0);
                }
                row[l.index()] = c;
                cut[l.index()] = best.1;
                len[l.index()] = best.0;
            }
            cost.push(row);
            cuts.push(cut);
            lengths.push(len);
            paths.push(self.path.clone());
        }
        // A bent elbow or knee is a geodesic maximum of its own, beside the path to the
        // hand or foot beyond it. Such a maximum is no limb's end while the farther
        // one is there: it costs extra for every limb but the head.
        if cfg.dominated_cost > 0.0 {
            for (bi, &mb) in maxima.iter().enumerate() {
                let pb = self.graph.pos[mb as usize];
                let db = self.dist0[mb as usize];
                let dominated = maxima.iter().enumerate().any(|(ai, &ma)| {
                    ai != bi
                        && self.dist0[ma as usize] > db + 150
                        && paths[ai]
                            .iter()
                            .any(|&p| (self.graph.pos[p as usize] - pb).norm() < 0.08)
                });
                if dominated {
                    for c in &mut cost[bi][1..] {
                        *c += cfg.dominated_cost;
                    }
                }
            }
        }
        LimbCosts {
            cost,
            cuts,
            lengths,
            paths,
        }
    }

    /// The seed's two-joint chain of limb `l` from `root`: fitted to the target points
    /// along `found`'s path (its part from the geodesic maximum to the cut nearest the
    /// root) and to the maximum, from the path's own bend and from the last frame's
    /// fit, whichever fits better; without a maximum the last fit, trusted less. The
    /// chain and its confidence; the limb's state is kept for the next frame.
    fn limb_chain(
        &mut self,
        l: Limb,
        root_p: Point3<f32>,
        found: Option<(&[u32], u32)>,
        torso: &TorsoPose,
        cfg: &PoseConfig,
        f: f32,
    ) -> (Chain, f32) {
        let li = l.index();
        let (l1, l2) = cfg.bones(l);
        let prev = self.limbs[li];
        let inv = torso.inverse();
        let Some((path, maximum)) = found else {
            // Occluded: keep the last fit (in the torso frame), trusted less.
            // Long unseen, it falls back to the rest pose.
            let s = prev.filter(|s| s.confidence >= 0.1).unwrap_or_else(|| {
                let d = cfg.rest_direction(l);
                let r_local = inv.apply(&root_p);
                LimbState {
                    mid: r_local + d * l1,
                    end: r_local + d * (l1 + l2),
                    extremity: None,
                    confidence: 0.1,
                }
            });
            let conf = (s.confidence * cfg.occluded_decay).clamp(0.0, 1.0);
            self.limbs[li] = Some(LimbState {
                confidence: conf,
                ..s
            });
            let mid = torso.apply(&s.mid);
            let end = torso.apply(&s.end);
            return (
                Chain {
                    root: root_p,
                    mid,
                    end,
                },
                conf,
            );
        };
        let targets = self.gather_targets(path, l, f);
        let mut cands: Vec<Chain> = Vec::with_capacity(2);
        // From the geodesic path: the middle joint where the path is one
        // upper bone from the root.
        let ext = self.graph.pos[maximum as usize];
        let ext_b = ext + ext.coords.normalize() * cfg.surface_offset(l);
        let mut mid_guess = ext_b;
        if l2 > 0.0 {
            for &p in path.iter().rev() {
                let q = self.graph.pos[p as usize];
                if (q - root_p).norm() >= l1 {
                    mid_guess = q + q.coords.normalize() * cfg.surface_offset(l);
                    break;
                }
            }
        }
        let up = torso.r * Vector3::y();
        let c0 = start_chain(root_p, mid_guess, ext_b, (l1, l2), up);
        cands.push(c0);
        if let Some(s) = prev {
            let (mid, end) = (torso.apply(&s.mid), torso.apply(&s.end));
            cands.push(start_chain(root_p, mid, end, (l1, l2), up));
        }
        let mut best: Option<(Chain, f32)> = None;
        for c in cands {
            let (fitc, e) = fit_chain(
                c,
                &targets,
                cfg.omega_succ,
                cfg.beyond_end_weight,
                cfg.chain_iterations,
            );
            if best.is_none_or(|(_, be)| e < be) {
                best = Some((fitc, e));
            }
        }
        let (mut fitc, e) = best.unwrap_or((c0, 0.0));
        // The hand follows the fingertips seen, a palm's length behind them
        // towards the elbow, rather than where the forearm's assumed length
        // puts it: a forearm a few centimetres off would otherwise shrink
        // every stroke the hand draws towards the elbow.
        if cfg.hand_behind_tip > 0.0 && matches!(l, Limb::LeftArm | Limb::RightArm) {
            if let Some(u) = (ext_b - fitc.mid).try_normalize(1e-6) {
                fitc.end = ext_b - u * cfg.hand_behind_tip;
            }
        }
        let rms = e.sqrt();
        let conf =
            ((1.0 - rms / 0.06).clamp(0.1, 1.0)) * (targets.len() as f32 / 30.0).clamp(0.2, 1.0);
        self.debug.targets[li] = targets;
        self.limbs[li] = Some(LimbState {
            mid: inv.apply(&fitc.mid),
            end: inv.apply(&fitc.end),
            extremity: Some(inv.apply(&ext)),
            confidence: conf,
        });
        (fitc, conf)
    }

    /// Step 7: the whole body registered to the frame, raced from the last frame's
    /// body, from it with the strayed limbs of the geodesic estimate `skel` (when
    /// `race`), from the geodesic estimate itself and, for a person perhaps side-on
    /// (`side_on`: the person's centroid), from standing side-on bodies. The winner's
    /// joints replace `skel`'s. False when the frame is lost: no chains this frame
    /// (`race` false) and no registered body either.
    fn register_body(
        &mut self,
        skel: &mut Skeleton,
        scene: Scene,
        cfg: &PoseConfig,
        tips: &[Option<Point3<f32>>; 5],
        race: bool,
        side_on: Option<Point3<f32>>,
    ) -> bool {
        let tpl = &scene.template;
        let frame = scene.frame(&self.points, &self.mask);
        self.reg.prepare(&frame, &cfg.register);
        let geodesic = race.then(|| BodyPose::from_skeleton(tpl, skel)).flatten();
        let hybrid = self
            .prev_body
            .zip(geodesic.filter(|_| cfg.register.race_hybrid))
            .and_then(|(prev, geo)| hybrid_start(tpl, &prev, &geo, tips, cfg));
        let mut starts: Vec<BodyPose> = [self.prev_body, hybrid, geodesic]
            .into_iter()
            .flatten()
            .collect();
        // A side-on body races from a standing pose, for every step, and without
        // the tips: they were assigned to the limbs of the frontal body.
        let side_on_cfg;
        let (register_cfg, tips_now) = match geodesic.zip(side_on) {
            Some((g, centroid)) => {
                starts.extend(side_on_starts(&g, &centroid));
                side_on_cfg = crate::register::RegisterConfig {
                    race_iterations: cfg.register.iterations,
                    ..cfg.register.clone()
                };
                (&side_on_cfg, [None; 5])
            }
            None => (&cfg.register, *tips),
        };
        match self.offered.take() {
            Some(OfferedStart::Also(s)) => starts.extend(BodyPose::from_skeleton(tpl, &s)),
            Some(OfferedStart::Only(s)) => {
                if let Some(b) = BodyPose::from_skeleton(tpl, &s) {
                    starts = vec![b];
                }
            }
            None => {}
        }
        let best = self.reg.fit(
            &frame,
            tpl,
            &starts,
            &tips_now,
            &self.prev_hidden,
            register_cfg,
        );
        if race {
            self.debug.geodesic = Some(*skel);
        }
        let mut registered = false;
        let mut hands = [None; 2];
        if let Some(b) = best {
            if self.cfg.calibrate_body {
                self.learn_body(&b, cfg);
            }
            let posed = Posed::new(tpl, &b.pose);
            let fitted = posed.skeleton(tpl);
            if fitted.is_finite() {
                skel.joints = fitted.joints;
                // Confidence: how much of the joint's segment the camera sees where
                // the body puts it.
                for j in Joint::ALL {
                    let seen = b.seen[crate::body::segment_of(j).index()];
                    skel.confidence[j.index()] = (0.1 + 0.9 * seen).clamp(0.0, 1.0);
                }
                crate::hands::hands_at_fingertips(skel, &posed, tpl, tips, cfg);
                let frame = scene.frame(&self.points, &self.mask);
                hands = crate::hands::hands_at_their_points(skel, &frame, tpl, &posed, cfg);
                self.prev_body = Some(b.pose);
                self.prev_hidden = crate::register::hidden_limbs(&b.seen);
                registered = true;
                self.debug.body = Some((b.pose, scene.template));
                self.debug.register_passes = b.passes;
                self.debug.register_energy = b.energy / self.reg.data_len().max(1) as f32;
                self.debug.register_points = self.reg.data_len();
            }
        }
        if !race {
            if !registered {
                // Neither chains nor a registered body: the frame is lost.
                self.prev_body = None;
                return false;
            }
            // The chains were skipped: their state (the limbs' last fits, in the
            // torso frame) follows the registered body.
            let inv = scene.torso.inverse();
            for l in Limb::ALL {
                let (_, jm, je) = l.joints();
                let end = inv.apply(&skel[je]);
                self.limbs[l.index()] = Some(LimbState {
                    mid: jm.map_or(end, |j| inv.apply(&skel[j])),
                    end,
                    extremity: tips[l.index()].map(|m| inv.apply(&m)),
                    confidence: skel.confidence[je.index()],
                });
            }
        }
        // Only now, so that the limbs' states above keep the fit's hands.
        for (j, h) in [Joint::LeftHand, Joint::RightHand].into_iter().zip(hands) {
            if let Some(h) = h {
                skel.set(j, h);
            }
        }
        true
    }

    /// The person's limb lengths (and collarbones' rest) learned from a registered
    /// body, from frames whose limbs the camera sees well.
    fn learn_body(&mut self, b: &crate::register::Fit, cfg: &PoseConfig) {
        use crate::body::Segment::*;
        let seen = |segs: &[crate::body::Segment]| {
            segs.iter().map(|s| b.seen[s.index()]).sum::<f32>() / segs.len() as f32
        };
        let gate = cfg.register.length_seen;
        let arms = seen(&[LeftUpperArm, LeftForearm, RightUpperArm, RightForearm]);
        let legs = seen(&[LeftThigh, LeftShin, RightThigh, RightShin]);
        self.calib.refine([
            b.length_step[0].filter(|_| arms >= gate),
            b.length_step[1].filter(|_| legs >= gate),
        ]);
        for (steps, upper, fore) in [
            (b.arm_bone_steps[0], LeftUpperArm, LeftForearm),
            (b.arm_bone_steps[1], RightUpperArm, RightForearm),
        ] {
            if let Some(s) = steps.filter(|_| seen(&[upper, fore]) >= gate) {
                self.calib.refine_arm_bones(s);
            }
        }
        if arms >= gate {
            let rel = |s: crate::body::Segment| {
                let r = b.pose.rotation[Chest.index()].inverse() * b.pose.rotation[s.index()];
                let v = r.scaled_axis();
                [v.x, v.y, v.z]
            };
            self.calib.refine_collars(
                [rel(LeftCollar), rel(RightCollar)],
                cfg.register.collar_gain,
            );
        }
    }

    /// The joints filtered over time: still joints stop jittering with the sensor's
    /// noise, moving ones keep up.
    fn smoothed(&mut self, mut s: Skeleton, t: f64) -> Skeleton {
        let (fc, beta) = (self.cfg.smoothing_min_cutoff, self.cfg.smoothing_beta);
        if fc <= 0.0 {
            return s;
        }
        if self.smooth.len() != Joint::COUNT {
            let f = OneEuro::new(fc, beta, self.cfg.smoothing_d_cutoff);
            self.smooth = vec![[f.clone(), f.clone(), f]; Joint::COUNT];
        }
        for (p, f) in s.joints.iter_mut().zip(&mut self.smooth) {
            for (c, fi) in f.iter_mut().enumerate() {
                p[c] = fi.filter(p[c] as f64, t) as f32;
            }
        }
        s
    }

    /// The torso turned about its axis to face where the toes point, when the two
    /// lowest maxima (the feet) agree on a direction more than 45° away from the
    /// torso's; `None` to keep it.
    fn facing_from_feet(&self, torso: &TorsoPose, maxima: &[u32]) -> Option<TorsoPose> {
        let inv = torso.inverse();
        let up = torso.r * Vector3::y();
        let mut feet: Vec<(f32, u32)> = maxima
            .iter()
            .map(|&m| (inv.apply(&self.graph.pos[m as usize]).y, m))
            .filter(|&(y, _)| y < -0.7)
            .collect();
        feet.sort_by(|a, b| a.0.total_cmp(&b.0));
        if feet.len() < 2 {
            return None;
        }
        let mut dirs = Vec::with_capacity(2);
        for &(_, m) in &feet[..2] {
            // Back along the geodesic path to about the ankle.
            let toe = self.graph.pos[m as usize];
            let d_toe = self.dist0[m as usize];
            let mut a = m;
            let mut guard = 0;
            while a != NONE && d_toe.saturating_sub(self.dist0[a as usize]) < 150 && guard < 10_000
            {
                a = self.pred0[a as usize];
                guard += 1;
            }
            if a == NONE {
                return None;
            }
            let d = toe - self.graph.pos[a as usize];
            let h = d - up * d.dot(&up);
            if h.norm() < 0.05 {
                return None;
            }
            dirs.push(h.normalize());
        }
        if dirs[0].dot(&dirs[1]) < 0.5 {
            return None;
        }
        let feet_dir = (dirs[0] + dirs[1]).try_normalize(1e-6)?;
        let fwd = torso.r * Vector3::z();
        let fwd_h = (fwd - up * fwd.dot(&up)).try_normalize(1e-6)?;
        let angle = fwd_h.cross(&feet_dir).dot(&up).atan2(fwd_h.dot(&feet_dir));
        if angle.abs() < std::f32::consts::FRAC_PI_4 {
            return None;
        }
        let turn = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(up), angle);
        Some(TorsoPose {
            r: turn * torso.r,
            t: torso.t,
        })
    }

    /// Target points of a limb (seed Eq. 16.10): the person's points within `d_e` of
    /// the geodesic path from the extremity to the limb root, no nearer the torso centre
    /// (geodesically) than the path's end, pushed back along their viewing ray by the
    /// limb's surface offset.
    fn gather_targets(&mut self, path: &[u32], l: Limb, f: f32) -> Vec<Point3<f32>> {
        let cfg = &self.cfg;
        let g = &self.graph;
        let d_e = cfg.d_e(l);
        let off = cfg.surface_offset(l);
        let mut out = Vec::new();
        if path.is_empty() {
            return out;
        }
        self.stamp_now = self.stamp_now.wrapping_add(1);
        if self.stamp_now == 0 || self.stamp.len() != g.node_count() {
            self.stamp.clear();
            self.stamp.resize(g.node_count(), 0);
            self.stamp_now = 1;
        }
        let floor_d =
            self.dist0[path[path.len() - 1] as usize].saturating_sub((d_e * 1000.0) as u32);
        let spacing = (d_e * 500.0) as u32;
        let mut last_d = u32::MAX;
        let (w, h) = (g.width as i32, g.height as i32);
        for (pi, &p) in path.iter().enumerate() {
            let dp = self.dist0[p as usize];
            if pi + 1 != path.len() && last_d != u32::MAX && last_d.saturating_sub(dp) < spacing {
                continue;
            }
            last_d = dp;
            let c = g.pos[p as usize];
            let px = g.pixel_of_node[p as usize] as i32;
            let (u, v) = (px % w, px / w);
            let r = ((d_e * f / c.z).ceil() as i32).clamp(1, 200);
            let step = if r > 10 { 2 } else { 1 };
            let d2 = d_e * d_e;
            let mut vv = (v - r).max(0);
            while vv <= (v + r).min(h - 1) {
                let mut uu = (u - r).max(0);
                while uu <= (u + r).min(w - 1) {
                    let b = g.node_of_pixel[(vv * w + uu) as usize];
                    if b != NONE && self.stamp[b as usize] != self.stamp_now {
                        let q = g.pos[b as usize];
                        let db = self.dist0[b as usize];
                        if db != INF && db >= floor_d && (q - c).norm_squared() < d2 {
                            self.stamp[b as usize] = self.stamp_now;
                            out.push(q + q.coords.normalize() * off);
                        }
                    }
                    uu += step;
                }
                vv += step;
            }
        }
        out
    }
}

/// Starts for a person who may be side-on: standing, arms hanging, turned a quarter
/// either way from the camera, about the person's centroid a little behind its surface,
/// upright as the geodesic estimate's pelvis. The seed's torso step fits its frontal
/// model to a flank and nothing later turns the body by a quarter; from these the
/// registration's energy tells the two apart (a side-on person: 1.4 against 1.9 for
/// the frontal start, the true pose 0.9).
fn side_on_starts(geodesic: &BodyPose, centroid: &Point3<f32>) -> [BodyPose; 2] {
    use crate::body::Segment;
    // The centroid of the surface the camera sees lies in front of the body's axis.
    const BEHIND_SURFACE: f32 = 0.05;
    let up = geodesic.rotation[Segment::Pelvis.index()] * Vector3::y();
    [1.0f32, -1.0].map(|side| {
        let toward = Vector3::new(0.0, 0.0, side);
        let x = (toward - up * up.dot(&toward))
            .try_normalize(1e-6)
            .unwrap_or(toward);
        let r = nalgebra::Rotation3::from_basis_unchecked(&[x, up, x.cross(&up)]);
        BodyPose {
            pelvis: centroid + Vector3::new(0.0, 0.0, BEHIND_SURFACE),
            rotation: [r; Segment::COUNT],
        }
    })
}

/// A chain from `root` bent towards `mid` and reaching for `end`, with bones `l1` and
/// `l2`; a limb of one bone (`l2` zero: the head) is a straight one towards `end`, or
/// along `up` when `end` is the root.
fn start_chain(
    root: Point3<f32>,
    mid: Point3<f32>,
    end: Point3<f32>,
    (l1, l2): (f32, f32),
    up: Vector3<f32>,
) -> Chain {
    if l2 > 0.0 {
        return Chain::towards(root, mid - root, end, l1, l2);
    }
    let d = (end - root).try_normalize(1e-6).unwrap_or(up);
    Chain {
        root,
        mid: root + d * l1,
        end: root + d * l1,
    }
}

/// What the registration needs of the frame besides the estimator's own buffers.
struct Scene<'a> {
    k: &'a Intrinsics,
    width: usize,
    height: usize,
    /// This frame's body template; the registered body's debug view keeps it.
    template: BodyTemplate,
    /// The torso frame of this frame's seed steps (torso frame → camera frame).
    torso: &'a TorsoPose,
}

impl<'a> Scene<'a> {
    /// The person's points of this frame as the registration reads them.
    fn frame<'p>(&self, points: &'p [Point3<f32>], mask: &'p [bool]) -> Frame<'p>
    where
        'a: 'p,
    {
        Frame {
            points,
            mask,
            width: self.width,
            height: self.height,
            k: self.k,
        }
    }
}

/// The tracked body `prev` with every limb whose tip strayed (lies farther than
/// [`crate::register::RegisterConfig::race_gap`] from the geodesic maximum given to it)
/// taken from the geodesic estimate `geo`: an arm dropped from a T-pose within a frame,
/// say, while the rest is tracked well. None when no tip strayed.
fn hybrid_start(
    tpl: &BodyTemplate,
    prev: &BodyPose,
    geo: &BodyPose,
    tips: &[Option<Point3<f32>>; 5],
    cfg: &PoseConfig,
) -> Option<BodyPose> {
    let posed = Posed::new(tpl, prev);
    let mut h = *prev;
    let mut changed = false;
    for l in Limb::ALL {
        let (seg, local) = tpl.tips[l.index()];
        if tips[l.index()]
            .is_some_and(|m| (posed.point(seg, &local) - m).norm() > cfg.register.race_gap)
        {
            h = h.with_limb_of(geo, l);
            changed = true;
        }
    }
    changed.then_some(h)
}
