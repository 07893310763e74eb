//! Skeletons drawn over a depth image (PNG): the quickest way to see a pose bug.

use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use image::{Rgb, RgbImage};
use nalgebra::Point3;

/// The estimate's colour.
pub const GREEN: [u8; 3] = [40, 220, 60];
/// The truth's colour.
pub const RED: [u8; 3] = [240, 40, 40];
/// A third skeleton's colour (the geodesic estimate, say).
pub const BLUE: [u8; 3] = [60, 120, 255];
/// Colour of points marked (maxima, targets).
pub const YELLOW: [u8; 3] = [250, 220, 30];

/// The depth image as gray (near = bright), the person's pixels tinted.
pub fn depth_image(depth: &DepthView, mask: Option<&[bool]>) -> RgbImage {
    let (w, h) = (depth.width(), depth.height());
    let px = depth.pixels();
    let (mut lo, mut hi) = (u16::MAX, 0u16);
    for &d in px {
        if d > 0 {
            lo = lo.min(d);
            hi = hi.max(d);
        }
    }
    let span = (hi.saturating_sub(lo)).max(1) as f32;
    // A mask of another resolution (the estimator's reduced one) is scaled.
    let (mw, mh, mask) = match mask {
        Some(m) if !m.is_empty() => {
            let f = ((px.len() as f32 / m.len() as f32).sqrt().round() as u32).max(1);
            (w / f, h / f, Some((m, f)))
        }
        _ => (0, 0, None),
    };
    RgbImage::from_fn(w, h, |u, v| {
        let i = (v * w + u) as usize;
        let d = px[i];
        if d == 0 {
            return Rgb([0, 0, 40]);
        }
        let g = (235.0 - 200.0 * (d - lo) as f32 / span) as u8;
        let inside = mask.is_some_and(|(m, f)| {
            let (mu, mv) = (u / f, v / f);
            mu < mw && mv < mh && m.get((mv * mw + mu) as usize).copied().unwrap_or(false)
        });
        if inside {
            Rgb([g / 2 + 60, g / 2 + 40, g])
        } else {
            Rgb([g, g, g])
        }
    })
}

fn put(img: &mut RgbImage, x: i32, y: i32, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, Rgb(c));
    }
}

/// A line, `thick` pixels wide.
pub fn line(img: &mut RgbImage, a: (f32, f32), b: (f32, f32), c: [u8; 3], thick: i32) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as i32).clamp(1, 4000);
    for s in 0..=n {
        let t = s as f32 / n as f32;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        for dy in -(thick / 2)..=(thick / 2) {
            for dx in -(thick / 2)..=(thick / 2) {
                put(img, x.round() as i32 + dx, y.round() as i32 + dy, c);
            }
        }
    }
}

/// A filled disc.
pub fn dot(img: &mut RgbImage, p: (f32, f32), r: i32, c: [u8; 3]) {
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy <= r * r {
                put(img, p.0.round() as i32 + dx, p.1.round() as i32 + dy, c);
            }
        }
    }
}

/// Bones and joints of a skeleton; the person's left side drawn with lighter dots.
pub fn skeleton(img: &mut RgbImage, k: &Intrinsics, s: &Skeleton, c: [u8; 3]) {
    let proj = |p: &Point3<f32>| k.project(p).filter(|q| q.0.is_finite() && q.1.is_finite());
    for (a, b) in Joint::BONES {
        if let (Some(pa), Some(pb)) = (proj(&s[a]), proj(&s[b])) {
            line(img, pa, pb, c, 1);
        }
    }
    for j in Joint::ALL {
        if let Some(p) = proj(&s[j]) {
            let left = j.name().starts_with("left");
            dot(img, p, 3, c);
            if left {
                dot(img, p, 1, [255, 255, 255]);
            }
        }
    }
}
