//! Continuous synthetic hand streams for evaluating the spotter: gesture samples drawn
//! at a steady speed, joined by random non-gesture hand movement, as skeletons of a
//! person facing the camera; and scoring of spotted gestures against the truth.

use crate::data::{Sample, Trajectory};
use crate::features::resample;
use crate::spot::SpottedGesture;
use crate::tracker::skeleton_with_hand;
use airglyph_core::Skeleton;
use rand::Rng;
use serde::Serialize;

/// How streams are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamConfig {
    pub fps: f32,
    /// Hand speed while drawing and moving, shoulder widths per second.
    pub speed: f32,
    /// Gesture size (larger side) range, shoulder widths.
    pub size: (f32, f32),
    /// Random movement segments between two gestures.
    pub moves: (usize, usize),
    /// Tracking noise (shoulder widths, uniform ±).
    pub noise: f32,
    /// Distance of the person from the camera, metres.
    pub distance: f32,
    /// Probability that the hand pauses (0.1–0.3 s) before and after a gesture.
    pub pause_prob: f64,
}

impl Default for StreamConfig {
    fn default() -> Self {
        Self {
            fps: 30.0,
            speed: 1.5,
            size: (0.8, 1.2),
            moves: (1, 3),
            noise: 0.004,
            distance: 2.2,
            pause_prob: 0.3,
        }
    }
}

/// A drawn gesture in a stream: its label and its first and last frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthGesture {
    pub label: String,
    pub start: u64,
    pub end: u64,
}

/// A stream: body-frame hand points, one a frame, and what was drawn where.
#[derive(Debug, Clone, Default)]
pub struct SyntheticStream {
    pub points: Vec<[f32; 2]>,
    pub truth: Vec<TruthGesture>,
}

impl SyntheticStream {
    pub fn skeleton(&self, frame: usize, distance: f32) -> Skeleton {
        let p = self.points[frame];
        skeleton_with_hand(p[0], p[1], distance)
    }
}

fn walk(points: &mut Vec<[f32; 2]>, path: &[[f32; 2]], step: f32) {
    // Walks along `path` at `step` per frame, continuing from the last point.
    let Some(&first) = path.first() else { return };
    let mut cur = *points.last().unwrap_or(&first);
    for &p in path {
        loop {
            let (dx, dy) = (p[0] - cur[0], p[1] - cur[1]);
            let d = (dx * dx + dy * dy).sqrt();
            if d < step {
                break;
            }
            cur = [cur[0] + dx / d * step, cur[1] + dy / d * step];
            points.push(cur);
        }
    }
}

/// A smooth random movement from `from` to `to` through random curves (quadratic Bezier
/// pieces through `segments − 1` random waypoints).
pub fn random_path<R: Rng>(
    rng: &mut R,
    from: [f32; 2],
    to: [f32; 2],
    segments: usize,
) -> Vec<[f32; 2]> {
    let mut way = vec![from];
    for _ in 1..segments {
        way.push([rng.gen_range(-1.2..1.6), rng.gen_range(-0.8..1.6)]);
    }
    way.push(to);
    let mut out = Vec::new();
    for w in way.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (mx, my) = ((a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0);
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let bend = rng.gen_range(-0.6..0.6) * len;
        let (nx, ny) = if len > 1e-6 {
            (-(b[1] - a[1]) / len, (b[0] - a[0]) / len)
        } else {
            (0.0, 0.0)
        };
        let c = [mx + nx * bend, my + ny * bend];
        for k in 0..=24 {
            let t = k as f32 / 24.0;
            let u = 1.0 - t;
            out.push([
                u * u * a[0] + 2.0 * u * t * c[0] + t * t * b[0],
                u * u * a[1] + 2.0 * u * t * c[1] + t * t * b[1],
            ]);
        }
    }
    out
}

/// Builds one stream from the samples, in the given order.
pub fn build_stream<R: Rng>(
    samples: &[&Sample],
    cfg: &StreamConfig,
    rng: &mut R,
) -> SyntheticStream {
    let step = cfg.speed / cfg.fps;
    let mut s = SyntheticStream::default();
    let mut pos = [rng.gen_range(-0.5..0.5), rng.gen_range(0.5..1.2)];
    s.points.push(pos);
    for sample in samples {
        let t = sample.trajectory();
        // Normalized (larger side 1, centred) at a high resolution, then placed.
        let r = resample(&t, 200);
        let size = rng.gen_range(cfg.size.0..=cfg.size.1);
        let centre = [rng.gen_range(0.0..0.6), rng.gen_range(0.0..0.6)];
        let g: Vec<[f32; 2]> = r
            .points
            .iter()
            .map(|p| [centre[0] + p[0] * size, centre[1] + p[1] * size])
            .collect();
        let moves = rng.gen_range(cfg.moves.0..=cfg.moves.1);
        let path = random_path(rng, pos, g[0], moves);
        walk(&mut s.points, &path, step * rng.gen_range(0.8..1.3));
        let pause = |s: &mut SyntheticStream, rng: &mut R| {
            if rng.gen_bool(cfg.pause_prob) {
                let last = *s.points.last().unwrap_or(&pos);
                for _ in 0..rng.gen_range(3..10) {
                    s.points.push(last);
                }
            }
        };
        pause(&mut s, rng);
        let start = s.points.len() as u64;
        walk(&mut s.points, &g, step);
        let end = s.points.len().saturating_sub(1) as u64;
        pause(&mut s, rng);
        s.truth.push(TruthGesture {
            label: sample.label.clone(),
            start,
            end: end.max(start),
        });
        pos = *s.points.last().unwrap_or(&pos);
    }
    // Movement after the last gesture.
    let to = [rng.gen_range(-0.5..0.5), rng.gen_range(0.5..1.2)];
    let path = random_path(rng, pos, to, 2);
    walk(&mut s.points, &path, step);
    if cfg.noise > 0.0 {
        for p in &mut s.points {
            p[0] += rng.gen_range(-cfg.noise..cfg.noise);
            p[1] += rng.gen_range(-cfg.noise..cfg.noise);
        }
    }
    s
}

/// A stream of random movement only (`seconds` long).
pub fn random_movement<R: Rng>(seconds: f32, cfg: &StreamConfig, rng: &mut R) -> SyntheticStream {
    let step = cfg.speed / cfg.fps;
    let frames = (seconds * cfg.fps) as usize;
    let mut s = SyntheticStream::default();
    let mut pos = [0.0f32, 0.8];
    s.points.push(pos);
    while s.points.len() < frames {
        let to = [rng.gen_range(-1.2..1.6), rng.gen_range(-0.8..1.6)];
        let path = random_path(rng, pos, to, 1);
        walk(&mut s.points, &path, step * rng.gen_range(0.8..1.3));
        pos = *s.points.last().unwrap_or(&pos);
    }
    s.points.truncate(frames);
    for p in &mut s.points {
        p[0] += rng.gen_range(-cfg.noise..=cfg.noise);
        p[1] += rng.gen_range(-cfg.noise..=cfg.noise);
    }
    s
}

/// Spotting result counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct SpottingScore {
    pub gestures: usize,
    pub correct: usize,
    pub substitutions: usize,
    pub deletions: usize,
    pub insertions: usize,
    pub reliability: f64,
}

impl SpottingScore {
    pub fn add(&mut self, o: &SpottingScore) {
        self.gestures += o.gestures;
        self.correct += o.correct;
        self.substitutions += o.substitutions;
        self.deletions += o.deletions;
        self.insertions += o.insertions;
        self.reliability = self.correct as f64 / (self.gestures + self.insertions).max(1) as f64;
    }
}

/// Matches spotted gestures to the truth: a spotted gesture matches a drawn one when
/// their frame intervals overlap by at least half of the shorter one.
pub fn score(truth: &[TruthGesture], spotted: &[SpottedGesture]) -> SpottingScore {
    let mut used = vec![false; spotted.len()];
    let mut sc = SpottingScore {
        gestures: truth.len(),
        ..Default::default()
    };
    for t in truth {
        let mut found = None;
        for (i, g) in spotted.iter().enumerate() {
            if used[i] {
                continue;
            }
            let lo = t.start.max(g.start_seq);
            let hi = t.end.min(g.end_seq);
            let ov = hi.saturating_sub(lo) as f64;
            let shorter = (t.end - t.start)
                .min(g.end_seq.saturating_sub(g.start_seq))
                .max(1) as f64;
            if hi > lo && ov >= 0.5 * shorter {
                found = Some(i);
                break;
            }
        }
        match found {
            Some(i) => {
                used[i] = true;
                if spotted[i].label == t.label {
                    sc.correct += 1;
                } else {
                    sc.substitutions += 1;
                }
            }
            None => sc.deletions += 1,
        }
    }
    sc.insertions = used.iter().filter(|u| !**u).count();
    sc.reliability = sc.correct as f64 / (sc.gestures + sc.insertions).max(1) as f64;
    sc
}

/// Convenience for a trajectory of body-frame points.
pub fn trajectory(points: &[[f32; 2]]) -> Trajectory {
    Trajectory::from_points(points.to_vec())
}
