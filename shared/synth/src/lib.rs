//! Synthetic people: bodies, skinning, motion, depth rendering and exact ground truth.
//!
//! A [`Synthesizer`] renders a person into 16-bit depth frames (millimetres, 0 = no
//! data) with the pinhole intrinsics of airglyph-core, and reports the 16 ground-truth
//! joints of airglyph-core for every frame, at anatomical joint centres inside the body
//! (hand = palm centre, foot = ankle, torso = mid-chest on the spine, pelvis = between
//! the hips) but for the head, the top of the head, in the camera frame
//! (docs/architecture.md, "Camera frame and joints").
//!
//! ```no_run
//! use airglyph_synth::{SceneConfig, Synthesizer, MotionSpec, ScriptedPose, Background};
//! let cfg = SceneConfig {
//!     motion: MotionSpec::Pose(ScriptedPose::PointAtCamera),
//!     background: Background::FloorAndWall,
//!     sensor_noise: true,
//!     ..SceneConfig::default()
//! };
//! let mut synth = Synthesizer::new(cfg)?;
//! let k = synth.intrinsics();
//! let mut depth = vec![0u16; (k.width * k.height) as usize];
//! let truth = synth.render_into(0, &mut depth)?;
//! println!("head at {:?}", truth.skeleton.get(airglyph_core::Joint::Head));
//! # Ok::<(), airglyph_synth::SynthError>(())
//! ```
//!
//! Pieces, each usable alone:
//! - [`Body`]: a skinned mesh. [`BodySpec::Procedural`] is built in (ellipsoids and
//!   tapered capsules rigidly bound to 19 bones; height and build are parameters);
//!   [`BodySpec::MakeHuman`] loads the MakeHuman CC0 body with its `cmu_mb` rig and
//!   weights from the asset cache that `scripts/fetch-assets` fills (linear blend
//!   skinning, 4 bones a vertex), in any of MakeHuman's macro shapes
//!   ([`MakeHumanShape`]: gender, age, muscle, weight, height, proportions, ethnic
//!   mix; [`makehuman::shape`] says how its targets are weighed). The default shape is
//!   the raw base mesh, the body every figure before shapes was measured on.
//! - [`Pose`] on the canonical skeleton ([`Bone`], 19 bones, T-pose reference): what
//!   every motion source produces and every body consumes.
//! - [`MotionSpec`]: scripted poses ([`ScriptedPose`], the hard cases of the seed
//!   paper), BVH clips (any naming convention, rest-pose offsets handled), and
//!   air-drawing of symbols ([`DrawSpec`]) with ground-truth gesture boundaries.
//! - [`hand`]: hands in static postures ([`HandPosture`]: open, fist, point, thumb-up,
//!   V, pinch), a procedural hand of articulated fingers sized from the body's forearm
//!   that replaces the body's own where [`SceneConfig::hands`] asks, turned at the wrist
//!   as it says, and for the drawing hand optionally one posture while a symbol is drawn
//!   and another between ([`HandSpec::drawing`]: the pen lifted by the hand);
//!   [`FrameTruth::hands`] gives each hand's posture in the frame, palm, orientation
//!   and fingertips.
//! - [`raster::Raster`]: the z-buffer rasterizer; [`sensor`]: the Kinect-like noise.
//! - [`write_recording`]: a whole recording on disk (airglyph-core's format, plus
//!   `joints.csv`, for air-drawing `gestures.csv`, and with hand postures `hands.csv`).
//!
//! Everything is deterministic given [`SceneConfig::seed`].
//!
//! Frames: frame `i` is at time `i / fps`; [`Synthesizer::len`] is `None` for endless
//! motion (scripted poses, repeating air-drawing: the live demo) and `Some(n)` for a
//! clip or a finite list of symbols. Frames past the end hold the last pose.
//!
//! Frames of reference: the person's [`Pose`] lives in the body frame (metres, y up,
//! facing +z, +x the person's left, floor y = 0); [`Placement`] puts it in front of the
//! camera (by default 2.7 m away, camera 1 m high, facing it), and everything reported
//! ([`FrameTruth::skeleton`]) is in airglyph-core's camera frame (x right, y down, z
//! forward). Facing the camera, the person's left is on the image's right. An
//! air-drawn symbol is written as the person sees it, so the camera sees it mirrored.
//!
//! The calls other crates make:
//!
//! ```text
//! Synthesizer::new(cfg: SceneConfig) -> Result<Synthesizer, SynthError>
//! synth.render_into(index: usize, depth: &mut [u16]) -> Result<FrameTruth, SynthError>
//! synth.render(index: usize) -> (DepthImage, FrameTruth)
//! synth.len() -> Option<usize>          synth.intrinsics() -> Intrinsics
//! synth.fps() -> f32                    synth.gestures() -> Vec<GestureTruth>
//! synth.labels() -> &[u8]               (per pixel: the Bone seen, or raster::NO_LABEL)
//! write_recording(cfg, frames, dir: &Path, progress: impl FnMut(usize))
//!     -> Result<RecordingSummary, SynthError>   (+ joints.csv, gestures.csv, hands.csv)
//! makehuman::default_assets_dir() -> PathBuf;  makehuman::assets_present(&Path) -> bool
//! makehuman::targets_present(&Path) -> bool   MakeHumanShape::parse("gender=0,weight=0.8")
//! ```
//!
//! Benchmark (`cargo bench -p airglyph-synth`): skinning + rendering the MakeHuman body
//! (13,380 vertices, 26,756 triangles) at 640×480 on one thread runs at 700+ frames/s on
//! a quiet machine (≈ 960 frames per CPU second); the rasterizer takes 80% of it.

#![warn(missing_docs)]

pub mod air3d;
pub mod body;
pub mod bvh;
pub mod canon;
pub mod draw;
pub mod error;
pub mod glyphs;
pub mod hand;
pub mod makehuman;
pub mod motion;
pub mod poses;
pub mod raster;
pub mod room;
pub mod sensor;
pub mod shapes3d;

pub use airglyph_core::gestures::GestureTruth;
pub use body::{Affine, Body, ProceduralBody};
pub use canon::{Bone, Pose, TposeSkeleton};
pub use error::SynthError;
pub use hand::{Finger, HandPosture, HandSpec, HandTruth, Hands};
pub use makehuman::MakeHumanShape;
pub use motion::{DrawSpec, MotionSpec};
pub use poses::{Posture, ScriptedPose, Side};
pub use room::{Background, Chair, Mug, Prop, Table};

use airglyph_core::gestures::write_gestures_csv;
use airglyph_core::recording::{RecordingInfo, RecordingWriter};
use airglyph_core::{DepthImage, DepthView, Intrinsics, Joint, Skeleton};
use nalgebra::{Matrix3, Point3, Vector3};
use std::path::{Path, PathBuf};

/// Which body to render.
#[derive(Debug, Clone, PartialEq)]
pub enum BodySpec {
    /// The built-in procedural person.
    Procedural(ProceduralBody),
    /// The MakeHuman body; `assets` is the folder holding `mpfb2/` (None: see
    /// [`makehuman::default_assets_dir`]).
    MakeHuman {
        /// The folder holding `mpfb2/`, or None for the default.
        assets: Option<PathBuf>,
        /// Its macro shape (gender, age, muscle, weight, height, …); the default is the
        /// raw base mesh, as before shapes existed.
        shape: MakeHumanShape,
    },
}

impl BodySpec {
    /// Builds or loads the body.
    pub fn load(&self) -> Result<Body, SynthError> {
        match self {
            BodySpec::Procedural(p) => Body::procedural(p),
            BodySpec::MakeHuman { assets, shape } => {
                let dir = assets.clone().unwrap_or_else(makehuman::default_assets_dir);
                makehuman::load_shaped(&dir, shape)
            }
        }
    }
}

/// Where the person stands relative to the camera. The camera looks horizontally (then
/// tilted down by `camera_tilt_deg`) at the person, who faces it when `yaw_deg` = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// From the camera to the person's hips, along the floor, metres.
    pub distance_m: f32,
    /// Camera height above the floor, metres.
    pub camera_height_m: f32,
    /// Camera pitch down, degrees.
    pub camera_tilt_deg: f32,
    /// The person's turn to their left, degrees.
    pub yaw_deg: f32,
    /// The person's offset to the camera's right, metres.
    pub lateral_m: f32,
    /// From the person to the wall behind (with [`Background::FloorAndWall`]), metres.
    pub wall_behind_m: f32,
    /// The camera follows the person across the floor: a clip's horizontal root travel
    /// is removed (its turns, bends and jumps are kept), as on a treadmill. Motion
    /// capture clips walk and jump metres away; without this the person leaves the
    /// image or comes too close for the sensor.
    pub follow: bool,
}

impl Default for Placement {
    fn default() -> Self {
        Self {
            distance_m: 2.7,
            camera_height_m: 1.0,
            camera_tilt_deg: 0.0,
            yaw_deg: 0.0,
            lateral_m: 0.0,
            wall_behind_m: 1.5,
            follow: false,
        }
    }
}

/// Everything that defines a synthetic scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneConfig {
    /// Whose body is rendered.
    pub body: BodySpec,
    /// How it moves.
    pub motion: MotionSpec,
    /// The virtual camera.
    pub intrinsics: Intrinsics,
    /// Frames a second.
    pub fps: f32,
    /// Apply the Kinect-like sensor model ([`sensor`]).
    pub sensor_noise: bool,
    /// What is behind the person.
    pub background: Background,
    /// Furniture where the person starts.
    pub props: Vec<Prop>,
    /// Standing, or seated (on a chair, when `props` has one at the seat's height).
    pub posture: Posture,
    /// Where the person stands before the camera.
    pub placement: Placement,
    /// Each hand's posture and turn at the wrist; the default keeps the body's own
    /// hands as the pose holds them.
    pub hands: Hands<HandSpec>,
    /// Seeds every random choice: the same seed renders the same frames.
    pub seed: u64,
}

impl Default for SceneConfig {
    fn default() -> Self {
        Self {
            body: BodySpec::Procedural(ProceduralBody::default()),
            motion: MotionSpec::Poses,
            intrinsics: Intrinsics::default(),
            fps: 30.0,
            sensor_noise: false,
            background: Background::None,
            props: Vec::new(),
            posture: Posture::Standing,
            placement: Placement::default(),
            hands: Hands::default(),
            seed: 0,
        }
    }
}

impl SceneConfig {
    /// This scene with the camera framing the person from the waist or the chest up, as
    /// a camera on a desk, a screen or a robot sees someone near it: at the height of
    /// their face (0.3 m below the top of the head, standing or seated as
    /// [`SceneConfig::posture`] says) and tilted so that the top of the image passes
    /// 0.12 m above the head at the person's distance. How much of the body the image
    /// holds then follows from the distance and the lens.
    pub fn framing_upper_body(mut self) -> Result<Self, SynthError> {
        let body = self.body.load()?;
        let sk = body.tpose();
        let seated = ScriptedPose::Neutral.pose_in(sk, self.posture);
        let top = sk.tail(Bone::Head).y + (seated.root.y - sk.head(Bone::Hips).y);
        let k = &self.intrinsics;
        let pl = &mut self.placement;
        pl.camera_height_m = top - 0.3;
        let above_axis = (k.cy / k.fy).atan();
        let to_top = ((top + 0.12 - pl.camera_height_m) / pl.distance_m).atan();
        pl.camera_tilt_deg = (above_axis - to_top).to_degrees();
        Ok(self)
    }
}

/// The ground truth of one rendered frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTruth {
    /// The frame's index.
    pub index: usize,
    /// `index / fps` in nanoseconds.
    pub capture_ns: u64,
    /// The 16 joints, camera frame, metres (confidence 1), each visible when it is in the
    /// camera's view: inside the image and before everything around the person at its
    /// pixel (a table, the floor, the walls). A joint hidden only by the person's own
    /// body is in view: what a pose estimator should still estimate.
    pub skeleton: Skeleton,
    /// Per joint: it projects inside the image onto its own body part (no other part of
    /// the body hides it).
    pub visible: [bool; Joint::COUNT],
    /// The symbol being air-drawn in this frame, if any.
    pub gesture: Option<GestureTruth>,
    /// Each hand's posture, place and orientation.
    pub hands: Hands<HandTruth>,
}

/// Renders frames of a scene. Holds its scratch buffers: reuse one for many frames.
pub struct Synthesizer {
    cfg: SceneConfig,
    body: Body,
    motion: motion::Motion,
    camera: Affine,
    background: Option<Vec<u16>>,
    raster: raster::Raster,
    hands: hand::HandRenderer,
    xf: Vec<Affine>,
    skinned: Vec<Point3<f32>>,
    labels: Vec<u8>,
}

impl Synthesizer {
    /// Builds the body, the motion and the background; checks every parameter.
    pub fn new(cfg: SceneConfig) -> Result<Self, SynthError> {
        cfg.intrinsics
            .validate()
            .map_err(|e| SynthError::Config(format!("intrinsics: {e}")))?;
        if !(cfg.fps.is_finite() && cfg.fps > 0.0 && cfg.fps <= 1000.0) {
            return Err(SynthError::Config(format!(
                "fps {} must be in (0, 1000]",
                cfg.fps
            )));
        }
        let pl = &cfg.placement;
        let finite = [
            pl.distance_m,
            pl.camera_height_m,
            pl.camera_tilt_deg,
            pl.yaw_deg,
            pl.lateral_m,
            pl.wall_behind_m,
        ]
        .iter()
        .all(|v| v.is_finite());
        if !finite || pl.distance_m < 0.5 || pl.distance_m > 20.0 || pl.wall_behind_m < 0.3 {
            return Err(SynthError::Config(format!(
                "placement {pl:?}: distances must be finite, 0.5–20 m to the person and ≥ 0.3 m to the wall"
            )));
        }
        for prop in &cfg.props {
            if !prop.is_sane() {
                return Err(SynthError::Config(format!(
                    "{prop:?}: sizes must be finite, positive and under 5 m"
                )));
            }
            if pl.distance_m - prop.reach_m() < 0.4 {
                return Err(SynthError::Config(format!(
                    "{prop:?} reaches {:.2} m towards the camera, {:.2} m away: move the camera back (--distance)",
                    prop.reach_m(),
                    pl.distance_m
                )));
            }
            if let Prop::Mug(m) = prop {
                let tables = cfg.props.iter().filter_map(|p| match p {
                    Prop::Table(t) => Some(t.height_m),
                    _ => None,
                });
                if !tables.into_iter().any(|h| (h - m.base_m).abs() < 0.005) {
                    return Err(SynthError::Config(format!(
                        "{prop:?} stands on a table: add a table whose top is at its base ({} m)",
                        m.base_m
                    )));
                }
            }
        }
        if let Posture::Seated { seat_height_m } = cfg.posture {
            if !(0.2..=1.0).contains(&seat_height_m) {
                return Err(SynthError::Config(format!(
                    "seat height {seat_height_m} m must be 0.2–1 m"
                )));
            }
        }
        for side in hand::SIDES {
            let h = cfg.hands.get(side);
            if !(h.roll_deg.is_finite() && h.pitch_deg.is_finite()) {
                return Err(SynthError::Config(format!(
                    "{side:?} hand: roll {} and pitch {} must be finite degrees",
                    h.roll_deg, h.pitch_deg
                )));
            }
            if let Some(d) = h.drawing {
                let why = if side != Side::Right {
                    Some("only the right hand draws")
                } else if h.posture.is_none() {
                    Some("it needs a posture between symbols too")
                } else if !matches!(cfg.motion, MotionSpec::Draw(_)) {
                    Some("the motion draws no symbol (draw:SYMBOLS)")
                } else {
                    None
                };
                if let Some(why) = why {
                    return Err(SynthError::Config(format!(
                        "{side:?} hand: a posture while drawing ({}): {why}",
                        d.name()
                    )));
                }
            }
        }
        let body = cfg.body.load()?;
        let hands = hand::HandRenderer::new(&body, &cfg.hands);
        let setting = motion::Setting {
            posture: cfg.posture,
            table_m: cfg.props.iter().find_map(|p| match p {
                Prop::Table(t) => Some(t.height_m),
                _ => None,
            }),
        };
        let motion = motion::Motion::new(&cfg.motion, body.tpose(), setting, cfg.fps, cfg.seed)?;
        let camera = camera_from_body(pl);
        let background = room::render(&cfg.intrinsics, pl, cfg.background, &cfg.props);
        let n = (cfg.intrinsics.width * cfg.intrinsics.height) as usize;
        Ok(Self {
            cfg,
            body,
            motion,
            camera,
            background,
            raster: raster::Raster::new(),
            hands,
            xf: Vec::new(),
            skinned: Vec::new(),
            labels: vec![raster::NO_LABEL; n],
        })
    }

    /// The scene it renders.
    pub fn config(&self) -> &SceneConfig {
        &self.cfg
    }

    /// The virtual camera's intrinsics.
    pub fn intrinsics(&self) -> Intrinsics {
        self.cfg.intrinsics
    }

    /// Frames a second.
    pub fn fps(&self) -> f32 {
        self.cfg.fps
    }

    /// The body it renders.
    pub fn body(&self) -> &Body {
        &self.body
    }

    /// Frames in the motion, or `None` when it never ends.
    pub fn len(&self) -> Option<usize> {
        self.motion.len()
    }

    /// Whether the motion has no frame at all (never: a clip has at least one).
    pub fn is_empty(&self) -> bool {
        self.len() == Some(0)
    }

    /// Every air-drawn symbol of a finite motion with its frames.
    pub fn gestures(&self) -> Vec<GestureTruth> {
        self.motion.gestures()
    }

    /// The transform from the body frame to the camera frame.
    pub fn camera_from_body(&self) -> Affine {
        self.camera
    }

    /// The pose (canonical skeleton, body frame) of frame `index`, the hands turned at
    /// the wrists as [`SceneConfig::hands`] says.
    pub fn pose(&self, index: usize) -> Pose {
        let mut p = self.motion.pose(index);
        if self.cfg.placement.follow {
            p.root.x = 0.0;
            p.root.z = 0.0;
        }
        hand::turn_wrists(&mut p, &self.cfg.hands);
        p
    }

    /// Per pixel of the last rendered frame, the canonical [`Bone`] whose surface it shows
    /// (`Bone as u8`), or [`raster::NO_LABEL`] for background and empty pixels.
    pub fn labels(&self) -> &[u8] {
        &self.labels
    }

    /// Renders frame `index` into `depth` (row-major, `width × height`, millimetres,
    /// 0 = no data) and returns its ground truth.
    pub fn render_into(
        &mut self,
        index: usize,
        depth: &mut [u16],
    ) -> Result<FrameTruth, SynthError> {
        let k = self.cfg.intrinsics;
        let n = (k.width * k.height) as usize;
        if depth.len() != n {
            return Err(SynthError::Config(format!(
                "depth buffer has {} pixels, the {}x{} camera needs {n}",
                depth.len(),
                k.width,
                k.height
            )));
        }
        let pose = self.pose(index);
        self.body.bone_transforms(&pose, &mut self.xf);
        for a in &mut self.xf {
            *a = a.then(&self.camera);
        }
        self.body.skin(&self.xf, &mut self.skinned);
        match &self.background {
            Some(bg) => depth.copy_from_slice(bg),
            None => depth.fill(0),
        }
        self.labels.fill(raster::NO_LABEL);
        let gesture = self.motion.gesture(index);
        let (tris, tri_label) = self.hands.body_triangles(&self.body);
        self.raster.rasterize(
            &k,
            &self.skinned,
            tris,
            tri_label,
            true,
            depth,
            Some(&mut self.labels),
        );
        let hands = self.hands.draw(
            &k,
            &mut self.raster,
            &self.body,
            &pose,
            &self.xf,
            &self.camera,
            depth,
            &mut self.labels,
            gesture.is_some(),
        );
        let joints = self.body.joints_from(&self.xf);
        let mut visible = [false; Joint::COUNT];
        let mut in_view = [false; Joint::COUNT];
        for j in Joint::ALL {
            visible[j.index()] = self.joint_visible(j, &joints[j.index()]);
            in_view[j.index()] = self.in_view(&joints[j.index()]);
        }
        if self.cfg.sensor_noise {
            sensor::SensorModel::default().apply(&k, depth, self.cfg.seed, index);
        }
        Ok(FrameTruth {
            index,
            capture_ns: (index as f64 * 1e9 / self.cfg.fps as f64).round() as u64,
            skeleton: Skeleton {
                visible: in_view,
                ..Skeleton::new(joints)
            },
            visible,
            gesture,
            hands,
        })
    }

    /// Renders frame `index` into a new image.
    pub fn render(&mut self, index: usize) -> (DepthImage, FrameTruth) {
        let k = self.cfg.intrinsics;
        let mut img = DepthImage::empty(k.width, k.height);
        let truth = self
            .render_into(index, img.pixels_mut())
            .expect("buffer sized from the intrinsics");
        (img, truth)
    }

    /// The index of the pixel `p` projects to, if inside the image.
    fn pixel(&self, p: &Point3<f32>) -> Option<usize> {
        let k = &self.cfg.intrinsics;
        let (u, v) = k.project(p)?;
        let (u, v) = (u.round(), v.round());
        (u >= 0.0 && v >= 0.0 && u < k.width as f32 && v < k.height as f32)
            .then(|| v as usize * k.width as usize + u as usize)
    }

    /// Inside the image and before the static scene at its pixel.
    fn in_view(&self, p: &Point3<f32>) -> bool {
        let Some(i) = self.pixel(p) else {
            return false;
        };
        let behind = self.background.as_ref().map_or(0, |bg| bg[i]);
        behind == 0 || behind as f32 > p.z * 1000.0
    }

    fn joint_visible(&self, j: Joint, p: &Point3<f32>) -> bool {
        let Some(i) = self.pixel(p) else {
            return false;
        };
        let l = self.labels[i];
        l != raster::NO_LABEL && own_bones(j).iter().any(|b| *b as u8 == l)
    }
}

/// The body parts around a joint: if one of them is what the camera sees at the joint's
/// pixel, the joint is not hidden by another part of the body.
pub fn own_bones(j: Joint) -> &'static [Bone] {
    use Bone::*;
    match j {
        Joint::Head => &[Head, Neck],
        Joint::Neck => &[Neck, Chest, Head, LeftCollar, RightCollar],
        Joint::Torso => &[Chest, Spine],
        Joint::Pelvis => &[Hips, Spine, LeftThigh, RightThigh],
        Joint::LeftShoulder => &[LeftCollar, LeftUpperArm, Chest],
        Joint::LeftElbow => &[LeftUpperArm, LeftForearm],
        Joint::LeftHand => &[LeftHand, LeftForearm],
        Joint::RightShoulder => &[RightCollar, RightUpperArm, Chest],
        Joint::RightElbow => &[RightUpperArm, RightForearm],
        Joint::RightHand => &[RightHand, RightForearm],
        Joint::LeftHip => &[Hips, Spine, LeftThigh],
        Joint::LeftKnee => &[LeftThigh, LeftShin],
        Joint::LeftFoot => &[LeftShin, LeftFoot],
        Joint::RightHip => &[Hips, Spine, RightThigh],
        Joint::RightKnee => &[RightThigh, RightShin],
        Joint::RightFoot => &[RightShin, RightFoot],
    }
}

/// Body frame (y up, facing +z, floor y = 0) to camera frame (x right, y down, z
/// forward) for a placement.
pub fn camera_from_body(pl: &Placement) -> Affine {
    let yaw = poses::yaw(pl.yaw_deg.to_radians());
    let ry = *yaw.to_rotation_matrix().matrix();
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    let t = pl.camera_tilt_deg.to_radians();
    let tilt = Matrix3::new(1.0, 0.0, 0.0, 0.0, t.cos(), -t.sin(), 0.0, t.sin(), t.cos());
    Affine {
        m: tilt * flip * ry,
        t: tilt * Vector3::new(pl.lateral_m, pl.camera_height_m, pl.distance_m),
    }
}

/// What [`write_recording`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingSummary {
    /// Frames written.
    pub frames: usize,
    /// The symbols drawn in them, as `gestures.csv` has them.
    pub gestures: Vec<GestureTruth>,
}

/// Renders `frames` frames (fewer if the motion is shorter) into a new recording in
/// `dir`: airglyph-core's format with `joints.csv`, `gestures.csv`
/// (`label,start_frame,end_frame`) when the motion air-draws, and `hands.csv` (each
/// hand's truth, [`hand::CSV_HEADER`]) when the scene sets a hand's posture or turn. `progress` is called
/// after every frame with the number written so far.
pub fn write_recording(
    cfg: SceneConfig,
    frames: usize,
    dir: &Path,
    mut progress: impl FnMut(usize),
) -> Result<RecordingSummary, SynthError> {
    let source = format!("synthetic:{}", describe(&cfg));
    let mut synth = Synthesizer::new(cfg)?;
    let n = synth.len().map_or(frames, |len| len.min(frames));
    let k = synth.intrinsics();
    let mut writer =
        RecordingWriter::create(dir, RecordingInfo::new(k, synth.fps(), source), true)?;
    let mut depth = vec![0u16; (k.width * k.height) as usize];
    let mut hands = if synth.cfg.hands != Hands::default() {
        Some(hand::HandsCsv::create(&dir.join("hands.csv"))?)
    } else {
        None
    };
    for i in 0..n {
        let truth = synth.render_into(i, &mut depth)?;
        let view = DepthView::new(k.width, k.height, &depth).expect("sized from intrinsics");
        writer.write_frame(view, truth.capture_ns, Some(&truth.skeleton))?;
        if let Some(csv) = &mut hands {
            csv.write(i, &truth.hands)?;
        }
        progress(i + 1);
    }
    let gestures: Vec<GestureTruth> = synth
        .gestures()
        .into_iter()
        .filter(|g| g.end_frame < n)
        .collect();
    if matches!(synth.cfg.motion, MotionSpec::Draw(_)) {
        write_gestures_csv(&dir.join("gestures.csv"), &gestures)?;
    }
    Ok(RecordingSummary {
        frames: n,
        gestures,
    })
}

fn describe(cfg: &SceneConfig) -> String {
    let body = match &cfg.body {
        BodySpec::Procedural(p) => format!("procedural-{:.2}m-{:.2}", p.height_m, p.build),
        BodySpec::MakeHuman { shape, .. } if shape.is_default() => "makehuman".into(),
        BodySpec::MakeHuman { shape, .. } => format!("makehuman[{}]", shape.label()),
    };
    let motion = match &cfg.motion {
        MotionSpec::Poses => "poses".to_string(),
        MotionSpec::Pose(p) => format!("pose:{}", p.name()),
        MotionSpec::Bvh(p) => format!(
            "bvh:{}",
            p.file_name()
                .map(|f| f.to_string_lossy())
                .unwrap_or_default()
        ),
        MotionSpec::Draw(d) => format!("draw:{}", d.symbols),
        MotionSpec::Rest => "rest".to_string(),
    };
    let mut out = format!("{body}/{motion}");
    for side in hand::SIDES {
        let h = cfg.hands.get(side);
        if let Some(p) = h.posture {
            out.push_str(&format!("/{}-hand:{}", side.name(), p.name()));
        }
        if let Some(p) = h.drawing {
            out.push_str(&format!("/{}-pen:{}", side.name(), p.name()));
        }
    }
    if let Posture::Seated { .. } = cfg.posture {
        out.push_str("/seated");
    }
    for p in &cfg.props {
        out.push_str(match p {
            Prop::Table(_) => "/table",
            Prop::Chair(_) => "/chair",
            Prop::Mug(_) => "/mug",
        });
    }
    out
}
