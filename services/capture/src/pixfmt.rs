//! Depth pixel formats as V4L2 drivers deliver them, converted to millimetres.
//!
//! Pure Rust and compiled without any camera feature, so every conversion is tested on
//! buffers laid out as the drivers lay them out: rows `stride` (V4L2's `bytesperline`)
//! bytes apart, with padding after each row that must never leak into the image.

use serde::Serialize;

/// A depth format airglyph can read from a V4L2 device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum DepthFormat {
    /// `Z16 `: 16-bit little-endian depth (RealSense and most UVC depth cameras), in the
    /// camera's depth unit (1 mm unless the device says otherwise: see `scale`).
    Z16,
    /// `Y16 `: 16-bit little-endian grey, which depth cameras without a Z16 code (e.g.
    /// Orbbec, some ToF modules) use for depth in millimetres.
    Y16,
    /// `Y10B`: the Kinect v1's disparity through the gspca `kinect` driver in depth mode
    /// (`depth_mode=1`): 10 bits a pixel, packed big-endian, converted to millimetres with
    /// the OpenKinect disparity fit (approximate: calibrate with `scale` if it matters).
    KinectY10B,
}

impl DepthFormat {
    /// Every format this build converts.
    pub const ALL: [DepthFormat; 3] = [DepthFormat::Z16, DepthFormat::Y16, DepthFormat::KinectY10B];

    /// The V4L2 four-character code.
    pub fn fourcc(self) -> [u8; 4] {
        match self {
            DepthFormat::Z16 => *b"Z16 ",
            DepthFormat::Y16 => *b"Y16 ",
            DepthFormat::KinectY10B => *b"Y10B",
        }
    }

    /// The format of a V4L2 four-character code, if it is a depth format we convert.
    pub fn from_fourcc(code: &[u8; 4]) -> Option<Self> {
        Self::ALL.into_iter().find(|f| &f.fourcc() == code)
    }

    /// Short name for listings and `format=` in a source spec.
    pub fn name(self) -> &'static str {
        match self {
            DepthFormat::Z16 => "Z16",
            DepthFormat::Y16 => "Y16",
            DepthFormat::KinectY10B => "Y10B",
        }
    }

    /// The format named `name` in `format=` (`Z16`, `Y16`, `Y10B`), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(name.trim()))
    }

    /// Bytes of pixel data in one row of `width` pixels (without the driver's padding).
    pub fn row_bytes(self, width: u32) -> usize {
        match self {
            DepthFormat::Z16 | DepthFormat::Y16 => width as usize * 2,
            DepthFormat::KinectY10B => (width as usize * 10).div_ceil(8),
        }
    }

    /// Preference when a device offers several: real depth codes first.
    pub fn rank(self) -> u8 {
        match self {
            DepthFormat::Z16 => 0,
            DepthFormat::Y16 => 1,
            DepthFormat::KinectY10B => 2,
        }
    }
}

/// Where the pixels are in a driver's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Bytes from the start of one row to the next (`bytesperline`); 0 means packed rows.
    pub stride: usize,
}

/// Why a buffer cannot be converted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PixError {
    #[error(
        "{format:?} rows of {width} pixels need {need} bytes but the driver's stride is {stride}"
    )]
    /// A row of the buffer is shorter than a row of pixels.
    Stride {
        /// The pixel format.
        format: DepthFormat,
        /// The frame's width.
        width: u32,
        /// The driver's stride, bytes.
        stride: usize,
        /// The bytes a row needs.
        need: usize,
    },
    /// The buffer holds less than a frame.
    #[error("the driver delivered {got} bytes, a {width}x{height} {format:?} frame needs {need}")]
    Short {
        /// The pixel format.
        format: DepthFormat,
        /// The frame's width.
        width: u32,
        /// The frame's height.
        height: u32,
        /// Bytes delivered.
        got: usize,
        /// Bytes a frame needs.
        need: usize,
    },
    /// The output buffer is not the frame's size.
    #[error("the output buffer holds {got} pixels, the frame has {need}")]
    Output {
        /// Pixels the output holds.
        got: usize,
        /// Pixels the frame has.
        need: usize,
    },
    /// The depth scale cannot convert.
    #[error("depth scale {0} must be finite and positive")]
    Scale(f32),
}

/// Kinect v1 disparity (11-bit scale) to millimetres, OpenKinect's fit; 0 for no data.
pub fn kinect_disparity_to_mm(raw11: u16) -> u16 {
    if raw11 >= 2047 {
        return 0;
    }
    let denom = 3.330_949_5_f64 - 0.003_071_101_6 * raw11 as f64;
    if denom <= 0.0 {
        return 0;
    }
    let mm = 1000.0 / denom;
    if !(0.0..65535.0).contains(&mm) {
        0
    } else {
        mm.round() as u16
    }
}

fn scaled(v: u16, scale: f32) -> u16 {
    let x = (v as f32 * scale).round();
    if x >= 65535.0 {
        65535
    } else {
        x as u16
    }
}

/// Converts one frame to millimetres into `out` (`width × height`, row-major).
/// `scale` multiplies the format's native unit (1.0: Z16/Y16 are millimetres).
pub fn to_millimetres(
    format: DepthFormat,
    layout: Layout,
    src: &[u8],
    scale: f32,
    out: &mut [u16],
) -> Result<(), PixError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(PixError::Scale(scale));
    }
    let (w, h) = (layout.width as usize, layout.height as usize);
    let row = format.row_bytes(layout.width);
    let stride = if layout.stride == 0 {
        row
    } else {
        layout.stride
    };
    if stride < row {
        return Err(PixError::Stride {
            format,
            width: layout.width,
            stride,
            need: row,
        });
    }
    // The last row needs no padding after it: drivers may or may not deliver it.
    let need = if h == 0 { 0 } else { stride * (h - 1) + row };
    if src.len() < need {
        return Err(PixError::Short {
            format,
            width: layout.width,
            height: layout.height,
            got: src.len(),
            need,
        });
    }
    if out.len() != w * h {
        return Err(PixError::Output {
            got: out.len(),
            need: w * h,
        });
    }
    for (y, dst) in out.chunks_exact_mut(w.max(1)).take(h).enumerate() {
        let line = &src[y * stride..y * stride + row];
        match format {
            DepthFormat::Z16 | DepthFormat::Y16 => {
                for (d, b) in dst.iter_mut().zip(line.chunks_exact(2)) {
                    let v = u16::from_le_bytes([b[0], b[1]]);
                    *d = if scale == 1.0 { v } else { scaled(v, scale) };
                }
            }
            DepthFormat::KinectY10B => {
                for (x, d) in dst.iter_mut().enumerate() {
                    let raw = read_bits_be(line, x * 10, 10);
                    // 1023 is the sensor's "no reading"; the 10-bit mode drops the LSB of
                    // the 11-bit disparity.
                    let mm = if raw >= 1023 {
                        0
                    } else {
                        kinect_disparity_to_mm(raw << 1)
                    };
                    *d = if scale == 1.0 { mm } else { scaled(mm, scale) };
                }
            }
        }
    }
    Ok(())
}

/// `n` (≤ 16) bits starting at bit `bit` of a big-endian bit stream.
fn read_bits_be(bytes: &[u8], bit: usize, n: usize) -> u16 {
    let mut v: u32 = 0;
    let first = bit / 8;
    // Three bytes always cover 10 bits at any offset.
    for i in 0..3 {
        v = (v << 8) | *bytes.get(first + i).unwrap_or(&0) as u32;
    }
    let shift = 24 - (bit % 8) - n;
    ((v >> shift) & ((1u32 << n) - 1)) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAD: u8 = 0xAB;

    /// Packs 10-bit values big-endian, as the gspca kinect driver delivers them.
    fn pack_y10b(values: &[u16]) -> Vec<u8> {
        let mut out = vec![0u8; (values.len() * 10).div_ceil(8)];
        for (i, &v) in values.iter().enumerate() {
            for b in 0..10 {
                if v & (1 << (9 - b)) != 0 {
                    let bit = i * 10 + b;
                    out[bit / 8] |= 0x80 >> (bit % 8);
                }
            }
        }
        out
    }

    /// A driver buffer: each row's pixel bytes, then padding up to `stride`.
    fn with_stride(rows: &[Vec<u8>], stride: usize, last_padded: bool) -> Vec<u8> {
        let mut buf = Vec::new();
        for (i, r) in rows.iter().enumerate() {
            buf.extend_from_slice(r);
            if i + 1 < rows.len() || last_padded {
                buf.resize(buf.len() + stride - r.len(), PAD);
            }
        }
        buf
    }

    fn depth_rows(w: usize, h: usize) -> Vec<Vec<u16>> {
        (0..h)
            .map(|y| (0..w).map(|x| (400 + y * 97 + x * 13) as u16).collect())
            .collect()
    }

    #[test]
    fn z16_and_y16_with_padded_rows_are_read_little_endian_and_padding_ignored() {
        for format in [DepthFormat::Z16, DepthFormat::Y16] {
            // A RealSense-like 848-wide row padded to 1728 bytes, and an odd tiny size.
            for (w, h, stride) in [(848usize, 3usize, 1728usize), (5, 4, 16), (7, 2, 14)] {
                let rows = depth_rows(w, h);
                let bytes: Vec<Vec<u8>> = rows
                    .iter()
                    .map(|r| r.iter().flat_map(|v| v.to_le_bytes()).collect())
                    .collect();
                for last_padded in [true, false] {
                    let buf = with_stride(&bytes, stride, last_padded);
                    let mut out = vec![0u16; w * h];
                    let layout = Layout {
                        width: w as u32,
                        height: h as u32,
                        stride,
                    };
                    to_millimetres(format, layout, &buf, 1.0, &mut out).unwrap();
                    assert_eq!(out, rows.concat(), "{format:?} {w}x{h} stride {stride}");
                }
            }
        }
    }

    #[test]
    fn z16_scale_converts_device_units() {
        // A D405 reports depth in 0.1 mm units.
        let buf: Vec<u8> = [10000u16, 12345, 0, 65535]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let mut out = [0u16; 4];
        let layout = Layout {
            width: 4,
            height: 1,
            stride: 0,
        };
        to_millimetres(DepthFormat::Z16, layout, &buf, 0.1, &mut out).unwrap();
        assert_eq!(out, [1000, 1235, 0, 6554]);
        to_millimetres(DepthFormat::Z16, layout, &buf, 2.0, &mut out).unwrap();
        assert_eq!(out[3], 65535, "saturates");
        assert!(to_millimetres(DepthFormat::Z16, layout, &buf, f32::NAN, &mut out).is_err());
    }

    #[test]
    fn kinect_y10b_unpacks_big_endian_bits_per_row() {
        // The driver's own layout: 640 px, bytesperline = 800, no padding.
        let (w, h) = (640usize, 3usize);
        let raw: Vec<Vec<u16>> = (0..h)
            .map(|y| (0..w).map(|x| ((x * 3 + y * 200) % 1024) as u16).collect())
            .collect();
        let rows: Vec<Vec<u8>> = raw.iter().map(|r| pack_y10b(r)).collect();
        assert_eq!(rows[0].len(), 800);
        let buf = with_stride(&rows, 800, false);
        let mut out = vec![0u16; w * h];
        let layout = Layout {
            width: w as u32,
            height: h as u32,
            stride: 800,
        };
        to_millimetres(DepthFormat::KinectY10B, layout, &buf, 1.0, &mut out).unwrap();
        for (i, &r) in raw.concat().iter().enumerate() {
            let want = if r >= 1023 {
                0
            } else {
                kinect_disparity_to_mm(r << 1)
            };
            assert_eq!(out[i], want, "pixel {i} raw {r}");
        }
        // A width whose rows do not end on a byte, padded to 4-byte alignment.
        let (w, h, stride) = (6usize, 2usize, 12usize);
        let raw: Vec<Vec<u16>> = vec![vec![1023, 0, 300, 511, 600, 1], vec![5, 6, 7, 8, 9, 1022]];
        let rows: Vec<Vec<u8>> = raw.iter().map(|r| pack_y10b(r)).collect();
        let buf = with_stride(&rows, stride, true);
        let mut out = vec![7u16; w * h];
        let layout = Layout {
            width: w as u32,
            height: h as u32,
            stride,
        };
        to_millimetres(DepthFormat::KinectY10B, layout, &buf, 1.0, &mut out).unwrap();
        assert_eq!(out[0], 0, "1023 is no reading");
        assert_eq!(out[2], kinect_disparity_to_mm(600));
        assert_eq!(out[11], kinect_disparity_to_mm(2044));
    }

    #[test]
    fn kinect_fit_gives_plausible_distances() {
        // Disparity ~ 750 (11-bit) is about 1 m, ~ 900 about 2 m for a Kinect v1.
        let one = kinect_disparity_to_mm(750);
        let two = kinect_disparity_to_mm(900);
        assert!((900..1100).contains(&one), "{one}");
        assert!((1700..2400).contains(&two), "{two}");
        assert_eq!(kinect_disparity_to_mm(2047), 0);
    }

    #[test]
    fn bad_buffers_are_errors_not_panics() {
        let layout = Layout {
            width: 4,
            height: 2,
            stride: 6,
        };
        let mut out = vec![0u16; 8];
        assert!(matches!(
            to_millimetres(DepthFormat::Z16, layout, &[0; 100], 1.0, &mut out),
            Err(PixError::Stride { need: 8, .. })
        ));
        let layout = Layout {
            width: 4,
            height: 2,
            stride: 8,
        };
        let err = to_millimetres(DepthFormat::Z16, layout, &[0; 15], 1.0, &mut out).unwrap_err();
        assert!(err.to_string().contains("needs 16"), "{err}");
        assert!(matches!(
            to_millimetres(DepthFormat::Z16, layout, &[0; 16], 1.0, &mut out[..7]),
            Err(PixError::Output { .. })
        ));
        let empty = Layout {
            width: 0,
            height: 0,
            stride: 0,
        };
        to_millimetres(DepthFormat::KinectY10B, empty, &[], 1.0, &mut []).unwrap();
    }

    #[test]
    fn fourcc_and_names_round_trip() {
        for f in DepthFormat::ALL {
            assert_eq!(DepthFormat::from_fourcc(&f.fourcc()), Some(f));
            assert_eq!(DepthFormat::from_name(f.name()), Some(f));
        }
        assert_eq!(DepthFormat::from_fourcc(b"YUYV"), None);
    }
}
