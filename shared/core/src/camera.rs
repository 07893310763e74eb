//! The pinhole camera model: x right, y down, z forward, metres (docs/architecture.md,
//! "Camera frame and joints").

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// The largest width or height of a depth image anywhere in airglyph: 8192 pixels, a
/// 128 MiB frame; every camera made today is below 1920.
pub const MAX_SIDE: u32 = 8192;

/// Pinhole intrinsics of a depth camera, in pixels, for one resolution.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Horizontal focal length, pixels.
    pub fx: f32,
    /// Vertical focal length, pixels.
    pub fy: f32,
    /// Principal point's column, pixels.
    pub cx: f32,
    /// Principal point's row, pixels.
    pub cy: f32,
}

/// Known cameras, so a user names a device instead of typing focal lengths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// Kinect v1 depth at 640×480 (fx ≈ fy ≈ 575.8 px, 57°×43° field of view).
    KinectV1Vga,
    /// Kinect v1 depth at 320×240, the same optics binned 2×2.
    KinectV1Qvga,
    /// Intel RealSense D435 depth at 640×480 (typical factory calibration, 87°×58°).
    RealSenseD435,
}

impl Preset {
    /// Every preset, in the order `--help` lists them.
    pub const ALL: [Preset; 3] = [
        Preset::KinectV1Vga,
        Preset::KinectV1Qvga,
        Preset::RealSenseD435,
    ];

    /// The preset's name on the command line (`intrinsics=NAME`).
    pub fn name(self) -> &'static str {
        match self {
            Preset::KinectV1Vga => "kinect-v1-640x480",
            Preset::KinectV1Qvga => "kinect-v1-320x240",
            Preset::RealSenseD435 => "realsense-d435",
        }
    }

    /// The preset a command-line name names, if any.
    pub fn from_name(name: &str) -> Option<Preset> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The camera's intrinsics at the preset's resolution.
    pub fn intrinsics(self) -> Intrinsics {
        match self {
            Preset::KinectV1Vga => Intrinsics::new(640, 480, 575.8, 575.8, 319.5, 239.5),
            Preset::KinectV1Qvga => Intrinsics::new(320, 240, 287.9, 287.9, 159.5, 119.5),
            Preset::RealSenseD435 => Intrinsics::new(640, 480, 383.0, 383.0, 320.0, 240.0),
        }
    }
}

/// Why a set of intrinsics cannot describe a real camera.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntrinsicsError {
    /// The image is empty or beyond the largest size accepted.
    #[error("image size {width}x{height} is empty or larger than 8192x8192")]
    Size {
        /// The width given.
        width: u32,
        /// The height given.
        height: u32,
    },
    /// A focal length is not finite or out of the accepted range.
    #[error("focal length fx={fx}, fy={fy} must be finite and between 1 and 100000 px")]
    Focal {
        /// The horizontal focal length given.
        fx: f32,
        /// The vertical focal length given.
        fy: f32,
    },
    /// The principal point lies outside the image.
    #[error("principal point ({cx}, {cy}) lies outside the {width}x{height} image")]
    Principal {
        /// Its column.
        cx: f32,
        /// Its row.
        cy: f32,
        /// The image's width.
        width: u32,
        /// The image's height.
        height: u32,
    },
}

impl Intrinsics {
    /// Intrinsics from their six numbers, unchecked (see [`Intrinsics::validate`]).
    pub const fn new(width: u32, height: u32, fx: f32, fy: f32, cx: f32, cy: f32) -> Self {
        Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
        }
    }

    /// Intrinsics from horizontal and vertical fields of view (radians), principal point
    /// at the image centre, as OpenNI2 reports them.
    pub fn from_fov(width: u32, height: u32, hfov: f32, vfov: f32) -> Self {
        let fx = width as f32 / (2.0 * (hfov / 2.0).tan());
        let fy = height as f32 / (2.0 * (vfov / 2.0).tan());
        Self::new(
            width,
            height,
            fx,
            fy,
            (width as f32 - 1.0) / 2.0,
            (height as f32 - 1.0) / 2.0,
        )
    }

    /// The same optics at another resolution (binning or upsampling).
    pub fn scaled_to(&self, width: u32, height: u32) -> Self {
        let sx = width as f32 / self.width as f32;
        let sy = height as f32 / self.height as f32;
        Self::new(
            width,
            height,
            self.fx * sx,
            self.fy * sy,
            (self.cx + 0.5) * sx - 0.5,
            (self.cy + 0.5) * sy - 0.5,
        )
    }

    /// Checks that these numbers can describe a camera; every value read from a file or
    /// from shared memory goes through here before it is used.
    pub fn validate(&self) -> Result<(), IntrinsicsError> {
        let Intrinsics {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
        } = *self;
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(IntrinsicsError::Size { width, height });
        }
        let focal_ok = |f: f32| f.is_finite() && (1.0..=100_000.0).contains(&f);
        if !focal_ok(fx) || !focal_ok(fy) {
            return Err(IntrinsicsError::Focal { fx, fy });
        }
        let inside = |c: f32, n: u32| c.is_finite() && c >= -0.5 && c <= n as f32 - 0.5;
        if !inside(cx, width) || !inside(cy, height) {
            return Err(IntrinsicsError::Principal {
                cx,
                cy,
                width,
                height,
            });
        }
        Ok(())
    }

    /// The point seen at pixel (u, v) at depth `z` metres.
    #[inline]
    pub fn back_project(&self, u: f32, v: f32, z: f32) -> Point3<f32> {
        Point3::new((u - self.cx) * z / self.fx, (v - self.cy) * z / self.fy, z)
    }

    /// The pixel (u, v) a point projects to, or `None` behind the camera.
    #[inline]
    pub fn project(&self, p: &Point3<f32>) -> Option<(f32, f32)> {
        (p.z > 0.0).then(|| (p.x * self.fx / p.z + self.cx, p.y * self.fy / p.z + self.cy))
    }

    /// The side of one pixel, in metres, at depth `z`: what a geodesic edge threshold
    /// scales with.
    #[inline]
    pub fn pixel_footprint(&self, z: f32) -> f32 {
        z * 2.0 / (self.fx + self.fy)
    }
}

impl Default for Intrinsics {
    fn default() -> Self {
        Preset::KinectV1Vga.intrinsics()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_inverts_back_projection() {
        let k = Preset::RealSenseD435.intrinsics();
        let p = k.back_project(100.0, 400.0, 2.5);
        let (u, v) = k.project(&p).unwrap();
        assert!((u - 100.0).abs() < 1e-3 && (v - 400.0).abs() < 1e-3);
    }

    #[test]
    fn presets_are_valid_and_named_uniquely() {
        for p in Preset::ALL {
            p.intrinsics().validate().unwrap();
            assert_eq!(Preset::from_name(p.name()), Some(p));
        }
    }

    #[test]
    fn qvga_kinect_is_the_vga_one_binned() {
        let vga = Preset::KinectV1Vga.intrinsics().scaled_to(320, 240);
        let qvga = Preset::KinectV1Qvga.intrinsics();
        assert!((vga.fx - qvga.fx).abs() < 1e-3 && (vga.cx - qvga.cx).abs() < 1e-3);
    }

    #[test]
    fn bad_intrinsics_are_refused() {
        let k = Intrinsics {
            fx: f32::NAN,
            ..Intrinsics::default()
        };
        assert!(matches!(k.validate(), Err(IntrinsicsError::Focal { .. })));
        let k = Intrinsics {
            cx: 2000.0,
            ..Intrinsics::default()
        };
        assert!(matches!(
            k.validate(),
            Err(IntrinsicsError::Principal { .. })
        ));
        let k = Intrinsics {
            width: 0,
            ..Intrinsics::default()
        };
        assert!(matches!(k.validate(), Err(IntrinsicsError::Size { .. })));
    }

    #[test]
    fn from_fov_matches_kinect_focal_length() {
        let k = Intrinsics::from_fov(640, 480, 1.014_468_6, 0.789_809);
        assert!((k.fx - 575.8).abs() < 1.0, "{}", k.fx);
    }
}
