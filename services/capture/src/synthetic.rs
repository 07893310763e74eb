//! The built-in synthetic person (airglyph-synth), rendered live at the camera's rate.

use crate::source::{DepthSource, Frame, Pacing, SourceError, SourceOptions};
use airglyph_core::camera::Preset;
use airglyph_core::{Intrinsics, Skeleton};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::wire::SourceKind;
use airglyph_synth::{DrawSpec, MotionSpec, SceneConfig, Synthesizer};
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

/// The scene `synthetic:SCRIPT` renders: a Kinect v1 at 640×480, 30 fps. Public so
/// tools can know the ground truth (e.g. which symbol is drawn when) of what capture sends.
pub fn scene(script: Option<&str>, looping: bool) -> Result<SceneConfig, SourceError> {
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
    script: String,
    opts: SourceOptions,
    next: usize,
    start_ns: Option<u64>,
    last: Option<Skeleton>,
}

impl SyntheticSource {
    /// The scene `script` names (the moving person by default).
    pub fn open(script: Option<&str>, opts: &SourceOptions) -> Result<Self, SourceError> {
        let cfg = scene(script, opts.looping)?;
        let synth = Synthesizer::new(cfg).map_err(|e| SourceError::Fatal(e.to_string()))?;
        Ok(Self {
            synth,
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
