//! Recordings on disk (docs/architecture.md, "Recordings"):
//!
//! ```text
//! DIR/recording.toml     format version, size, fps, intrinsics, depth unit, source
//! DIR/depth/000000.png   16-bit grayscale PNG, millimetres, 0 = no data
//! DIR/frames.csv         index,capture_time_ns
//! DIR/joints.csv         index, then x,y,z of the 16 joints (metres, camera frame), then
//!                        whether each is in the camera's view (1/0; recordings written
//!                        before 2026-12-04 lack these columns: all in view); optional
//! ```
//!
//! Every error names the file, and the frame or line where there is one.

use crate::camera::{Intrinsics, IntrinsicsError};
use crate::depth::DepthView;
use crate::skeleton::{Joint, Skeleton};
use image::codecs::png::{CompressionType, FilterType, PngDecoder, PngEncoder};
use image::{ColorType, ExtendedColorType, ImageDecoder, ImageEncoder};
use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use std::fs::{self, File};
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The format version this build reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// What went wrong with a recording, and where.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// `recording.toml` is missing a value, has a wrong one, or another version.
    #[error("{}: {reason}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// A frame's PNG cannot be used.
    #[error("{}: frame {frame}: {reason}", path.display())]
    Frame {
        /// The PNG.
        path: PathBuf,
        /// Its frame index.
        frame: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A line of a CSV file is wrong.
    #[error("{}:{line}: {reason}", path.display())]
    Csv {
        /// The CSV file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
}

impl RecordingError {
    fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_owned(),
            source,
        }
    }
}

/// `recording.toml`: everything needed to interpret the frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordingInfo {
    /// [`FORMAT_VERSION`] when written; another is refused.
    pub format_version: u32,
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// Nominal frame rate (`frames.csv` has each frame's own time).
    pub fps: f32,
    /// Millimetres per depth unit in the PNGs; airglyph writes 1.0.
    pub depth_unit_mm: f32,
    /// Where the frames came from, e.g. `synthetic`, `openni2:Dummy`.
    pub source: String,
    /// The camera's focal lengths and principal point.
    pub intrinsics: PinholeToml,
}

/// The focal lengths and principal point, as stored in `recording.toml`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PinholeToml {
    /// Horizontal focal length, pixels.
    pub fx: f32,
    /// Vertical focal length, pixels.
    pub fy: f32,
    /// Principal point's column, pixels.
    pub cx: f32,
    /// Principal point's row, pixels.
    pub cy: f32,
}

impl RecordingInfo {
    /// The manifest of frames from a camera with intrinsics `k` at `fps`, in millimetres.
    pub fn new(k: Intrinsics, fps: f32, source: impl Into<String>) -> Self {
        Self {
            format_version: FORMAT_VERSION,
            width: k.width,
            height: k.height,
            fps,
            depth_unit_mm: 1.0,
            source: source.into(),
            intrinsics: PinholeToml {
                fx: k.fx,
                fy: k.fy,
                cx: k.cx,
                cy: k.cy,
            },
        }
    }

    /// The intrinsics at the recording's size.
    pub fn intrinsics(&self) -> Intrinsics {
        let PinholeToml { fx, fy, cx, cy } = self.intrinsics;
        Intrinsics::new(self.width, self.height, fx, fy, cx, cy)
    }

    fn validate(&self) -> Result<(), String> {
        if self.format_version != FORMAT_VERSION {
            return Err(format!(
                "format_version {} is not supported (this build reads version {FORMAT_VERSION})",
                self.format_version
            ));
        }
        self.intrinsics()
            .validate()
            .map_err(|e: IntrinsicsError| e.to_string())?;
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return Err(format!("fps {} must be in (0, 1000]", self.fps));
        }
        if !(self.depth_unit_mm.is_finite() && self.depth_unit_mm > 0.0) {
            return Err(format!(
                "depth_unit_mm {} must be positive",
                self.depth_unit_mm
            ));
        }
        Ok(())
    }
}

/// The path of frame `index`'s PNG inside a recording.
pub fn frame_path(dir: &Path, index: usize) -> PathBuf {
    dir.join("depth").join(format!("{index:06}.png"))
}

/// A recording opened for reading: manifest, timestamps and ground truth are read and
/// checked at open; frames are decoded on demand.
#[derive(Debug)]
pub struct Recording {
    dir: PathBuf,
    info: RecordingInfo,
    capture_ns: Vec<u64>,
    joints: Option<Vec<Skeleton>>,
}

impl Recording {
    /// Opens the recording in `dir`: reads and checks the manifest, `frames.csv` and
    /// `joints.csv` if there is one; the frames are read when asked for.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self, RecordingError> {
        let dir = dir.as_ref().to_owned();
        if !dir.is_dir() {
            return Err(RecordingError::Manifest {
                path: dir,
                reason: "is not a recording directory (no such directory)".into(),
            });
        }
        let manifest = dir.join("recording.toml");
        let text = fs::read_to_string(&manifest).map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                RecordingError::Manifest {
                    path: manifest.clone(),
                    reason: "missing: every recording starts with a recording.toml (for depth \
                             PNGs made elsewhere, write it and frames.csv beside depth/ as \
                             docs/architecture.md, \"Recordings\", shows)"
                        .into(),
                }
            } else {
                RecordingError::io(&manifest, e)
            }
        })?;
        let info: RecordingInfo = toml::from_str(&text).map_err(|e| RecordingError::Manifest {
            path: manifest.clone(),
            reason: e.message().to_owned(),
        })?;
        info.validate().map_err(|reason| RecordingError::Manifest {
            path: manifest,
            reason,
        })?;
        let capture_ns = read_frames_csv(&dir.join("frames.csv"))?;
        let joints_path = dir.join("joints.csv");
        let joints = if joints_path.exists() {
            let joints = read_joints_csv(&joints_path)?;
            if joints.len() != capture_ns.len() {
                return Err(RecordingError::Csv {
                    path: joints_path,
                    line: joints.len() + 1,
                    reason: format!(
                        "has {} frames but frames.csv has {}",
                        joints.len(),
                        capture_ns.len()
                    ),
                });
            }
            Some(joints)
        } else {
            None
        };
        Ok(Self {
            dir,
            info,
            capture_ns,
            joints,
        })
    }

    /// The recording's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Its manifest.
    pub fn info(&self) -> &RecordingInfo {
        &self.info
    }

    /// The camera's intrinsics.
    pub fn intrinsics(&self) -> Intrinsics {
        self.info.intrinsics()
    }

    /// How many frames it has.
    pub fn len(&self) -> usize {
        self.capture_ns.len()
    }

    /// Whether it has no frame.
    pub fn is_empty(&self) -> bool {
        self.capture_ns.is_empty()
    }

    /// Capture time of frame `index`, CLOCK_MONOTONIC ns of the recording machine.
    pub fn capture_ns(&self, index: usize) -> u64 {
        self.capture_ns[index]
    }

    /// Ground-truth skeleton of frame `index`, where the recording has one.
    pub fn joints(&self, index: usize) -> Option<&Skeleton> {
        self.joints.as_ref().map(|j| &j[index])
    }

    /// Whether it has ground-truth joints (`joints.csv`).
    pub fn has_joints(&self) -> bool {
        self.joints.is_some()
    }

    /// Decodes frame `index` straight into `out` (`width × height` pixels, mm).
    pub fn read_frame_into(&self, index: usize, out: &mut [u16]) -> Result<(), RecordingError> {
        let path = frame_path(&self.dir, index);
        let bad = |reason: String| RecordingError::Frame {
            path: path.clone(),
            frame: index,
            reason,
        };
        let (w, h) = (self.info.width, self.info.height);
        if out.len() != w as usize * h as usize {
            return Err(bad(format!(
                "buffer holds {} pixels, the frame {w}x{h}",
                out.len()
            )));
        }
        let file = File::open(&path).map_err(|e| bad(e.to_string()))?;
        let decoder = PngDecoder::new(BufReader::new(file)).map_err(|e| bad(e.to_string()))?;
        match decoder.color_type() {
            ColorType::L16 => {}
            other => {
                return Err(bad(format!(
                    "is {other:?} but depth frames must be 16-bit grayscale (L16) PNG"
                )))
            }
        }
        if decoder.dimensions() != (w, h) {
            let (fw, fh) = decoder.dimensions();
            return Err(bad(format!("is {fw}x{fh} but recording.toml says {w}x{h}")));
        }
        // The decoder writes native-endian u16, so it can fill the caller's buffer as is.
        decoder
            .read_image(bytemuck::cast_slice_mut(out))
            .map_err(|e| {
                bad(format!(
                    "cannot be decoded ({e}); the file may be truncated"
                ))
            })?;
        if self.info.depth_unit_mm != 1.0 {
            let unit = self.info.depth_unit_mm;
            for d in out.iter_mut() {
                *d = (*d as f32 * unit).round().min(u16::MAX as f32) as u16;
            }
        }
        Ok(())
    }

    /// Decodes frame `index` into a new image.
    pub fn read_frame(&self, index: usize) -> Result<crate::DepthImage, RecordingError> {
        let mut px = vec![0; self.info.width as usize * self.info.height as usize];
        self.read_frame_into(index, &mut px)?;
        Ok(crate::DepthImage::new(self.info.width, self.info.height, px).expect("sized above"))
    }
}

fn read_lines(path: &Path) -> Result<Vec<(usize, String)>, RecordingError> {
    let file = File::open(path).map_err(|e| RecordingError::io(path, e))?;
    BufReader::new(file)
        .lines()
        .enumerate()
        .map(|(i, l)| {
            l.map(|l| (i + 1, l)).map_err(|e| RecordingError::Csv {
                path: path.to_owned(),
                line: i + 1,
                reason: e.to_string(),
            })
        })
        .collect()
}

fn read_frames_csv(path: &Path) -> Result<Vec<u64>, RecordingError> {
    let bad = |line, reason: String| RecordingError::Csv {
        path: path.to_owned(),
        line,
        reason,
    };
    let mut times: Vec<u64> = Vec::new();
    for (line, text) in read_lines(path)? {
        let text = text.trim();
        if line == 1 || text.is_empty() {
            if line == 1 && text != "index,capture_time_ns" {
                return Err(bad(
                    1,
                    format!("header is {text:?}, expected \"index,capture_time_ns\""),
                ));
            }
            continue;
        }
        let (index, t) = text
            .split_once(',')
            .ok_or_else(|| bad(line, format!("{text:?} is not \"index,capture_time_ns\"")))?;
        let index: usize = index
            .trim()
            .parse()
            .map_err(|_| bad(line, format!("index {index:?} is not a number")))?;
        let t: u64 = t
            .trim()
            .parse()
            .map_err(|_| bad(line, format!("time {t:?} is not a number of ns")))?;
        if index != times.len() {
            return Err(bad(
                line,
                format!(
                    "frame index {index} follows {} (a gap or a repeat)",
                    times.len() as i64 - 1
                ),
            ));
        }
        if let Some(&prev) = times.last() {
            if t <= prev {
                return Err(bad(
                    line,
                    format!("capture time {t} ns of frame {index} is not after {prev} ns of the frame before"),
                ));
            }
        }
        times.push(t);
    }
    Ok(times)
}

fn joints_header() -> String {
    let mut h = String::from("index");
    for j in Joint::ALL {
        for axis in ["x", "y", "z"] {
            h.push_str(&format!(",{}_{axis}", j.name()));
        }
    }
    h
}

/// The header with the visibility columns, which recordings have had since 2026-12-04.
fn joints_header_with_visibility() -> String {
    let mut h = joints_header();
    for j in Joint::ALL {
        h.push_str(&format!(",{}_visible", j.name()));
    }
    h
}

fn read_joints_csv(path: &Path) -> Result<Vec<Skeleton>, RecordingError> {
    let bad = |line, reason: String| RecordingError::Csv {
        path: path.to_owned(),
        line,
        reason,
    };
    let (plain, with_visibility) = (joints_header(), joints_header_with_visibility());
    let mut columns = 0;
    let mut out = Vec::new();
    for (line, text) in read_lines(path)? {
        let text = text.trim();
        if line == 1 {
            columns = if text == with_visibility {
                1 + 4 * Joint::COUNT
            } else if text == plain {
                1 + 3 * Joint::COUNT
            } else {
                return Err(bad(1, format!("header must be {with_visibility:?}")));
            };
            continue;
        }
        if text.is_empty() {
            continue;
        }
        let fields: Vec<&str> = text.split(',').collect();
        if fields.len() != columns {
            return Err(bad(
                line,
                format!("has {} fields, expected {columns}", fields.len()),
            ));
        }
        if fields[0].trim().parse::<usize>().ok() != Some(out.len()) {
            return Err(bad(
                line,
                format!("index {:?} should be {}", fields[0], out.len()),
            ));
        }
        let mut joints = [Point3::origin(); Joint::COUNT];
        for (j, p) in joints.iter_mut().enumerate() {
            for a in 0..3 {
                let f = fields[1 + 3 * j + a];
                let v: f32 = f
                    .trim()
                    .parse()
                    .ok()
                    .filter(|v: &f32| v.is_finite())
                    .ok_or_else(|| bad(line, format!("{} is not a finite number", f)))?;
                p[a] = v;
            }
        }
        let mut skeleton = Skeleton::new(joints);
        for (j, f) in fields.iter().skip(1 + 3 * Joint::COUNT).enumerate() {
            skeleton.visible[j] = match f.trim() {
                "1" => true,
                "0" => false,
                other => {
                    return Err(bad(
                        line,
                        format!(
                            "{}_visible is {other:?}, expected 1 or 0",
                            Joint::ALL[j].name()
                        ),
                    ))
                }
            };
        }
        out.push(skeleton);
    }
    Ok(out)
}

/// Writes a recording frame by frame. The CSV rows are flushed with every frame, so a
/// writer that is killed leaves a recording readable up to its last whole frame.
pub struct RecordingWriter {
    dir: PathBuf,
    info: RecordingInfo,
    frames: BufWriter<File>,
    joints: Option<BufWriter<File>>,
    written: usize,
    encode_buf: Vec<u8>,
}

impl RecordingWriter {
    /// Creates `dir` (which must not hold a recording already) and its manifest.
    pub fn create(
        dir: impl AsRef<Path>,
        info: RecordingInfo,
        with_joints: bool,
    ) -> Result<Self, RecordingError> {
        let dir = dir.as_ref().to_owned();
        info.validate().map_err(|reason| RecordingError::Manifest {
            path: dir.join("recording.toml"),
            reason,
        })?;
        let manifest = dir.join("recording.toml");
        if manifest.exists() {
            return Err(RecordingError::Manifest {
                path: manifest,
                reason: "already exists: refusing to overwrite a recording".into(),
            });
        }
        let depth = dir.join("depth");
        fs::create_dir_all(&depth).map_err(|e| RecordingError::io(&depth, e))?;
        let text = toml::to_string(&info).expect("RecordingInfo serializes");
        fs::write(&manifest, text).map_err(|e| RecordingError::io(&manifest, e))?;
        let open = |name: &str, header: &str| -> Result<BufWriter<File>, RecordingError> {
            let path = dir.join(name);
            let mut w =
                BufWriter::new(File::create(&path).map_err(|e| RecordingError::io(&path, e))?);
            writeln!(w, "{header}").map_err(|e| RecordingError::io(&path, e))?;
            Ok(w)
        };
        let frames = open("frames.csv", "index,capture_time_ns")?;
        let joints = if with_joints {
            Some(open("joints.csv", &joints_header_with_visibility())?)
        } else {
            None
        };
        Ok(Self {
            dir,
            info,
            frames,
            joints,
            written: 0,
            encode_buf: Vec::new(),
        })
    }

    /// The recording's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.written
    }

    /// Appends one frame. `joints` must be given exactly when the writer was created
    /// with ground truth.
    pub fn write_frame(
        &mut self,
        depth: DepthView<'_>,
        capture_ns: u64,
        joints: Option<&Skeleton>,
    ) -> Result<(), RecordingError> {
        let index = self.written;
        let path = frame_path(&self.dir, index);
        let bad = |reason: String| RecordingError::Frame {
            path: path.clone(),
            frame: index,
            reason,
        };
        if (depth.width(), depth.height()) != (self.info.width, self.info.height) {
            return Err(bad(format!(
                "is {}x{} but the recording is {}x{}",
                depth.width(),
                depth.height(),
                self.info.width,
                self.info.height
            )));
        }
        if self.joints.is_some() != joints.is_some() {
            return Err(bad(
                "ground-truth joints must be given for every frame or for none".into(),
            ));
        }
        self.encode_buf.clear();
        PngEncoder::new_with_quality(&mut self.encode_buf, CompressionType::Fast, FilterType::Up)
            .write_image(
                bytemuck::cast_slice(depth.pixels()),
                depth.width(),
                depth.height(),
                ExtendedColorType::L16,
            )
            .map_err(|e| bad(e.to_string()))?;
        fs::write(&path, &self.encode_buf).map_err(|e| bad(e.to_string()))?;
        let csv = self.dir.join("frames.csv");
        writeln!(self.frames, "{index},{capture_ns}")
            .and_then(|_| self.frames.flush())
            .map_err(|e| RecordingError::io(&csv, e))?;
        if let (Some(w), Some(s)) = (self.joints.as_mut(), joints) {
            let mut row = index.to_string();
            for p in &s.joints {
                row.push_str(&format!(",{:.6},{:.6},{:.6}", p.x, p.y, p.z));
            }
            for v in s.visible {
                row.push_str(if v { ",1" } else { ",0" });
            }
            let csv = self.dir.join("joints.csv");
            writeln!(w, "{row}")
                .and_then(|_| w.flush())
                .map_err(|e| RecordingError::io(&csv, e))?;
        }
        self.written += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DepthImage;

    fn ramp(w: u32, h: u32, seed: u16) -> DepthImage {
        let px = (0..w * h)
            .map(|i| ((i as u16).wrapping_mul(37)).wrapping_add(seed))
            .collect();
        DepthImage::new(w, h, px).unwrap()
    }

    fn write(dir: &Path, n: usize, joints: bool) {
        let k = Intrinsics::new(8, 6, 10.0, 10.0, 3.5, 2.5);
        let mut w =
            RecordingWriter::create(dir, RecordingInfo::new(k, 30.0, "test"), joints).unwrap();
        for i in 0..n {
            let mut s = Skeleton::new([Point3::new(i as f32, 0.5, 2.0); Joint::COUNT]);
            s.joints[3].y = -0.25;
            s.visible[5] = i % 2 == 0;
            w.write_frame(
                ramp(8, 6, i as u16).view(),
                1_000 + i as u64 * 33_333_333,
                joints.then_some(&s),
            )
            .unwrap();
        }
    }

    #[test]
    fn frames_and_ground_truth_round_trip_bit_exact() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 3, true);
        let rec = Recording::open(tmp.path()).unwrap();
        assert_eq!(rec.len(), 3);
        for i in 0..3 {
            assert_eq!(rec.read_frame(i).unwrap(), ramp(8, 6, i as u16));
            assert_eq!(rec.capture_ns(i), 1_000 + i as u64 * 33_333_333);
            let s = rec.joints(i).unwrap();
            assert_eq!(s.joints[0], Point3::new(i as f32, 0.5, 2.0));
            assert_eq!(s.joints[3].y, -0.25);
            assert_eq!(s.visible[5], i % 2 == 0);
            assert_eq!(s.visible.iter().filter(|v| !**v).count(), i % 2);
        }
    }

    #[test]
    fn joints_written_before_visibility_read_as_all_in_view() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 2, true);
        let csv = tmp.path().join("joints.csv");
        // Drop the 16 visibility columns, as recordings before them were written.
        let old: String = fs::read_to_string(&csv)
            .unwrap()
            .lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                f[..1 + 3 * Joint::COUNT].join(",") + "\n"
            })
            .collect();
        fs::write(&csv, old).unwrap();
        let rec = Recording::open(tmp.path()).unwrap();
        assert!(rec.joints(0).unwrap().visible.iter().all(|v| *v));
        // A visibility that is neither 1 nor 0 is named.
        let tmp = tempfile::tempdir().unwrap();
        let csv = tmp.path().join("joints.csv");
        write(tmp.path(), 2, true);
        let text = fs::read_to_string(&csv).unwrap();
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        lines[2] = lines[2].rsplit_once(',').unwrap().0.to_string() + ",yes";
        fs::write(&csv, lines.join("\n")).unwrap();
        let err = Recording::open(tmp.path()).unwrap_err().to_string();
        assert!(
            err.contains("joints.csv:3") && err.contains("right_foot_visible is \"yes\""),
            "{err}"
        );
    }

    #[test]
    fn missing_manifest_is_named() {
        let tmp = tempfile::tempdir().unwrap();
        let err = Recording::open(tmp.path()).unwrap_err().to_string();
        assert!(
            err.contains("recording.toml") && err.contains("missing"),
            "{err}"
        );
        // Where to read how to make one from frames of another program.
        assert!(err.contains("docs/architecture.md"), "{err}");
    }

    #[test]
    fn truncated_png_names_the_file_and_frame() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 2, false);
        let p = frame_path(tmp.path(), 1);
        let bytes = fs::read(&p).unwrap();
        fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
        let rec = Recording::open(tmp.path()).unwrap();
        rec.read_frame(0).unwrap();
        let err = rec.read_frame(1).unwrap_err().to_string();
        assert!(
            err.contains("000001.png") && err.contains("frame 1"),
            "{err}"
        );
    }

    #[test]
    fn eight_bit_png_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 1, false);
        image::GrayImage::new(8, 6)
            .save(frame_path(tmp.path(), 0))
            .unwrap();
        let err = Recording::open(tmp.path())
            .unwrap()
            .read_frame(0)
            .unwrap_err()
            .to_string();
        assert!(err.contains("16-bit") && err.contains("L8"), "{err}");
    }

    #[test]
    fn frames_csv_gap_and_time_going_back_are_refused() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 3, false);
        let csv = tmp.path().join("frames.csv");
        fs::write(&csv, "index,capture_time_ns\n0,10\n2,20\n").unwrap();
        let err = Recording::open(tmp.path()).unwrap_err().to_string();
        assert!(err.contains("frames.csv:3") && err.contains("gap"), "{err}");
        fs::write(&csv, "index,capture_time_ns\n0,10\n1,30\n2,20\n").unwrap();
        let err = Recording::open(tmp.path()).unwrap_err().to_string();
        assert!(
            err.contains("frames.csv:4") && err.contains("not after"),
            "{err}"
        );
    }

    #[test]
    fn a_csv_line_that_is_not_utf8_is_named() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 1, true);
        let csv = tmp.path().join("joints.csv");
        let mut bytes = fs::read(&csv).unwrap();
        bytes.extend_from_slice(b"1,\xff\xfe\n");
        fs::write(&csv, bytes).unwrap();
        let err = Recording::open(tmp.path()).unwrap_err().to_string();
        assert!(
            err.contains("joints.csv:3") && err.contains("UTF-8"),
            "{err}"
        );
    }

    #[test]
    fn writer_refuses_to_overwrite_and_wrong_sizes() {
        let tmp = tempfile::tempdir().unwrap();
        write(tmp.path(), 1, false);
        let k = Intrinsics::new(8, 6, 10.0, 10.0, 3.5, 2.5);
        assert!(
            RecordingWriter::create(tmp.path(), RecordingInfo::new(k, 30.0, "x"), false).is_err()
        );
        let other = tempfile::tempdir().unwrap();
        let mut w =
            RecordingWriter::create(other.path(), RecordingInfo::new(k, 30.0, "x"), false).unwrap();
        assert!(w.write_frame(ramp(4, 4, 0).view(), 0, None).is_err());
    }
}
