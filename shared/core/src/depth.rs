//! Depth images: row-major `u16` millimetres, 0 = no data.

use crate::camera::Intrinsics;
use nalgebra::Point3;

/// A `width × height` slice of depth pixels does not have that many pixels.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a {width}x{height} depth image needs {} pixels, got {len}", *width as usize * *height as usize)]
pub struct SizeMismatch {
    /// The width claimed.
    pub width: u32,
    /// The height claimed.
    pub height: u32,
    /// The pixels there are.
    pub len: usize,
}

/// A borrowed depth image, e.g. over a shared-memory sample: no copy is made.
#[derive(Debug, Clone, Copy)]
pub struct DepthView<'a> {
    width: u32,
    height: u32,
    pixels: &'a [u16],
}

/// An owned depth image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DepthImage {
    width: u32,
    height: u32,
    pixels: Vec<u16>,
}

fn check(width: u32, height: u32, len: usize) -> Result<(), SizeMismatch> {
    if width as usize * height as usize == len {
        Ok(())
    } else {
        Err(SizeMismatch { width, height, len })
    }
}

impl<'a> DepthView<'a> {
    /// A view of `pixels` as a `width × height` image; refuses a slice of another length.
    pub fn new(width: u32, height: u32, pixels: &'a [u16]) -> Result<Self, SizeMismatch> {
        check(width, height, pixels.len())?;
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row-major, millimetres, 0 = no data.
    pub fn pixels(&self) -> &'a [u16] {
        self.pixels
    }

    /// Depth at (u, v) in millimetres, 0 where the sensor saw nothing.
    #[inline]
    pub fn get(&self, u: u32, v: u32) -> u16 {
        self.pixels[(v * self.width + u) as usize]
    }

    /// A copy that owns its pixels.
    pub fn to_owned(&self) -> DepthImage {
        DepthImage {
            width: self.width,
            height: self.height,
            pixels: self.pixels.to_vec(),
        }
    }

    /// The organized point cloud of this image: one point per pixel, in metres.
    pub fn back_project(&self, k: &Intrinsics) -> PointCloud {
        let mut points = Vec::with_capacity(self.pixels.len());
        for v in 0..self.height {
            let row = &self.pixels[(v * self.width) as usize..((v + 1) * self.width) as usize];
            for (u, &d) in row.iter().enumerate() {
                points.push(if d == 0 {
                    Point3::origin()
                } else {
                    k.back_project(u as f32, v as f32, d as f32 * 1e-3)
                });
            }
        }
        PointCloud {
            width: self.width,
            height: self.height,
            points,
        }
    }
}

impl DepthImage {
    /// An image of `pixels`; refuses a vector of another length than `width × height`.
    pub fn new(width: u32, height: u32, pixels: Vec<u16>) -> Result<Self, SizeMismatch> {
        check(width, height, pixels.len())?;
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// An image with no data anywhere.
    pub fn empty(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![0; width as usize * height as usize],
        }
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row-major, millimetres, 0 = no data.
    pub fn pixels(&self) -> &[u16] {
        &self.pixels
    }

    /// The pixels, to write into.
    pub fn pixels_mut(&mut self) -> &mut [u16] {
        &mut self.pixels
    }

    /// The pixels, giving the image up (to reuse its buffer).
    pub fn into_pixels(self) -> Vec<u16> {
        self.pixels
    }

    /// A borrowed view of the image.
    pub fn view(&self) -> DepthView<'_> {
        DepthView {
            width: self.width,
            height: self.height,
            pixels: &self.pixels,
        }
    }

    /// The depth at pixel (u, v), millimetres; panics outside the image.
    #[inline]
    pub fn get(&self, u: u32, v: u32) -> u16 {
        self.view().get(u, v)
    }

    /// Sets the depth at pixel (u, v); panics outside the image.
    #[inline]
    pub fn set(&mut self, u: u32, v: u32, mm: u16) {
        self.pixels[(v * self.width + u) as usize] = mm;
    }
}

/// An organized point cloud: point `v * width + u` is what pixel (u, v) saw; pixels
/// without data hold the origin (z = 0), which no real surface can be at.
#[derive(Debug, Clone)]
pub struct PointCloud {
    /// Width of the image the cloud came from.
    pub width: u32,
    /// Height of the image the cloud came from.
    pub height: u32,
    /// One point a pixel, row-major, camera frame, metres.
    pub points: Vec<Point3<f32>>,
}

impl PointCloud {
    /// The point pixel (u, v) saw, or None where it had no depth.
    #[inline]
    pub fn at(&self, u: u32, v: u32) -> Option<&Point3<f32>> {
        let p = &self.points[(v * self.width + u) as usize];
        (p.z > 0.0).then_some(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_refuses_a_payload_of_the_wrong_length() {
        let px = vec![0u16; 10];
        let err = DepthView::new(4, 3, &px).unwrap_err();
        assert_eq!(
            err,
            SizeMismatch {
                width: 4,
                height: 3,
                len: 10
            }
        );
        assert!(err.to_string().contains("needs 12 pixels, got 10"));
    }

    #[test]
    fn back_projection_puts_the_principal_point_on_the_axis() {
        let k = Intrinsics::new(3, 3, 100.0, 100.0, 1.0, 1.0);
        let mut img = DepthImage::empty(3, 3);
        img.set(1, 1, 2000);
        img.set(2, 1, 1000);
        let cloud = img.view().back_project(&k);
        assert_eq!(cloud.at(1, 1).unwrap(), &Point3::new(0.0, 0.0, 2.0));
        assert!((cloud.at(2, 1).unwrap().x - 0.01).abs() < 1e-6);
        assert!(cloud.at(0, 0).is_none());
    }
}
