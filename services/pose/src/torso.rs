//! The torso: its region by distance transform, a first orientation by PCA, then a
//! rigid torso model registered by mutual closest points and Horn's closed form.

use crate::body::{BodyPose, BodyTemplate, Posed};
use crate::cells::Cells;
use crate::dt::{DistanceTransform, Open};
use crate::geodesic::Geodesic;
use crate::geom::{horn_rigid, Moments, Rigid};
use crate::graph::{GeoGraph, NONE};
use crate::Limb;
use airglyph_core::Joint;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// The torso's key points, each a `T`: in the torso frame ([`TorsoConfig::keypoints`])
/// or the camera frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TorsoPoints<T> {
    /// The neck (the head's root).
    pub neck: T,
    /// The pelvis joint.
    pub pelvis: T,
    /// The left shoulder (the left arm's root).
    pub left_shoulder: T,
    /// The right shoulder.
    pub right_shoulder: T,
    /// The left hip (the left leg's root).
    pub left_hip: T,
    /// The right hip.
    pub right_hip: T,
    /// The torso joint (mid-chest on the spine), the geodesic search's root.
    pub torso: T,
}

impl<T> TorsoPoints<T> {
    /// Each point mapped by `f`, in the order of [`TorsoPoints::to_array`].
    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> TorsoPoints<U> {
        TorsoPoints {
            neck: f(self.neck),
            pelvis: f(self.pelvis),
            left_shoulder: f(self.left_shoulder),
            right_shoulder: f(self.right_shoulder),
            left_hip: f(self.left_hip),
            right_hip: f(self.right_hip),
            torso: f(self.torso),
        }
    }

    /// The points in the order of [`TorsoPoints::JOINTS`].
    pub fn to_array(self) -> [T; 7] {
        [
            self.neck,
            self.pelvis,
            self.left_shoulder,
            self.right_shoulder,
            self.left_hip,
            self.right_hip,
            self.torso,
        ]
    }

    /// The point a limb is rooted at: the neck, a shoulder or a hip.
    pub fn root_of(&self, limb: Limb) -> &T {
        match limb {
            Limb::Head => &self.neck,
            Limb::LeftArm => &self.left_shoulder,
            Limb::RightArm => &self.right_shoulder,
            Limb::LeftLeg => &self.left_hip,
            Limb::RightLeg => &self.right_hip,
        }
    }
}

impl<T> TorsoPoints<T> {
    /// The skeleton's joint of each point, in the order of [`TorsoPoints::to_array`].
    pub const JOINTS: [Joint; 7] = [
        Joint::Neck,
        Joint::Pelvis,
        Joint::LeftShoulder,
        Joint::RightShoulder,
        Joint::LeftHip,
        Joint::RightHip,
        Joint::Torso,
    ];
}

/// Settings of the torso step (part of [`crate::PoseConfig`]); lengths in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TorsoConfig {
    /// Torso region: pixels whose distance-transform value is at least this share of the
    /// maximum (seed Eq. 16.2, with the inequality the right way round).
    pub dt_share: f32,
    /// Torso-region points nearer the camera than the region's median depth by more
    /// than this (a hand or forearm before the chest) are left out of its PCA.
    pub front_band: f32,
    /// Mutual closest points farther apart than this are not correspondences (seed: 0.1 m).
    pub icp_max_dist: f32,
    /// Most steps of the torso model's registration.
    pub icp_iterations: usize,
    /// Registration whose RMS residual exceeds this is redone from the PCA initialisation.
    pub icp_reinit_residual: f32,
    /// How far along its axis the registered torso may lie from the torso region's
    /// centre when the next frame's registration starts from it (0 = unbounded).
    pub max_offset: f32,
    /// Turns (degrees, about the torso axis) of the PCA frame tried when registering
    /// afresh; the lowest residual wins (the first unless another is 10 % better).
    pub reinit_yaws: Vec<f32>,
    /// Turn the torso to face where the toes point when they disagree by over 45°.
    pub feet_facing: bool,
    /// A person found afresh whose torso core is narrower than this (half width;
    /// [`TorsoFit::core_half_width`]) may be side-on: the articulated registration also
    /// races a standing body turned a quarter either way (0 = never).
    pub side_on_half_width: f32,
    /// Half-axes of the elliptic-cylinder torso model: lateral.
    pub half_width: f32,
    /// Front-back half-axis of the torso model.
    pub half_depth: f32,
    /// The torso model's lower end below the torso joint (negative).
    pub bottom: f32,
    /// The torso model's upper end above the torso joint.
    pub top: f32,
    /// Key points in the torso frame: x = person's left, y = up, z = forward (out of the
    /// chest), origin the model's centre.
    pub keypoints: TorsoPoints<[f32; 3]>,
    /// Height of the top of the head above the torso frame's origin: the head's geodesic
    /// maximum fixes the torso's position along its axis (0 = off).
    pub head_top_height: f32,
}

impl Default for TorsoConfig {
    fn default() -> Self {
        Self {
            dt_share: 0.5,
            front_band: 0.12,
            icp_max_dist: 0.1,
            icp_iterations: 12,
            icp_reinit_residual: 0.035,
            max_offset: 0.09,
            reinit_yaws: vec![0.0],
            feet_facing: true,
            side_on_half_width: 0.125,
            half_width: 0.16,
            half_depth: 0.11,
            bottom: -0.30,
            top: 0.20,
            // Measured on the MakeHuman body of airglyph-synth (the evaluation's body),
            // standing, in the frame the head-top anchor fixes; symmetrised.
            keypoints: TorsoPoints {
                neck: [0.0, 0.356, -0.071],
                pelvis: [0.0, -0.181, -0.038],
                left_shoulder: [0.178, 0.29, -0.005],
                right_shoulder: [-0.178, 0.29, -0.005],
                left_hip: [0.11, -0.181, -0.039],
                right_hip: [-0.11, -0.181, -0.039],
                torso: [0.0, 0.262, -0.074],
            },
            head_top_height: 0.60,
        }
    }
}

/// Torso frame → camera frame: x = person's left, y = up, z = forward, origin the torso
/// joint (mid-chest on the spine).
pub type TorsoPose = Rigid;

/// Result of the torso step.
#[derive(Debug, Clone, Copy)]
pub struct TorsoFit {
    /// Torso frame → camera frame.
    pub pose: TorsoPose,
    /// RMS distance of the matched model points, metres.
    pub residual: f32,
    /// Model points matched in the last step.
    pub matches: usize,
    /// Whether the registration was started from PCA rather than the last frame.
    pub reinitialised: bool,
    /// The pixel of the largest distance-transform value (inside the torso), and the
    /// PCA frame of the torso region this frame; `None` when the pose was known, which
    /// needs neither.
    pub core_pixel: Option<usize>,
    /// See `core_pixel`.
    pub pca: Option<TorsoPose>,
    /// Half the width of the person's mask across the core pixel's row, metres, when
    /// the torso was looked for afresh: narrower for a person side-on than for one
    /// facing the camera or turned away (pose NOTES).
    pub core_half_width: Option<f32>,
}

/// A point cloud of the torso model with outward normals, in the torso frame.
#[derive(Debug, Clone)]
pub struct TorsoModel {
    pub points: Vec<Point3<f32>>,
    pub normals: Vec<Vector3<f32>>,
}

impl TorsoModel {
    /// An elliptic cylinder from `torso_bottom` to `torso_top` whose upper part rounds
    /// into the shoulders.
    pub fn new(cfg: &TorsoConfig) -> Self {
        Self::with_resolution(cfg, 14, 28)
    }

    /// The model with `rings` rings of `around` points.
    pub fn with_resolution(cfg: &TorsoConfig, rings: usize, around: usize) -> Self {
        let (a, b) = (cfg.half_width, cfg.half_depth);
        let mut points = Vec::new();
        let mut normals = Vec::new();
        for i in 0..rings {
            let y = cfg.bottom + (cfg.top - cfg.bottom) * i as f32 / (rings - 1) as f32;
            // Shoulders: the lateral half-axis shrinks over the top 6 cm.
            let top_gap = cfg.top - y;
            let shrink = if top_gap < 0.06 {
                let s = 1.0 - top_gap / 0.06;
                (1.0 - 0.35 * s * s).max(0.4)
            } else {
                1.0
            };
            let aa = a * shrink;
            for j in 0..around {
                let th = std::f32::consts::TAU * j as f32 / around as f32;
                let (s, c) = th.sin_cos();
                points.push(Point3::new(aa * s, y, b * c));
                normals.push(Vector3::new(s / aa, 0.0, c / b).normalize());
            }
        }
        Self { points, normals }
    }
}

/// Where the torso step starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TorsoStart {
    /// Nothing known: registration from the PCA frame.
    Fresh,
    /// The last frame's pose and its offset from the torso region's centre: registration
    /// from there, redone from PCA when the residual is too large.
    Track(TorsoPose, Vector3<f32>),
    /// The pose is known (the last frame's registered body): nothing to do (the
    /// distance transform and the torso region's PCA, most of the step, are skipped).
    Known(TorsoPose),
}

/// Reusable state of the torso step.
#[derive(Debug)]
pub struct TorsoEstimator {
    model: TorsoModel,
    dt: DistanceTransform,
    dist: Vec<f32>,
    data: Vec<Point3<f32>>,
    world: Vec<Point3<f32>>,
    visible: Vec<usize>,
    cells: Cells,
    nn_model: Vec<(u32, f32)>,
    nn_data: Vec<(u32, f32)>,
    src: Vec<Point3<f32>>,
    dst: Vec<Point3<f32>>,
    stack: Vec<u32>,
    region: Vec<bool>,
    region_z: Vec<f32>,
    sub_mask: Vec<bool>,
    sub_dist: Vec<f32>,
}

impl TorsoEstimator {
    /// The torso step's buffers and the torso model of `cfg`.
    pub fn new(cfg: &TorsoConfig) -> Self {
        Self {
            model: TorsoModel::new(cfg),
            dt: DistanceTransform::default(),
            dist: Vec::new(),
            data: Vec::new(),
            world: Vec::new(),
            visible: Vec::new(),
            cells: Cells::default(),
            nn_model: Vec::new(),
            nn_data: Vec::new(),
            src: Vec::new(),
            dst: Vec::new(),
            stack: Vec::new(),
            region: Vec::new(),
            region_z: Vec::new(),
            sub_mask: Vec::new(),
            sub_dist: Vec::new(),
        }
    }

    /// Distance transform of the mask, then the torso region (pixels with at least
    /// `torso_dt_share` of the largest distance, connected to it) and its PCA frame.
    pub fn initial_pose(
        &mut self,
        points: &[Point3<f32>],
        mask: &[bool],
        width: usize,
        height: usize,
        cfg: &TorsoConfig,
        up_hint: Vector3<f32>,
    ) -> Option<(TorsoPose, usize)> {
        // The transform over the person's bounding box (plus a background margin) only.
        let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0, 0);
        for v in 0..height {
            let row = &mask[v * width..(v + 1) * width];
            if let Some(a) = row.iter().position(|&m| m) {
                let b = row.iter().rposition(|&m| m).unwrap_or(a);
                u0 = u0.min(a);
                u1 = u1.max(b);
                v0 = v0.min(v);
                v1 = v1.max(v);
            }
        }
        if u0 == usize::MAX {
            return None;
        }
        let (sw, sh) = (u1 - u0 + 1, v1 - v0 + 1);
        self.sub_mask.clear();
        for v in v0..=v1 {
            self.sub_mask
                .extend_from_slice(&mask[v * width + u0..v * width + u1 + 1]);
        }
        // Where the person is cut from view (the image's edge, a table before them) the
        // body goes on: the torso is no narrower there than the cut shows.
        let open = Open {
            left: cut_beyond(points, mask, width, height, (u0, v0, u1, v1), Side::Left),
            right: cut_beyond(points, mask, width, height, (u0, v0, u1, v1), Side::Right),
            top: cut_beyond(points, mask, width, height, (u0, v0, u1, v1), Side::Top),
            bottom: cut_beyond(points, mask, width, height, (u0, v0, u1, v1), Side::Bottom),
        };
        self.dt
            .compute_open(&self.sub_mask, sw, sh, open, &mut self.sub_dist);
        self.dist.clear();
        self.dist.resize(width * height, 0.0);
        for (r, v) in (v0..=v1).enumerate() {
            self.dist[v * width + u0..v * width + u1 + 1]
                .copy_from_slice(&self.sub_dist[r * sw..(r + 1) * sw]);
        }
        let (core, &dmax) = self
            .dist
            .iter()
            .enumerate()
            .filter(|(i, _)| points[*i].z > 0.0)
            .max_by(|a, b| a.1.total_cmp(b.1))?;
        if dmax <= 0.0 {
            return None;
        }
        let thr = dmax * cfg.dt_share * cfg.dt_share;
        self.region.clear();
        self.region.resize(mask.len(), false);
        self.stack.clear();
        self.stack.push(core as u32);
        self.region[core] = true;
        self.region_z.clear();
        while let Some(i) = self.stack.pop() {
            let i = i as usize;
            self.region_z.push(points[i].z);
            let (u, v) = (i % width, i / width);
            let mut visit = |j: usize| {
                if !self.region[j] && self.dist[j] >= thr && points[j].z > 0.0 {
                    self.region[j] = true;
                    self.stack.push(j as u32);
                }
            };
            if u > 0 {
                visit(i - 1);
            }
            if u + 1 < width {
                visit(i + 1);
            }
            if v > 0 {
                visit(i - width);
            }
            if v + 1 < height {
                visit(i + width);
            }
        }
        // A hand or forearm held before the chest lies inside the torso's silhouette
        // but well in front of its surface: leave such points out of the PCA.
        if self.region_z.is_empty() {
            return None;
        }
        let k = self.region_z.len() / 2;
        let (_, &mut median_z, _) = self.region_z.select_nth_unstable_by(k, f32::total_cmp);
        let mut m = Moments::default();
        for (i, &inside) in self.region.iter().enumerate() {
            if inside && points[i].z > median_z - cfg.front_band {
                m.add(&points[i]);
            }
        }
        let pca = m.pca()?;
        let mut up: Vector3<f32> = pca.axes.column(0).into_owned();
        if up.dot(&up_hint) < 0.0 {
            up = -up;
        }
        // A squat torso region can have its long axis sideways: trust the hint then.
        if up.dot(&up_hint) < 0.5 || pca.std[0] < 1.2 * pca.std[1] {
            up = up_hint;
        }
        let mut fwd: Vector3<f32> = pca.axes.column(2).into_owned();
        if fwd.z > 0.0 {
            fwd = -fwd;
        }
        let left = up.cross(&fwd).try_normalize(1e-6)?;
        let fwd = left.cross(&up).try_normalize(1e-6)?;
        let up = fwd.cross(&left);
        let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[left, up, fwd]));
        // The core points lie on the front surface; the torso joint is behind them.
        let t = pca.mean.coords - fwd * (0.8 * cfg.half_depth);
        let pose = Rigid { r, t };
        pose.is_finite().then_some((pose, core))
    }

    /// Registers the torso model to the person's points by mutual closest points
    /// (closer than `icp_max_dist`) and Horn's closed form, starting from `init`.
    pub fn register(
        &mut self,
        points: &[Point3<f32>],
        mask: &[bool],
        width: usize,
        height: usize,
        cfg: &TorsoConfig,
        init: TorsoPose,
    ) -> (TorsoPose, f32, usize) {
        // Data: the person's points near the torso, thinned to about a thousand.
        let centre = Point3::from(init.t);
        let reach = (cfg.top - cfg.bottom).max(cfg.half_width * 2.0) * 0.75 + cfg.icp_max_dist;
        let count = mask.iter().filter(|&&m| m).count();
        let stride = ((count as f32 / 800.0).sqrt().ceil() as usize).max(1);
        self.data.clear();
        for v in (0..height).step_by(stride) {
            for u in (0..width).step_by(stride) {
                let i = v * width + u;
                if mask[i] && points[i].z > 0.0 && (points[i] - centre).norm() < reach {
                    self.data.push(points[i]);
                }
            }
        }
        let mut pose = init;
        let mut residual = f32::INFINITY;
        let mut matches = 0;
        if self.data.len() < 10 {
            return (pose, residual, 0);
        }
        let max2 = cfg.icp_max_dist * cfg.icp_max_dist;
        self.cells.build(&self.data, cfg.icp_max_dist);
        for _ in 0..cfg.icp_iterations {
            // Model points facing the camera (at the origin).
            self.world.clear();
            self.visible.clear();
            for (k, (p, n)) in self
                .model
                .points
                .iter()
                .zip(&self.model.normals)
                .enumerate()
            {
                let wp = pose.apply(p);
                let wn = pose.apply_vec(n);
                if wn.dot(&wp.coords) < 0.0 {
                    self.visible.push(k);
                    self.world.push(wp);
                }
            }
            if self.world.is_empty() {
                break;
            }
            // Closest data point of each visible model point, and vice versa, among
            // those within `icp_max_dist`: a farther pair is no match. Of equally near
            // points, the first.
            self.nn_model.clear();
            self.nn_model
                .resize(self.data.len(), (u32::MAX, f32::INFINITY));
            self.nn_data.clear();
            for (mi, m) in self.world.iter().enumerate() {
                let mut best = (u32::MAX, f32::INFINITY);
                let (data, nn_model) = (&self.data, &mut self.nn_model);
                self.cells.near(m, |di| {
                    let e = (m - data[di as usize]).norm_squared();
                    if e < best.1 || (e == best.1 && di < best.0) {
                        best = (di, e);
                    }
                    let back = &mut nn_model[di as usize];
                    if e < back.1 {
                        *back = (mi as u32, e);
                    }
                });
                self.nn_data.push(best);
            }
            self.src.clear();
            self.dst.clear();
            let mut sum = 0.0f32;
            for (mi, &(di, e)) in self.nn_data.iter().enumerate() {
                if di != u32::MAX && e < max2 && self.nn_model[di as usize].0 == mi as u32 {
                    self.src.push(self.world[mi]);
                    self.dst.push(self.data[di as usize]);
                    sum += e;
                }
            }
            matches = self.src.len();
            if matches < 6 {
                residual = f32::INFINITY;
                break;
            }
            let new_residual = (sum / matches as f32).sqrt();
            let step = horn_rigid(&self.src, &self.dst);
            if !step.is_finite() {
                break;
            }
            pose = step.compose(&pose);
            let converged = (residual - new_residual).abs() < 1e-6;
            residual = new_residual;
            if converged {
                break;
            }
        }
        (pose, residual, matches)
    }

    /// The torso step of one frame: register from `prev` when given, and from the PCA
    /// initialisation when there is no previous pose or its residual is too large.
    #[allow(clippy::too_many_arguments)]
    pub fn fit(
        &mut self,
        points: &[Point3<f32>],
        mask: &[bool],
        width: usize,
        height: usize,
        cfg: &TorsoConfig,
        start: TorsoStart,
        up_hint: Vector3<f32>,
    ) -> Option<TorsoFit> {
        let prev = match start {
            TorsoStart::Known(pose) => {
                return Some(TorsoFit {
                    pose,
                    residual: 0.0,
                    matches: 0,
                    reinitialised: false,
                    core_pixel: None,
                    pca: None,
                    core_half_width: None,
                })
            }
            TorsoStart::Track(pose, offset) => Some((pose, offset)),
            TorsoStart::Fresh => None,
        };
        let (init, core) = self.initial_pose(points, mask, width, height, cfg, up_hint)?;
        let core_half_width = row_half_width(points, mask, width, core);
        // Tracking starts from the last orientation, placed where the torso region is now
        // (the last frame's offset from its centre kept): a cylinder cannot be pulled
        // along its axis by closest points, so a jump would otherwise be lost.
        if let Some((prev, offset)) = prev {
            let prev = Rigid {
                r: prev.r,
                t: init.t + prev.r * offset,
            };
            let (pose, residual, matches) = self.register(points, mask, width, height, cfg, prev);
            if residual <= cfg.icp_reinit_residual && pose.is_finite() {
                return Some(TorsoFit {
                    pose,
                    residual,
                    matches,
                    reinitialised: false,
                    core_pixel: Some(core),
                    pca: Some(init),
                    core_half_width,
                });
            }
        }
        // The surface a camera sees of a torso faces it, turned or not: a region whose
        // flattest direction lies far from the camera's ray is flattest for another
        // reason (forearms along a table, a belly above it), and then the ray is the
        // better guess for a torso found afresh. (Tracking keeps its own turn, and
        // there the region's forward only places the start behind its surface.)
        let init = facing_the_camera(init, cfg);
        // From PCA the torso is taken to face the camera; a person seen from the side
        // fits the model turned a quarter, so those are tried as well.
        let mut best: Option<(TorsoPose, f32, usize)> = None;
        for yaw in cfg.reinit_yaws.iter() {
            let turn = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw.to_radians());
            let start = Rigid {
                r: init.r * turn,
                t: init.t,
            };
            let (pose, residual, matches) = self.register(points, mask, width, height, cfg, start);
            if pose.is_finite() && best.is_none_or(|b| residual < b.1 * 0.9) {
                best = Some((pose, residual, matches));
            }
        }
        let (mut pose, mut residual, mut matches) = best.unwrap_or((init, f32::INFINITY, 0));
        // A torso's front and back look alike to the model: one that turned its back to
        // the camera (a belly down to a table top, the forearms on it) is also tried
        // turned round, which is kept when it explains the points about as well.
        if residual.is_finite() && facing(&pose) <= 0.0 {
            let round = Rotation3::from_axis_angle(&Vector3::y_axis(), std::f32::consts::PI);
            let start = Rigid {
                r: pose.r * round,
                t: pose.t,
            };
            let (p, r, m) = self.register(points, mask, width, height, cfg, start);
            if p.is_finite() && facing(&p) > 0.0 && r < FRONT_BACK_SLACK * residual {
                (pose, residual, matches) = (p, r, m);
            }
        }
        Some(TorsoFit {
            pose,
            residual,
            matches,
            reinitialised: true,
            core_pixel: Some(core),
            pca: Some(init),
            core_half_width,
        })
    }
}

/// The cosine of the largest angle between a torso's forward and the ray to the camera
/// at which it counts as facing the camera (45°): a fresh torso's forward is the PCA's
/// only within it, and only within it does the torso's back plane tell what lies
/// behind the body.
pub(crate) const FACING_COS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// The cosine of the angle between `pose`'s forward and the ray from it to the camera:
/// 1 facing the camera, −1 its back to it.
pub(crate) fn facing(pose: &TorsoPose) -> f32 {
    (pose.r * Vector3::z()).dot(&-pose.t.normalize())
}

/// `init`, the torso region's PCA frame ([`TorsoEstimator::initial_pose`]), turned about
/// its up to face the camera when its forward lies farther than [`FACING_COS`] from the
/// ray, its surface point (the region's centre) kept.
fn facing_the_camera(init: TorsoPose, cfg: &TorsoConfig) -> TorsoPose {
    let behind = 0.8 * cfg.half_depth;
    let fwd = init.r * Vector3::z();
    let surface = init.t + fwd * behind;
    let to_camera = -surface.normalize();
    if fwd.dot(&to_camera) >= FACING_COS {
        return init;
    }
    let up = init.r * Vector3::y();
    let Some(left) = up.cross(&to_camera).try_normalize(1e-6) else {
        return init;
    };
    let fwd = left.cross(&up);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[left, up, fwd]));
    Rigid {
        r,
        t: surface - fwd * behind,
    }
}

/// A torso turned to face the camera is kept over one facing away when its residual is
/// at most this many times the other's.
const FRONT_BACK_SLACK: f32 = 1.5;

/// Half the distance, along the camera's x, between the ends of the mask's run through
/// pixel `at` in its row.
fn row_half_width(points: &[Point3<f32>], mask: &[bool], width: usize, at: usize) -> Option<f32> {
    let row = at - at % width;
    let inside = |i: usize| mask[i] && points[i].z > 0.0;
    if !inside(at) {
        return None;
    }
    let mut lo = at;
    while lo > row && inside(lo - 1) {
        lo -= 1;
    }
    let mut hi = at;
    while hi + 1 < row + width && inside(hi + 1) {
        hi += 1;
    }
    Some((points[hi].x - points[lo].x).abs() / 2.0)
}

/// A side of the person's bounding box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Left,
    Right,
    Top,
    Bottom,
}

/// Whether the person continues beyond a side of their bounding box `(u0, v0, u1, v1)`:
/// it is the image's edge, or most of the person's pixels along it border something
/// nearer that hides what goes on (a table before the waist).
fn cut_beyond(
    points: &[Point3<f32>],
    mask: &[bool],
    width: usize,
    height: usize,
    (u0, v0, u1, v1): (usize, usize, usize, usize),
    side: Side,
) -> bool {
    let edge = match side {
        Side::Left => u0 == 0,
        Side::Right => u1 + 1 >= width,
        Side::Top => v0 == 0,
        Side::Bottom => v1 + 1 >= height,
    };
    if edge {
        return true;
    }
    // The person's pixels along the side and the pixel just beyond each.
    let pairs: Vec<(usize, usize)> = match side {
        Side::Left => (v0..=v1)
            .map(|v| (v * width + u0, v * width + u0 - 1))
            .collect(),
        Side::Right => (v0..=v1)
            .map(|v| (v * width + u1, v * width + u1 + 1))
            .collect(),
        Side::Top => (u0..=u1)
            .map(|u| (v0 * width + u, (v0 - 1) * width + u))
            .collect(),
        Side::Bottom => (u0..=u1)
            .map(|u| (v1 * width + u, (v1 + 1) * width + u))
            .collect(),
    };
    let (mut along, mut hidden) = (0, 0);
    for (inner, outer) in pairs {
        if !mask[inner] || points[inner].z <= 0.0 {
            continue;
        }
        along += 1;
        let q = points[outer];
        if !mask[outer] && q.z > 0.0 && q.z < points[inner].z - crate::view::OCCLUDER_GAP {
            hidden += 1;
        }
    }
    along > 0 && 2 * hidden > along
}

/// The torso key points in the camera frame.
pub fn keypoints(pose: &TorsoPose, cfg: &TorsoConfig) -> TorsoPoints<Point3<f32>> {
    cfg.keypoints
        .map(|[x, y, z]| pose.apply(&Point3::new(x, y, z)))
}

/// The torso frame of the seed's steps (key points of [`TorsoConfig::keypoints`])
/// that fits the registered body `body` (of template `tpl`) best.
pub fn of_body(body: &BodyPose, tpl: &BodyTemplate, cfg: &TorsoConfig) -> Option<TorsoPose> {
    let s = Posed::new(tpl, body).skeleton(tpl);
    let model: Vec<Point3<f32>> = cfg
        .keypoints
        .to_array()
        .iter()
        .map(|&[x, y, z]| Point3::new(x, y, z))
        .collect();
    let seen: Vec<Point3<f32>> = TorsoPoints::<()>::JOINTS.iter().map(|&j| s[j]).collect();
    let pose = horn_rigid(&model, &seen);
    pose.is_finite().then_some(pose)
}

/// The torso model slides along its own axis (a cylinder's surface does not pin it);
/// the top of the head does: `torso` moved along its axis to hold `head_top` (the
/// head's geodesic maximum, at `pixel` of an image of `size`) at
/// [`TorsoConfig::head_top_height`] above its origin. `inv` is the inverse of the torso
/// the maximum was assigned with. Only a head top straight above the torso, not far
/// off, is trusted; a head cut by the image border has its top out of sight.
pub fn anchored_at_head_top(
    torso: &mut TorsoPose,
    inv: &TorsoPose,
    head_top: &Point3<f32>,
    (pu, pv): (usize, usize),
    (w, h): (usize, usize),
    cfg: &TorsoConfig,
) {
    let top = inv.apply(head_top);
    let dy = top.y - cfg.head_top_height;
    let inside = pu > 2 && pv > 2 && pu + 3 < w && pv + 3 < h;
    if inside && dy.abs() < 0.15 && top.x.abs() < 0.12 && top.z.abs() < 0.2 {
        torso.t += torso.r * nalgebra::Vector3::new(0.0, dy, 0.0);
    }
}

/// How high above the torso's origin the top of the head is, along the torso's up, as
/// the person's mask shows it: the highest of the points within 10 cm of the torso's
/// axis and 20–100 cm above its origin (the 99th percentile, a flying pixel is no
/// head). `None` when there are none, or when the head reaches the image's top edge and
/// its top is out of sight.
pub fn head_top_of_mask(
    points: &[Point3<f32>],
    mask: &[bool],
    width: usize,
    pose: &TorsoPose,
) -> Option<f32> {
    let inv = pose.inverse();
    let mut tops: Vec<f32> = Vec::new();
    let mut at_edge = false;
    for (i, (p, &m)) in points.iter().zip(mask).enumerate() {
        if !m || p.z <= 0.0 {
            continue;
        }
        let q = inv.apply(p);
        if q.x.abs() < 0.10 && q.z.abs() < 0.25 && (0.2..1.0).contains(&q.y) {
            tops.push(q.y);
            at_edge |= i < 2 * width;
        }
    }
    if tops.len() < 10 || at_edge {
        return None;
    }
    let k = tops.len() * 99 / 100;
    let (_, &mut top, _) = tops.select_nth_unstable_by(k, f32::total_cmp);
    Some(top)
}

/// The torso turned about its axis to face where the toes point, when the two
/// lowest maxima (the feet) agree on a direction more than 45° away from the
/// torso's; `None` to keep it. The torso model cannot tell front from back, nor well a
/// quarter turn; the feet can.
pub fn facing_from_feet(
    torso: &TorsoPose,
    maxima: &[u32],
    graph: &GeoGraph,
    geo: &Geodesic,
) -> Option<TorsoPose> {
    let inv = torso.inverse();
    let up = torso.r * Vector3::y();
    let mut feet: Vec<(f32, u32)> = maxima
        .iter()
        .map(|&m| (inv.apply(&graph.pos[m as usize]).y, m))
        .filter(|&(y, _)| y < -0.7)
        .collect();
    feet.sort_by(|a, b| a.0.total_cmp(&b.0));
    if feet.len() < 2 {
        return None;
    }
    let mut dirs = Vec::with_capacity(2);
    for &(_, m) in &feet[..2] {
        // Back along the geodesic path to about the ankle.
        let toe = graph.pos[m as usize];
        let d_toe = geo.dist(m);
        let mut a = m;
        let mut guard = 0;
        while a != NONE && d_toe.saturating_sub(geo.dist(a)) < 150 && guard < 10_000 {
            a = geo.pred(a);
            guard += 1;
        }
        if a == NONE {
            return None;
        }
        let d = toe - graph.pos[a as usize];
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Renders the model's own visible points as an organized cloud, so registration
    /// must find the pose they were rendered at.
    #[test]
    fn registration_recovers_a_displaced_torso() {
        let cfg = TorsoConfig {
            icp_iterations: 40,
            ..TorsoConfig::default()
        };
        let truth = Rigid {
            r: Rotation3::from_euler_angles(0.05, 0.3, 0.1),
            t: Vector3::new(0.1, -0.2, 2.5),
        };
        let model = TorsoModel::with_resolution(&cfg, 60, 120);
        let mut pts = Vec::new();
        for (p, n) in model.points.iter().zip(&model.normals) {
            let wp = truth.apply(p);
            if truth.apply_vec(n).dot(&wp.coords) < 0.0 {
                pts.push(wp);
            }
        }
        let mask = vec![true; pts.len()];
        let mut est = TorsoEstimator::new(&cfg);
        let init = Rigid {
            r: Rotation3::from_euler_angles(0.0, 0.15, 0.0),
            t: truth.t + Vector3::new(0.03, 0.02, 0.04),
        };
        let (pose, residual, matches) = est.register(&pts, &mask, pts.len(), 1, &cfg, init);
        assert!(matches > 20);
        assert!(residual < 0.01, "{residual}");
        assert!((pose.t - truth.t).norm() < 0.02, "{:?}", pose.t - truth.t);
        // The axis is well determined; the turn about it, for an elliptic cylinder seen
        // from one side, only weakly.
        let (up, up_true) = (pose.r * Vector3::y(), truth.r * Vector3::y());
        assert!(up.angle(&up_true) < 0.05, "{}", up.angle(&up_true));
    }
}
