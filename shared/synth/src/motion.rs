//! Motion sources: what drives the canonical skeleton frame by frame.

use crate::canon::Pose;
use crate::canon::TposeSkeleton;
use crate::error::SynthError;
use crate::poses::{Posture, ScriptedPose};
use airglyph_core::gestures::GestureTruth;
use std::path::PathBuf;

/// What the person does.
#[derive(Debug, Clone, PartialEq)]
pub enum MotionSpec {
    /// Cycles through every [`ScriptedPose`] (1 s each, 0.5 s blends, with a slow
    /// seeded sway of the body); endless.
    Poses,
    /// Holds one scripted pose; endless.
    Pose(ScriptedPose),
    /// Plays a BVH motion-capture clip, resampled to the scene's fps; as long as the clip.
    Bvh(PathBuf),
    /// Air-draws symbols with the right hand.
    Draw(DrawSpec),
    /// Arms at rest, as between gestures: moves between the rest poses the posture and
    /// the props allow ([`ScriptedPose::AT_REST`]: hanging, on the thighs, in the lap,
    /// crossed, on a table when there is one), holding each for a few seconds; endless.
    Rest,
}

impl MotionSpec {
    /// Parses the command-line form: `poses`, `rest`, `pose:NAME`, `draw:SYMBOLS` or a
    /// BVH file.
    /// `samples` gives air-drawn symbols their shapes from a trajectory JSONL; `repeat`
    /// makes the drawing endless.
    pub fn parse(spec: &str, samples: Option<PathBuf>, repeat: bool) -> Result<Self, SynthError> {
        let bad = |m: String| SynthError::Config(format!("motion {spec:?}: {m}"));
        if spec == "poses" {
            return Ok(MotionSpec::Poses);
        }
        if spec == "rest" {
            return Ok(MotionSpec::Rest);
        }
        if let Some(name) = spec.strip_prefix("pose:") {
            return ScriptedPose::from_name(name)
                .map(MotionSpec::Pose)
                .ok_or_else(|| {
                    let names: Vec<_> = ScriptedPose::ALL.iter().map(|p| p.name()).collect();
                    bad(format!("known poses are {}", names.join(", ")))
                });
        }
        if let Some(symbols) = spec.strip_prefix("draw:") {
            if symbols.is_empty() {
                return Err(bad("draw: needs symbols, e.g. draw:0123ABC".into()));
            }
            return Ok(MotionSpec::Draw(DrawSpec {
                symbols: symbols.into(),
                samples,
                repeat,
                rest: None,
            }));
        }
        let path = PathBuf::from(spec);
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("bvh"))
            || path.is_file()
        {
            return Ok(MotionSpec::Bvh(path));
        }
        Err(bad(
            "expected poses, rest, pose:NAME, draw:SYMBOLS or a .bvh file".into(),
        ))
    }
}

/// Air-drawing: the right hand traces each symbol on a plane in front of the body, with
/// idle and random non-gesture movement between symbols.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawSpec {
    /// The symbols to draw, in order (0–9, A–Z with the built-in templates; any label
    /// present in `samples`): one a character, or names separated by commas, which may
    /// be gestures of the 3-D vocabulary (`push,circle-up,7`; [`crate::shapes3d`]).
    pub symbols: String,
    /// A trajectory JSONL file (docs/architecture.md, "Trajectory JSONL") to take the
    /// symbols' shapes from instead of the built-in templates.
    pub samples: Option<PathBuf>,
    /// Starts again after the last symbol: endless (the live demo).
    pub repeat: bool,
    /// Where the arms rest between symbols; `None`: hanging when standing, on the table
    /// or else on the thighs when seated.
    pub rest: Option<ScriptedPose>,
}

/// Where the motion happens: what the person's posture and surroundings give the arms
/// to rest on.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Setting {
    pub posture: Posture,
    /// The top of the table in front of the person, metres above the floor, if any.
    pub table_m: Option<f32>,
}

impl Setting {
    /// The rest poses that fit: no hands on a table that is not there.
    fn rest_poses(self) -> Vec<ScriptedPose> {
        ScriptedPose::AT_REST
            .into_iter()
            .filter(|p| *p != ScriptedPose::HandsOnTable || self.table_m.is_some())
            .filter(|p| *p != ScriptedPose::Neutral || self.posture == Posture::Standing)
            .collect()
    }

    /// Where arms rest between symbols unless told.
    pub(crate) fn default_rest(self) -> ScriptedPose {
        match (self.posture, self.table_m) {
            (Posture::Standing, _) => ScriptedPose::Neutral,
            (Posture::Seated { .. }, Some(_)) => ScriptedPose::HandsOnTable,
            (Posture::Seated { .. }, None) => ScriptedPose::HandsOnThighs,
        }
    }
}

/// Standing still is never still: a slow seeded sway of the whole body (a few degrees
/// of turn, a centimetre or two of weight shift) over endless and air-drawing motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sway {
    phase: [f32; 3],
    period_s: [f32; 3],
    fps: f32,
}

impl Sway {
    pub(crate) fn new(seed: u64, fps: f32) -> Self {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5157_4159);
        Self {
            phase: [0.0; 3].map(|_| rng.gen_range(0.0..std::f32::consts::TAU)),
            period_s: [
                rng.gen_range(4.0..7.0),
                rng.gen_range(5.0..9.0),
                rng.gen_range(3.0..6.0),
            ],
            fps,
        }
    }

    pub(crate) fn apply(&self, p: &mut Pose, frame: usize) {
        let t = frame as f32 / self.fps;
        let w = |i: usize| (std::f32::consts::TAU * t / self.period_s[i] + self.phase[i]).sin();
        let turn = 2.5f32.to_radians() * w(0);
        p.root.x += 0.015 * w(1);
        p.root.z += 0.01 * w(2);
        p.rotate_all(crate::poses::yaw(turn));
    }
}

pub(crate) enum Motion {
    Static(Box<Pose>),
    Cycle {
        poses: Vec<Pose>,
        hold: usize,
        blend: usize,
        sway: Sway,
    },
    Clip(Vec<Pose>),
    Draw(Box<crate::draw::Drawing>),
}

impl Motion {
    pub(crate) fn new(
        spec: &MotionSpec,
        sk: &TposeSkeleton,
        setting: Setting,
        fps: f32,
        seed: u64,
    ) -> Result<Motion, SynthError> {
        let posture = setting.posture;
        Ok(match spec {
            MotionSpec::Pose(p) => Motion::Static(Box::new(p.pose_in(sk, posture))),
            MotionSpec::Poses => Motion::Cycle {
                poses: ScriptedPose::HARD_CASES
                    .iter()
                    .map(|p| p.pose_in(sk, posture))
                    .collect(),
                hold: (fps * 1.0).round().max(1.0) as usize,
                blend: (fps * 0.5).round().max(1.0) as usize,
                sway: Sway::new(seed, fps),
            },
            MotionSpec::Rest => {
                use rand::{Rng, SeedableRng};
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x8E57);
                let choice = setting.rest_poses();
                let mut poses: Vec<Pose> = Vec::new();
                let mut last = None;
                while poses.len() < 32 {
                    let k = rng.gen_range(0..choice.len());
                    if Some(k) != last || choice.len() == 1 {
                        poses.push(choice[k].pose_in(sk, posture));
                        last = Some(k);
                    }
                }
                Motion::Cycle {
                    poses,
                    hold: (fps * 2.5).round().max(1.0) as usize,
                    blend: (fps * 1.0).round().max(1.0) as usize,
                    sway: Sway::new(seed, fps),
                }
            }
            MotionSpec::Bvh(path) => {
                let clip = crate::bvh::BvhClip::load(path)?;
                let mut poses = clip.retarget(sk, fps);
                for p in &mut poses {
                    posture.apply(sk, p);
                }
                Motion::Clip(poses)
            }
            MotionSpec::Draw(d) => Motion::Draw(Box::new(crate::draw::Drawing::new(
                d, sk, setting, fps, seed,
            )?)),
        })
    }

    pub(crate) fn len(&self) -> Option<usize> {
        match self {
            Motion::Static(_) | Motion::Cycle { .. } => None,
            Motion::Clip(c) => Some(c.len()),
            Motion::Draw(d) => d.len(),
        }
    }

    pub(crate) fn pose(&self, frame: usize) -> Pose {
        match self {
            Motion::Static(p) => **p,
            Motion::Cycle {
                poses,
                hold,
                blend,
                sway,
            } => {
                let period = hold + blend;
                let i = (frame / period) % poses.len();
                let t = frame % period;
                let mut p = if t < *hold {
                    poses[i]
                } else {
                    let s = (t - hold) as f32 / *blend as f32;
                    let s = s * s * (3.0 - 2.0 * s);
                    poses[i].lerp(&poses[(i + 1) % poses.len()], s)
                };
                sway.apply(&mut p, frame);
                p
            }
            Motion::Clip(c) => c[frame.min(c.len().saturating_sub(1))],
            Motion::Draw(d) => d.pose(frame),
        }
    }

    pub(crate) fn gesture(&self, frame: usize) -> Option<GestureTruth> {
        match self {
            Motion::Draw(d) => d.gesture(frame),
            _ => None,
        }
    }

    /// Every gesture of a finite motion, in order.
    pub(crate) fn gestures(&self) -> Vec<GestureTruth> {
        match self {
            Motion::Draw(d) => d.gestures(),
            _ => Vec::new(),
        }
    }
}
