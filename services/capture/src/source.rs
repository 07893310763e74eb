//! The `DepthSource` trait and the `--source` syntax.

use airglyph_core::Intrinsics;
use airglyph_ipc::wire::SourceKind;
use std::path::PathBuf;
use std::str::FromStr;

/// One frame's metadata; its pixels went into the caller's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// When the frame entered the pipeline (CLOCK_MONOTONIC ns), or 0 to stamp it on send.
    pub capture_ns: u64,
    /// The source's own timestamp, e.g. a recording's `frames.csv` time.
    pub source_ns: u64,
}

/// Why a source could not deliver a frame.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The frame is unusable but the stream goes on (e.g. a corrupt PNG): skip and count it.
    #[error("frame skipped: {0}")]
    Skipped(String),
    /// The source cannot go on.
    #[error("{0}")]
    Fatal(String),
}

/// A producer of depth frames of a fixed size.
pub trait DepthSource {
    /// Camera model of every frame this source delivers.
    fn intrinsics(&self) -> Intrinsics;
    /// Nominal frame rate.
    fn fps(&self) -> f32;
    fn kind(&self) -> SourceKind;
    /// Where frames come from, for logs and `recording.toml`.
    fn describe(&self) -> String;
    /// Writes the next frame into `out` (`width × height` pixels, millimetres), blocking
    /// until it is due. `Ok(None)` at the end of a finite stream.
    fn next_frame(&mut self, out: &mut [u16]) -> Result<Option<Frame>, SourceError>;
    /// Ground truth of the last frame, for sources that know it (synthetic).
    fn last_truth(&self) -> Option<airglyph_core::Skeleton> {
        None
    }
}

/// How a finite source is paced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pacing {
    /// At the recorded times (or the nominal fps).
    #[default]
    Realtime,
    /// As fast as the consumer takes them.
    Fast,
}

/// Options that apply to every source.
#[derive(Debug, Clone, Default)]
pub struct SourceOptions {
    pub pacing: Pacing,
    /// Start again at the first frame at the end.
    pub looping: bool,
}

/// A `--source` argument.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    /// `recording:DIR`
    Recording(PathBuf),
    /// `synthetic[:SCRIPT]`
    Synthetic(Option<String>),
    /// `v4l2:/dev/videoN`
    V4l2(PathBuf),
    /// `openni2[:URI]`
    OpenNi2(Option<String>),
}

impl FromStr for SourceSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (kind, arg) = match s.split_once(':') {
            Some((k, a)) => (k, Some(a)),
            None => (s, None),
        };
        let nonempty = |a: Option<&str>| a.filter(|a| !a.is_empty()).map(str::to_owned);
        match kind {
            "recording" => nonempty(arg)
                .map(|a| SourceSpec::Recording(a.into()))
                .ok_or_else(|| "recording needs a directory: recording:DIR".to_owned()),
            "synthetic" => Ok(SourceSpec::Synthetic(nonempty(arg))),
            "v4l2" => nonempty(arg)
                .map(|a| SourceSpec::V4l2(a.into()))
                .ok_or_else(|| "v4l2 needs a device: v4l2:/dev/videoN".to_owned()),
            "openni2" => Ok(SourceSpec::OpenNi2(nonempty(arg))),
            other => Err(format!(
                "unknown source {other:?}: expected synthetic, recording:DIR, v4l2:/dev/videoN or openni2[:URI]"
            )),
        }
    }
}

impl std::fmt::Display for SourceSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SourceSpec::Recording(d) => write!(f, "recording:{}", d.display()),
            SourceSpec::Synthetic(None) => write!(f, "synthetic"),
            SourceSpec::Synthetic(Some(s)) => write!(f, "synthetic:{s}"),
            SourceSpec::V4l2(d) => write!(f, "v4l2:{}", d.display()),
            SourceSpec::OpenNi2(None) => write!(f, "openni2"),
            SourceSpec::OpenNi2(Some(u)) => write!(f, "openni2:{u}"),
        }
    }
}

/// Opens the source a spec names.
pub fn open(spec: &SourceSpec, opts: &SourceOptions) -> Result<Box<dyn DepthSource>, SourceError> {
    match spec {
        SourceSpec::Recording(dir) => Ok(Box::new(crate::recording::RecordingSource::open(
            dir, opts,
        )?)),
        SourceSpec::Synthetic(script) => Ok(Box::new(crate::synthetic::SyntheticSource::open(
            script.as_deref(),
            opts,
        )?)),
        SourceSpec::V4l2(_) => Err(SourceError::Fatal(
            "V4L2 support is not compiled in: rebuild airglyph-capture with --features v4l2".into(),
        )),
        SourceSpec::OpenNi2(_) => Err(SourceError::Fatal(
            "OpenNI2 support is not compiled in: rebuild airglyph-capture with --features openni2"
                .into(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_print_back() {
        for s in [
            "recording:/data/rec",
            "synthetic",
            "synthetic:draw:ABC",
            "v4l2:/dev/video2",
            "openni2",
            "openni2:Dummy",
        ] {
            assert_eq!(s.parse::<SourceSpec>().unwrap().to_string(), s);
        }
    }

    #[test]
    fn bad_specs_say_what_is_expected() {
        let err = "kinect".parse::<SourceSpec>().unwrap_err();
        assert!(
            err.contains("unknown source \"kinect\"") && err.contains("recording:DIR"),
            "{err}"
        );
        assert!("recording:"
            .parse::<SourceSpec>()
            .unwrap_err()
            .contains("recording:DIR"));
    }
}
