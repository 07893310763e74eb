//! The picture, drawn in one place for the page and for `airglyph snapshot`: the depth
//! image colour-mapped, the skeleton over it, the recognizer's view of the drawing hand
//! (its path and the last gesture's Bezier points, in the body frame the gesture stage
//! measures in), each hand's posture beside it, the last gestures with their scores
//! and a caption.

use crate::colormap::colourize;
use crate::draw::{disc, line, rect, text, text_height, text_width};
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use image::{Rgb, RgbImage};

// Colours the depth map never takes (it spans turbo's blues, greens, yellows and reds),
// so the overlay stands out on any depth, even after JPEG compression.
/// A bone.
pub const BONE: Rgb<u8> = Rgb([255, 255, 255]);
/// A joint the pose stage is sure of (confidence ≥ [`SURE`]).
pub const JOINT: Rgb<u8> = Rgb([255, 0, 255]);
/// A joint the pose stage is unsure of.
pub const JOINT_UNSURE: Rgb<u8> = Rgb([128, 128, 128]);
/// The hand's path as the recognizer took it.
pub const TRAIL: Rgb<u8> = Rgb([255, 255, 120]);
/// The last gesture's Bezier points.
pub const BEZIER: Rgb<u8> = Rgb([160, 0, 255]);
/// Text.
pub const TEXT: Rgb<u8> = Rgb([255, 255, 255]);
const PANEL: Rgb<u8> = Rgb([0, 0, 0]);

/// Confidence from which a joint is drawn as sure.
pub const SURE: f32 = 0.5;

/// A recognized gesture as the picture shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct GestureLine {
    /// The symbol.
    pub label: String,
    /// The classifier's confidence, 0–1.
    pub score: f32,
    /// Seconds since it was recognized.
    pub age_s: f32,
}

/// A hand's posture as the picture shows it: beside the hand joint.
#[derive(Debug, Clone, PartialEq)]
pub struct HandPosture {
    /// The hand joint it is drawn beside.
    pub joint: Joint,
    /// The posture model's label.
    pub label: String,
    /// The classifier's confidence, 0–1.
    pub confidence: f32,
}

/// Everything drawn over the depth image.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overlay {
    /// The skeleton estimated from the frame (camera frame, drawn where it projects).
    pub skeleton: Option<Skeleton>,
    /// The postures of the skeleton's hands that were classified.
    pub postures: Vec<HandPosture>,
    /// The drawing hand's recent path as the gesture stage's recognizer took it, oldest
    /// first: body frame (x to the person's right, y down, shoulder widths).
    pub trail: Vec<[f32; 2]>,
    /// The last gesture's Bezier points, in the same frame.
    pub bezier: Vec<[f32; 2]>,
    /// Newest first.
    pub gestures: Vec<GestureLine>,
    /// A line at the bottom: the frame, its size, whether a person was found.
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
        postures(&mut img, sk, &o.postures, k, s);
    }
    recognizer(&mut img, &o.trail, &o.bezier, s);
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

/// Each posture's label and confidence on a dark tag up and to the side of its hand:
/// away from the other hand when both are tagged (hands held together, or crossed, do
/// not stack their tags), else away from the body (a right hand's is to the image's
/// left); a tag that would still cover the other goes above it; all inside the picture.
fn postures(img: &mut RgbImage, sk: &Skeleton, postures: &[HandPosture], k: &Intrinsics, s: u32) {
    let pad = 2 * s as i64;
    let size = (img.width() as i64, img.height() as i64);
    for (t, [x, y, w, h]) in posture_tags(sk, postures, k, s, size) {
        rect(img, x, y, w, h, PANEL, 0.7);
        text(img, x + pad, y + pad, &t, s, TEXT);
    }
}

/// Each tag's text and rectangle (x, y, width, height) in a picture of `size`.
fn posture_tags(
    sk: &Skeleton,
    postures: &[HandPosture],
    k: &Intrinsics,
    s: u32,
    size: (i64, i64),
) -> Vec<(String, [i64; 4])> {
    let pad = 2 * s as i64;
    let gap = 6 * s as i64;
    let at: Vec<Option<(f32, f32)>> = postures.iter().map(|p| k.project(&sk[p.joint])).collect();
    let mut placed: Vec<(String, [i64; 4])> = Vec::new();
    for (i, p) in postures.iter().enumerate() {
        let Some((u, v)) = at[i] else {
            continue;
        };
        let t = format!("{} {:.2}", p.label, p.confidence);
        let (w, h) = (text_width(&t, s) + 2 * pad, text_height(s) + 2 * pad);
        let other_u = at
            .iter()
            .enumerate()
            .find_map(|(j, a)| a.filter(|_| j != i).map(|(ou, _)| ou));
        let leftwards = match other_u {
            Some(ou) => u < ou || (u == ou && p.joint == Joint::RightHand),
            None => p.joint == Joint::RightHand,
        };
        let x = if leftwards {
            u as i64 - gap - w
        } else {
            u as i64 + gap
        };
        let x = x.clamp(0, (size.0 - w).max(0));
        let mut y = (v as i64 - gap - h).clamp(0, (size.1 - h).max(0));
        for (_, r) in &placed {
            if x < r[0] + r[2] && r[0] < x + w && y < r[1] + r[3] && r[1] < y + h {
                // Above the other, or below it where there is no room above.
                y = if r[1] - h - pad >= 0 {
                    r[1] - h - pad
                } else {
                    r[1] + r[3] + pad
                };
            }
        }
        placed.push((t, [x, y, w, h]));
    }
    placed
}

/// The path fades in from its oldest point, so the direction of drawing shows.
fn path(img: &mut RgbImage, points: &[[f32; 2]], sf: f32) {
    let n = points.len().max(2) as f32;
    for (i, pair) in points.windows(2).enumerate() {
        let alpha = 0.25 + 0.75 * (i + 1) as f32 / (n - 1.0);
        line(img, pair[0], pair[1], 2.0 * sf, TRAIL, alpha.min(1.0));
    }
}

/// Smallest extent the recognizer's panel shows, in shoulder widths: a resting hand's
/// jitter is not blown up to fill the panel.
const MIN_EXTENT: f32 = 1.0;

/// The recognizer's view in a square panel in the top-right corner: the hand's path in
/// the body frame the gesture stage measures it in (x to the person's right, y down, so
/// a symbol reads as drawn), fading into the past, and the last gesture's Bezier points
/// in the same frame; scaled to fit what is shown.
fn recognizer(img: &mut RgbImage, trail: &[[f32; 2]], bezier: &[[f32; 2]], s: u32) {
    let Some(fit) = Fit::of(trail.iter().chain(bezier)) else {
        return;
    };
    let sf = s as f32;
    let pad = 4 * s as i64;
    let side = (img.height() / 3) as i64;
    let (x0, y0) = (img.width() as i64 - side - pad, pad);
    rect(img, x0, y0, side, side, PANEL, 0.55);
    text(img, x0 + pad, y0 + pad, "recognizer", s, TEXT);
    let inner = side as f32 - 2.0 * (pad as f32 + text_height(s) as f32);
    let centre = [x0 as f32 + side as f32 / 2.0, y0 as f32 + side as f32 / 2.0];
    let at = |p: &[f32; 2]| fit.place(p, centre, inner);
    let trail: Vec<[f32; 2]> = trail.iter().map(at).collect();
    path(img, &trail, sf);
    let bezier: Vec<[f32; 2]> = bezier.iter().map(at).collect();
    for pair in bezier.windows(2) {
        line(img, pair[0], pair[1], sf, BEZIER, 0.8);
    }
    for p in &bezier {
        // A white rim keeps the points visible over the trail and over the panel.
        disc(img, p[0], p[1], 2.0 * sf + 1.0, BONE, 1.0);
        disc(img, p[0], p[1], 2.0 * sf, BEZIER, 1.0);
    }
}

/// Where body-frame points go in the recognizer's panel: their bounding box's centre at
/// the panel's, its larger side (at least [`MIN_EXTENT`]) across the panel.
struct Fit {
    centre: [f32; 2],
    extent: f32,
}

impl Fit {
    fn of<'a>(points: impl Iterator<Item = &'a [f32; 2]>) -> Option<Self> {
        let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
        let mut any = false;
        for p in points.filter(|p| p.iter().all(|v| v.is_finite())) {
            any = true;
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        any.then(|| Self {
            centre: [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0],
            extent: (hi[0] - lo[0]).max(hi[1] - lo[1]).max(MIN_EXTENT),
        })
    }

    fn place(&self, p: &[f32; 2], centre: [f32; 2], side: f32) -> [f32; 2] {
        let k = side / self.extent;
        [
            centre[0] + (p[0] - self.centre[0]) * k,
            centre[1] + (p[1] - self.centre[1]) * k,
        ]
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
pub(crate) mod tests {
    use super::*;
    use nalgebra::Point3;

    /// A person facing the camera `z` metres away, the right hand raised: every joint in
    /// a place of its own.
    pub(crate) fn person(z: f32) -> Skeleton {
        // x, y in metres, in `Joint::ALL` order.
        const AT: [[f32; 2]; Joint::COUNT] = [
            [0.0, -0.55], // head
            [0.0, -0.35], // neck
            [0.0, -0.1],  // torso
            [0.0, 0.2],   // pelvis
            [0.18, -0.3], // left shoulder, elbow, hand
            [0.28, -0.05],
            [0.3, 0.2],
            [-0.18, -0.3], // right shoulder, elbow, hand
            [-0.3, -0.45],
            [-0.32, -0.62],
            [0.1, 0.22], // left hip, knee, foot
            [0.1, 0.65],
            [0.1, 1.05],
            [-0.1, 0.22], // right hip, knee, foot
            [-0.1, 0.65],
            [-0.1, 1.05],
        ];
        Skeleton::new(AT.map(|[x, y]| Point3::new(x, y, z)))
    }

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
        let mut sk = person(3.0);
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
    fn the_recognizers_path_and_bezier_points_are_drawn_in_their_panel() {
        let k = Intrinsics::default();
        let px = wall(&k, 2000);
        let depth = DepthView::new(k.width, k.height, &px).unwrap();
        // A stroke to the person's right, 2 shoulder widths long, in the body frame.
        let trail: Vec<[f32; 2]> = (0..30).map(|i| [i as f32 / 14.5 - 1.0, 0.5]).collect();
        let overlay = Overlay {
            trail,
            bezier: vec![[-1.0, 0.5], [0.0, 0.5], [1.0, 0.5]],
            gestures: vec![GestureLine {
                label: "7".into(),
                score: 0.83,
                age_s: 2.0,
            }],
            caption: "frame 12".into(),
            ..Overlay::default()
        };
        let img = render(depth, &k, &overlay);
        // The panel: 160 px square in the top-right corner, 8 px from the edges; the
        // stroke across its middle row, left to right as the person drew it.
        let (x0, side) = (k.width - 160 - 8, 160);
        let mid = 8 + side / 2;
        assert_eq!(
            *img.get_pixel(x0 + side / 2, mid),
            BEZIER,
            "the middle point"
        );
        let newest = img.get_pixel(x0 + 120, mid + 2);
        assert!(
            (0..3).all(|c| newest[c].abs_diff(TRAIL[c]) < 40),
            "the newest path is nearly opaque: {newest:?}"
        );
        let oldest = img.get_pixel(x0 + 32, mid + 2);
        assert!(oldest[1] < newest[1] - 50, "the oldest fades: {oldest:?}");
        // Outside the panel the picture is untouched by the path.
        assert_eq!(*img.get_pixel(400, 320), *img.get_pixel(300, 320));
        let outside = (0..k.height)
            .flat_map(|y| (0..x0).map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) == TRAIL)
            .count();
        assert_eq!(outside, 0, "the path stays in its panel");
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
        // Nothing to show: no panel.
        let bare = render(depth, &k, &Overlay::default());
        assert_eq!(bare.get_pixel(x0 + 10, 20), bare.get_pixel(10, 300));
    }

    #[test]
    fn a_hands_posture_is_written_beside_it() {
        let k = Intrinsics::default();
        let px = wall(&k, 3000);
        let depth = DepthView::new(k.width, k.height, &px).unwrap();
        let sk = person(2.0);
        let with = |postures: Vec<HandPosture>| {
            render(
                depth,
                &k,
                &Overlay {
                    skeleton: Some(sk),
                    postures,
                    ..Overlay::default()
                },
            )
        };
        let bare = with(Vec::new());
        let tagged = with(vec![HandPosture {
            joint: Joint::RightHand,
            label: "thumb_up".into(),
            confidence: 0.87,
        }]);
        // Text pixels near the right hand (raised, at the image's left of the body) that
        // were not white before (bones are white too): "thumb_up 0.87" is 13 characters
        // of 16x16 pixels.
        let (u, v) = k.project(&sk[Joint::RightHand]).unwrap();
        let (x0, y0) = ((u - 240.0).max(0.0) as u32, (v - 40.0).max(0.0) as u32);
        let written = (y0..v as u32)
            .flat_map(|y| (x0..u as u32).map(move |x| (x, y)))
            .filter(|&(x, y)| *tagged.get_pixel(x, y) == TEXT && *bare.get_pixel(x, y) != TEXT)
            .count();
        assert!(written > 13 * 20, "{written} text pixels");
        // Only text and its tag changed: the joints are all still drawn.
        assert_eq!(count(&tagged, JOINT), count(&bare, JOINT));
        // A hand near the picture's edge keeps its tag inside the picture.
        let mut edge = sk;
        edge.joints[Joint::LeftHand.index()] = Point3::new(0.55, -0.4, 1.0);
        let img = render(
            depth,
            &k,
            &Overlay {
                skeleton: Some(edge),
                postures: vec![HandPosture {
                    joint: Joint::LeftHand,
                    label: "open".into(),
                    confidence: 0.5,
                }],
                ..Overlay::default()
            },
        );
        let right_edge = (0..k.height)
            .flat_map(|y| (k.width - 90..k.width).map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) == TEXT)
            .count();
        assert!(
            right_edge > 50,
            "{right_edge} text pixels at the right edge"
        );
    }

    #[test]
    fn the_tags_of_two_hands_close_together_or_crossed_do_not_cover_each_other() {
        let k = Intrinsics::default();
        let tag = |joint, label: &str| HandPosture {
            joint,
            label: label.into(),
            confidence: 1.0,
        };
        let both = [tag(Joint::LeftHand, "thumb-up"), tag(Joint::RightHand, "v")];
        let overlap = |a: &[i64; 4], b: &[i64; 4]| {
            a[0] < b[0] + b[2] && b[0] < a[0] + a[2] && a[1] < b[1] + b[3] && b[1] < a[1] + a[3]
        };
        let mut sk = person(1.2);
        // Hands held together before the body, then crossed, then at the bottom edge.
        for (left, right) in [
            ([0.03, 0.3], [-0.03, 0.3]),
            ([-0.05, 0.3], [0.05, 0.3]),
            ([0.0, 0.5], [0.01, 0.5]),
        ] {
            sk.joints[Joint::LeftHand.index()] = Point3::new(left[0], left[1], 1.2);
            sk.joints[Joint::RightHand.index()] = Point3::new(right[0], right[1], 1.2);
            let tags = posture_tags(&sk, &both, &k, 2, (640, 480));
            assert_eq!(tags.len(), 2);
            assert!(!overlap(&tags[0].1, &tags[1].1), "{tags:?}");
            for (_, r) in &tags {
                assert!(
                    r[0] >= 0 && r[1] >= 0 && r[0] + r[2] <= 640 && r[1] + r[3] <= 480,
                    "{r:?}"
                );
            }
        }
    }

    #[test]
    fn a_small_frame_and_a_skeleton_behind_the_camera_do_not_panic() {
        let k = Intrinsics::default().scaled_to(80, 60);
        let px = vec![0u16; 80 * 60];
        let mut sk = person(2.0);
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
