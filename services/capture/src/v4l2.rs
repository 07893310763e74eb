//! V4L2 depth cameras (crate v4l): RealSense and other UVC depth cameras (Z16, Y16) and
//! the Kinect v1 through the gspca `kinect` driver (Y10B). V4L2 carries no intrinsics:
//! they come from the source's `intrinsics=` option or from a known-device preset.

use crate::pixfmt::{to_millimetres, DepthFormat, Layout};
use crate::source::{CameraOptions, DepthSource, Frame, SourceError};
use airglyph_core::camera::Preset;
use airglyph_core::Intrinsics;
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::wire::SourceKind;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;
use v4l::buffer::Type;
use v4l::framesize::FrameSizeEnum;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, FourCC};

/// How long a device may stay silent before `next_frame` reports it.
const FRAME_TIMEOUT: Duration = Duration::from_secs(2);

fn fatal(msg: impl Into<String>) -> SourceError {
    SourceError::Fatal(msg.into())
}

/// One depth format of a device with its sizes and rates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct V4l2Mode {
    /// The pixel format.
    pub format: DepthFormat,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frame rates (frames per second) the driver lists for this size.
    pub fps: Vec<f32>,
}

/// A V4L2 device as `airglyph devices` lists it.
#[derive(Debug, Clone, Serialize)]
pub struct V4l2Listing {
    /// The device node.
    pub path: PathBuf,
    /// The card's name, as the driver reports it.
    pub card: String,
    /// The driver's name.
    pub driver: String,
    /// Its depth formats with their sizes and rates.
    pub depth_modes: Vec<V4l2Mode>,
    /// Four-character codes of its other (non-depth) formats.
    pub other_formats: Vec<String>,
}

/// The `/dev/video*` nodes, sorted.
pub fn device_nodes() -> Vec<PathBuf> {
    let mut nodes: Vec<PathBuf> = std::fs::read_dir("/dev")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().starts_with("video"))
                .map(|e| e.path())
                .collect()
        })
        .unwrap_or_default();
    nodes.sort();
    nodes
}

/// Every V4L2 capture device with its depth modes (devices that cannot be opened are
/// skipped with a log line).
pub fn list_devices() -> Vec<V4l2Listing> {
    let mut out = Vec::new();
    for path in device_nodes() {
        match guarded(&path, || describe(&path)) {
            Ok(l) => out.push(l),
            Err(e) => tracing::debug!(device = %path.display(), "{e}"),
        }
    }
    out
}

/// Runs `f`, turning a panic inside the v4l crate (it unwraps driver strings as UTF-8)
/// into an error about that device.
fn guarded<T>(path: &Path, f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|_| {
        Err(format!(
            "{}: the driver returned data the v4l crate cannot read",
            path.display()
        ))
    })
}

fn fourcc_text(f: &FourCC) -> String {
    f.repr
        .iter()
        .map(|&c| if c.is_ascii_graphic() { c as char } else { ' ' })
        .collect::<String>()
        .trim_end()
        .to_owned()
}

fn describe(path: &Path) -> Result<V4l2Listing, String> {
    let dev = Device::with_path(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let caps = dev
        .query_caps()
        .map_err(|e| format!("{}: not a V4L2 device: {e}", path.display()))?;
    let formats = dev.enum_formats().unwrap_or_default();
    let mut depth_modes = Vec::new();
    let mut other_formats = Vec::new();
    for f in &formats {
        match DepthFormat::from_fourcc(&f.fourcc.repr) {
            Some(df) => depth_modes.extend(modes_of(&dev, df)),
            None => other_formats.push(fourcc_text(&f.fourcc)),
        }
    }
    Ok(V4l2Listing {
        path: path.to_owned(),
        card: caps.card,
        driver: caps.driver,
        depth_modes,
        other_formats,
    })
}

fn modes_of(dev: &Device, format: DepthFormat) -> Vec<V4l2Mode> {
    let fourcc = FourCC::new(&format.fourcc());
    let mut sizes = Vec::new();
    for fs in dev.enum_framesizes(fourcc).unwrap_or_default() {
        match fs.size {
            FrameSizeEnum::Discrete(d) => sizes.push((d.width, d.height)),
            // Continuous ranges would list thousands of sizes: name the ends.
            FrameSizeEnum::Stepwise(s) => {
                sizes.push((s.min_width, s.min_height));
                sizes.push((s.max_width, s.max_height));
            }
        }
    }
    sizes
        .into_iter()
        .map(|(width, height)| {
            let fps = dev
                .enum_frameintervals(fourcc, width, height)
                .unwrap_or_default()
                .into_iter()
                .filter_map(|fi| match fi.interval {
                    v4l::frameinterval::FrameIntervalEnum::Discrete(fr) if fr.numerator > 0 => {
                        Some(fr.denominator as f32 / fr.numerator as f32)
                    }
                    _ => None,
                })
                .collect();
            V4l2Mode {
                format,
                width,
                height,
                fps,
            }
        })
        .collect()
}

/// The depth format to stream, given the fourccs a device offers.
pub fn choose_format(
    device: &str,
    offered: &[[u8; 4]],
    want: Option<DepthFormat>,
) -> Result<DepthFormat, String> {
    let mut depth: Vec<DepthFormat> = offered
        .iter()
        .filter_map(DepthFormat::from_fourcc)
        .collect();
    depth.sort_by_key(|f| f.rank());
    let names = |v: &[[u8; 4]]| {
        if v.is_empty() {
            "no formats at all".to_owned()
        } else {
            v.iter()
                .map(|c| String::from_utf8_lossy(c).trim_end().to_owned())
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    if depth.is_empty() {
        return Err(format!(
            "{device} has no depth format (it offers {}); airglyph reads Z16, Y16 and the \
             Kinect's Y10B (gspca kinect with depth_mode=1): is this the camera's depth node? \
             `airglyph devices` lists them",
            names(offered)
        ));
    }
    match want {
        None => Ok(depth[0]),
        Some(w) if depth.contains(&w) => Ok(w),
        Some(w) => Err(format!(
            "{device} does not offer format {} (its depth formats: {})",
            w.name(),
            depth
                .iter()
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// The size to ask for: the requested one if listed, else 640×480 if listed, else the
/// first the driver lists.
pub fn choose_size(
    device: &str,
    sizes: &[(u32, u32)],
    want: Option<(u32, u32)>,
) -> Result<(u32, u32), String> {
    if let Some(w) = want {
        if sizes.is_empty() || sizes.contains(&w) {
            return Ok(w);
        }
        let list: Vec<String> = sizes.iter().map(|(w, h)| format!("{w}x{h}")).collect();
        return Err(format!(
            "{device} does not support {}x{} depth (it offers {})",
            w.0,
            w.1,
            list.join(", ")
        ));
    }
    if sizes.contains(&(640, 480)) {
        return Ok((640, 480));
    }
    sizes
        .first()
        .copied()
        .ok_or_else(|| format!("{device} lists no frame size for its depth format"))
}

/// Intrinsics from the user's choice, else from a preset for a camera we know by name.
pub fn intrinsics_for(
    card: &str,
    cam: &CameraOptions,
    width: u32,
    height: u32,
) -> Result<Intrinsics, String> {
    if let Some(k) = cam.chosen_intrinsics(width, height) {
        return Ok(k);
    }
    let lower = card.to_ascii_lowercase();
    let preset = if lower.contains("realsense") {
        Some(Preset::RealSenseD435)
    } else if lower.contains("kinect") {
        Some(Preset::KinectV1Vga)
    } else {
        None
    };
    let Some(p) = preset else {
        let names: Vec<_> = Preset::ALL.iter().map(|p| p.name()).collect();
        return Err(format!(
            "no intrinsics known for {card:?} (V4L2 carries none): add intrinsics=fx,fy,cx,cy \
             or a preset ({}) to the source",
            names.join(", ")
        ));
    };
    let k = p.intrinsics();
    Ok(if (k.width, k.height) == (width, height) {
        k
    } else {
        k.scaled_to(width, height)
    })
}

/// Depth frames from a V4L2 device, read through memory-mapped driver buffers and
/// converted straight into the caller's buffer.
pub struct V4l2Source {
    // Declared first: the stream (and its mapped buffers) goes before the device.
    stream: v4l::io::mmap::Stream<'static>,
    _device: Device,
    path: PathBuf,
    format: DepthFormat,
    layout: Layout,
    scale: f32,
    intrinsics: Intrinsics,
    fps: f32,
}

impl V4l2Source {
    /// Opens the depth node at `path` with the camera options; fails saying what to add
    /// when the intrinsics are unknown.
    pub fn open(path: &Path, cam: &CameraOptions) -> Result<Self, SourceError> {
        let mut fatal_msg = None;
        let r = guarded(path, || {
            Self::open_unguarded(path, cam).map_err(|e| {
                fatal_msg = Some(e);
                String::new()
            })
        });
        match (r, fatal_msg) {
            (Ok(s), _) => Ok(s),
            (Err(_), Some(e)) => Err(e),
            (Err(m), None) => Err(fatal(m)),
        }
    }

    fn open_unguarded(path: &Path, cam: &CameraOptions) -> Result<Self, SourceError> {
        let name = path.display().to_string();
        if cam.start.is_some() {
            return Err(fatal(format!(
                "{name}: start= applies to .oni recordings, not to a live camera"
            )));
        }
        if !path.exists() {
            let nodes = device_nodes();
            return Err(fatal(if nodes.is_empty() {
                format!("no V4L2 device {name}: this machine has no /dev/video* device (is the camera plugged in and its driver loaded?)")
            } else {
                let list: Vec<String> = nodes.iter().map(|p| p.display().to_string()).collect();
                format!(
                    "no V4L2 device {name}; present: {} (`airglyph devices` shows which has depth)",
                    list.join(", ")
                )
            }));
        }
        let dev = Device::with_path(path).map_err(|e| fatal(format!("{name}: {e}")))?;
        let caps = dev
            .query_caps()
            .map_err(|e| fatal(format!("{name} is not a V4L2 device: {e}")))?;
        let card = format!("{name} ({})", caps.card);
        let offered: Vec<[u8; 4]> = dev
            .enum_formats()
            .map_err(|e| fatal(format!("{card}: listing formats: {e}")))?
            .iter()
            .map(|f| f.fourcc.repr)
            .collect();
        let format = choose_format(&card, &offered, cam.format).map_err(fatal)?;
        let sizes: Vec<(u32, u32)> = modes_of(&dev, format)
            .iter()
            .map(|m| (m.width, m.height))
            .collect();
        let want = match (cam.width, cam.height) {
            (Some(w), Some(h)) => Some((w, h)),
            _ => None,
        };
        let (w, h) = choose_size(&card, &sizes, want).map_err(fatal)?;
        let fourcc = FourCC::new(&format.fourcc());
        let set = dev
            .set_format(&v4l::Format::new(w, h, fourcc))
            .map_err(|e| {
                fatal(format!(
                    "{card}: setting {}x{} {}: {e}",
                    w,
                    h,
                    format.name()
                ))
            })?;
        if set.fourcc != fourcc || (set.width, set.height) != (w, h) {
            return Err(fatal(format!(
                "{card}: asked for {}x{} {}, the driver chose {}x{} {}",
                w,
                h,
                format.name(),
                set.width,
                set.height,
                fourcc_text(&set.fourcc)
            )));
        }
        if let Some(fps) = cam.fps {
            dev.set_params(&v4l::video::capture::Parameters::with_fps(fps))
                .map_err(|e| fatal(format!("{card}: setting {fps} fps: {e}")))?;
        }
        let fps = dev
            .params()
            .ok()
            .filter(|p| p.interval.numerator > 0)
            .map(|p| p.interval.denominator as f32 / p.interval.numerator as f32)
            .unwrap_or(30.0);
        if let Some(want) = cam.fps {
            if (fps - want as f32).abs() > 0.5 {
                return Err(fatal(format!(
                    "{card}: asked for {want} fps at {w}x{h}, the driver runs at {fps:.1}"
                )));
            }
        }
        let intrinsics = intrinsics_for(&card, cam, w, h).map_err(fatal)?;
        intrinsics
            .validate()
            .map_err(|e| fatal(format!("{card}: intrinsics: {e}")))?;
        let mut stream = v4l::io::mmap::Stream::with_buffers(&dev, Type::VideoCapture, 4)
            .map_err(|e| fatal(format!("{card}: mapping capture buffers: {e}")))?;
        stream.set_timeout(FRAME_TIMEOUT);
        Ok(Self {
            stream,
            _device: dev,
            path: path.to_owned(),
            format,
            layout: Layout {
                width: w,
                height: h,
                stride: set.stride as usize,
            },
            scale: cam.scale.unwrap_or(1.0),
            intrinsics,
            fps,
        })
    }
}

impl DepthSource for V4l2Source {
    fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }

    fn fps(&self) -> f32 {
        self.fps
    }

    fn kind(&self) -> SourceKind {
        SourceKind::V4l2
    }

    fn describe(&self) -> String {
        format!("v4l2:{} ({})", self.path.display(), self.format.name())
    }

    fn next_frame(&mut self, out: &mut [u16]) -> Result<Option<Frame>, SourceError> {
        let (buf, meta) = match self.stream.next() {
            Ok(x) => x,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                return Err(SourceError::Skipped(format!(
                    "no frame from {} for {} s",
                    self.path.display(),
                    FRAME_TIMEOUT.as_secs()
                )))
            }
            Err(e) => return Err(fatal(format!("{}: {e}", self.path.display()))),
        };
        let used = match meta.bytesused as usize {
            0 => buf.len(),
            n => n.min(buf.len()),
        };
        let source_ns = meta.timestamp.sec.max(0) as u64 * 1_000_000_000
            + meta.timestamp.usec.max(0) as u64 * 1000;
        to_millimetres(self.format, self.layout, &buf[..used], self.scale, out)
            .map_err(|e| SourceError::Skipped(format!("{}: {e}", self.path.display())))?;
        Ok(Some(Frame {
            capture_ns: monotonic_ns(),
            source_ns,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_device_is_a_clear_error() {
        let err = match V4l2Source::open(
            Path::new("/dev/video-airglyph-none"),
            &CameraOptions::default(),
        ) {
            Err(SourceError::Fatal(m)) => m,
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("opened a device that does not exist"),
        };
        assert!(
            err.contains("no V4L2 device /dev/video-airglyph-none"),
            "{err}"
        );
    }

    #[test]
    fn a_device_without_depth_formats_is_a_clear_error() {
        let err =
            choose_format("/dev/video0 (HD Webcam)", &[*b"YUYV", *b"MJPG"], None).unwrap_err();
        assert!(
            err.contains("has no depth format")
                && err.contains("YUYV, MJPG")
                && err.contains("Z16"),
            "{err}"
        );
        let err = choose_format("/dev/video0 (x)", &[], None).unwrap_err();
        assert!(err.contains("no formats at all"), "{err}");
    }

    #[test]
    fn depth_formats_are_preferred_in_order_and_a_named_one_must_exist() {
        let offered = [*b"YUYV", *b"Y16 ", *b"Z16 "];
        assert_eq!(choose_format("d", &offered, None), Ok(DepthFormat::Z16));
        assert_eq!(
            choose_format("d", &offered, Some(DepthFormat::Y16)),
            Ok(DepthFormat::Y16)
        );
        let err = choose_format("d", &offered, Some(DepthFormat::KinectY10B)).unwrap_err();
        assert!(
            err.contains("does not offer format Y10B") && err.contains("Z16, Y16"),
            "{err}"
        );
    }

    #[test]
    fn sizes_and_intrinsics_are_chosen_or_refused_clearly() {
        let sizes = [(1280, 720), (848, 480), (640, 480)];
        assert_eq!(choose_size("d", &sizes, None), Ok((640, 480)));
        assert_eq!(choose_size("d", &sizes, Some((848, 480))), Ok((848, 480)));
        let err = choose_size("d", &sizes, Some((320, 200))).unwrap_err();
        assert!(err.contains("320x200") && err.contains("848x480"), "{err}");
        let k = intrinsics_for(
            "Intel(R) RealSense(TM) Depth Camera 435",
            &CameraOptions::default(),
            848,
            480,
        )
        .unwrap();
        assert_eq!((k.width, k.height), (848, 480));
        let err = intrinsics_for("Some ToF", &CameraOptions::default(), 640, 480).unwrap_err();
        assert!(err.contains("intrinsics=fx,fy,cx,cy"), "{err}");
    }

    /// Runs against a real camera when `AIRGLYPH_V4L2_DEVICE` names one (e.g.
    /// `AIRGLYPH_V4L2_DEVICE=/dev/video2 cargo test -p airglyph-capture --features v4l2
    /// v4l2_hardware`); otherwise it passes without doing anything.
    #[test]
    fn v4l2_hardware_streams_depth_frames() {
        let Ok(dev) = std::env::var("AIRGLYPH_V4L2_DEVICE") else {
            eprintln!("AIRGLYPH_V4L2_DEVICE not set: skipping the V4L2 hardware test");
            return;
        };
        let listed = list_devices();
        let me = listed
            .iter()
            .find(|l| l.path == Path::new(&dev))
            .unwrap_or_else(|| panic!("{dev} is not listed: {listed:?}"));
        assert!(
            !me.depth_modes.is_empty(),
            "{dev} lists no depth mode: {me:?}"
        );
        let opts: CameraOptions = std::env::var("AIRGLYPH_V4L2_OPTIONS")
            .ok()
            .map(|o| {
                match format!("v4l2:{dev}?{o}")
                    .parse::<crate::SourceSpec>()
                    .unwrap()
                {
                    crate::SourceSpec::V4l2(_, o) => o,
                    _ => unreachable!(),
                }
            })
            .unwrap_or_default();
        let mut src = V4l2Source::open(Path::new(&dev), &opts).unwrap();
        let k = src.intrinsics();
        let mut px = vec![0u16; (k.width * k.height) as usize];
        let mut nonzero = 0;
        for _ in 0..30 {
            let f = src
                .next_frame(&mut px)
                .unwrap()
                .expect("a live camera never ends");
            assert!(f.capture_ns > 0);
            nonzero = px.iter().filter(|&&d| d > 0).count();
        }
        assert!(
            nonzero > px.len() / 10,
            "a depth camera sees something: {nonzero} valid pixels"
        );
    }
}
