//! From skeletons to the drawing hand's trajectory in a body frame: origin between the
//! shoulders, scaled by the shoulder width, projected on the body's frontal plane, so a
//! gesture does not depend on where the person stands or how tall they are. The frame is
//! held steady while the person draws (`body_frame`); the hand's path in it is smoothed
//! by the One Euro filter (Casiez, Roussel, Vogel, CHI 2012).

use crate::body_frame::{BodyFrame, FrameSmoother, FrameSmoothing};
pub use airglyph_core::filter::{OneEuro, OneEuroPlane};
use airglyph_core::{Joint, Skeleton};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Which hand draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Hand {
    /// The person's left.
    Left,
    /// The person's right.
    Right,
}

impl Hand {
    /// Its name in JSON and in logs: "left" or "right".
    pub fn name(self) -> &'static str {
        match self {
            Hand::Left => "left",
            Hand::Right => "right",
        }
    }
}

/// Hand tracker settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrackerConfig {
    /// One Euro parameters for body-frame coordinates (shoulder widths): the cut-off
    /// of a still hand (Hz)…
    pub min_cutoff: f64,
    /// …how fast it rises with the hand's speed…
    pub beta: f64,
    /// …and the cut-off of the speed's own filter (Hz).
    pub d_cutoff: f64,
    /// Joints below this confidence make the frame unusable.
    pub min_confidence: f32,
    /// A fixed drawing hand, or None to pick the raised/forward one.
    pub hand: Option<Hand>,
    /// The other hand must lead by this much (metres) for this many frames to switch.
    pub switch_margin: f32,
    /// See `switch_margin`.
    pub switch_frames: u32,
    /// How the body frame is held steady while the person draws.
    pub frame: FrameSmoothing,
    /// One cut-off for both coordinates, from the hand's speed in the plane (true), or
    /// one a coordinate from that coordinate's own speed (false, as before). Per
    /// coordinate, a stroke along x is smoothed in y as if the hand were still, which
    /// rounds the turn at its end.
    pub plane_filter: bool,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            min_cutoff: 1.5,
            // Air-drawing reaches 4 shoulder widths a second: at 0.5 the filter lagged
            // by a fifth of a symbol and rounded its corners (a "5" became an "S").
            beta: 2.0,
            d_cutoff: 1.0,
            // The pose stage gives 0.1 (its floor) to an arm it sees but fits poorly,
            // as it does an arm drawing before the chest, whose hand it still places
            // within centimetres: at 0.2 the tracker dropped nine in ten frames of
            // every symbol drawn, and a path full of gaps is worse than a noisy one.
            min_confidence: 0.1,
            hand: None,
            switch_margin: 0.05,
            switch_frames: 5,
            frame: FrameSmoothing::default(),
            plane_filter: true,
        }
    }
}

/// A point of the hand trajectory in the body frame: x to the person's right, y down,
/// in shoulder widths from the point between the shoulders; and how far the hand is in
/// front of the shoulders (towards where the person faces, shoulder widths), unfiltered
/// and filtered: the depth of a gesture drawn in 3-D.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandPoint {
    /// Towards the person's right shoulder…
    pub x: f32,
    /// …and down the spine, filtered.
    pub y: f32,
    /// In front of the shoulders, unfiltered.
    pub forward: f32,
    /// In front of the shoulders, filtered (z towards where the person faces: the
    /// camera, for a person facing it). Its own One Euro filter, with the plane's
    /// settings, so the plane's path is what it was before depth was kept.
    pub z: f32,
    /// The hand it is.
    pub hand: Hand,
}

/// Turns skeletons into the drawing hand's smoothed body-frame trajectory.
#[derive(Debug, Clone)]
pub struct HandTracker {
    cfg: TrackerConfig,
    hand: Hand,
    lead: u32,
    filter: HandFilter,
    depth: OneEuro,
    frame: FrameSmoother,
}

impl HandTracker {
    /// A tracker that has seen nothing yet; it starts with `cfg.hand`, or the right.
    pub fn new(cfg: TrackerConfig) -> Self {
        Self {
            hand: cfg.hand.unwrap_or(Hand::Right),
            cfg,
            lead: 0,
            filter: HandFilter::new(&cfg),
            depth: OneEuro::new(cfg.min_cutoff, cfg.beta, cfg.d_cutoff),
            frame: FrameSmoother::new(cfg.frame),
        }
    }

    /// The hand it follows now.
    pub fn hand(&self) -> Hand {
        self.hand
    }

    /// Forgets the person (the filter's and the body frame's state); the hand it
    /// follows stays.
    pub fn reset(&mut self) {
        self.filter.reset();
        self.depth.reset();
        self.lead = 0;
        self.frame.reset();
    }

    /// The body-frame hand point of one skeleton at `time_ns`, or None when the
    /// skeleton is unusable (non-finite, low confidence, degenerate shoulders).
    pub fn update(&mut self, s: &Skeleton, time_ns: u64) -> Option<HandPoint> {
        // The pelvis is not among them: behind a table or below the image's edge the
        // pose stage reports it unseen, but its place is the fitted torso's, which is
        // all the body frame's down axis asks of it.
        let needed = [Joint::LeftShoulder, Joint::RightShoulder, Joint::Neck];
        if !s.is_finite()
            || needed
                .iter()
                .any(|j| s.confidence[j.index()] < self.cfg.min_confidence)
        {
            return None;
        }
        let t = time_ns as f64 * 1e-9;
        let frame = self.frame.update(BodyFrame::of(s)?, t);
        let (origin, ey) = (frame.origin, frame.ey);
        let (ls, rs) = (
            s[Joint::LeftShoulder].coords,
            s[Joint::RightShoulder].coords,
        );
        // Pick the drawing hand: the one further forward (towards the camera) and higher.
        if self.cfg.hand.is_none() {
            let lead = |h: Joint, sh: Vector3<f32>| {
                let p = s[h].coords;
                (sh.z - p.z) - ey.dot(&(p - origin)) * 0.5
            };
            let (l, r) = (lead(Joint::LeftHand, ls), lead(Joint::RightHand, rs));
            let (mine, other) = match self.hand {
                Hand::Left => (l, r),
                Hand::Right => (r, l),
            };
            if other > mine + self.cfg.switch_margin {
                self.lead += 1;
                if self.lead >= self.cfg.switch_frames {
                    self.hand = match self.hand {
                        Hand::Left => Hand::Right,
                        Hand::Right => Hand::Left,
                    };
                    self.lead = 0;
                    self.filter.reset();
                    self.depth.reset();
                }
            } else {
                self.lead = 0;
            }
        }
        let hj = match self.hand {
            Hand::Left => Joint::LeftHand,
            Hand::Right => Joint::RightHand,
        };
        if s.confidence[hj.index()] < self.cfg.min_confidence {
            return None;
        }
        let [x, y, forward] = frame.project(s[hj].coords);
        let [x, y] = self.filter.filter([x as f64, y as f64], t);
        let z = self.depth.filter(forward as f64, t);
        Some(HandPoint {
            x: x as f32,
            y: y as f32,
            forward,
            z: z as f32,
            hand: self.hand,
        })
    }
}

/// The hand's One Euro filter in the body frame, as [`TrackerConfig::plane_filter`]
/// chooses: one cut-off for both coordinates, or one a coordinate (as before).
#[derive(Debug, Clone)]
pub enum HandFilter {
    Plane(OneEuroPlane),
    Axes([OneEuro; 2]),
}

impl HandFilter {
    pub fn new(cfg: &TrackerConfig) -> Self {
        let (fc, beta, dc) = (cfg.min_cutoff, cfg.beta, cfg.d_cutoff);
        if cfg.plane_filter {
            Self::Plane(OneEuroPlane::new(fc, beta, dc))
        } else {
            Self::Axes([OneEuro::new(fc, beta, dc), OneEuro::new(fc, beta, dc)])
        }
    }

    /// Filters point `p` observed at time `t` seconds.
    pub fn filter(&mut self, p: [f64; 2], t: f64) -> [f64; 2] {
        match self {
            Self::Plane(f) => f.filter(p, t),
            Self::Axes([fx, fy]) => [fx.filter(p[0], t), fy.filter(p[1], t)],
        }
    }

    /// Forgets the hand: the next point passes unchanged.
    pub fn reset(&mut self) {
        match self {
            Self::Plane(f) => f.reset(),
            Self::Axes(fs) => fs.iter_mut().for_each(OneEuro::reset),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body_frame::skeleton_with_hand;

    #[test]
    fn body_frame_is_independent_of_distance_and_picks_the_raised_hand() {
        let mut a = HandTracker::new(TrackerConfig::default());
        let mut b = HandTracker::new(TrackerConfig::default());
        let pa = a.update(&skeleton_with_hand(0.4, -0.2, 2.0), 0).unwrap();
        let pb = b.update(&skeleton_with_hand(0.4, -0.2, 3.5), 0).unwrap();
        assert_eq!(pa.hand, Hand::Right);
        assert!(
            (pa.x - 0.4).abs() < 1e-4 && (pa.y + 0.2).abs() < 1e-4,
            "{pa:?}"
        );
        // skeleton_with_hand holds the hand 0.35 m in front of 0.36 m wide shoulders.
        assert!((pa.forward - 0.35 / 0.36).abs() < 1e-3, "{pa:?}");
        // The first point passes the filter unchanged.
        assert_eq!(pa.z, pa.forward);
        assert!((pa.x - pb.x).abs() < 1e-4 && (pa.y - pb.y).abs() < 1e-4);
    }

    #[test]
    fn a_push_towards_the_camera_is_tracked_in_depth_not_in_the_plane() {
        let mut t = HandTracker::new(TrackerConfig::default());
        let mut s = skeleton_with_hand(0.2, 0.1, 2.5);
        let hand = Joint::RightHand.index();
        let at_rest = s.joints[hand].coords;
        let mut last = None;
        // 0.3 m towards the camera (−z in the camera frame) over a second, then held.
        for i in 0..60u64 {
            let f = (i as f32 / 30.0).min(1.0);
            s.joints[hand].coords = at_rest - nalgebra::Vector3::new(0.0, 0.0, 0.3 * f);
            last = t.update(&s, i * 33_333_333);
        }
        let p = last.unwrap();
        let first_z = 0.35 / 0.36;
        assert!((p.z - (first_z + 0.3 / 0.36)).abs() < 0.01, "{p:?}");
        assert!(
            (p.x - 0.2).abs() < 1e-3 && (p.y - 0.1).abs() < 1e-3,
            "{p:?}"
        );
    }

    #[test]
    fn a_hand_the_pose_stage_is_unsure_of_is_still_followed() {
        let mut t = HandTracker::new(TrackerConfig::default());
        let mut s = skeleton_with_hand(0.4, -0.2, 2.0);
        s.confidence[Joint::RightHand.index()] = 0.1;
        assert!(t.update(&s, 0).is_some());
        s.confidence[Joint::RightHand.index()] = 0.05;
        assert!(t.update(&s, 33_000_000).is_none());
    }

    #[test]
    fn a_person_whose_pelvis_a_table_hides_is_followed() {
        // Seated at a desk, the pose stage reports the pelvis and legs not visible
        // (confidence 0) with their places the fit's.
        let mut t = HandTracker::new(TrackerConfig::default());
        let mut s = skeleton_with_hand(0.4, -0.2, 1.4);
        for j in Joint::LOWER {
            s.confidence[j.index()] = 0.0;
            s.visible[j.index()] = false;
        }
        let p = t.update(&s, 0).expect("followed");
        assert!(
            (p.x - 0.4).abs() < 1e-4 && (p.y + 0.2).abs() < 1e-4,
            "{p:?}"
        );
    }

    #[test]
    fn unusable_skeletons_give_none() {
        let mut t = HandTracker::new(TrackerConfig::default());
        let mut s = skeleton_with_hand(0.0, 0.0, 2.0);
        s.joints[Joint::LeftShoulder.index()].x = f32::NAN;
        assert!(t.update(&s, 0).is_none());
        let mut s = skeleton_with_hand(0.0, 0.0, 2.0);
        s.confidence[Joint::RightShoulder.index()] = 0.0;
        assert!(t.update(&s, 0).is_none());
    }

    /// The width of a square (1 shoulder width a side, drawn in 2 s after a rest at its
    /// corner) as tracked, when the chest turns `degrees` per shoulder width the hand
    /// is to the right, as an estimated chest does with the drawing arm.
    fn tracked_width(cfg: TrackerConfig, degrees: f32) -> f32 {
        use nalgebra::{Rotation3, Vector3};
        let mut t = HandTracker::new(cfg);
        let corners = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]];
        let (mut lo, mut hi) = (f32::MAX, f32::MIN);
        for i in 0..90u64 {
            let k = i.saturating_sub(30) as f32 / 15.0;
            let (leg, f) = ((k as usize).min(3), (k - k.floor()).min(1.0));
            let (a, b) = (corners[leg], corners[leg + 1]);
            let (x, y) = if k >= 4.0 {
                (0.0, 0.0)
            } else {
                (a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f)
            };
            let mut s = skeleton_with_hand(x - 0.5, y - 0.5, 2.5);
            let turn = Rotation3::from_axis_angle(&Vector3::y_axis(), (degrees * x).to_radians());
            let centre = (s[Joint::LeftShoulder].coords + s[Joint::RightShoulder].coords) / 2.0;
            for j in [Joint::LeftShoulder, Joint::RightShoulder] {
                s.joints[j.index()].coords = turn * (s[j].coords - centre) + centre;
            }
            let p = t.update(&s, i * 33_333_333).unwrap();
            if i >= 30 {
                (lo, hi) = (lo.min(p.x), hi.max(p.x));
            }
        }
        hi - lo
    }

    #[test]
    fn a_chest_turning_with_the_hand_does_not_squeeze_the_path() {
        let cfg = TrackerConfig::default();
        let truth = tracked_width(cfg, 0.0);
        let held = tracked_width(cfg, 2.0);
        let raw = tracked_width(
            TrackerConfig {
                frame: FrameSmoothing {
                    seconds: 0.0,
                    ..cfg.frame
                },
                ..cfg
            },
            2.0,
        );
        assert!((held / truth - 1.0).abs() < 0.01, "{held} against {truth}");
        assert!((raw / truth - 1.0).abs() > 0.025, "{raw} against {truth}");
    }

    /// The smallest and largest distance from the centre of a circle (radius 0.5
    /// shoulder widths, drawn at 1.5 a second, 30 frames a second) as filtered over its
    /// second turn, and the jitter left of ±0.01 noise on a resting hand.
    fn circle_and_jitter(plane_filter: bool) -> (f64, f64, f64) {
        let mut hand = HandFilter::new(&TrackerConfig {
            plane_filter,
            ..TrackerConfig::default()
        });
        let mut filter = |p: [f64; 2], t: f64| hand.filter(p, t);
        let (mut lo, mut hi) = (f64::MAX, 0.0f64);
        // 1.5 shoulder widths a second on a circle of radius 0.5: 3 radians a second.
        for i in 0..126 {
            let a = 3.0 * i as f64 / 30.0;
            let q = filter([0.5 * a.cos(), 0.5 * a.sin()], i as f64 / 30.0);
            if i >= 63 {
                let r = q[0].hypot(q[1]);
                (lo, hi) = (lo.min(r), hi.max(r));
            }
        }
        let mut jitter = 0.0f64;
        for i in 126..300 {
            let n = if i % 2 == 0 { 0.01 } else { -0.01 };
            let q = filter([0.5 + n, 0.5 - n], i as f64 / 30.0);
            if i > 240 {
                jitter = jitter.max((q[0] - 0.5).abs()).max((q[1] - 0.5).abs());
            }
        }
        (lo, hi, jitter)
    }

    #[test]
    fn the_plane_filter_keeps_a_circle_round_and_smooths_a_resting_hand() {
        let (plane_lo, plane_hi, plane_jitter) = circle_and_jitter(true);
        let (axes_lo, axes_hi, axes_jitter) = circle_and_jitter(false);
        // One cut-off from the hand's speed: the circle stays a circle (the lag only
        // shrinks it, by 0.7 %). A cut-off a coordinate from that coordinate's own
        // speed smooths each one hardest where it turns, at a different time for x
        // and y: the circle comes out an ellipse (its radius varies by about 5 %).
        assert!(plane_hi - plane_lo < 0.002, "{plane_lo}..{plane_hi}");
        assert!(axes_hi - axes_lo > 0.01, "{axes_lo}..{axes_hi}");
        // At rest both smooth alike.
        assert!(
            plane_jitter < 0.002 && axes_jitter < 0.002,
            "{plane_jitter} {axes_jitter}"
        );
    }

    #[test]
    fn one_euro_smooths_jitter_and_follows_motion() {
        let mut f = OneEuro::new(1.0, 0.5, 1.0);
        let mut last = 0.0;
        for i in 0..300 {
            let noise = if i % 2 == 0 { 0.01 } else { -0.01 };
            last = f.filter(noise, i as f64 / 30.0);
        }
        assert!(last.abs() < 0.005);
        for i in 300..330 {
            last = f.filter((i - 300) as f64 * 0.05, i as f64 / 30.0);
        }
        assert!(last > 1.0, "{last}");
    }
}
