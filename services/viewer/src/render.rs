//! The picture, drawn in one place for the page and for `airglyph snapshot`: the depth
//! image colour-mapped, the skeleton over it, the drawing hand's trail with its Bezier
//! points, the last gestures with their scores and a caption.

use crate::colormap::colourize;
use crate::draw::{disc, line, rect, text, text_height, text_width};
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use image::{Rgb, RgbImage};

// Colours the depth map never takes (it spans turbo's blues, greens, yellows and reds),
// so the overlay stands out on any depth, even after JPEG compression.
pub const BONE: Rgb<u8> = Rgb([255, 255, 255]);
/// A joint the pose stage is sure of (confidence ≥ [`SURE`]).
pub const JOINT: Rgb<u8> = Rgb([255, 0, 255]);
pub const JOINT_UNSURE: Rgb<u8> = Rgb([128, 128, 128]);
pub const TRAIL: Rgb<u8> = Rgb([255, 255, 120]);
pub const BEZIER: Rgb<u8> = Rgb([160, 0, 255]);
pub const TEXT: Rgb<u8> = Rgb([255, 255, 255]);
const PANEL: Rgb<u8> = Rgb([0, 0, 0]);

/// Confidence from which a joint is drawn as sure.
pub const SURE: f32 = 0.5;

/// A recognized gesture as the picture shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct GestureLine {
    pub label: String,
    pub score: f32,
    /// Seconds since it was recognized.
    pub age_s: f32,
}

/// Everything drawn over the depth image. Points are pixels (u right, v down).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overlay {
    pub skeleton: Option<Skeleton>,
    /// The drawing hand's recent positions, oldest first.
    pub trail: Vec<[f32; 2]>,
    /// Points of the Bezier curve whose control points are the trail.
    pub bezier: Vec<[f32; 2]>,
    /// Newest first.
    pub gestures: Vec<GestureLine>,
    pub caption: String,
}

/// Where each joint of `s` lands in the image (`None` behind the camera).
pub fn project_joints(s: &Skeleton, k: &Intrinsics) -> [Option<[f32; 2]>; Joint::COUNT] {
    s.joints.map(|p| k.project(&p).map(|(u, v)| [u, v]))
}

/// The picture of one depth frame with its overlay, as large as the frame.
pub fn render(depth: DepthView<'_>, k: &Intrinsics, o: &Overlay) -> RgbImage {
    let (w, h) = (depth.width(), depth.height());
    let mut img = RgbImage::new(w, h);
    colourize(&depth, &mut img);
    // Line widths and text grow with the image: 1 at 320×240, 2 at 640×480.
    let s = (w / 320).max(1);
    let sf = s as f32;
    if let Some(sk) = &o.skeleton {
        skeleton(&mut img, sk, k, sf);
    }
    trail(&mut img, &o.trail, sf);
    for pair in o.bezier.windows(2) {
        line(&mut img, pair[0], pair[1], sf, BEZIER, 0.8);
    }
    for p in &o.bezier {
        // A white rim keeps the points visible over the trail and over dark depth.
        disc(&mut img, p[0], p[1], 3.0 * sf + 1.0, BONE, 1.0);
        disc(&mut img, p[0], p[1], 3.0 * sf, BEZIER, 1.0);
    }
    gestures(&mut img, &o.gestures, s);
    caption(&mut img, &o.caption, s);
    img
}

/// The picture as PNG, fast compression: what `airglyph snapshot` writes.
pub fn encode_png(img: &RgbImage) -> Result<Vec<u8>, image::ImageError> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )?;
    Ok(out)
}

/// The picture as JPEG of `quality` (1–100): what browsers are sent.
pub fn encode_jpeg(img: &RgbImage, quality: u8) -> Result<Vec<u8>, image::ImageError> {
    use image::codecs::jpeg::JpegEncoder;
    use image::ImageEncoder;
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, quality.clamp(1, 100)).write_image(
        img.as_raw(),
        img.width(),
        img.height(),
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(out)
}

fn skeleton(img: &mut RgbImage, sk: &Skeleton, k: &Intrinsics, sf: f32) {
    let at = project_joints(sk, k);
    for (a, b) in Joint::BONES {
        if let (Some(pa), Some(pb)) = (at[a.index()], at[b.index()]) {
            line(img, pa, pb, 2.0 * sf, BONE, 1.0);
        }
    }
    for j in Joint::ALL {
        if let Some(p) = at[j.index()] {
            let c = if sk.confidence[j.index()] >= SURE {
                JOINT
            } else {
                JOINT_UNSURE
            };
            disc(img, p[0], p[1], 3.0 * sf, c, 1.0);
        }
    }
}

/// The trail fades in from its oldest point, so the direction of drawing shows.
fn trail(img: &mut RgbImage, points: &[[f32; 2]], sf: f32) {
    let n = points.len().max(2) as f32;
    for (i, pair) in points.windows(2).enumerate() {
        let alpha = 0.25 + 0.75 * (i + 1) as f32 / (n - 1.0);
        line(img, pair[0], pair[1], 2.0 * sf, TRAIL, alpha.min(1.0));
    }
}

/// The newest gesture large in the top-left corner with its score and age beside it,
/// the three before it small below: compact, so it hides little of the person.
fn gestures(img: &mut RgbImage, gestures: &[GestureLine], s: u32) {
    let pad = 4 * s as i64;
    let Some((newest, older)) = gestures.split_first() else {
        let t = "no gesture yet";
        rect(
            img,
            0,
            0,
            text_width(t, s) + 2 * pad,
            text_height(s) + 2 * pad,
            PANEL,
            0.55,
        );
        text(img, pad, pad, t, s, TEXT);
        return;
    };
    let big = 4 * s;
    let beside_x = pad + text_width(&newest.label, big) + pad;
    let beside = [format!("score {:.2}", newest.score), age(newest.age_s)];
    let below: Vec<String> = older
        .iter()
        .take(3)
        .map(|g| format!("{} {:.2} {}", g.label, g.score, age(g.age_s)))
        .collect();
    let line = text_height(s) + pad / 2;
    let width = below
        .iter()
        .map(|t| pad + text_width(t, s))
        .chain(beside.iter().map(|t| beside_x + text_width(t, s)))
        .max()
        .unwrap_or(0)
        + pad;
    let top = pad + text_height(big).max(2 * line) + pad / 2;
    rect(
        img,
        0,
        0,
        width,
        top + below.len() as i64 * line + pad / 2,
        PANEL,
        0.55,
    );
    text(img, pad, pad, &newest.label, big, TEXT);
    for (i, t) in beside.iter().enumerate() {
        text(img, beside_x, pad + i as i64 * line, t, s, TEXT);
    }
    for (i, t) in below.iter().enumerate() {
        text(img, pad, top + i as i64 * line, t, s, TEXT);
    }
}

fn age(s: f32) -> String {
    if s < 60.0 {
        format!("{s:.0}s ago")
    } else {
        format!("{:.0}min ago", s / 60.0)
    }
}

fn caption(img: &mut RgbImage, caption: &str, s: u32) {
    if caption.is_empty() {
        return;
    }
    let pad = 3 * s as i64;
    let h = text_height(s) + 2 * pad;
    let y = img.height() as i64 - h;
    rect(img, 0, y, text_width(caption, s) + 2 * pad, h, PANEL, 0.55);
    text(img, pad, y + pad, caption, s, TEXT);
}

#[cfg(test)]
mod tests {
    use super::*;
    use airglyph_gesture::skeleton_with_hand;

    fn wall(k: &Intrinsics, mm: u16) -> Vec<u16> {
        vec![mm; (k.width * k.height) as usize]
    }

    fn count(img: &RgbImage, c: Rgb<u8>) -> usize {
        img.pixels().filter(|p| **p == c).count()
    }

    #[test]
    fn each_joint_is_drawn_where_the_camera_projects_it() {
        let k = Intrinsics::default();
        let mut px = wall(&k, 2500);
        // A nearer band so the colour map has a range to spread.
        px[..(k.width * 20) as usize].fill(1500);
        let depth = DepthView::new(k.width, k.height, &px).unwrap();
        // At 3 m the whole body is in view.
        let mut sk = skeleton_with_hand(0.3, -0.6, 3.0);
        sk.confidence[Joint::LeftFoot.index()] = 0.1;
        let overlay = Overlay {
            skeleton: Some(sk),
            ..Overlay::default()
        };
        let img = render(depth, &k, &overlay);
        assert_eq!(img.dimensions(), (k.width, k.height));
        for j in Joint::ALL {
            let (u, v) = k.project(&sk[j]).unwrap();
            let want = if j == Joint::LeftFoot {
                JOINT_UNSURE
            } else {
                JOINT
            };
            assert_eq!(
                *img.get_pixel(u.round() as u32, v.round() as u32),
                want,
                "{} at ({u:.0}, {v:.0})",
                j.name()
            );
        }
        // Half-way along the neck–head bone: the bone's colour.
        let (hu, hv) = k.project(&sk[Joint::Head]).unwrap();
        let (nu, nv) = k.project(&sk[Joint::Neck]).unwrap();
        let mid = img.get_pixel(((hu + nu) / 2.0) as u32, ((hv + nv) / 2.0) as u32);
        assert_eq!(*mid, BONE);
        // Away from the person: the wall's colour, the same as without a skeleton.
        let bare = render(depth, &k, &Overlay::default());
        assert_eq!(img.get_pixel(600, 200), bare.get_pixel(600, 200));
        assert_eq!(count(&bare, JOINT), 0);
        assert!(count(&img, JOINT) > 15 * 20, "every joint is a disc");
    }

    #[test]
    fn overlay_colours_stand_out_from_every_depth_colour() {
        // Far enough that a JPEG of the picture keeps them apart too (the system test
        // finds the joints in a browser's screenshot by colour).
        for c in [JOINT, JOINT_UNSURE, TRAIL, BEZIER, BONE, TEXT] {
            let nearest = crate::colormap::tests::all_colours()
                .into_iter()
                .map(|d| (0..3).map(|k| c[k].abs_diff(d[k]) as u32).max().unwrap())
                .min()
                .unwrap();
            assert!(nearest >= 60, "{c:?} is within {nearest} of a depth colour");
        }
    }

    #[test]
    fn trail_bezier_and_gestures_are_drawn() {
        let k = Intrinsics::default();
        let px = wall(&k, 2000);
        let depth = DepthView::new(k.width, k.height, &px).unwrap();
        let trail: Vec<[f32; 2]> = (0..30).map(|i| [300.0 + i as f32 * 5.0, 300.0]).collect();
        let overlay = Overlay {
            trail: trail.clone(),
            bezier: vec![[300.0, 300.0], [372.0, 300.0], [445.0, 300.0]],
            gestures: vec![GestureLine {
                label: "7".into(),
                score: 0.83,
                age_s: 2.0,
            }],
            caption: "frame 12".into(),
            ..Overlay::default()
        };
        let img = render(depth, &k, &overlay);
        assert_eq!(*img.get_pixel(372, 300), BEZIER);
        // Beside the Bezier polyline (1 px each side) but on the trail (2 px each side).
        let newest = img.get_pixel(430, 302);
        assert!(
            (0..3).all(|c| newest[c].abs_diff(TRAIL[c]) < 16),
            "the newest trail is nearly opaque: {newest:?}"
        );
        let oldest = img.get_pixel(302, 302);
        assert!(oldest[1] < newest[1] - 50, "the oldest fades: {oldest:?}");
        assert_eq!(*img.get_pixel(400, 320), *img.get_pixel(600, 200));
        // The label "7" at four times 8×8 in the top-left panel, its caption at the bottom.
        let panel_text = (0..60u32)
            .flat_map(|y| (0..60u32).map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) == TEXT)
            .count();
        assert!(panel_text > 100, "{panel_text} label pixels");
        let bottom_text = (k.height - 20..k.height)
            .flat_map(|y| (0..100u32).map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) == TEXT)
            .count();
        assert!(bottom_text > 20, "{bottom_text} caption pixels");
    }

    #[test]
    fn a_small_frame_and_a_skeleton_behind_the_camera_do_not_panic() {
        let k = Intrinsics::default().scaled_to(80, 60);
        let px = vec![0u16; 80 * 60];
        let mut sk = skeleton_with_hand(0.0, 0.0, 2.0);
        sk.joints[Joint::Head.index()].z = -1.0;
        let overlay = Overlay {
            skeleton: Some(sk),
            caption: "a caption far longer than the picture is wide".into(),
            ..Overlay::default()
        };
        let img = render(DepthView::new(80, 60, &px).unwrap(), &k, &overlay);
        assert_eq!(img.dimensions(), (80, 60));
    }
}
