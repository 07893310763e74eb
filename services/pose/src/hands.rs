//! Where the hand joints go once the body is registered: behind the fingertips seen
//! ([`hands_at_fingertips`]), then across the forearm onto the hand's own points
//! ([`hands_at_their_points`]).
//!
//! The body model has no hand: its forearm capsule runs on to the fingertips, and its
//! hand joint (the palm's centre) is a fixed point of the forearm. A real hand turns at
//! the wrist, so even from the true pose itself the fit's hands lie off the truth,
//! mostly across the forearm and too deep (pose NOTES). The points
//! the fitted body gives to a forearm near its hand are the hand's own, though: their
//! centre, set back along the camera's ray by half a hand's thickness (the camera sees
//! the hand's front), is where the palm is across the forearm. Along the forearm it is
//! not (the wrist's and fingers' points weigh on it), so the hand moves only across.
//!
//! That second step moves only the published joints: the tracked body, the limbs'
//! states and the next frame's start are the fit's, so the tracker is not steered by
//! it.

use crate::chains::ChainConfig;
use crate::register::{nearest_is, Frame, Placed};
use crate::{body::BodyTemplate, body::Posed, body::Segment, Limb};
use airglyph_core::{Joint, Skeleton};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Settings of where the hands go (part of [`crate::PoseConfig`]); metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HandsConfig {
    /// The hand joint (palm centre) this far behind the arm's extremity (fingertips),
    /// towards the elbow, instead of at the fitted chain's end; 0 = the chain's end.
    pub behind_tip: f32,
    /// After the registration, each hand moves across its forearm to the centre of the
    /// forearm's points within this radius (0 = off), set back along the camera's ray
    /// by `behind_surface`.
    pub points_radius: f32,
    /// See `points_radius`.
    pub behind_surface: f32,
    /// A hand is placed behind the fingertips seen (as the seed's chains place it) when
    /// they lie this near the fitted body's fingertips; farther, the fit's hand stays.
    pub tip_trust: f32,
}

impl Default for HandsConfig {
    fn default() -> Self {
        Self {
            behind_tip: 0.11,
            points_radius: 0.10,
            behind_surface: 0.018,
            tip_trust: 0.12,
        }
    }
}

/// Mean-shift steps of a hand towards the centre of its points.
const STEPS: usize = 3;
/// Fewer points than this near a hand (hidden, or out of the image) leave it where the
/// fit put it.
const MIN_POINTS: usize = 5;

/// The hands of a registered body moved to follow the fingertips seen (the arms'
/// geodesic maxima `tips`), as in the seed's chains: a capsule forearm cannot bend at
/// the wrist, and its end lags a quickly drawing hand. Only where the body's own tip
/// lies within [`HandsConfig::tip_trust`] of the maximum. `chains`: where the
/// fingertips seen are set back to the surface ([`ChainConfig::surface_offset`]), as the
/// chains set them.
pub fn hands_at_fingertips(
    skel: &mut Skeleton,
    posed: &Posed,
    tpl: &BodyTemplate,
    tips: &[Option<Point3<f32>>; 5],
    cfg: &HandsConfig,
    chains: &ChainConfig,
) {
    for (l, hand, elbow) in [
        (Limb::LeftArm, Joint::LeftHand, Joint::LeftElbow),
        (Limb::RightArm, Joint::RightHand, Joint::RightElbow),
    ] {
        let (Some(ext), true) = (tips[l.index()], cfg.behind_tip > 0.0) else {
            continue;
        };
        let ext_b = ext + ext.coords.normalize() * chains.surface_offset(l);
        let (seg, local) = tpl.tips[l.index()];
        let tip = posed.point(seg, &local);
        if (tip - ext_b).norm() > cfg.tip_trust {
            continue;
        }
        if let Some(u) = (ext_b - skel[elbow]).try_normalize(1e-6) {
            skel.set(hand, ext_b - u * cfg.behind_tip);
            // Its fingertips are in sight.
            let c = &mut skel.confidence[hand.index()];
            *c = c.max(0.9);
        }
    }
}

/// Where each hand (left, right) lies among its points, for the body whose capsules
/// `placed` are registered to `frame`; None where the hand keeps the fit's place (too
/// few points, or [`HandsConfig::points_radius`] 0). `skel` holds the fitted hands and
/// elbows.
pub fn hands_at_their_points(
    skel: &Skeleton,
    frame: &Frame,
    placed: &[Placed],
    cfg: &HandsConfig,
) -> [Option<Point3<f32>>; 2] {
    let radius = cfg.points_radius;
    if radius <= 0.0 {
        return [None; 2];
    }
    [
        (Joint::LeftHand, Joint::LeftElbow, Segment::LeftForearm),
        (Joint::RightHand, Joint::RightElbow, Segment::RightForearm),
    ]
    .map(|(hand, elbow, forearm)| {
        let start = skel[hand];
        let axis = (start - skel[elbow]).try_normalize(1e-6)?;
        // The forearm's points within reach of every step, found once: the hand moves
        // by centimetres.
        let own: Vec<Point3<f32>> = frame
            .pixels_near(&start, 1.5 * radius)
            .map(|i| frame.points[i])
            .filter(|p| nearest_is(placed, p, forearm))
            .collect();
        let mut h = start;
        for _ in 0..STEPS {
            let (sum, n) = own
                .iter()
                .filter(|p| (*p - h).norm_squared() < radius * radius)
                .fold((Vector3::zeros(), 0usize), |(s, n), p| {
                    (s + p.coords, n + 1)
                });
            if n < MIN_POINTS {
                break;
            }
            let centre = Point3::from(sum / n as f32);
            let palm = centre + centre.coords.normalize() * cfg.behind_surface;
            let d = palm - h;
            h += d - axis * d.dot(&axis);
        }
        (h != start).then_some(h)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::{BodyConfig, Shape};
    use crate::register::place;
    use crate::view::testing::facing;
    use airglyph_core::Intrinsics;

    /// A body standing 2.5 m before the camera, arms hanging, and a camera image to
    /// put points in.
    fn standing() -> (BodyTemplate, Posed, Skeleton, Intrinsics) {
        let t = BodyTemplate::new(&Shape::makehuman(), &BodyConfig::default());
        let posed = Posed::new(&t, &facing(Point3::new(0.0, 0.0, 2.5)));
        let skel = posed.skeleton(&t);
        (t, posed, skel, Intrinsics::default().scaled_to(320, 240))
    }

    /// Points on a grid over a disc of `radius` around `centre`, facing the camera.
    fn disc(centre: Point3<f32>, radius: f32) -> Vec<Point3<f32>> {
        let n = 12;
        let mut out = Vec::new();
        for i in -n..=n {
            for j in -n..=n {
                let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
                if x * x + y * y <= 1.0 {
                    out.push(centre + Vector3::new(x, y, 0.0) * radius);
                }
            }
        }
        out
    }

    /// Each point at its pixel (the nearest where two meet).
    fn image(k: &Intrinsics, points: &[Point3<f32>]) -> (Vec<Point3<f32>>, Vec<bool>) {
        let (w, h) = (k.width as usize, k.height as usize);
        let mut img = vec![Point3::origin(); w * h];
        let mut mask = vec![false; w * h];
        for p in points {
            let Some((u, v)) = k.project(p) else { continue };
            let (u, v) = (u.round() as usize, v.round() as usize);
            if u < w && v < h && (!mask[v * w + u] || p.z < img[v * w + u].z) {
                img[v * w + u] = *p;
                mask[v * w + u] = true;
            }
        }
        (img, mask)
    }

    #[test]
    fn a_hand_turned_at_the_wrist_is_found_across_its_forearm_and_only_there() {
        let (t, posed, skel, k) = standing();
        let cfg = HandsConfig::default();
        let (hand, elbow) = (skel[Joint::LeftHand], skel[Joint::LeftElbow]);
        let axis = (hand - elbow).normalize();
        // The palm 4 cm outwards of where the fit put the hand (a wrist turned
        // sideways), its front surface facing the camera.
        let palm = hand + Vector3::new(0.04, 0.0, 0.0);
        let surface = palm - Vector3::z() * cfg.behind_surface;
        let seen = disc(surface, 0.04);
        let place_in = |points: &[Point3<f32>], cfg: &HandsConfig| {
            let (img, mask) = image(&k, points);
            let frame = Frame {
                points: &img,
                mask: &mask,
                width: k.width as usize,
                height: k.height as usize,
                k: &k,
                floor: None,
            };
            hands_at_their_points(&skel, &frame, &place(&t, &posed), cfg)
        };
        let [left, right] = place_in(&seen, &cfg);
        let moved = left.expect("the left hand has its points") - hand;
        // Across the forearm, outwards, most of the way; not along it.
        assert!(moved.dot(&axis).abs() < 1e-4, "{moved:?}");
        assert!(moved.x > 0.025 && moved.x < 0.045, "{moved:?}");
        assert!(
            moved.z.abs() < 0.01,
            "set back to the palm's centre: {moved:?}"
        );
        // The right hand has no points near it: it stays where the fit put it.
        assert_eq!(right, None);

        // Points nearer the thigh than the forearm (a hanging hand beside the hip) are
        // the thigh's: they do not pull the hand.
        let (hip, knee) = (skel[Joint::LeftHip], skel[Joint::LeftKnee]);
        let axis_there = hip + (knee - hip) * ((hand.y - hip.y) / (knee.y - hip.y));
        let out = (hand - axis_there).normalize();
        let placed = place(&t, &posed);
        let thigh_surface = (0..200)
            .map(|i| axis_there + out * (i as f32 * 0.001))
            .find(|p| !nearest_is(&placed, p, Segment::LeftThigh))
            .expect("the thigh's surface lies between its axis and the hand");
        let beside = disc(thigh_surface - out * 0.01, 0.015);
        assert!(beside.iter().all(|p| (p - hand).norm() < cfg.points_radius));
        let mut with_thigh = seen.clone();
        with_thigh.extend(beside);
        assert_eq!(place_in(&with_thigh, &cfg)[0], left);

        // Off: nothing moves.
        let mut off = cfg.clone();
        off.points_radius = 0.0;
        assert_eq!(place_in(&seen, &off), [None; 2]);
    }
}
