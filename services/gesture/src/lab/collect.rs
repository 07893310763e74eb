//! Cutting a stream of skeletons into repetitions of one gesture, for recording a
//! vocabulary of one's own (`airglyph collect`).
//!
//! The person draws the gesture again and again and lets the hand come to rest between
//! repetitions. A repetition is the movement between two rests; of it, the drawing is
//! the part made with the hand held out in front of the body (as one draws on a pane in
//! the air), from the slowest moment where the hand arrives there to the slowest moment
//! where it leaves: the hand's travel from and back to a lowered rest is left out, and a
//! movement that never reaches forward (scratching one's face, reaching to the side) is
//! no repetition at all.

use crate::tracker::{HandPoint, HandTracker, TrackerConfig};
use airglyph_core::Skeleton;
use serde::{Deserialize, Serialize};

/// How repetitions are found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RepetitionConfig {
    /// The hand rests while slower than this (shoulder widths a second)…
    pub rest_speed: f32,
    /// …for at least this long.
    pub rest_seconds: f64,
    /// The hand draws when at least this far in front of the shoulders (shoulder
    /// widths; about a quarter of a metre).
    pub min_forward: f32,
    /// Smallest drawing (larger side, shoulder widths) and its duration range.
    pub min_size: f32,
    /// See `min_size`.
    pub min_seconds: f64,
    /// See `min_size`.
    pub max_seconds: f64,
    /// How the drawing hand is followed.
    pub tracker: TrackerConfig,
}

impl Default for RepetitionConfig {
    fn default() -> Self {
        Self {
            rest_speed: 0.25,
            rest_seconds: 0.3,
            min_forward: 0.7,
            min_size: 0.2,
            min_seconds: 0.25,
            max_seconds: 10.0,
            tracker: TrackerConfig::default(),
        }
    }
}

/// One repetition: the drawn path in the body frame (shoulder widths, x right, y down)
/// with the time of each point in milliseconds from its start, its depth, and the
/// frames it spans.
#[derive(Debug, Clone, PartialEq)]
pub struct Repetition {
    /// x, y (shoulder widths) and t (ms) of each point.
    pub points: Vec<[f32; 3]>,
    /// The depth of each point: how far in front of the shoulders the hand was
    /// (shoulder widths, filtered as x and y are).
    pub depth: Vec<f32>,
    /// The frame sequence numbers of its first and last point.
    pub start_seq: u64,
    /// See `start_seq`.
    pub end_seq: u64,
}

/// Finds repetitions in a stream of skeletons (or body-frame hand points).
#[derive(Debug, Clone)]
pub struct RepetitionSegmenter {
    cfg: RepetitionConfig,
    tracker: HandTracker,
    /// The movement going on: (x, y, forward, filtered forward; frame, time ns).
    moving: Vec<([f32; 4], u64, u64)>,
    /// Whether the hand rests (it does at the start).
    resting: bool,
    /// Since when the hand has been slow (index into `moving`).
    slow_from: Option<usize>,
}

impl RepetitionSegmenter {
    /// A segmenter that has seen nothing yet: the hand rests.
    pub fn new(cfg: RepetitionConfig) -> Self {
        Self {
            tracker: HandTracker::new(cfg.tracker),
            cfg,
            moving: Vec::new(),
            resting: true,
            slow_from: None,
        }
    }

    /// Feeds one skeleton; returns a repetition when one has just ended.
    pub fn push(&mut self, s: &Skeleton, seq: u64, time_ns: u64) -> Option<Repetition> {
        let p = self.tracker.update(s, time_ns)?;
        self.push_point(p, seq, time_ns)
    }

    /// Feeds one body-frame hand point.
    pub fn push_point(&mut self, p: HandPoint, seq: u64, time_ns: u64) -> Option<Repetition> {
        if !(p.x.is_finite() && p.y.is_finite() && p.forward.is_finite()) {
            return None;
        }
        self.moving.push(([p.x, p.y, p.forward, p.z], seq, time_ns));
        let n = self.moving.len();
        // Speed over the last two frames (the points are already smoothed), in space:
        // a push towards the camera is a movement, not a rest.
        let speed = if n >= 3 {
            let (a, b) = (self.moving[n - 3], self.moving[n - 1]);
            let dt = (b.2.saturating_sub(a.2) as f64 * 1e-9).max(1e-4) as f32;
            distance(&a.0, &b.0) / dt
        } else {
            0.0
        };
        if speed >= self.cfg.rest_speed {
            self.slow_from = None;
            if self.resting {
                // The hand sets off: the movement starts a couple of frames back.
                self.resting = false;
                self.moving.drain(..n.saturating_sub(3));
            }
            return None;
        }
        let from = *self.slow_from.get_or_insert(n - 1);
        let slow_for = time_ns.saturating_sub(self.moving[from].2) as f64 * 1e-9;
        if slow_for < self.cfg.rest_seconds {
            return None;
        }
        if self.resting {
            // Keep only the last few points of a rest.
            self.moving.drain(..n.saturating_sub(3));
            self.slow_from = Some(self.moving.len() - 1);
            return None;
        }
        self.resting = true;
        let movement: Vec<_> = self.moving.drain(..=from).collect();
        self.slow_from = Some(self.moving.len().saturating_sub(1));
        self.drawing(&movement)
    }

    /// The stream has ended: the movement going on, if it is a repetition.
    pub fn finish(&mut self) -> Option<Repetition> {
        if self.resting {
            return None;
        }
        self.resting = true;
        let movement = std::mem::take(&mut self.moving);
        self.drawing(&movement)
    }

    /// The drawing within one movement, if there is one.
    fn drawing(&self, m: &[([f32; 4], u64, u64)]) -> Option<Repetition> {
        let forward: Vec<usize> = (0..m.len())
            .filter(|&i| m[i].0[2] >= self.cfg.min_forward)
            .collect();
        let (&a, &b) = (forward.first()?, forward.last()?);
        let speed = |i: usize| {
            let (p, q) = (m[i.saturating_sub(1)], m[(i + 1).min(m.len() - 1)]);
            let dt = (q.2.saturating_sub(p.2) as f64 * 1e-9).max(1e-4) as f32;
            distance(&p.0, &q.0) / dt
        };
        // The hand reaches the pane before the drawing starts and leaves it after it
        // ends: start and end where it is slowest just inside.
        let window = |from: usize, to: usize| from..=to.min(m.len() - 1);
        let reach = ((0.35 * m.len() as f64) as usize).min(12);
        let start = window(a, a + reach)
            .min_by(|&i, &j| speed(i).total_cmp(&speed(j)))
            .unwrap_or(a);
        let end = window(b.saturating_sub(reach).max(start), b)
            .min_by(|&i, &j| speed(i).total_cmp(&speed(j)))
            .unwrap_or(b);
        if end <= start {
            return None;
        }
        let part = &m[start..=end];
        let secs = part[part.len() - 1].2.saturating_sub(part[0].2) as f64 * 1e-9;
        let in_space: Vec<[f32; 3]> = part.iter().map(|p| [p.0[0], p.0[1], p.0[3]]).collect();
        let (lo, hi) = crate::features3d::bbox3(&in_space);
        // Its size in space: a push is as much a drawing as a stroke across.
        let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
        if size < self.cfg.min_size || secs < self.cfg.min_seconds || secs > self.cfg.max_seconds {
            return None;
        }
        let t0 = part[0].2;
        Some(Repetition {
            points: part
                .iter()
                .map(|p| [p.0[0], p.0[1], (p.2 - t0) as f32 * 1e-6])
                .collect(),
            depth: part.iter().map(|p| p.0[3]).collect(),
            start_seq: part[0].1,
            end_seq: part[part.len() - 1].1,
        })
    }
}

/// How far apart two points of a movement are in space (x, y and the filtered depth).
fn distance(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[3] - a[3]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::Hand;

    fn point(x: f32, y: f32, forward: f32) -> HandPoint {
        HandPoint {
            x,
            y,
            forward,
            z: forward,
            hand: Hand::Right,
        }
    }

    /// Rest low, raise the hand forward, draw an L, lower it, rest; twice; plus a
    /// movement to the face in between that never reaches forward.
    #[test]
    fn finds_each_drawing_between_rests_and_skips_other_movement() {
        let mut seg = RepetitionSegmenter::new(RepetitionConfig::default());
        let mut frames: Vec<HandPoint> = Vec::new();
        let rest = |f: &mut Vec<HandPoint>, at: [f32; 3], n: usize| {
            f.extend((0..n).map(|_| point(at[0], at[1], at[2])));
        };
        // Minimum-jerk travel between two points (x, y, forward).
        let go = |f: &mut Vec<HandPoint>, a: [f32; 3], b: [f32; 3], n: usize| {
            for i in 1..=n {
                let t = i as f32 / n as f32;
                let s = t * t * t * (10.0 - 15.0 * t + 6.0 * t * t);
                f.push(point(
                    a[0] + s * (b[0] - a[0]),
                    a[1] + s * (b[1] - a[1]),
                    a[2] + s * (b[2] - a[2]),
                ));
            }
        };
        let low = [0.8, 1.7, 0.2];
        let top = [0.0, -0.2, 1.2];
        let corner = [0.0, 0.8, 1.2];
        let right = [0.6, 0.8, 1.2];
        let face = [0.2, -0.5, 0.4];
        rest(&mut frames, low, 20);
        for k in 0..2 {
            go(&mut frames, low, top, 15);
            go(&mut frames, top, corner, 15);
            go(&mut frames, corner, right, 12);
            go(&mut frames, right, low, 15);
            rest(&mut frames, low, 20);
            if k == 0 {
                go(&mut frames, low, face, 15);
                rest(&mut frames, face, 15);
                go(&mut frames, face, low, 15);
                rest(&mut frames, low, 20);
            }
        }
        let mut reps = Vec::new();
        for (i, p) in frames.iter().enumerate() {
            reps.extend(seg.push_point(*p, i as u64, i as u64 * 33_333_333));
        }
        reps.extend(seg.finish());
        assert_eq!(reps.len(), 2, "{reps:?}");
        for r in &reps {
            // From about the top of the L to about its right end, with times in ms.
            let (first, last) = (r.points[0], r.points[r.points.len() - 1]);
            assert!(
                first[0].abs() < 0.05 && (first[1] + 0.2).abs() < 0.05,
                "{first:?}"
            );
            assert!(
                (last[0] - 0.6).abs() < 0.05 && (last[1] - 0.8).abs() < 0.05,
                "{last:?}"
            );
            assert_eq!(first[2], 0.0);
            assert!((last[2] - 27.0 * 33.333).abs() < 100.0, "{last:?}");
        }
    }

    /// A push towards the camera from a hand held out in front: a repetition of its
    /// own, whose depth says how far the hand went.
    #[test]
    fn a_push_towards_the_camera_is_a_repetition_with_its_depth() {
        let mut seg = RepetitionSegmenter::new(RepetitionConfig::default());
        let mut frames: Vec<HandPoint> = Vec::new();
        let (low, held) = ([0.8, 1.7, 0.2], [0.2, 0.0, 0.8]);
        let go = |f: &mut Vec<HandPoint>, a: [f32; 3], b: [f32; 3], n: usize| {
            for i in 1..=n {
                let t = i as f32 / n as f32;
                let s = t * t * t * (10.0 - 15.0 * t + 6.0 * t * t);
                f.push(point(
                    a[0] + s * (b[0] - a[0]),
                    a[1] + s * (b[1] - a[1]),
                    a[2] + s * (b[2] - a[2]),
                ));
            }
        };
        frames.extend((0..20).map(|_| point(low[0], low[1], low[2])));
        go(&mut frames, low, held, 15);
        let pushed = [held[0], held[1], held[2] + 0.7];
        go(&mut frames, held, pushed, 15);
        go(&mut frames, pushed, low, 15);
        frames.extend((0..20).map(|_| point(low[0], low[1], low[2])));
        let mut reps = Vec::new();
        for (i, p) in frames.iter().enumerate() {
            reps.extend(seg.push_point(*p, i as u64, i as u64 * 33_333_333));
        }
        reps.extend(seg.finish());
        assert_eq!(reps.len(), 1, "{reps:?}");
        let r = &reps[0];
        assert_eq!(r.depth.len(), r.points.len());
        let (lo, hi) = r
            .depth
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &z| (a.min(z), b.max(z)));
        assert!(hi - lo > 0.5, "{lo}..{hi}");
    }
}
