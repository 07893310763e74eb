//! The few raster primitives the picture needs, on an `image::RgbImage`: thick lines,
//! discs, translucent boxes and 8×8 bitmap text. Written here because they are a few
//! lines each; plotters' bitmap backend could draw the shapes, but its text needs the
//! system's fonts, which a headless device may not have.

use font8x8::UnicodeFonts;
use image::{Rgb, RgbImage};

/// Blends `c` over the pixel at (x, y) with opacity `alpha` in [0, 1]; outside the image
/// nothing happens (overlays may reach past the border).
pub fn blend(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>, alpha: f32) {
    if x < 0 || y < 0 || x >= img.width() as i64 || y >= img.height() as i64 {
        return;
    }
    let p = img.get_pixel_mut(x as u32, y as u32);
    if alpha >= 1.0 {
        *p = c;
        return;
    }
    let a = alpha.clamp(0.0, 1.0);
    for k in 0..3 {
        p[k] = (p[k] as f32 * (1.0 - a) + c[k] as f32 * a).round() as u8;
    }
}

/// A filled disc of radius `r` pixels centred on (cx, cy).
pub fn disc(img: &mut RgbImage, cx: f32, cy: f32, r: f32, c: Rgb<u8>, alpha: f32) {
    if !(cx.is_finite() && cy.is_finite()) {
        return;
    }
    let (x0, x1) = ((cx - r).floor() as i64, (cx + r).ceil() as i64);
    let (y0, y1) = ((cy - r).floor() as i64, (cy + r).ceil() as i64);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            if dx * dx + dy * dy <= r * r {
                blend(img, x, y, c, alpha);
            }
        }
    }
}

/// A line `width` pixels wide from a to b: every pixel within width/2 of the segment.
pub fn line(img: &mut RgbImage, a: [f32; 2], b: [f32; 2], width: f32, c: Rgb<u8>, alpha: f32) {
    if !a.iter().chain(&b).all(|v| v.is_finite()) {
        return;
    }
    let h = width / 2.0;
    let (x0, x1) = (a[0].min(b[0]) - h, a[0].max(b[0]) + h);
    let (y0, y1) = (a[1].min(b[1]) - h, a[1].max(b[1]) + h);
    // Clip the box to the image: a joint projected far outside must not cost a scan of
    // millions of pixels.
    let (w, ht) = (img.width() as f32, img.height() as f32);
    let (x0, x1) = (x0.max(0.0).floor() as i64, x1.min(w - 1.0).ceil() as i64);
    let (y0, y1) = (y0.max(0.0).floor() as i64, y1.min(ht - 1.0).ceil() as i64);
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (px, py) = (x as f32 - a[0], y as f32 - a[1]);
            let t = if len2 > 0.0 {
                ((px * dx + py * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (ex, ey) = (px - t * dx, py - t * dy);
            if ex * ex + ey * ey <= h * h {
                blend(img, x, y, c, alpha);
            }
        }
    }
}

/// A filled rectangle.
pub fn rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, c: Rgb<u8>, alpha: f32) {
    for yy in y.max(0)..(y + h).min(img.height() as i64) {
        for xx in x.max(0)..(x + w).min(img.width() as i64) {
            blend(img, xx, yy, c, alpha);
        }
    }
}

/// Glyph height in pixels at `scale` (glyphs are 8×8 cells).
pub fn text_height(scale: u32) -> i64 {
    8 * scale as i64
}

/// Width of `s` in pixels at `scale`.
pub fn text_width(s: &str, scale: u32) -> i64 {
    s.chars().count() as i64 * 8 * scale as i64
}

/// Draws `s` with its top-left corner at (x, y), each font pixel `scale` pixels square.
/// Characters outside Basic Latin are drawn as '?'.
pub fn text(img: &mut RgbImage, x: i64, y: i64, s: &str, scale: u32, c: Rgb<u8>) {
    let scale = scale.max(1) as i64;
    for (i, ch) in s.chars().enumerate() {
        let glyph = font8x8::BASIC_FONTS
            .get(ch)
            .or_else(|| font8x8::BASIC_FONTS.get('?'))
            .unwrap_or([0; 8]);
        let gx = x + i as i64 * 8 * scale;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                // font8x8 stores each row least significant bit first (leftmost pixel).
                if bits >> col & 1 == 1 {
                    for sy in 0..scale {
                        for sx in 0..scale {
                            blend(
                                img,
                                gx + col * scale + sx,
                                y + row as i64 * scale + sy,
                                c,
                                1.0,
                            );
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: Rgb<u8> = Rgb([255, 0, 0]);

    fn count(img: &RgbImage, c: Rgb<u8>) -> usize {
        img.pixels().filter(|p| **p == c).count()
    }

    #[test]
    fn a_line_covers_its_segment_and_width_only() {
        let mut img = RgbImage::new(40, 20);
        line(&mut img, [5.0, 10.0], [34.0, 10.0], 3.0, RED, 1.0);
        assert_eq!(*img.get_pixel(5, 10), RED);
        assert_eq!(*img.get_pixel(20, 11), RED);
        assert_eq!(*img.get_pixel(20, 13), Rgb([0, 0, 0]));
        assert_eq!(*img.get_pixel(37, 10), Rgb([0, 0, 0]));
        // 30 columns of 3 pixels, and round caps one pixel past each end.
        assert_eq!(count(&img, RED), 32 * 3);
    }

    #[test]
    fn shapes_past_the_border_or_not_finite_are_clipped_not_panics() {
        let mut img = RgbImage::new(10, 10);
        line(&mut img, [-1e9, -1e9], [1e9, 1e9], 2.0, RED, 1.0);
        disc(&mut img, 9.0, 9.0, 3.0, RED, 1.0);
        disc(&mut img, f32::NAN, 1.0, 3.0, RED, 1.0);
        line(&mut img, [f32::INFINITY, 0.0], [1.0, 1.0], 2.0, RED, 1.0);
        rect(&mut img, -5, -5, 100, 2, RED, 0.5);
        text(&mut img, 8, 8, "Ω", 3, RED);
        assert!(count(&img, RED) > 0);
    }

    #[test]
    fn blending_mixes_and_text_draws_glyph_pixels() {
        let mut img = RgbImage::from_pixel(2, 1, Rgb([0, 0, 200]));
        blend(&mut img, 0, 0, RED, 0.5);
        assert_eq!(*img.get_pixel(0, 0), Rgb([128, 0, 100]));
        let mut img = RgbImage::new(16, 8);
        text(&mut img, 0, 0, "I", 1, RED);
        // font8x8's 'I' starts with a bar over columns 1–4 (0x1E, leftmost bit first).
        assert_eq!(*img.get_pixel(1, 0), RED);
        assert_eq!(*img.get_pixel(4, 0), RED);
        assert_eq!(*img.get_pixel(0, 0), Rgb([0, 0, 0]));
        assert_eq!(*img.get_pixel(5, 0), Rgb([0, 0, 0]));
        assert_eq!(text_width("ab", 2), 32);
    }
}
