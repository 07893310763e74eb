//! OpenNI2 devices (Kinect, Xtion, Astra, the runtime's `Dummy`) and `.oni` recordings,
//! through OpenNI2's C API (openni2-sys).
//!
//! The C API is used directly rather than through the `openni2` crate (0.4): that crate
//! panics on pixel formats it does not know, sets playback repeat with a 1-byte bool
//! (which OpenNI2 rejects), has no wait-with-timeout, and ignores a frame's stride.
//!
//! Traps of Debian's OpenNI2 2.2.0.33 this module works around:
//! - a `.oni` recorded from a stream without cropping support plays no frame at all: we
//!   play a copy with the missing records added (see [`crate::onifile`]) and say so;
//! - playback speed −1 (manual) is the only mode that neither paces nor drops frames, so
//!   we always use it and pace real-time playback ourselves by the recorded timestamps;
//! - repeat is on by default and must be turned off with a 4-byte int;
//! - `read_frame` blocks at the end of a file: we wait with `oniWaitForAnyStream` and a
//!   timeout, and stop after the file's frame count;
//! - seeking hangs: looping reopens the file instead;
//! - the recorder must start ~50 ms before the stream and be destroyed before the stream
//!   and the device, and OpenNI2 is never shut down (shutting down right after a `Dummy`
//!   stream stops crashes).

use crate::source::{CameraOptions, DepthSource, Frame, Pacing, SourceError, SourceOptions};
use airglyph_core::Intrinsics;
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::wire::SourceKind;
use openni2_sys::*;
use serde::Serialize;
use std::ffi::{CStr, CString};
use std::os::raw::{c_float, c_int, c_void};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

/// How long a live device may stay silent before we report it (and check for Ctrl-C).
const LIVE_TIMEOUT_MS: c_int = 2000;
/// At the end of a file no frame comes: this long without one ends playback.
const PLAYBACK_TIMEOUT_MS: c_int = 2000;

fn fatal(msg: impl Into<String>) -> SourceError {
    SourceError::Fatal(msg.into())
}

fn extended_error() -> String {
    // SAFETY: OpenNI2 returns a pointer to a static, NUL-terminated buffer.
    let p = unsafe { oniGetExtendedError() };
    if p.is_null() {
        return String::new();
    }
    unsafe { CStr::from_ptr(p) }
        .to_string_lossy()
        .trim()
        .to_owned()
}

fn status_text(rc: OniStatus) -> String {
    let base = match rc {
        ONI_STATUS_ERROR => "error",
        ONI_STATUS_NOT_IMPLEMENTED => "not implemented",
        ONI_STATUS_NOT_SUPPORTED => "not supported",
        ONI_STATUS_BAD_PARAMETER => "bad parameter",
        ONI_STATUS_OUT_OF_FLOW => "out of flow",
        ONI_STATUS_NO_DEVICE => "no device",
        ONI_STATUS_TIME_OUT => "timed out",
        _ => "unknown status",
    };
    let ext = extended_error();
    if ext.is_empty() {
        base.to_owned()
    } else {
        format!("{base}: {ext}")
    }
}

fn check(rc: OniStatus, what: &str) -> Result<(), SourceError> {
    if rc == ONI_STATUS_OK {
        Ok(())
    } else {
        Err(fatal(format!("OpenNI2: {what}: {}", status_text(rc))))
    }
}

/// Initializes OpenNI2 once per process; it is never shut down (see the module docs).
pub fn init() -> Result<(), SourceError> {
    static INIT: OnceLock<Result<(), String>> = OnceLock::new();
    INIT.get_or_init(|| {
        // SAFETY: plain C call; 2002 = ONI_API_VERSION of OpenNI 2.2.
        let rc = unsafe { oniInitialize(2 * 1000 + 2) };
        if rc == ONI_STATUS_OK {
            Ok(())
        } else {
            Err(format!(
                "OpenNI2 failed to initialize ({}); is libopenni2-0 installed with its drivers \
                 (/usr/lib/<arch>/OpenNI2/Drivers)? scripts/setup installs it",
                status_text(rc)
            ))
        }
    })
    .clone()
    .map_err(SourceError::Fatal)
}

fn c_str(chars: &[std::os::raw::c_char]) -> String {
    let bytes: Vec<u8> = chars
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// A depth mode a device offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DepthMode {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frames a second.
    pub fps: u32,
    /// `DEPTH_1_MM`, `DEPTH_100_UM`, or the raw shift formats we cannot use.
    pub format: &'static str,
}

fn format_name(f: OniPixelFormat) -> &'static str {
    match f {
        ONI_PIXEL_FORMAT_DEPTH_1_MM => "DEPTH_1_MM",
        ONI_PIXEL_FORMAT_DEPTH_100_UM => "DEPTH_100_UM",
        ONI_PIXEL_FORMAT_SHIFT_9_2 => "SHIFT_9_2",
        ONI_PIXEL_FORMAT_SHIFT_9_3 => "SHIFT_9_3",
        _ => "other",
    }
}

fn usable(f: OniPixelFormat) -> bool {
    f == ONI_PIXEL_FORMAT_DEPTH_1_MM || f == ONI_PIXEL_FORMAT_DEPTH_100_UM
}

/// An OpenNI2 device as `airglyph devices` lists it.
#[derive(Debug, Clone, Serialize)]
pub struct DeviceListing {
    /// What to open it by (`openni2:URI`).
    pub uri: String,
    /// Its maker, as the driver reports it.
    pub vendor: String,
    /// Its name, as the driver reports it.
    pub name: String,
    /// USB vendor id.
    pub usb_vendor_id: u16,
    /// USB product id.
    pub usb_product_id: u16,
    /// The depth modes it offers.
    pub depth_modes: Vec<DepthMode>,
}

/// The devices OpenNI2's drivers find, with their depth modes. `Dummy` is not listed
/// (OpenNI2 opens it by URI only).
pub fn list_devices() -> Result<Vec<DeviceListing>, SourceError> {
    init()?;
    let mut ptr: *mut OniDeviceInfo = std::ptr::null_mut();
    let mut count: c_int = 0;
    // SAFETY: OpenNI2 allocates the list; we release it below.
    check(
        unsafe { oniGetDeviceList(&mut ptr, &mut count) },
        "listing devices",
    )?;
    let infos: Vec<OniDeviceInfo> = if ptr.is_null() || count <= 0 {
        Vec::new()
    } else {
        // SAFETY: `count` entries at `ptr`, valid until released.
        unsafe { std::slice::from_raw_parts(ptr, count as usize) }.to_vec()
    };
    if !ptr.is_null() {
        unsafe { oniReleaseDeviceList(ptr) };
    }
    let mut out = Vec::new();
    for info in infos {
        let uri = c_str(&info.uri);
        let depth_modes = Device::open(Some(&uri))
            .map(|d| d.depth_modes())
            .unwrap_or_default();
        out.push(DeviceListing {
            uri,
            vendor: c_str(&info.vendor),
            name: c_str(&info.name),
            usb_vendor_id: info.usbVendorId,
            usb_product_id: info.usbProductId,
            depth_modes,
        });
    }
    Ok(out)
}

struct Device(OniDeviceHandle);

impl Device {
    fn open(uri: Option<&str>) -> Result<Device, SourceError> {
        init()?;
        let c = match uri {
            Some(u) => Some(
                CString::new(u)
                    .map_err(|_| fatal(format!("OpenNI2 URI {u:?} contains a NUL byte")))?,
            ),
            None => None,
        };
        let mut handle: OniDeviceHandle = std::ptr::null_mut();
        let p = c.as_ref().map_or(std::ptr::null(), |c| c.as_ptr());
        // SAFETY: `p` is NULL (any device) or a valid C string for the call's duration.
        let rc = unsafe { oniDeviceOpen(p, &mut handle) };
        if rc != ONI_STATUS_OK || handle.is_null() {
            let why = status_text(rc);
            let known: Vec<String> = list_uris();
            let known = if known.is_empty() {
                "no device is connected".to_owned()
            } else {
                format!("connected: {}", known.join(", "))
            };
            return Err(fatal(match uri {
                None => format!(
                    "no OpenNI2 device found ({why}); connect a Kinect, Xtion or Astra, or \
                     name one: openni2:Dummy, openni2:FILE.oni"
                ),
                Some(u) => format!(
                    "OpenNI2 cannot open device {u:?} ({why}); {known}; the runtime's test \
                     device is openni2:Dummy, a recording is openni2:FILE.oni"
                ),
            }));
        }
        Ok(Device(handle))
    }

    fn depth_modes(&self) -> Vec<DepthMode> {
        // SAFETY: the device is open; the returned info lives as long as the device.
        let info = unsafe { oniDeviceGetSensorInfo(self.0, ONI_SENSOR_DEPTH) };
        modes_of(info)
    }

    fn set_int(&self, prop: OniDeviceProperty, value: c_int) -> OniStatus {
        // SAFETY: a 4-byte int, as OpenNI2 expects for boolean and integer properties.
        unsafe {
            oniDeviceSetProperty(
                self.0,
                prop,
                &value as *const c_int as *const c_void,
                std::mem::size_of::<c_int>() as c_int,
            )
        }
    }

    fn set_float(&self, prop: OniDeviceProperty, value: c_float) -> OniStatus {
        // SAFETY: a 4-byte float.
        unsafe {
            oniDeviceSetProperty(
                self.0,
                prop,
                &value as *const c_float as *const c_void,
                std::mem::size_of::<c_float>() as c_int,
            )
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: opened by oniDeviceOpen, closed once.
        unsafe { oniDeviceClose(self.0) };
    }
}

fn list_uris() -> Vec<String> {
    let mut ptr: *mut OniDeviceInfo = std::ptr::null_mut();
    let mut count: c_int = 0;
    // SAFETY: as in list_devices.
    let rc = unsafe { oniGetDeviceList(&mut ptr, &mut count) };
    if rc != ONI_STATUS_OK || ptr.is_null() {
        return Vec::new();
    }
    let uris = unsafe { std::slice::from_raw_parts(ptr, count.max(0) as usize) }
        .iter()
        .map(|i| c_str(&i.uri))
        .collect();
    unsafe { oniReleaseDeviceList(ptr) };
    uris
}

fn modes_of(info: *const OniSensorInfo) -> Vec<DepthMode> {
    if info.is_null() {
        return Vec::new();
    }
    // SAFETY: OpenNI2's sensor info: `numSupportedVideoModes` entries.
    let info = unsafe { &*info };
    if info.pSupportedVideoModes.is_null() || info.numSupportedVideoModes <= 0 {
        return Vec::new();
    }
    let modes = unsafe {
        std::slice::from_raw_parts(
            info.pSupportedVideoModes,
            info.numSupportedVideoModes as usize,
        )
    };
    let mut out: Vec<DepthMode> = modes
        .iter()
        .filter(|m| m.resolutionX > 0 && m.resolutionY > 0 && m.fps > 0)
        .map(|m| DepthMode {
            width: m.resolutionX as u32,
            height: m.resolutionY as u32,
            fps: m.fps as u32,
            format: format_name(m.pixelFormat),
        })
        .collect();
    out.dedup();
    out
}

struct Stream(OniStreamHandle);

impl Stream {
    fn get<T: Copy>(&self, prop: OniStreamProperty) -> Option<T> {
        let mut v = std::mem::MaybeUninit::<T>::uninit();
        let mut size = std::mem::size_of::<T>() as c_int;
        // SAFETY: OpenNI2 writes at most `size` bytes; we check it wrote exactly that.
        let rc =
            unsafe { oniStreamGetProperty(self.0, prop, v.as_mut_ptr() as *mut c_void, &mut size) };
        (rc == ONI_STATUS_OK && size as usize == std::mem::size_of::<T>())
            .then(|| unsafe { v.assume_init() })
    }

    fn video_mode(&self) -> Option<OniVideoMode> {
        self.get::<OniVideoMode>(ONI_STREAM_PROPERTY_VIDEO_MODE)
    }
}

impl Drop for Stream {
    fn drop(&mut self) {
        // SAFETY: created by oniDeviceCreateStream, destroyed once.
        unsafe { oniStreamStop(self.0) };
        // Two of OpenNI2's own drivers free a stream while a thread of theirs may still
        // use it, unless it has first seen the stream stopped: the Dummy device's frame
        // thread (stopping it only clears a flag, read after a 33 ms sleep), and a
        // file's player thread (libOniFile's PlayerDevice::MainLoop walks its stream
        // list without the lock the removal takes, in a busy loop at the file's end;
        // stopped, the stream sends it to sleep 10 ms between walks). Destroying at
        // once crashed the process (SIGSEGV in those threads) about one looping reopen
        // in a hundred, and now and then a test that opened the Dummy device after
        // another had closed it.
        std::thread::sleep(Duration::from_millis(STREAM_SETTLE_MS));
        // SAFETY: as above.
        unsafe { oniStreamDestroy(self.0) };
    }
}

/// How long a stopped stream is left before it is destroyed: longer than any sleep of
/// the driver threads that may still look at it (33 ms for the Dummy device).
const STREAM_SETTLE_MS: u64 = 50;

struct Recorder(OniRecorderHandle);

impl Drop for Recorder {
    fn drop(&mut self) {
        // SAFETY: destroying writes the frame count and seek table, then frees it.
        unsafe {
            oniRecorderStop(self.0);
            oniRecorderDestroy(&mut self.0);
        }
    }
}

/// A `.oni` file opened for playback, possibly through a repaired copy.
struct Playback {
    file: PathBuf,
    /// The repaired copy we play instead (removed on drop).
    copy: Option<PathBuf>,
    frames: u64,
}

impl Drop for Playback {
    fn drop(&mut self) {
        if let Some(c) = &self.copy {
            let _ = std::fs::remove_file(c);
        }
    }
}

fn looks_like_file(uri: &str) -> bool {
    uri.to_ascii_lowercase().ends_with(".oni") || Path::new(uri).is_file()
}

/// Checks a `.oni` file and, when it lacks the cropping records, writes a repaired copy.
fn prepare_playback(uri: &str) -> Result<Playback, SourceError> {
    let path = PathBuf::from(uri);
    let bytes = std::fs::read(&path).map_err(|e| fatal(format!("{uri}: {e}")))?;
    let nodes = crate::onifile::depth_nodes(&bytes).map_err(|e| fatal(format!("{uri}: {e}")))?;
    let Some(node) = nodes.first() else {
        return Err(fatal(format!("{uri}: the recording has no depth stream")));
    };
    let frames = if node.frames > 0 {
        node.frames
    } else {
        node.data_records
    } as u64;
    if frames == 0 {
        return Err(fatal(format!(
            "{uri}: the recording has no frames (was the recorder stopped before the stream \
             started?)"
        )));
    }
    let fixed =
        crate::onifile::add_missing_cropping(&bytes).map_err(|e| fatal(format!("{uri}: {e}")))?;
    let copy = match fixed {
        None => None,
        Some(fixed) => {
            static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
            let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "recording".into());
            let copy = std::env::temp_dir().join(format!(
                "airglyph-{}-{n}-{stem}-cropfix.oni",
                std::process::id()
            ));
            std::fs::write(&copy, fixed).map_err(|e| fatal(format!("{}: {e}", copy.display())))?;
            tracing::warn!(
                file = uri,
                copy = %copy.display(),
                "this .oni lacks the cropping property (recorded from a stream without \
                 cropping, e.g. the Dummy device); OpenNI2 would play none of its frames, so \
                 a copy with cropping off added is played instead (the file is unchanged)"
            );
            Some(copy)
        }
    };
    Ok(Playback {
        file: path,
        copy,
        frames,
    })
}

/// Depth frames from an OpenNI2 device or `.oni` file.
///
/// Field order is drop order: the recorder goes before the stream, the stream before
/// the device.
pub struct OpenNi2Source {
    /// None only between closing the file and opening it again ([`Self::reopen`]).
    handles: Option<Handles>,
    playback: Option<Playback>,
    uri: Option<String>,
    cam: CameraOptions,
    opts: SourceOptions,
    intrinsics: Intrinsics,
    fps: f32,
    pixel_format: OniPixelFormat,
    /// Frames delivered in this pass over a file.
    delivered: u64,
    /// (CLOCK_MONOTONIC, recorded µs) of the first frame of a real-time pass.
    epoch: Option<(u64, u64)>,
}

/// What OpenNI2 holds open for a source, in the order it must be released (the
/// recorder before its stream, the stream before its device).
struct Handles {
    _recorder: Option<Recorder>,
    stream: Stream,
    _device: Device,
}

impl OpenNi2Source {
    /// Opens `uri` (a device URI, `Dummy`, a `.oni` file) or the first device.
    pub fn open(
        uri: Option<&str>,
        cam: &CameraOptions,
        opts: &SourceOptions,
    ) -> Result<Self, SourceError> {
        Self::open_inner(uri, cam, opts, None)
    }

    /// Like [`open`](Self::open), and records the depth stream to `oni` through
    /// OpenNI2's recorder for as long as the source lives.
    pub fn open_recording(
        uri: Option<&str>,
        cam: &CameraOptions,
        opts: &SourceOptions,
        oni: &Path,
    ) -> Result<Self, SourceError> {
        Self::open_inner(uri, cam, opts, Some(oni))
    }

    fn open_inner(
        uri: Option<&str>,
        cam: &CameraOptions,
        opts: &SourceOptions,
        record_to: Option<&Path>,
    ) -> Result<Self, SourceError> {
        if let Some(f) = cam.format {
            return Err(fatal(format!(
                "format={} applies to v4l2 sources; OpenNI2 depth is always millimetres",
                f.name()
            )));
        }
        if cam.scale.is_some() {
            return Err(fatal(
                "scale= applies to v4l2 sources; OpenNI2 reports its depth unit itself",
            ));
        }
        let playback = match uri {
            Some(u) if looks_like_file(u) => Some(prepare_playback(u)?),
            _ => None,
        };
        let open_uri: Option<String> = match &playback {
            Some(p) => Some(
                p.copy
                    .as_ref()
                    .unwrap_or(&p.file)
                    .to_string_lossy()
                    .into_owned(),
            ),
            None => uri.map(str::to_owned),
        };
        let device = Device::open(open_uri.as_deref())?;
        if playback.is_some() {
            // Manual speed: neither paced nor dropped; we pace ourselves.
            check(
                device.set_float(ONI_DEVICE_PROPERTY_PLAYBACK_SPEED, -1.0),
                "setting playback speed",
            )?;
            check(
                device.set_int(ONI_DEVICE_PROPERTY_PLAYBACK_REPEAT_ENABLED, 0),
                "turning playback repeat off",
            )?;
        }
        let name = uri.unwrap_or("the first device");
        let modes = device.depth_modes();
        let mut handle: OniStreamHandle = std::ptr::null_mut();
        // SAFETY: the device is open.
        let rc = unsafe { oniDeviceCreateStream(device.0, ONI_SENSOR_DEPTH, &mut handle) };
        if rc != ONI_STATUS_OK || handle.is_null() {
            return Err(fatal(format!(
                "OpenNI2 device {name} has no depth stream ({})",
                status_text(rc)
            )));
        }
        let stream = Stream(handle);
        let current = stream
            .video_mode()
            .ok_or_else(|| fatal(format!("OpenNI2 device {name}: cannot read its video mode")))?;
        let mode = choose_mode(name, current, &modes, cam, playback.is_some())?;
        if !same_mode(&mode, &current) {
            // SAFETY: an OniVideoMode, by value.
            let rc = unsafe {
                oniStreamSetProperty(
                    stream.0,
                    ONI_STREAM_PROPERTY_VIDEO_MODE,
                    &mode as *const OniVideoMode as *const c_void,
                    std::mem::size_of::<OniVideoMode>() as c_int,
                )
            };
            check(rc, &format!("setting depth mode {}", mode_text(&mode)))?;
        }
        let (w, h) = (mode.resolutionX as u32, mode.resolutionY as u32);
        let intrinsics = match cam.chosen_intrinsics(w, h) {
            Some(k) => k,
            None => {
                let hfov = stream.get::<c_float>(ONI_STREAM_PROPERTY_HORIZONTAL_FOV);
                let vfov = stream.get::<c_float>(ONI_STREAM_PROPERTY_VERTICAL_FOV);
                match (hfov, vfov) {
                    (Some(hf), Some(vf)) if hf > 0.0 && vf > 0.0 => {
                        Intrinsics::from_fov(w, h, hf, vf)
                    }
                    _ => {
                        // Dummy, and recordings of it, report none. OpenNI2 cameras are
                        // PrimeSense-like: assume the Kinect v1's optics, and say so.
                        tracing::warn!(
                            device = name,
                            "reports no field of view: assuming Kinect v1 optics; give \
                             intrinsics=fx,fy,cx,cy or a preset in the source to override"
                        );
                        airglyph_core::camera::Preset::KinectV1Vga
                            .intrinsics()
                            .scaled_to(w, h)
                    }
                }
            }
        };
        intrinsics
            .validate()
            .map_err(|e| fatal(format!("OpenNI2 device {name}: intrinsics: {e}")))?;
        let recorder = match record_to {
            Some(path) => Some(start_recorder(&stream, path)?),
            None => None,
        };
        // SAFETY: the stream exists.
        check(
            unsafe { oniStreamStart(stream.0) },
            "starting the depth stream",
        )?;
        let frames_prop = stream.get::<c_int>(ONI_STREAM_PROPERTY_NUMBER_OF_FRAMES);
        let mut playback = playback;
        if let (Some(p), Some(n)) = (playback.as_mut(), frames_prop) {
            if n > 0 {
                p.frames = n as u64;
            }
        }
        let start = cam.start.unwrap_or(0);
        match &playback {
            Some(p) if start >= p.frames => {
                return Err(fatal(format!(
                    "{name}: start={start} but the recording has {} frames (0 to {})",
                    p.frames,
                    p.frames - 1
                )))
            }
            None if start > 0 => {
                return Err(fatal(format!(
                    "{name}: start= applies to .oni recordings, not to a live device"
                )))
            }
            _ => {}
        }
        let mut me = Self {
            handles: Some(Handles {
                _recorder: recorder,
                stream,
                _device: device,
            }),
            playback,
            uri: uri.map(str::to_owned),
            cam: cam.clone(),
            opts: opts.clone(),
            intrinsics,
            fps: mode.fps as f32,
            pixel_format: mode.pixelFormat,
            delivered: 0,
            epoch: None,
        };
        // No seeking in this OpenNI2 (it hangs): read and drop frames up to `start`.
        for i in 0..start {
            if !me.wait(PLAYBACK_TIMEOUT_MS)? {
                return Err(fatal(format!(
                    "{name}: the recording ended at frame {i} of {start} skipped"
                )));
            }
            let mut ptr: *mut OniFrame = std::ptr::null_mut();
            // SAFETY: a frame is ready; released at once.
            let rc = unsafe { oniStreamReadFrame(me.stream()?.0, &mut ptr) };
            check(rc, "skipping to the start frame")?;
            if !ptr.is_null() {
                unsafe { oniFrameRelease(ptr) };
            }
            me.delivered += 1;
        }
        Ok(me)
    }

    /// Frames in the `.oni` file being played, if this is playback.
    pub fn file_frames(&self) -> Option<u64> {
        self.playback.as_ref().map(|p| p.frames)
    }

    /// Starts the file over: OpenNI2's seek hangs in this build, so reopen.
    fn reopen(&mut self) -> Result<(), SourceError> {
        // Close the file's player before opening the file again, as one would expect:
        // with the old one still open, reopening crashed inside libOniFile more often
        // (see `Drop for Stream`).
        self.handles = None;
        *self = Self::open_inner(self.uri.as_deref(), &self.cam, &self.opts, None)?;
        Ok(())
    }

    fn stream(&self) -> Result<&Stream, SourceError> {
        self.handles
            .as_ref()
            .map(|h| &h.stream)
            .ok_or_else(|| fatal("OpenNI2: the recording could not be opened again"))
    }

    fn wait(&self, timeout_ms: c_int) -> Result<bool, SourceError> {
        let mut handles = [self.stream()?.0];
        let mut ready: c_int = -1;
        // SAFETY: one valid stream handle.
        let rc = unsafe { oniWaitForAnyStream(handles.as_mut_ptr(), 1, &mut ready, timeout_ms) };
        match rc {
            ONI_STATUS_OK => Ok(true),
            ONI_STATUS_TIME_OUT => Ok(false),
            other => Err(fatal(format!(
                "OpenNI2: waiting for a depth frame: {}",
                status_text(other)
            ))),
        }
    }
}

fn start_recorder(stream: &Stream, path: &Path) -> Result<Recorder, SourceError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| fatal(format!("{}: {e}", dir.display())))?;
    }
    let c = CString::new(path.to_string_lossy().as_bytes())
        .map_err(|_| fatal(format!("{}: path contains a NUL byte", path.display())))?;
    let mut handle: OniRecorderHandle = std::ptr::null_mut();
    // SAFETY: valid C string; OpenNI2 creates the file.
    let rc = unsafe { oniCreateRecorder(c.as_ptr(), &mut handle) };
    if rc != ONI_STATUS_OK || handle.is_null() {
        return Err(fatal(format!(
            "{}: OpenNI2 cannot create the recording ({})",
            path.display(),
            status_text(rc)
        )));
    }
    let rec = Recorder(handle);
    // SAFETY: both handles are alive; lossless (0) keeps the pixels bit-exact.
    check(
        unsafe { oniRecorderAttachStream(rec.0, stream.0, 0) },
        "attaching the depth stream to the recorder",
    )?;
    check(unsafe { oniRecorderStart(rec.0) }, "starting the recorder")?;
    // The recorder's thread writes the stream's header records first.
    std::thread::sleep(Duration::from_millis(50));
    Ok(rec)
}

fn mode_text(m: &OniVideoMode) -> String {
    format!(
        "{}x{}@{} {}",
        m.resolutionX,
        m.resolutionY,
        m.fps,
        format_name(m.pixelFormat)
    )
}

fn same_mode(a: &OniVideoMode, b: &OniVideoMode) -> bool {
    (a.pixelFormat, a.resolutionX, a.resolutionY, a.fps)
        == (b.pixelFormat, b.resolutionX, b.resolutionY, b.fps)
}

fn wants(cam: &CameraOptions, m: &OniVideoMode) -> bool {
    cam.width.is_none_or(|w| w as c_int == m.resolutionX)
        && cam.height.is_none_or(|h| h as c_int == m.resolutionY)
        && cam.fps.is_none_or(|f| f as c_int == m.fps)
}

/// The mode to stream: the current one if it fits the request, else the first supported
/// depth mode (millimetres before 100 µm) that does.
fn choose_mode(
    name: &str,
    current: OniVideoMode,
    modes: &[DepthMode],
    cam: &CameraOptions,
    playback: bool,
) -> Result<OniVideoMode, SourceError> {
    if usable(current.pixelFormat) && wants(cam, &current) {
        return Ok(current);
    }
    let offered = || {
        let list: Vec<String> = modes
            .iter()
            .map(|m| format!("{}x{}@{} {}", m.width, m.height, m.fps, m.format))
            .collect();
        if list.is_empty() {
            "none".to_owned()
        } else {
            list.join(", ")
        }
    };
    if playback {
        return Err(fatal(format!(
            "{name}: the recording is {}; a recording plays in the mode it was recorded in{}",
            mode_text(&current),
            if usable(current.pixelFormat) {
                ": drop mode= from the source".to_owned()
            } else {
                " and this pixel format is not depth in millimetres".to_owned()
            }
        )));
    }
    let mut candidates: Vec<OniVideoMode> = modes
        .iter()
        .map(|m| OniVideoMode {
            pixelFormat: match m.format {
                "DEPTH_1_MM" => ONI_PIXEL_FORMAT_DEPTH_1_MM,
                "DEPTH_100_UM" => ONI_PIXEL_FORMAT_DEPTH_100_UM,
                _ => -1,
            },
            resolutionX: m.width as c_int,
            resolutionY: m.height as c_int,
            fps: m.fps as c_int,
        })
        .filter(|m| usable(m.pixelFormat) && wants(cam, m))
        .collect();
    candidates.sort_by_key(|m| (m.pixelFormat != ONI_PIXEL_FORMAT_DEPTH_1_MM) as u8);
    candidates.into_iter().next().ok_or_else(|| {
        let asked = crate::source::CameraOptions {
            width: cam.width,
            height: cam.height,
            fps: cam.fps,
            ..Default::default()
        };
        fatal(format!(
            "OpenNI2 device {name} does not support the depth mode {} (it offers: {})",
            asked.to_string().trim_start_matches("?mode="),
            offered()
        ))
    })
}

/// Copies one OpenNI2 frame into `out`, honouring its stride and unit.
fn copy_frame(
    f: &OniFrame,
    format: OniPixelFormat,
    k: &Intrinsics,
    out: &mut [u16],
) -> Result<(), String> {
    let (w, h) = (k.width as usize, k.height as usize);
    if f.width as usize != w || f.height as usize != h {
        return Err(format!(
            "frame is {}x{}, the stream was {}x{}",
            f.width, f.height, w, h
        ));
    }
    if out.len() != w * h {
        return Err(format!(
            "output holds {} pixels, the frame has {}",
            out.len(),
            w * h
        ));
    }
    let stride = if f.stride > 0 {
        f.stride as usize
    } else {
        w * 2
    };
    let need = if h == 0 { 0 } else { stride * (h - 1) + w * 2 };
    if stride < w * 2 || f.data.is_null() || (f.dataSize.max(0) as usize) < need {
        return Err(format!(
            "frame data is {} bytes with stride {stride}, {w}x{h} depth needs {need}",
            f.dataSize
        ));
    }
    // SAFETY: OpenNI2 guarantees `dataSize` readable bytes at `data`, checked above.
    let bytes = unsafe { std::slice::from_raw_parts(f.data as *const u8, f.dataSize as usize) };
    for (y, dst) in out.chunks_exact_mut(w.max(1)).take(h).enumerate() {
        let row = &bytes[y * stride..y * stride + w * 2];
        for (d, b) in dst.iter_mut().zip(row.chunks_exact(2)) {
            let v = u16::from_ne_bytes([b[0], b[1]]);
            *d = if format == ONI_PIXEL_FORMAT_DEPTH_100_UM {
                ((v as u32 + 5) / 10) as u16
            } else {
                v
            };
        }
    }
    Ok(())
}

impl DepthSource for OpenNi2Source {
    fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }

    fn fps(&self) -> f32 {
        self.fps
    }

    fn kind(&self) -> SourceKind {
        SourceKind::OpenNi2
    }

    fn describe(&self) -> String {
        match &self.uri {
            Some(u) => format!("openni2:{u}"),
            None => "openni2".into(),
        }
    }

    fn next_frame(&mut self, out: &mut [u16]) -> Result<Option<Frame>, SourceError> {
        if let Some(total) = self.file_frames() {
            if self.delivered >= total {
                if !self.opts.looping {
                    return Ok(None);
                }
                self.reopen()?;
            }
        }
        let timeout = if self.playback.is_some() {
            PLAYBACK_TIMEOUT_MS
        } else {
            LIVE_TIMEOUT_MS
        };
        if !self.wait(timeout)? {
            return match &self.playback {
                Some(p) => {
                    tracing::warn!(
                        file = %p.file.display(),
                        played = self.delivered,
                        frames = p.frames,
                        "no more frames from the recording before its frame count"
                    );
                    Ok(None)
                }
                None => Err(SourceError::Skipped(format!(
                    "no depth frame from {} for {} s",
                    self.describe(),
                    LIVE_TIMEOUT_MS / 1000
                ))),
            };
        }
        let mut ptr: *mut OniFrame = std::ptr::null_mut();
        // SAFETY: the stream has a frame ready; we release it below.
        let rc = unsafe { oniStreamReadFrame(self.stream()?.0, &mut ptr) };
        if rc != ONI_STATUS_OK || ptr.is_null() {
            return Err(SourceError::Skipped(format!(
                "OpenNI2: reading a frame: {}",
                status_text(rc)
            )));
        }
        // SAFETY: a valid frame until oniFrameRelease.
        let frame = unsafe { *ptr };
        let copied = copy_frame(&frame, self.pixel_format, &self.intrinsics, out);
        unsafe { oniFrameRelease(ptr) };
        copied.map_err(SourceError::Skipped)?;
        self.delivered += 1;
        let source_us = frame.timestamp;
        if self.playback.is_some() && self.opts.pacing == Pacing::Realtime {
            let now = monotonic_ns();
            let (start, first) = *self.epoch.get_or_insert((now, source_us));
            let due = start + source_us.saturating_sub(first) * 1000;
            if due > now {
                std::thread::sleep(Duration::from_nanos(due - now));
            }
        }
        Ok(Some(Frame {
            capture_ns: monotonic_ns(),
            // 0 means "no source time" on the wire, and OpenNI2's recorder starts a
            // file's clock at 0: its first frame is reported at 1 ns.
            source_ns: source_us.saturating_mul(1000).max(1),
        }))
    }
}

/// The depth modes of the device at `uri` (also `Dummy`, which device lists omit).
pub fn depth_modes_of(uri: &str) -> Result<Vec<DepthMode>, SourceError> {
    Ok(Device::open(Some(uri))?.depth_modes())
}
