//! The `DepthSource` trait and the `--source` syntax.

use airglyph_core::camera::MAX_SIDE;
use airglyph_core::Intrinsics;
use airglyph_ipc::wire::SourceKind;
use std::path::PathBuf;
use std::str::FromStr;

/// The highest frame rate a camera option may ask for.
pub const MAX_FPS: u32 = 1000;

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
    /// Which kind of source it is, as the depth header carries it.
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
    /// How frames are paced: in real time, or as fast as they come.
    pub pacing: Pacing,
    /// Start again at the first frame at the end.
    pub looping: bool,
}

/// A `--source` argument.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    /// `recording:DIR`
    Recording(PathBuf),
    /// `synthetic[:SCRIPT]`: a motion (`draw:SYMBOLS`, `poses`, `pose:NAME`, a BVH
    /// file) or `posture:NAME` (a hand posture held; `synthetic::posture_scenes`).
    Synthetic(Option<String>),
    /// `v4l2:/dev/videoN[?OPTIONS]`
    V4l2(PathBuf, CameraOptions),
    /// `openni2[:URI][?OPTIONS]`: a device URI, `Dummy`, or a `.oni` file.
    OpenNi2(Option<String>, CameraOptions),
}

/// Camera settings after `?` in a `v4l2:` or `openni2:` source, `&`-separated:
/// `mode=640x480@30` (any part may be left out: `mode=@60`, `mode=848x480`),
/// `format=Z16|Y16|Y10B` (V4L2), `intrinsics=PRESET` or `intrinsics=fx,fy,cx,cy`,
/// `scale=0.1` (device depth unit in millimetres), `start=N` (a `.oni` plays from its
/// frame N: OpenNI2 cannot seek, so the file is read from the start and N frames skipped).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraOptions {
    /// Width asked for (`mode=WxH`).
    pub width: Option<u32>,
    /// Height asked for.
    pub height: Option<u32>,
    /// Frame rate asked for (`mode=@FPS`).
    pub fps: Option<u32>,
    /// Pixel format asked for (`format=`, V4L2).
    pub format: Option<crate::pixfmt::DepthFormat>,
    /// Intrinsics given (`intrinsics=`).
    pub intrinsics: Option<IntrinsicsChoice>,
    /// The device's depth unit in millimetres (`scale=`).
    pub scale: Option<f32>,
    /// The `.oni` frame to play from (`start=`).
    pub start: Option<u64>,
}

/// Where a camera's intrinsics come from when the user names them.
#[derive(Debug, Clone, PartialEq)]
pub enum IntrinsicsChoice {
    /// A known camera's intrinsics.
    Preset(airglyph_core::camera::Preset),
    /// fx, fy, cx, cy in pixels at the capture resolution.
    Explicit([f32; 4]),
}

impl CameraOptions {
    /// Whether no option was given.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// Intrinsics for a `width × height` stream when the user chose them (a preset is
    /// scaled to the stream's resolution).
    pub fn chosen_intrinsics(&self, width: u32, height: u32) -> Option<Intrinsics> {
        match self.intrinsics.as_ref()? {
            IntrinsicsChoice::Preset(p) => {
                let k = p.intrinsics();
                Some(if (k.width, k.height) == (width, height) {
                    k
                } else {
                    k.scaled_to(width, height)
                })
            }
            IntrinsicsChoice::Explicit([fx, fy, cx, cy]) => {
                Some(Intrinsics::new(width, height, *fx, *fy, *cx, *cy))
            }
        }
    }

    fn parse(text: &str) -> Result<Self, String> {
        let mut o = CameraOptions::default();
        for item in text.split('&').filter(|i| !i.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| format!("camera option {item:?} needs a value: KEY=VALUE"))?;
            match key {
                "mode" => {
                    let (size, fps) = match value.split_once('@') {
                        Some((s, f)) => (s, Some(f)),
                        None => (value, None),
                    };
                    let bad = || {
                        format!(
                            "mode={value}: expected WIDTHxHEIGHT@FPS, e.g. 640x480@30, with sides of \
                             1-{MAX_SIDE} pixels and 1-{MAX_FPS} frames a second"
                        )
                    };
                    // Bounded here: the frame size is what capture allocates in shared
                    // memory, before any camera is asked.
                    let side = |s: &str| s.parse().ok().filter(|n| (1..=MAX_SIDE).contains(n));
                    if !size.is_empty() {
                        let (w, h) = size.split_once('x').ok_or_else(bad)?;
                        o.width = Some(side(w).ok_or_else(bad)?);
                        o.height = Some(side(h).ok_or_else(bad)?);
                    }
                    if let Some(f) = fps {
                        o.fps = Some(
                            f.parse()
                                .ok()
                                .filter(|f| (1..=MAX_FPS).contains(f))
                                .ok_or_else(bad)?,
                        );
                    }
                }
                "format" => {
                    o.format = Some(crate::pixfmt::DepthFormat::from_name(value).ok_or_else(|| {
                        format!("format={value}: supported depth formats are Z16, Y16, Y10B")
                    })?)
                }
                "intrinsics" => {
                    o.intrinsics = Some(
                        if let Some(p) = airglyph_core::camera::Preset::from_name(value) {
                            IntrinsicsChoice::Preset(p)
                        } else {
                            let v: Vec<f32> = value
                                .split(',')
                                .map(|x| x.trim().parse::<f32>())
                                .collect::<Result<_, _>>()
                                .ok()
                                .filter(|v: &Vec<f32>| v.len() == 4 && v.iter().all(|x| x.is_finite()))
                                .ok_or_else(|| {
                                    let names: Vec<_> = airglyph_core::camera::Preset::ALL
                                        .iter()
                                        .map(|p| p.name())
                                        .collect();
                                    format!(
                                        "intrinsics={value}: expected fx,fy,cx,cy or a preset ({})",
                                        names.join(", ")
                                    )
                                })?;
                            IntrinsicsChoice::Explicit([v[0], v[1], v[2], v[3]])
                        },
                    )
                }
                "start" => {
                    o.start = Some(value.parse().map_err(|_| {
                        format!("start={value}: expected a frame number (0 is the first)")
                    })?)
                }
                "scale" => {
                    o.scale = Some(
                        value
                            .parse::<f32>()
                            .ok()
                            .filter(|s| s.is_finite() && *s > 0.0)
                            .ok_or_else(|| {
                                format!("scale={value}: expected a positive number (millimetres per device unit)")
                            })?,
                    )
                }
                other => {
                    return Err(format!(
                        "unknown camera option {other:?}: expected mode, format, intrinsics, scale or start"
                    ))
                }
            }
        }
        Ok(o)
    }
}

impl std::fmt::Display for CameraOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut items = Vec::new();
        if self.width.is_some() || self.fps.is_some() {
            let mut m = String::from("mode=");
            if let (Some(w), Some(h)) = (self.width, self.height) {
                m.push_str(&format!("{w}x{h}"));
            }
            if let Some(fps) = self.fps {
                m.push_str(&format!("@{fps}"));
            }
            items.push(m);
        }
        if let Some(fmt) = self.format {
            items.push(format!("format={}", fmt.name()));
        }
        match &self.intrinsics {
            Some(IntrinsicsChoice::Preset(p)) => items.push(format!("intrinsics={}", p.name())),
            Some(IntrinsicsChoice::Explicit([fx, fy, cx, cy])) => {
                items.push(format!("intrinsics={fx},{fy},{cx},{cy}"))
            }
            None => {}
        }
        if let Some(s) = self.scale {
            items.push(format!("scale={s}"));
        }
        if let Some(s) = self.start {
            items.push(format!("start={s}"));
        }
        if !items.is_empty() {
            write!(f, "?{}", items.join("&"))?;
        }
        Ok(())
    }
}

/// Splits `ARG?OPTIONS`.
fn with_options(arg: Option<&str>) -> Result<(Option<&str>, CameraOptions), String> {
    match arg.and_then(|a| a.split_once('?')) {
        Some((a, o)) => Ok((Some(a), CameraOptions::parse(o)?)),
        None => Ok((arg, CameraOptions::default())),
    }
}

impl FromStr for SourceSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        // `KIND:ARG`, or `KIND?OPTIONS` for a device named by nothing but its options
        // (`openni2?mode=640x480@30`: the first OpenNI2 device).
        let (kind, arg) = match s.split_once(':') {
            Some((k, a)) if !k.contains('?') => (k, Some(a)),
            _ => match s.split_once('?') {
                Some((k, _)) if k == "recording" || k == "synthetic" => {
                    return Err(format!("{k} takes no camera options (after `?`)"))
                }
                Some((k, _)) => (k, Some(&s[k.len()..])),
                None => (s, None),
            },
        };
        let nonempty = |a: Option<&str>| a.filter(|a| !a.is_empty()).map(str::to_owned);
        match kind {
            "recording" => nonempty(arg)
                .map(|a| SourceSpec::Recording(a.into()))
                .ok_or_else(|| "recording needs a directory: recording:DIR".to_owned()),
            "synthetic" => Ok(SourceSpec::Synthetic(nonempty(arg))),
            "v4l2" => {
                let (arg, opts) = with_options(arg)?;
                nonempty(arg)
                    .map(|a| SourceSpec::V4l2(a.into(), opts))
                    .ok_or_else(|| "v4l2 needs a device: v4l2:/dev/videoN".to_owned())
            }
            "openni2" => {
                let (arg, opts) = with_options(arg)?;
                Ok(SourceSpec::OpenNi2(nonempty(arg), opts))
            }
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
            SourceSpec::V4l2(d, o) => write!(f, "v4l2:{}{o}", d.display()),
            SourceSpec::OpenNi2(None, o) => write!(f, "openni2{o}"),
            SourceSpec::OpenNi2(Some(u), o) => write!(f, "openni2:{u}{o}"),
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
        #[cfg(feature = "v4l2")]
        SourceSpec::V4l2(dev, cam) => Ok(Box::new(crate::v4l2::V4l2Source::open(dev, cam)?)),
        #[cfg(not(feature = "v4l2"))]
        SourceSpec::V4l2(..) => Err(SourceError::Fatal(
            "V4L2 support is not compiled in: rebuild airglyph-capture with --features v4l2".into(),
        )),
        #[cfg(feature = "openni2")]
        SourceSpec::OpenNi2(uri, cam) => Ok(Box::new(crate::openni2::OpenNi2Source::open(
            uri.as_deref(),
            cam,
            opts,
        )?)),
        #[cfg(not(feature = "openni2"))]
        SourceSpec::OpenNi2(..) => Err(SourceError::Fatal(
            "OpenNI2 support is not compiled in: rebuild airglyph-capture with --features openni2"
                .into(),
        )),
    }
}

/// Opens an `openni2[:URI]` source that also records its depth stream to `oni` through
/// OpenNI2's recorder for as long as it lives (`airglyph record --oni FILE`).
pub fn open_recording_oni(
    spec: &SourceSpec,
    opts: &SourceOptions,
    oni: &std::path::Path,
) -> Result<Box<dyn DepthSource>, SourceError> {
    #[cfg(not(feature = "openni2"))]
    let _ = opts;
    match spec {
        #[cfg(feature = "openni2")]
        SourceSpec::OpenNi2(uri, cam) => Ok(Box::new(
            crate::openni2::OpenNi2Source::open_recording(uri.as_deref(), cam, opts, oni)?,
        )),
        #[cfg(not(feature = "openni2"))]
        SourceSpec::OpenNi2(..) => Err(SourceError::Fatal(format!(
            "{}: recording .oni needs OpenNI2, which is not compiled in: rebuild with --features openni2",
            oni.display()
        ))),
        other => Err(SourceError::Fatal(format!(
            "{}: only openni2 sources can be recorded to .oni (OpenNI2's recorder), not {other}",
            oni.display()
        ))),
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
            "openni2:/data/a.oni?mode=320x240@30&start=12",
            "openni2?mode=640x480@30",
            "v4l2:/dev/video0?mode=848x480@30&format=Z16&intrinsics=realsense-d435&scale=0.1",
            "v4l2:/dev/video0?mode=@60&intrinsics=380,381,320,240",
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
        assert!("recording?mode=@30"
            .parse::<SourceSpec>()
            .unwrap_err()
            .contains("no camera options"));
        assert!("v4l2?mode=@30"
            .parse::<SourceSpec>()
            .unwrap_err()
            .contains("v4l2:/dev/videoN"));
        // Both ways of naming the first OpenNI2 device with options are one source.
        assert_eq!(
            "openni2:?mode=@30".parse::<SourceSpec>(),
            "openni2?mode=@30".parse::<SourceSpec>()
        );
    }

    #[test]
    fn camera_options_parse_and_bad_ones_say_what_is_expected() {
        let SourceSpec::V4l2(dev, o) =
            "v4l2:/dev/video4?mode=640x480@30&intrinsics=kinect-v1-640x480"
                .parse::<SourceSpec>()
                .unwrap()
        else {
            panic!("v4l2 spec")
        };
        assert_eq!(dev, PathBuf::from("/dev/video4"));
        assert_eq!((o.width, o.height, o.fps), (Some(640), Some(480), Some(30)));
        let k = o.chosen_intrinsics(320, 240).unwrap();
        assert!(
            (k.fx - 287.9).abs() < 0.01,
            "a preset scales with the mode: {k:?}"
        );
        for (spec, want) in [
            ("v4l2:/dev/video0?mode=640-480", "WIDTHxHEIGHT@FPS"),
            ("v4l2:/dev/video0?mode=0x480", "WIDTHxHEIGHT@FPS"),
            ("v4l2:/dev/video0?mode=100000x480", "1-8192 pixels"),
            ("v4l2:/dev/video0?mode=640x480@100000", "1-1000 frames"),
            ("v4l2:/dev/video0?format=MJPG", "Z16, Y16, Y10B"),
            ("v4l2:/dev/video0?intrinsics=1,2", "realsense-d435"),
            ("v4l2:/dev/video0?scale=-1", "positive"),
            ("openni2:Dummy?fps=30", "unknown camera option \"fps\""),
            ("openni2:Dummy?mode", "KEY=VALUE"),
        ] {
            let err = spec.parse::<SourceSpec>().unwrap_err();
            assert!(err.contains(want), "{spec}: {err}");
        }
    }
}
