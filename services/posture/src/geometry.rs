//! Small pieces of camera geometry the other modules share.

use airglyph_core::{DepthView, Intrinsics};
use nalgebra::Point3;

/// The depth at (`u`, `v`) in metres, or `None` where the sensor saw nothing or the
/// pixel is outside the image.
pub(crate) fn pixel_at(depth: DepthView<'_>, u: u32, v: u32) -> Option<f32> {
    if u >= depth.width() || v >= depth.height() {
        return None;
    }
    let mm = depth.pixels()[(v * depth.width() + u) as usize];
    (mm > 0).then(|| mm as f32 / 1000.0)
}

/// The point seen at the centre of pixel (`u`, `v`) at depth `z` metres.
pub(crate) fn back_project(k: &Intrinsics, u: u32, v: u32, z: f32) -> Point3<f32> {
    k.back_project(u as f32, v as f32, z)
}
