//! The neck's base as the person's own outline shows it: below the top of the head the
//! body is as wide as the head, narrows at the neck and widens again at the shoulders.
//! Where it widens is a place on this person's body, whatever their build; the
//! template's torso, cut by the image at the waist, can slide along its axis, and
//! nothing of the template's own says how far.

use crate::torso::TorsoPose;
use nalgebra::{Point3, Vector3};

/// Height bins, metres.
const BIN: f32 = 0.01;
/// How far below the top of the head the profile is read, metres.
const DEPTH: f32 = 0.45;
const BINS: usize = (DEPTH / BIN) as usize;
/// Lateral reach from the head's centre line, metres: beyond it, an arm held out.
const REACH: f32 = 0.4;
/// A head's width, metres: a child's is over 0.12 m, nobody's is 0.3.
const MIN_HEAD: f32 = 0.11;
const MAX_HEAD: f32 = 0.3;
/// A neck's width at least, metres (an adult's is about 0.1 m).
const MIN_NECK: f32 = 0.06;
/// How high above the torso's origin the head's top lies at least, metres (a short
/// adult's is about 0.5 m up).
const MIN_CROWN: f32 = 0.3;

/// How far to the side of the head's maximum, and how far above it, the top of the
/// head is looked for among the maxima, metres: a head is about 0.15 m wide, and the
/// chin lies about 0.22 m under the top.
const HEAD_LINE: f32 = 0.08;
const HEAD_ABOVE: f32 = 0.3;

/// The outline's widths below the top of the head and where its neck ends.
#[derive(Debug, Clone, PartialEq)]
pub struct NeckBase {
    /// The base of the neck, on the head's centre line at the head's depth, camera frame.
    pub point: Point3<f32>,
    /// The torso's up it was measured along, camera frame.
    pub up: Vector3<f32>,
    /// How far below the top of the head, metres.
    pub below_top: f32,
    /// The head's width, the neck's narrowest, metres.
    pub head_width: f32,
    /// See `head_width`.
    pub neck_width: f32,
}

/// The neck's base in the mask of the person whose torso frame is `torso` (y up), below
/// the head's top `top` (a point of the mask, camera frame). `footprint` is a pixel's
/// width per metre of depth. `None` unless the outline shows a head, a neck narrower
/// than it and shoulders wider than both: a hand before the face, an arm beside the
/// head or a head cut by the image leave no such profile.
pub fn neck_base(
    points: &[Point3<f32>],
    mask: &[bool],
    torso: &TorsoPose,
    top: &Point3<f32>,
    footprint: f32,
) -> Option<NeckBase> {
    let inv = torso.inverse();
    let crown = inv.apply(top);
    // The profile is read along the torso's up: a torso fitted tilted away from the
    // head (lost, or lying along the chair's back) has no neck along it.
    let upright = crown.y >= MIN_CROWN && crown.x.abs() <= 0.5 * crown.y;
    if !upright {
        return None;
    }
    // Each bin's lateral offsets, from the crown's line.
    let mut bins: Vec<Vec<f32>> = vec![Vec::new(); BINS];
    for (p, _) in points.iter().zip(mask).filter(|(p, &m)| m && p.z > 0.0) {
        let q = inv.apply(p);
        let below = crown.y - q.y;
        let x = q.x - crown.x;
        if !(0.0..DEPTH).contains(&below) || x.abs() > REACH {
            continue;
        }
        bins[(below / BIN) as usize].push(x);
    }
    // Each bin's run of the outline through the centre line: neighbours closer than a
    // few pixels apart are one surface.
    let gap = (3.0 * footprint * top.z).max(0.015);
    let mut width = [f32::NAN; BINS];
    let mut centre = 0.0f32;
    for (b, xs) in bins.iter_mut().enumerate() {
        if xs.is_empty() {
            continue;
        }
        xs.sort_by(f32::total_cmp);
        let i = xs.partition_point(|&x| x < centre);
        let i = match (i.checked_sub(1), xs.get(i)) {
            (Some(l), Some(&r)) if centre - xs[l] > r - centre => i,
            (Some(l), _) => l,
            (None, _) => i,
        };
        if (xs[i] - centre).abs() > gap {
            continue;
        }
        let (mut lo, mut hi) = (i, i);
        while lo > 0 && xs[lo] - xs[lo - 1] < gap {
            lo -= 1;
        }
        while hi + 1 < xs.len() && xs[hi + 1] - xs[hi] < gap {
            hi += 1;
        }
        width[b] = xs[hi] - xs[lo];
        centre = 0.5 * (xs[hi] + xs[lo]);
    }
    // The sensor's noise frays the outline row by row: each bin the median of three.
    let width: [f32; BINS] = std::array::from_fn(|b| {
        let mut near: Vec<f32> = width[b.saturating_sub(1)..(b + 2).min(BINS)]
            .iter()
            .copied()
            .filter(|w| w.is_finite())
            .collect();
        near.sort_by(f32::total_cmp);
        near.get(near.len() / 2).copied().unwrap_or(f32::NAN)
    });
    // The head: the outline's widest before it narrows to the neck (within 25 cm of
    // its top, a head's height and more); then the neck, the narrowest below it before
    // the outline is wider than the head; its base, where it has widened to twice its
    // narrowest.
    let mut head: Option<usize> = None;
    for (b, &w) in width.iter().enumerate().take(25).skip(1) {
        match head {
            _ if !w.is_finite() => {}
            Some(h) if w < 0.8 * width[h] => break,
            Some(h) if w <= width[h] => {}
            _ => head = Some(b),
        }
    }
    let head = head?;
    if !(MIN_HEAD..MAX_HEAD).contains(&width[head]) {
        return None;
    }
    let head_width = width[head];
    let mut neck = head;
    // Bins a pixel's row missed (far away a pixel is more than a bin high) are skipped;
    // a longer gap is a hole, not a neck.
    let mut missed = 0;
    for b in head + 1..BINS {
        let w = width[b];
        if !w.is_finite() {
            missed += 1;
            if missed > 3 {
                return None;
            }
            continue;
        }
        missed = 0;
        if w < width[neck] {
            neck = b;
        }
        if w > 2.0 * width[neck] {
            let neck_width = width[neck];
            // A real neck: clearly narrower than the head, no sliver of noise.
            if neck_width > 0.75 * head_width || neck_width < MIN_NECK {
                return None;
            }
            let below_top = (b as f32 + 0.5) * BIN;
            let local = Point3::new(crown.x, crown.y - below_top, crown.z);
            return Some(NeckBase {
                point: torso.apply(&local),
                up: torso.r * Vector3::y(),
                below_top,
                head_width,
                neck_width,
            });
        }
    }
    None
}

/// The highest of the whole maxima on the head's line, above the head's maximum `head`
/// by at most a head's height (torso frame `torso`, y up): the top of the head when the
/// head's maximum is its chin, which juts out towards the camera and ends a geodesic
/// path of its own; the outline read below the chin shows a neck and shoulders but no
/// head.
pub fn head_top_maximum(
    head: &Point3<f32>,
    torso: &TorsoPose,
    whole: &[u32],
    pos: &[Point3<f32>],
) -> Option<Point3<f32>> {
    let inv = torso.inverse();
    let h = inv.apply(head);
    whole
        .iter()
        .map(|&m| (pos[m as usize], inv.apply(&pos[m as usize])))
        .filter(|(_, q)| {
            (q.x - h.x).abs() <= HEAD_LINE && (0.01..=HEAD_ABOVE).contains(&(q.y - h.y))
        })
        .max_by(|(_, a), (_, b)| a.y.total_cmp(&b.y))
        .map(|(p, _)| p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    const W: usize = 160;
    const H: usize = 120;
    const F: f32 = 130.0;
    const Z: f32 = 1.5;

    /// A person facing the camera 1.5 m away, drawn by `inside(x, y)` in metres on
    /// their plane (camera frame, y down): each pixel's point and the mask.
    fn scene(inside: impl Fn(f32, f32) -> bool) -> (Vec<Point3<f32>>, Vec<bool>) {
        let mut points = Vec::new();
        let mut mask = Vec::new();
        for v in 0..H {
            for u in 0..W {
                let (x, y) = (
                    (u as f32 - W as f32 / 2.0) * Z / F,
                    (v as f32 - H as f32 / 2.0) * Z / F,
                );
                let m = inside(x, y);
                points.push(if m {
                    Point3::new(x, y, Z)
                } else {
                    Point3::origin()
                });
                mask.push(m);
            }
        }
        (points, mask)
    }

    /// Torso frame (y up, z towards the camera) to camera frame (y down).
    fn facing() -> TorsoPose {
        TorsoPose {
            r: Rotation3::from_axis_angle(&Vector3::x_axis(), std::f32::consts::PI),
            t: Vector3::new(0.0, 0.0, Z),
        }
    }

    fn head(x: f32, y: f32) -> bool {
        (x / 0.08).powi(2) + ((y + 0.45) / 0.11).powi(2) <= 1.0
    }

    fn body(x: f32, y: f32) -> bool {
        head(x, y)
            || (x.abs() < 0.05 && (-0.36..-0.27).contains(&y))
            || (x.abs() < 0.22 && y >= -0.27)
    }

    /// The head's top: the highest point of the mask on the head's centre line.
    fn crown(mask: &[bool], points: &[Point3<f32>]) -> Point3<f32> {
        let i = (0..H)
            .map(|v| v * W + W / 2)
            .find(|&i| mask[i])
            .expect("a person");
        points[i]
    }

    #[test]
    fn the_base_is_where_the_neck_widens_into_the_shoulders() {
        // Alone, and with an arm raised beside the head, apart from it.
        let apart = |x: f32, y: f32| body(x, y) || ((0.11..0.17).contains(&x) && y > -0.6);
        for person in [&body as &dyn Fn(f32, f32) -> bool, &apart] {
            let (points, mask) = scene(person);
            let nb = neck_base(&points, &mask, &facing(), &crown(&mask, &points), 1.0 / F)
                .expect("a head, a neck and shoulders");
            assert!((nb.point.y + 0.27).abs() < 0.02, "{nb:?}");
            assert!((nb.neck_width - 0.10).abs() < 0.03, "{nb:?}");
        }
    }

    #[test]
    fn an_arm_against_the_neck_or_no_neck_shows_no_base() {
        // The upper arm raised against the side of the head and the neck.
        let arm = |x: f32, y: f32| body(x, y) || ((0.06..0.14).contains(&x) && y > -0.6);
        let (points, mask) = scene(arm);
        let top = crown(&mask, &points);
        assert_eq!(neck_base(&points, &mask, &facing(), &top, 1.0 / F), None);
        let block = |x: f32, y: f32| x.abs() < 0.2 && y > -0.55;
        let (points, mask) = scene(block);
        let top = crown(&mask, &points);
        assert_eq!(neck_base(&points, &mask, &facing(), &top, 1.0 / F), None);
    }
}
