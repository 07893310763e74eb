//! Depth to colour: the turbo colour map over the frame's own depth range, so a person
//! a metre away and a wall at six stay distinguishable without a setting.

use airglyph_core::DepthView;
use image::Rgb;
use std::sync::OnceLock;

/// What a pixel without depth (0 mm) is drawn as.
pub const NO_DEPTH: Rgb<u8> = Rgb([0, 0, 0]);

/// 256 samples of turbo (Mikhailov, Google 2019), far (blue) to near (red). Its darkest
/// ends are left out, so the far wall never looks like a hole without depth (black).
fn lut() -> &'static [Rgb<u8>; 256] {
    static LUT: OnceLock<[Rgb<u8>; 256]> = OnceLock::new();
    LUT.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = colorous::TURBO.eval_continuous(0.08 + 0.87 * i as f64 / 255.0);
            Rgb([c.r, c.g, c.b])
        })
    })
}

/// Millimetres per bin of the histogram the range is taken from.
const BIN_MM: u32 = 8;
const BINS: usize = (u16::MAX as u32 / BIN_MM + 1) as usize;

/// The depth range colours are spread over: the 1st to 99th percentile of the frame's
/// valid pixels (a few stray far or near pixels must not squeeze everyone else into one
/// colour). `None` when no pixel has depth.
pub fn depth_range(depth: &DepthView<'_>) -> Option<(u16, u16)> {
    let mut hist = vec![0u32; BINS];
    let mut valid = 0u64;
    for &d in depth.pixels() {
        if d != 0 {
            hist[(d as u32 / BIN_MM) as usize] += 1;
            valid += 1;
        }
    }
    if valid == 0 {
        return None;
    }
    let at = |q: f64| {
        let target = ((valid as f64 * q).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (bin, &n) in hist.iter().enumerate() {
            seen += n as u64;
            if seen >= target {
                return (bin as u32 * BIN_MM) as u16;
            }
        }
        u16::MAX
    };
    let (near, far) = (at(0.01), at(0.99).saturating_add(BIN_MM as u16));
    Some((near, far.max(near + 1)))
}

/// The colour of `mm` in the range (near, far): near is red, far is blue, no depth black.
pub fn colour(mm: u16, (near, far): (u16, u16)) -> Rgb<u8> {
    if mm == 0 {
        return NO_DEPTH;
    }
    let t = (far.saturating_sub(mm)) as u32 * 255 / (far - near).max(1) as u32;
    lut()[t.min(255) as usize]
}

/// Writes the colour-mapped frame into `out` (row-major RGB, as `image::RgbImage`).
pub fn colourize(depth: &DepthView<'_>, out: &mut [u8]) {
    let Some(range) = depth_range(depth) else {
        out.fill(0);
        return;
    };
    for (px, &d) in out.chunks_exact_mut(3).zip(depth.pixels()) {
        px.copy_from_slice(&colour(d, range).0);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn near_is_red_far_is_blue_and_no_depth_is_black() {
        let range = (1000, 3000);
        let near = colour(1000, range);
        let far = colour(3000, range);
        assert!(
            near[0] > 150 && near[0] > 2 * near[1].max(near[2]),
            "near {near:?}"
        );
        assert!(
            far[2] > 150 && far[2] > 2 * far[0].max(far[1]),
            "far {far:?}"
        );
        assert_eq!(colour(0, range), NO_DEPTH);
        // Out of range clamps instead of wrapping round.
        assert_eq!(colour(500, range), near);
        assert_eq!(colour(9000, range), far);
    }

    /// Every colour the depth image can take, for checks that overlays stand out.
    pub(crate) fn all_colours() -> Vec<Rgb<u8>> {
        lut().to_vec()
    }

    #[test]
    fn range_ignores_a_few_outliers_and_empty_frames() {
        let mut px = vec![2000u16; 1000];
        px[0] = 60_000;
        px[1] = 1;
        px[2] = 0;
        let d = DepthView::new(100, 10, &px).unwrap();
        let (near, far) = depth_range(&d).unwrap();
        assert!(near <= 2000 && 2000 < far && far < 2100, "{near}..{far}");
        let empty = vec![0u16; 4];
        assert_eq!(depth_range(&DepthView::new(2, 2, &empty).unwrap()), None);
    }
}
