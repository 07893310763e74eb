//! The built-in synthetic person (airglyph-synth), rendered live at the camera's rate.

use crate::source::{DepthSource, Frame, Pacing, SourceError, SourceOptions};
use airglyph_core::camera::Preset;
use airglyph_core::{Intrinsics, Skeleton};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::wire::SourceKind;
use airglyph_synth::{DrawSpec, HandPosture, MotionSpec, SceneConfig, ScriptedPose, Synthesizer};
use std::time::Duration;

/// What the demo person draws when no script is given: every built-in symbol, forever.
pub const DEMO_SYMBOLS: &str = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ";

/// The motion of `synthetic:SCRIPT` (see [`MotionSpec::parse`]); no script: the person
/// draws every symbol, forever.
pub fn motion(script: Option<&str>, repeat: bool) -> Result<MotionSpec, SourceError> {
    match script {
        None => Ok(MotionSpec::Draw(DrawSpec {
            symbols: DEMO_SYMBOLS.into(),
            samples: None,
            repeat: true,
            rest: None,
        })),
        Some(s) => MotionSpec::parse(s, None, repeat)
            .map_err(|e| SourceError::Fatal(format!("synthetic: {e}"))),
    }
}

/// The script of a person holding a hand posture: `synthetic:posture:NAME`.
pub const POSTURE_SCRIPT: &str = "posture:";

/// The palm's distances from the camera a posture session visits, metres.
const POSTURE_DISTANCES_M: [f32; 4] = [1.0, 1.5, 2.0, 2.5];
/// The hand's turns at the wrist a posture session shows, (roll, pitch) degrees on top
/// of palm-to-camera: the turns the built-in posture model was trained on, but edge-on.
const POSTURE_TURNS_DEG: [(f32, f32); 6] = [
    (0.0, 0.0),
    (45.0, 0.0),
    (-45.0, 0.0),
    (180.0, 0.0),
    (0.0, 40.0),
    (0.0, -40.0),
];
/// Frames each distance and turn of a posture session is held (a third of a second).
const POSTURE_HOLD_FRAMES: usize = 10;

/// The posture `synthetic:posture:NAME` names, if the script is one.
fn held_posture(script: Option<&str>) -> Option<Result<HandPosture, SourceError>> {
    let name = script?.strip_prefix(POSTURE_SCRIPT)?;
    Some(HandPosture::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = HandPosture::ALL.iter().map(|p| p.name()).collect();
        SourceError::Fatal(format!(
            "synthetic: {name:?} is not a hand posture: expected posture:NAME, NAME one of {}",
            names.join(", ")
        ))
    }))
}

/// The scenes of `synthetic:posture:NAME`, in the order they are shown, each for
/// [`POSTURE_HOLD_FRAMES`] frames, then again: the person raises the right hand beside
/// the head (the wave) holding `posture`, the palm turned to the camera and then by
/// each turn in [`POSTURE_TURNS_DEG`]; for each turn the palm is 1, 1.5, 2 and 2.5 m
/// away, the sensor model on every other scene. The camera frames the upper body as
/// one on a desk would.
pub fn posture_scenes(posture: HandPosture) -> Result<Vec<SceneConfig>, SourceError> {
    let fatal = |e: airglyph_synth::SynthError| SourceError::Fatal(format!("synthetic: {e}"));
    let truth = |cfg: &SceneConfig| -> Result<_, SourceError> {
        Ok(Synthesizer::new(cfg.clone()).map_err(fatal)?.render(0).1)
    };
    // Each distance calibrated once: the roll that turns the palm to the camera, and
    // where the person stands for the palm (not the body) to be at the distance.
    let mut facing = Vec::new();
    for &d in &POSTURE_DISTANCES_M {
        let mut cfg = SceneConfig {
            motion: MotionSpec::Pose(ScriptedPose::Wave),
            intrinsics: Preset::KinectV1Vga.intrinsics(),
            fps: 30.0,
            ..SceneConfig::default()
        };
        cfg.placement.distance_m = d;
        cfg = cfg.framing_upper_body().map_err(fatal)?;
        cfg.hands.right.posture = Some(posture);
        let h = truth(&cfg)?.hands.right;
        cfg.hands.right.roll_deg = (-h.thumb_side.z).atan2(-h.palm_normal.z).to_degrees();
        for _ in 0..2 {
            cfg.placement.distance_m += d - truth(&cfg)?.hands.right.palm_centre.z;
        }
        facing.push(cfg);
    }
    let mut scenes = Vec::new();
    for &(roll, pitch) in &POSTURE_TURNS_DEG {
        for base in &facing {
            let mut cfg = base.clone();
            cfg.hands.right.roll_deg += roll;
            cfg.hands.right.pitch_deg += pitch;
            cfg.sensor_noise = scenes.len() % 2 == 1;
            cfg.seed = scenes.len() as u64;
            scenes.push(cfg);
        }
    }
    Ok(scenes)
}

/// The scene `synthetic:SCRIPT` renders: a Kinect v1 at 640×480, 30 fps. Public so
/// tools can know the ground truth (e.g. which symbol is drawn when) of what capture sends.
/// For `posture:NAME`, the first of its scenes ([`posture_scenes`]).
pub fn scene(script: Option<&str>, looping: bool) -> Result<SceneConfig, SourceError> {
    if let Some(posture) = held_posture(script) {
        let mut scenes = posture_scenes(posture?)?;
        return Ok(scenes.swap_remove(0));
    }
    Ok(SceneConfig {
        motion: motion(script, looping)?,
        intrinsics: Preset::KinectV1Vga.intrinsics(),
        fps: 30.0,
        ..SceneConfig::default()
    })
}

/// The synthetic person rendered live (`synthetic[:…]`), with its exact skeleton.
pub struct SyntheticSource {
    synth: Synthesizer,
    /// A posture session's scenes, shown in turn ([`posture_scenes`]); empty for the
    /// other scripts, whose one scene `synth` renders.
    scenes: Vec<SceneConfig>,
    /// Which of `scenes` `synth` renders.
    showing: usize,
    script: String,
    opts: SourceOptions,
    next: usize,
    start_ns: Option<u64>,
    last: Option<Skeleton>,
}

impl SyntheticSource {
    /// The scene `script` names (the moving person by default).
    pub fn open(script: Option<&str>, opts: &SourceOptions) -> Result<Self, SourceError> {
        let scenes = match held_posture(script) {
            Some(posture) => posture_scenes(posture?)?,
            None => Vec::new(),
        };
        let cfg = match scenes.first() {
            Some(first) => first.clone(),
            None => scene(script, opts.looping)?,
        };
        let synth = Synthesizer::new(cfg).map_err(|e| SourceError::Fatal(e.to_string()))?;
        Ok(Self {
            synth,
            scenes,
            showing: 0,
            script: script.unwrap_or("").to_owned(),
            opts: opts.clone(),
            next: 0,
            start_ns: None,
            last: None,
        })
    }
}

impl DepthSource for SyntheticSource {
    fn intrinsics(&self) -> Intrinsics {
        self.synth.intrinsics()
    }

    fn fps(&self) -> f32 {
        self.synth.fps()
    }

    fn kind(&self) -> SourceKind {
        SourceKind::Synthetic
    }

    fn describe(&self) -> String {
        if self.script.is_empty() {
            "synthetic".into()
        } else {
            format!("synthetic:{}", self.script)
        }
    }

    fn next_frame(&mut self, out: &mut [u16]) -> Result<Option<Frame>, SourceError> {
        if self.synth.len().is_some_and(|n| self.next >= n) {
            if !self.opts.looping {
                return Ok(None);
            }
            self.next = 0;
            self.start_ns = None;
        }
        let index = self.next;
        self.next += 1;
        if !self.scenes.is_empty() {
            let due = (index / POSTURE_HOLD_FRAMES) % self.scenes.len();
            if due != self.showing {
                self.synth = Synthesizer::new(self.scenes[due].clone())
                    .map_err(|e| SourceError::Fatal(e.to_string()))?;
                self.showing = due;
            }
        }
        if self.opts.pacing == Pacing::Realtime {
            let start = *self.start_ns.get_or_insert_with(monotonic_ns);
            let due = start + (index as f64 * 1e9 / self.synth.fps() as f64) as u64;
            let now = monotonic_ns();
            if due > now {
                std::thread::sleep(Duration::from_nanos(due - now));
            }
        }
        // The virtual shutter closes now; rendering is the sensor's readout, part of
        // capture's latency.
        let capture_ns = monotonic_ns();
        let truth = self
            .synth
            .render_into(index, out)
            .map_err(|e| SourceError::Fatal(e.to_string()))?;
        self.last = Some(truth.skeleton);
        Ok(Some(Frame {
            capture_ns,
            source_ns: truth.capture_ns,
        }))
    }

    fn last_truth(&self) -> Option<Skeleton> {
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::Pacing;
    use airglyph_core::Joint;

    #[test]
    fn a_posture_session_holds_the_posture_at_each_distance_and_turn() {
        let scenes = posture_scenes(HandPosture::Point).unwrap();
        assert_eq!(
            scenes.len(),
            POSTURE_TURNS_DEG.len() * POSTURE_DISTANCES_M.len()
        );
        for (i, cfg) in scenes.iter().enumerate() {
            let hand = Synthesizer::new(cfg.clone())
                .unwrap()
                .render(0)
                .1
                .hands
                .right;
            assert_eq!(hand.posture, Some(HandPosture::Point), "scene {i}");
            let d = POSTURE_DISTANCES_M[i % POSTURE_DISTANCES_M.len()];
            let z = hand.palm_centre.z;
            assert!((z - d).abs() < 0.03, "scene {i}: palm at {z} m, not {d}");
            // The first turn is palm to the camera (the camera looks along +z).
            if i < POSTURE_DISTANCES_M.len() {
                assert!(
                    hand.palm_normal.z < -0.9,
                    "scene {i}: {:?}",
                    hand.palm_normal
                );
            }
        }
    }

    #[test]
    fn the_posture_source_moves_from_scene_to_scene() {
        let opts = SourceOptions {
            pacing: Pacing::Fast,
            looping: false,
        };
        let mut src = SyntheticSource::open(Some("posture:v"), &opts).unwrap();
        assert_eq!(src.describe(), "synthetic:posture:v");
        let k = src.intrinsics();
        let mut out = vec![0u16; (k.width * k.height) as usize];
        let mut hand_z = Vec::new();
        for _ in 0..POSTURE_HOLD_FRAMES * POSTURE_DISTANCES_M.len() {
            assert!(src.next_frame(&mut out).unwrap().is_some(), "endless");
            hand_z.push(src.last_truth().unwrap().get(Joint::RightHand).z);
        }
        // Each distance held for its frames, then the next, farther one.
        for (i, chunk) in hand_z.chunks(POSTURE_HOLD_FRAMES).enumerate() {
            let d = POSTURE_DISTANCES_M[i];
            assert!(
                chunk.iter().all(|z| (z - d).abs() < 0.1),
                "distance {d}: {chunk:?}"
            );
        }
    }

    #[test]
    fn an_unknown_posture_is_refused_with_the_names() {
        let opts = SourceOptions::default();
        let Err(e) = SyntheticSource::open(Some("posture:peace"), &opts) else {
            panic!("opened an unknown posture")
        };
        let msg = e.to_string();
        assert!(
            msg.contains("\"peace\" is not a hand posture") && msg.contains("thumb-up"),
            "{msg}"
        );
    }
}
