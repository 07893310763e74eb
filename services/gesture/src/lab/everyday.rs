//! A second generator of continuous hand streams, written from its own model of a
//! standing person rather than by varying the lab generator's settings
//! ([`crate::lab::build_stream`]), so that a spotter trained on one can be measured on
//! the other.
//!
//! Each stream is one person, drawn at random:
//! - a rest pose they return to (arm hanging beside the hip, hands clasped before the
//!   belly, hand on the hip, arms crossed), the other hand resting to match (the hand
//!   tracker picks whichever hand is further forward and higher, as it would in life);
//! - a distance from the camera (1.8–3.2 m), how far in front of the chest they draw
//!   (0.25–0.5 m), where and how large (0.6–1.3 shoulder widths) they draw;
//! - a drawing timing: constant speed, or speed ∝ radius of curvature^β with β between
//!   0.15 and 0.45 (the two-thirds power law is β = 1/3), limited by the drawer's own
//!   largest acceleration; with or without pauses at sharp corners; a slow or fast
//!   drawer (0.8–2.4 shoulder widths a second on average over time); starting and ending each symbol from a
//!   stop, holding there for 0–0.4 s;
//! - a tempo of ordinary movement, and a tracking noise (Gaussian, 0.002–0.008 shoulder
//!   widths, with a slow wobble).
//!
//! Ordinary movement is a vocabulary of everyday actions, each from and back to a rest
//! or chained: resting (with tremor), reaching for something and holding it, touching
//! the face or the chest, waving (1.5–3 Hz oscillation above the shoulder), pointing
//! (a held, outstretched arm), scratching (a small 3–6 Hz oscillation at the head, neck
//! or arm), gesticulating as one talks (small quick beats before the belly), a hand to
//! the pocket. Movements between places follow minimum-jerk timing along slightly
//! curved paths, their durations by Fitts' law.

use crate::features::resample;
use crate::lab::data::Sample;
use crate::lab::stream::{Body, SyntheticStream, TruthGesture};
use rand::Rng;
use std::f32::consts::{PI, TAU};

/// Frames a second of the streams.
pub const FPS: f32 = 30.0;

/// A hand position: body frame x, y (shoulder widths) and how far in front of the
/// shoulders it is (metres).
type P3 = [f32; 3];

/// How a person draws a symbol's path.
#[derive(Debug, Clone, Copy)]
enum Law {
    /// The same speed all along (but for the acceleration limit).
    Constant,
    /// Speed ∝ (radius of curvature)^β.
    Power(f32),
}

/// One person: everything about how they move that stays the same in their stream.
#[derive(Debug, Clone)]
struct Person {
    distance: f32,
    rest: P3,
    left: P3,
    draw_forward: f32,
    centre: [f32; 2],
    size: (f32, f32),
    law: Law,
    speed: f32,
    accel: f32,
    corner_pause: f64,
    hold: f32,
    tempo: f32,
    noise: f32,
    wobble: f32,
}

fn range<R: Rng>(rng: &mut R, a: f32, b: f32) -> f32 {
    rng.gen_range(a..b)
}

impl Person {
    fn new<R: Rng>(rng: &mut R) -> Self {
        // Rest pose of the right hand and where the left one rests with it.
        let (rest, left) = match rng.gen_range(0..4) {
            0 | 1 => {
                // Arms hanging: the hands beside the hips, at the body's depth.
                let r = [
                    range(rng, 0.55, 0.8),
                    range(rng, 1.7, 1.95),
                    range(rng, -0.02, 0.05),
                ];
                (r, [-r[0], r[1] + range(rng, -0.05, 0.05), r[2]])
            }
            2 => {
                // Hands clasped before the belly.
                let r = [
                    range(rng, 0.0, 0.25),
                    range(rng, 1.15, 1.45),
                    range(rng, 0.1, 0.2),
                ];
                (r, [r[0] - 0.15, r[1], r[2]])
            }
            _ => {
                // Hand on the hip, the other hanging.
                let r = [
                    range(rng, 0.85, 1.05),
                    range(rng, 1.25, 1.45),
                    range(rng, -0.05, 0.02),
                ];
                (r, [-0.65, 1.8, 0.0])
            }
        };
        let law = if rng.gen_bool(0.4) {
            Law::Constant
        } else {
            Law::Power(range(rng, 0.15, 0.45))
        };
        let s0 = range(rng, 0.6, 1.3);
        Self {
            distance: range(rng, 1.8, 3.2),
            rest,
            left,
            draw_forward: range(rng, 0.25, 0.5),
            centre: [range(rng, 0.0, 0.6), range(rng, -0.1, 0.6)],
            size: (s0, s0 * 1.2),
            law,
            speed: range(rng, 0.8, 2.4),
            accel: range(rng, 12.0, 50.0),
            corner_pause: if rng.gen_bool(0.5) {
                0.0
            } else {
                rng.gen_range(0.3..0.9)
            },
            hold: range(rng, 0.0, 0.4),
            tempo: range(rng, 0.7, 1.4),
            noise: range(rng, 0.002, 0.008),
            wobble: range(rng, 0.0, 0.01),
        }
    }
}

/// Builds a person's hand path frame by frame.
struct Hand<'a, R: Rng> {
    rng: &'a mut R,
    who: &'a Person,
    points: Vec<P3>,
    /// The pointing actions ([`SyntheticStream::pointing`]).
    pointing: Vec<(u64, u64, f64)>,
}

fn lerp(a: P3, b: P3, t: f32) -> P3 {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

fn dist2(a: [f32; 2], b: [f32; 2]) -> f32 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

impl<R: Rng> Hand<'_, R> {
    fn at(&self) -> P3 {
        *self.points.last().unwrap_or(&self.who.rest)
    }

    /// Holds still for `secs` with a physiological tremor (a few millimetres).
    fn hold(&mut self, secs: f32) {
        let p = self.at();
        let n = (secs * FPS).round() as usize;
        let (fx, fy) = (range(self.rng, 0.5, 1.5), range(self.rng, 0.5, 1.5));
        let (px, py) = (range(self.rng, 0.0, TAU), range(self.rng, 0.0, TAU));
        let a = range(self.rng, 0.003, 0.012);
        for i in 1..=n {
            let t = i as f32 / FPS;
            let e = (i as f32 / 6.0).min(1.0);
            self.points.push([
                p[0] + e * a * (TAU * fx * t + px).sin(),
                p[1] + e * a * (TAU * fy * t + py).sin(),
                p[2],
            ]);
        }
    }

    /// Moves to `to` along a slightly curved path with minimum-jerk timing, its
    /// duration by Fitts' law (scaled by the person's tempo and `pace`).
    fn go(&mut self, to: P3, pace: f32) {
        let from = self.at();
        let d = dist2([from[0], from[1]], [to[0], to[1]]) + (to[2] - from[2]).abs() / 0.36;
        if d < 1e-4 {
            return;
        }
        let secs = (0.2 + 0.15 * (1.0 + d / 0.04).log2()) * self.who.tempo * pace;
        let bend = range(self.rng, -0.25, 0.25) * d;
        let (ux, uy) = (
            (to[0] - from[0]) / d.max(1e-3),
            (to[1] - from[1]) / d.max(1e-3),
        );
        let mid = [
            (from[0] + to[0]) / 2.0 - uy * bend,
            (from[1] + to[1]) / 2.0 + ux * bend,
            (from[2] + to[2]) / 2.0,
        ];
        let n = (secs * FPS).round().max(2.0) as usize;
        for i in 1..=n {
            let t = i as f32 / n as f32;
            let s = t * t * t * (10.0 - 15.0 * t + 6.0 * t * t);
            let a = lerp(from, mid, s);
            let b = lerp(mid, to, s);
            self.points.push(lerp(a, b, s));
        }
    }

    /// Oscillates along a direction about the current place: `freq` Hz, `amp` shoulder
    /// widths, for `secs`, fading in and out.
    fn oscillate(&mut self, dir: [f32; 2], freq: f32, amp: f32, secs: f32) {
        let p = self.at();
        let n = (secs * FPS).round() as usize;
        for i in 1..=n {
            let t = i as f32 / FPS;
            // (sin π is a hair below 0 in f32: no square root of it.)
            let env = (PI * i as f32 / n as f32).sin().max(0.0).sqrt();
            let o = env * amp * (TAU * freq * t).sin();
            self.points
                .push([p[0] + dir[0] * o, p[1] + dir[1] * o, p[2]]);
        }
    }

    fn rest_pose(&mut self) -> P3 {
        let r = self.who.rest;
        [
            r[0] + range(self.rng, -0.05, 0.05),
            r[1] + range(self.rng, -0.05, 0.05),
            r[2],
        ]
    }

    /// One everyday action.
    fn action(&mut self) {
        match self.rng.gen_range(0..100) {
            0..=21 => {
                // Back to rest, and rest.
                let r = self.rest_pose();
                self.go(r, 1.0);
                let secs = range(self.rng, 0.5, 3.0);
                self.hold(secs);
            }
            22..=35 => {
                // Reach for something, hold it, bring the hand back a little.
                let to = [
                    range(self.rng, -0.6, 1.6),
                    range(self.rng, -0.3, 1.3),
                    range(self.rng, 0.3, 0.6),
                ];
                self.go(to, 1.0);
                let secs = range(self.rng, 0.2, 1.2);
                self.hold(secs);
                let back = lerp(to, self.who.rest, range(self.rng, 0.3, 1.0));
                self.go(back, 1.2);
            }
            36..=47 => {
                // Touch the face (chin, cheek, nose) or the chest, and stay a moment.
                let to = if self.rng.gen_bool(0.5) {
                    [
                        range(self.rng, -0.2, 0.2),
                        range(self.rng, -0.95, -0.55),
                        0.12,
                    ]
                } else {
                    [range(self.rng, -0.1, 0.5), range(self.rng, 0.2, 0.8), 0.05]
                };
                self.go(to, 1.0);
                let secs = range(self.rng, 0.4, 2.0);
                if self.rng.gen_bool(0.3) {
                    // Rubbing.
                    let a = range(self.rng, 0.0, PI);
                    let (f, amp) = (range(self.rng, 1.0, 2.5), range(self.rng, 0.02, 0.06));
                    self.oscillate([a.cos(), a.sin()], f, amp, secs);
                } else {
                    self.hold(secs);
                }
            }
            48..=56 => {
                // Wave: the hand raised above the shoulder, swinging side to side.
                let to = [
                    range(self.rng, 0.6, 1.3),
                    range(self.rng, -1.0, -0.3),
                    range(self.rng, 0.1, 0.35),
                ];
                self.go(to, 0.9);
                let (f, amp, secs) = (
                    range(self.rng, 1.5, 3.0),
                    range(self.rng, 0.1, 0.3),
                    range(self.rng, 0.8, 2.5),
                );
                let tilt = range(self.rng, -0.3, 0.3);
                self.oscillate([tilt.cos(), tilt.sin()], f, amp, secs);
            }
            57..=66 => {
                // Point at something: the arm outstretched, held.
                let to = [
                    range(self.rng, -0.6, 2.0),
                    range(self.rng, -0.6, 0.7),
                    range(self.rng, 0.45, 0.7),
                ];
                let first = self.points.len() as u64;
                self.go(to, 0.8);
                let secs = range(self.rng, 0.4, 2.0);
                self.hold(secs);
                let last = self.points.len().saturating_sub(1) as u64;
                self.pointing.push((first, last.max(first), 1.0));
            }
            67..=76 => {
                // Scratch: head, neck or the other arm, small and fast.
                let to = match self.rng.gen_range(0..3) {
                    0 => [range(self.rng, -0.3, 0.4), range(self.rng, -1.3, -1.0), 0.0],
                    1 => [
                        range(self.rng, -0.1, 0.4),
                        range(self.rng, -0.4, -0.1),
                        0.05,
                    ],
                    _ => [range(self.rng, -0.9, -0.5), range(self.rng, 0.2, 0.9), 0.1],
                };
                self.go(to, 1.0);
                let a = range(self.rng, 0.0, PI);
                let (f, amp, secs) = (
                    range(self.rng, 3.0, 6.0),
                    range(self.rng, 0.015, 0.05),
                    range(self.rng, 0.5, 2.0),
                );
                self.oscillate([a.cos(), a.sin()], f, amp, secs);
            }
            77..=90 => {
                // Gesticulate while talking: a few quick beats before the belly.
                let to = [
                    range(self.rng, 0.0, 0.8),
                    range(self.rng, 0.4, 1.2),
                    range(self.rng, 0.2, 0.4),
                ];
                self.go(to, 0.8);
                for _ in 0..self.rng.gen_range(2..6) {
                    let p = self.at();
                    let a = range(self.rng, 0.0, TAU);
                    let l = range(self.rng, 0.05, 0.25);
                    let q = [p[0] + l * a.cos(), p[1] + l * a.sin(), p[2]];
                    self.go(q, 0.5);
                }
            }
            _ => {
                // A hand to the pocket, and out again.
                let to = [range(self.rng, 0.7, 0.95), range(self.rng, 1.35, 1.6), 0.0];
                self.go(to, 1.0);
                let secs = range(self.rng, 0.3, 1.5);
                self.hold(secs);
            }
        }
    }

    /// Draws `path` (body frame, from its first point, where the hand is) with the
    /// person's timing; returns the first and last frame of the drawing.
    fn draw(&mut self, path: &[[f32; 2]]) -> (usize, usize) {
        let z = self.who.draw_forward;
        let frames = timed_drawing(path, self.who, self.rng);
        let first = self.points.len();
        self.points
            .extend(frames.iter().map(|p| [p[0], p[1], z + 0.02 * p[1]]));
        (first, self.points.len().saturating_sub(1).max(first))
    }
}

/// Arc-length step of the drawing timing, shoulder widths.
const STEP: f32 = 0.005;

/// The path at equal arc-length steps.
fn by_arc(path: &[[f32; 2]]) -> Vec<[f32; 2]> {
    let mut out: Vec<[f32; 2]> = path.first().copied().into_iter().collect();
    let mut carry = 0.0f32;
    for w in path.windows(2) {
        let l = dist2(w[0], w[1]);
        let mut s = STEP - carry;
        while s <= l {
            let t = s / l;
            out.push([
                w[0][0] + t * (w[1][0] - w[0][0]),
                w[0][1] + t * (w[1][1] - w[0][1]),
            ]);
            s += STEP;
        }
        carry = (carry + l) % STEP;
    }
    if let (Some(&last), Some(&end)) = (out.last(), path.last()) {
        if dist2(last, end) > 1e-4 {
            out.push(end);
        }
    }
    out
}

/// The frames of a drawing of `path` by `who`: the hand starts and ends it at rest.
/// The first point is not included, the last is.
fn timed_drawing<R: Rng>(path: &[[f32; 2]], who: &Person, rng: &mut R) -> Vec<[f32; 2]> {
    let d = by_arc(path);
    let n = d.len();
    if n < 3 {
        return d.into_iter().skip(1).collect();
    }
    // Curvature (Menger: of the circle through three points 2 cm apart).
    let h = 4usize;
    let mut kappa = vec![0.0f32; n];
    let mut turn = vec![0.0f32; n];
    for i in h..n.saturating_sub(h) {
        let (a, b, c) = (d[i - h], d[i], d[i + h]);
        let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        let den = dist2(a, b) * dist2(b, c) * dist2(a, c);
        kappa[i] = if den > 1e-9 {
            2.0 * cross.abs() / den
        } else {
            0.0
        };
        let u = [b[0] - a[0], b[1] - a[1]];
        let w = [c[0] - b[0], c[1] - b[1]];
        turn[i] = (u[0] * w[1] - u[1] * w[0])
            .atan2(u[0] * w[0] + u[1] * w[1])
            .abs();
    }
    let mut v: Vec<f32> = match who.law {
        Law::Constant => vec![1.0; n],
        Law::Power(beta) => kappa
            .iter()
            .map(|&k| (1.0 / (k + 0.5)).powf(beta))
            .collect(),
    };
    // Sharp corners (over 100° within 4 cm): the hand must nearly stop there.
    let mut corners = Vec::new();
    for i in 1..n - 1 {
        if turn[i] > 1.75 && turn[i] >= turn[i - 1] && turn[i] >= turn[i + 1] {
            v[i] = 0.0;
            corners.push(i);
        }
    }
    // Scale to the drawer's mean speed, then limit the acceleration from a stop at
    // both ends and at the corners (forwards and backwards).
    // (The mean over time: the path's length over the time it takes, corners aside.)
    let speed = who.speed * range(rng, 0.85, 1.15);
    let moving: Vec<f32> = v.iter().map(|&x| x.max(0.05)).collect();
    let secs: f32 = moving.iter().map(|&x| STEP / x).sum();
    let scale = secs * speed / (STEP * (n - 1) as f32);
    for (x, m) in v.iter_mut().zip(&moving) {
        *x = if *x == 0.0 { 0.0 } else { m * scale };
    }
    v[0] = 0.0;
    v[n - 1] = 0.0;
    for i in 1..n {
        v[i] = v[i].min((v[i - 1].powi(2) + 2.0 * who.accel * STEP).sqrt());
    }
    for i in (0..n - 1).rev() {
        v[i] = v[i].min((v[i + 1].powi(2) + 2.0 * who.accel * STEP).sqrt());
    }
    // Key frames (time, place) along the path, a corner's pause a second key frame at
    // the same place; the frames are sampled between them.
    let mut keys: Vec<(f32, [f32; 2])> = vec![(0.0, d[0])];
    let mut t = 0.0f32;
    for i in 1..n {
        t += STEP / ((v[i - 1] + v[i]) / 2.0).max(0.02);
        keys.push((t, d[i]));
        if corners.contains(&i) && rng.gen_bool(who.corner_pause) {
            t += range(rng, 0.06, 0.25);
            keys.push((t, d[i]));
        }
    }
    let frames = (t * FPS).ceil().max(1.0) as usize;
    let mut out = Vec::with_capacity(frames);
    let mut j = 1;
    for f in 1..=frames {
        let tf = (f as f32 / FPS).min(t);
        while j < keys.len() - 1 && keys[j].0 < tf {
            j += 1;
        }
        let ((ta, a), (tb, b)) = (keys[j - 1], keys[j]);
        let u = ((tf - ta) / (tb - ta).max(1e-6)).clamp(0.0, 1.0);
        out.push([a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])]);
    }
    out
}

/// A standard normal draw (Box–Muller).
fn gauss<R: Rng>(rng: &mut R) -> f32 {
    let u: f32 = rng.gen_range(1e-7..1.0);
    let v: f32 = rng.gen_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (TAU * v).cos()
}

/// The tracker's noise: Gaussian, and a slow wobble of the estimate.
fn noisy<R: Rng>(points: &[P3], who: &Person, rng: &mut R) -> Vec<[f32; 2]> {
    let (f1, f2) = (range(rng, 0.2, 0.8), range(rng, 0.2, 0.8));
    let (p1, p2) = (range(rng, 0.0, TAU), range(rng, 0.0, TAU));
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let t = i as f32 / FPS;
            [
                p[0] + who.noise * gauss(rng) + who.wobble * (TAU * f1 * t + p1).sin(),
                p[1] + who.noise * gauss(rng) + who.wobble * (TAU * f2 * t + p2).sin(),
            ]
        })
        .collect()
}

fn finish<R: Rng>(hand: Hand<'_, R>, truth: Vec<TruthGesture>) -> SyntheticStream {
    let Hand {
        rng,
        who,
        points,
        pointing,
    } = hand;
    let xy = noisy(&points, who, rng);
    let frames = points.len() as u64;
    SyntheticStream {
        points: xy,
        truth,
        body: Some(Body {
            distance: who.distance,
            forward: points.iter().map(|p| p[2]).collect(),
            left: who.left,
        }),
        pointing: pointing.into_iter().filter(|p| p.0 < frames).collect(),
    }
}

/// One person's stream drawing the samples in order among everyday actions.
pub fn everyday_stream<R: Rng>(samples: &[&Sample], rng: &mut R) -> SyntheticStream {
    let who = Person::new(rng);
    let mut hand = Hand {
        rng,
        who: &who,
        points: vec![who.rest],
        pointing: Vec::new(),
    };
    let secs = range(hand.rng, 0.3, 1.5);
    hand.hold(secs);
    let mut truth = Vec::new();
    for sample in samples {
        // 0–3 actions between two symbols (none: the next symbol follows at once).
        let actions = match hand.rng.gen_range(0..10) {
            0 | 1 => 0,
            2..=5 => 1,
            6..=8 => 2,
            _ => 3,
        };
        for _ in 0..actions {
            hand.action();
        }
        let r = resample(&sample.trajectory(), 200);
        let size = range(hand.rng, who.size.0, who.size.1);
        let c = [
            who.centre[0] + range(hand.rng, -0.15, 0.15),
            who.centre[1] + range(hand.rng, -0.15, 0.15),
        ];
        let g: Vec<[f32; 2]> = r
            .points
            .iter()
            .map(|p| [c[0] + p[0] * size, c[1] + p[1] * size])
            .collect();
        hand.go([g[0][0], g[0][1], who.draw_forward], 1.0);
        let before = range(hand.rng, 0.0, who.hold);
        hand.hold(before);
        let (first, last) = hand.draw(&g);
        truth.push(TruthGesture {
            label: sample.label.clone(),
            subject: sample.subject.clone(),
            start: first as u64,
            end: last as u64,
        });
        let after = range(hand.rng, 0.0, who.hold);
        hand.hold(after);
    }
    hand.action();
    finish(hand, truth)
}

/// One person's everyday actions alone, `seconds` long.
pub fn everyday_movement<R: Rng>(seconds: f32, rng: &mut R) -> SyntheticStream {
    let who = Person::new(rng);
    let frames = (seconds * FPS) as usize;
    let mut hand = Hand {
        rng,
        who: &who,
        points: vec![who.rest],
        pointing: Vec::new(),
    };
    while hand.points.len() < frames {
        hand.action();
    }
    hand.points.truncate(frames);
    finish(hand, Vec::new())
}
