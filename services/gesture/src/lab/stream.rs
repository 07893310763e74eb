//! Continuous synthetic hand streams for evaluating the spotter, and scoring of spotted
//! gestures against the truth.
//!
//! A stream is what the hand tracker would report of a person who draws gestures among
//! ordinary movement, in the body frame (shoulder widths, x right, y down), one point a
//! frame. Its timing follows how people move, so that neither the gestures nor the
//! movement around them are easier to tell apart than in life:
//! - Drawing follows the two-thirds power law (Lacquaniti, Terzuolo & Viviani 1983):
//!   speed ∝ curvature^(−1/3), so the hand slows in curves and nearly stops at sharp
//!   corners and where one stroke's travel meets the next, with bounded acceleration.
//!   Each symbol is drawn at its own mean speed (×0.75–1.3 of `speed`).
//! - Ordinary movement is made of the same kinds of motion: reaches to random places
//!   (curved, bell-shaped speed, ending at rest or still moving into the next one),
//!   small fidgets, and rests with a slow drift. So the hand also stops and turns
//!   between gestures, and a stop alone does not mark a gesture.
//! - The hand reaches a gesture's first point and leaves its last one at a low speed
//!   (between 0 and `flow` × the drawing's mean speed, never necessarily stopping); with
//!   probability `pause_prob` it also rests there for 0.1–0.5 s.
//! - Tracking noise is added last.

use crate::body_frame::skeleton_with_hand;
use crate::features::resample;
use crate::lab::data::Sample;
use crate::spot::{Candidate, Postures, SpottedGesture, Spotter};
use crate::tracker::{HandFilter, TrackerConfig};
use crate::trajectory::Trajectory;
use airglyph_core::{Joint, Skeleton};
use nalgebra::Point3;
use rand::Rng;
use serde::Serialize;

/// How streams are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamConfig {
    /// Frames a second.
    pub fps: f32,
    /// Mean hand speed while drawing, shoulder widths per second (each gesture ×0.75–1.3).
    pub speed: f32,
    /// Gesture size (larger side) range, shoulder widths.
    pub size: (f32, f32),
    /// Ordinary movements (reaches, fidgets, rests) between two gestures.
    pub moves: (usize, usize),
    /// Tracking noise (shoulder widths, uniform ±).
    pub noise: f32,
    /// Distance of the person from the camera, metres.
    pub distance: f32,
    /// Probability that the hand rests (0.1–0.5 s) before and after a gesture.
    pub pause_prob: f64,
    /// Largest speed, as a fraction of the drawing's mean speed, at which the hand
    /// enters or leaves a gesture (each boundary draws one between 0 and this).
    pub flow: f32,
    /// Mean speed range of reaches (the hand's travel between places), shoulder widths
    /// a second.
    pub reach_speed: (f32, f32),
    /// Probability that a symbol is drawn in one smooth movement (minimum-jerk timing
    /// over its whole path, not slowing at corners) instead of by the power law.
    pub one_movement: f64,
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
            flow: 0.5,
            reach_speed: (0.8, 2.0),
            one_movement: 0.0,
        }
    }
}

/// A drawn gesture in a stream: its label and its first and last frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthGesture {
    /// The sample's label.
    pub label: String,
    /// Who wrote the sample drawn here (the data's subject).
    pub subject: String,
    /// Its first frame…
    pub start: u64,
    /// …and its last.
    pub end: u64,
}

/// A stream: body-frame hand points, one a frame, and what was drawn where.
#[derive(Debug, Clone, Default)]
pub struct SyntheticStream {
    /// The hand, one point a frame (shoulder widths, body frame).
    pub points: Vec<[f32; 2]>,
    /// What was drawn, in order.
    pub truth: Vec<TruthGesture>,
    /// The person's body when the generator models it (the everyday generator): None
    /// for the lab generator's, whose hand is always 0.35 m in front of the chest.
    pub body: Option<Body>,
    /// Stretches of ordinary movement in which the person may point at something with
    /// the drawing hand: (first frame, last frame, the chance that they do). For a
    /// posture signal beside the path (`crate::lab::posture_signal`); the path does not
    /// depend on it.
    pub pointing: Vec<(u64, u64, f64)>,
}

/// What a generator knows of the person besides the hand's path in the plane.
#[derive(Debug, Clone, Default)]
pub struct Body {
    /// Distance from the camera, metres (instead of the one the stream is fed at).
    pub distance: f32,
    /// How far in front of the shoulders the right hand is, metres, a frame.
    pub forward: Vec<f32>,
    /// Where the left hand rests: body frame x, y (shoulder widths), metres in front.
    pub left: [f32; 3],
}

impl SyntheticStream {
    /// The skeleton of a person at `distance` metres whose right hand is at frame
    /// `frame`'s point: what the spotter is fed, so that the hand tracker is part of
    /// what is measured.
    pub fn skeleton(&self, frame: usize, distance: f32) -> Skeleton {
        let p = self.points[frame];
        let Some(body) = &self.body else {
            return skeleton_with_hand(p[0], p[1], distance);
        };
        let z = body.distance;
        let mut s = skeleton_with_hand(p[0], p[1], z);
        // Shoulder width 0.36 m, origin between the shoulders 0.3 m above the camera's
        // centre line, as `skeleton_with_hand` has them.
        let sw = 0.36f32;
        let fwd = body.forward.get(frame).copied().unwrap_or(0.35);
        s.joints[Joint::RightHand.index()] = Point3::new(-p[0] * sw, -0.3 + p[1] * sw, z - fwd);
        let l = body.left;
        s.joints[Joint::LeftHand.index()] = Point3::new(-l[0] * sw, -0.3 + l[1] * sw, z - l[2]);
        s
    }

    /// Feeds the stream through `spotter` as skeletons (frame i at i / fps seconds)
    /// and returns what it spotted, the stream's end included.
    pub fn spot(&self, spotter: &mut Spotter, cfg: &StreamConfig) -> Vec<SpottedGesture> {
        self.spot_traced(spotter, cfg, |_| {})
    }

    /// [`Self::spot`] with each frame's hand postures (`postures[i]` for frame i; frames
    /// past its end have none).
    pub fn spot_posed(
        &self,
        spotter: &mut Spotter,
        cfg: &StreamConfig,
        postures: &[Postures],
    ) -> Vec<SpottedGesture> {
        self.spot_traced_posed(spotter, cfg, postures, |_| {})
    }

    /// [`Self::spot`], handing `trace` what the spotter traced (its scored
    /// candidates, with [`Spotter::set_trace`]) after every frame.
    pub fn spot_traced(
        &self,
        spotter: &mut Spotter,
        cfg: &StreamConfig,
        trace: impl FnMut(Vec<Candidate>),
    ) -> Vec<SpottedGesture> {
        self.spot_traced_posed(spotter, cfg, &[], trace)
    }

    /// [`Self::spot_traced`] with each frame's hand postures, as [`Self::spot_posed`].
    pub fn spot_traced_posed(
        &self,
        spotter: &mut Spotter,
        cfg: &StreamConfig,
        postures: &[Postures],
        mut trace: impl FnMut(Vec<Candidate>),
    ) -> Vec<SpottedGesture> {
        let dt = (1e9 / cfg.fps as f64) as u64;
        let mut out = Vec::new();
        for i in 0..self.points.len() {
            let pose = postures.get(i).unwrap_or(&Postures::NONE);
            let skeleton = self.skeleton(i, cfg.distance);
            out.extend(
                spotter
                    .push_posed(&skeleton, pose, i as u64, i as u64 * dt)
                    .1,
            );
            trace(spotter.take_trace());
        }
        out.extend(spotter.finish());
        trace(spotter.take_trace());
        out
    }
}

/// Largest hand acceleration along the path, shoulder widths / s² (about 10 m/s²).
const MAX_ACCEL: f32 = 30.0;
/// Arc-length step of the timing computation, shoulder widths.
const DS: f32 = 0.004;

/// The path resampled at equal arc-length steps of `DS`.
fn dense(path: &[[f32; 2]]) -> Vec<[f32; 2]> {
    let mut out = Vec::new();
    let Some(&first) = path.first() else {
        return out;
    };
    out.push(first);
    let mut cur = first;
    let mut left = DS;
    for &p in &path[1..] {
        loop {
            let (dx, dy) = (p[0] - cur[0], p[1] - cur[1]);
            let d = (dx * dx + dy * dy).sqrt();
            if d < left {
                left -= d;
                cur = p;
                break;
            }
            cur = [cur[0] + dx / d * left, cur[1] + dy / d * left];
            out.push(cur);
            left = DS;
        }
    }
    if out.last() != Some(&cur) {
        out.push(cur);
    }
    out
}

/// The hand's positions, one a frame, moving along `path` (shoulder widths) by the
/// two-thirds power law at mean speed `mean` (before the boundary speeds and the
/// acceleration limit slow it), entering at speed `v0` and leaving at `v1`. The first
/// point is not included (it is where the previous movement ended); the last is.
pub fn timed_path(path: &[[f32; 2]], mean: f32, v0: f32, v1: f32, fps: f32) -> Vec<[f32; 2]> {
    let d = dense(path);
    let n = d.len();
    if n < 2 {
        return Vec::new();
    }
    // Curvature from the turning angle over ±k steps (≈ 4 cm of arm movement: a hand
    // does not follow finer wiggles of the template).
    let k = 10usize;
    let mut kappa = vec![0.0f32; n];
    for i in 0..n {
        let (a, b) = (i.saturating_sub(k), (i + k).min(n - 1));
        if a == i || b == i {
            continue;
        }
        let u = [d[i][0] - d[a][0], d[i][1] - d[a][1]];
        let w = [d[b][0] - d[i][0], d[b][1] - d[i][1]];
        let ang = (u[0] * w[1] - u[1] * w[0])
            .atan2(u[0] * w[0] + u[1] * w[1])
            .abs();
        kappa[i] = ang / ((b - a) as f32 * DS * 0.5);
    }
    // Speed ∝ (κ + κ0)^(−1/3); κ0 caps the speed on straight parts (radius 1 sw).
    let shape: Vec<f32> = kappa.iter().map(|&c| (c + 1.0).powf(-1.0 / 3.0)).collect();
    let length = DS * (n - 1) as f32;
    let target_t = length / mean.max(1e-3);
    let floor = 0.03 * mean;
    let mut scale = shape.iter().map(|s| DS / s).sum::<f32>() / target_t;
    let mut v = vec![0.0f32; n];
    for _ in 0..3 {
        for i in 0..n {
            v[i] = (scale * shape[i]).max(floor);
        }
        // Bounded acceleration, from the entry speed forwards and the exit speed back.
        v[0] = v[0].min(v0.max(floor));
        for i in 1..n {
            v[i] = v[i].min((v[i - 1] * v[i - 1] + 2.0 * MAX_ACCEL * DS).sqrt());
        }
        v[n - 1] = v[n - 1].min(v1.max(floor));
        for i in (0..n - 1).rev() {
            v[i] = v[i].min((v[i + 1] * v[i + 1] + 2.0 * MAX_ACCEL * DS).sqrt());
        }
        let t: f32 = (1..n).map(|i| 2.0 * DS / (v[i - 1] + v[i])).sum();
        // Speed up the unconstrained parts to keep the mean, within reason.
        scale *= (t / target_t).clamp(1.0, 1.5);
    }
    let dt = 1.0 / fps;
    let mut out = Vec::new();
    let mut t = 0.0f32;
    let mut next = dt;
    for i in 1..n {
        let step = 2.0 * DS / (v[i - 1] + v[i]);
        while t + step >= next {
            let f = (next - t) / step;
            out.push([
                d[i - 1][0] + f * (d[i][0] - d[i - 1][0]),
                d[i - 1][1] + f * (d[i][1] - d[i - 1][1]),
            ]);
            next += dt;
        }
        t += step;
    }
    if out.last() != Some(&d[n - 1]) {
        out.push(d[n - 1]);
    }
    out
}

/// The hand's positions, one a frame, reaching along `path` in `secs` with a
/// bell-shaped speed (minimum-jerk timing of the arc length, Flash & Hogan 1985),
/// entering at speed `v0` and leaving at `v1` (quintic Hermite terms for the boundary
/// speeds, zero acceleration at both ends). First point excluded, last included.
pub fn reach_path(path: &[[f32; 2]], secs: f32, v0: f32, v1: f32, fps: f32) -> Vec<[f32; 2]> {
    let d = dense(path);
    let n = d.len();
    if n < 2 {
        return Vec::new();
    }
    let length = DS * (n - 1) as f32;
    let frames = (secs * fps).round().max(1.0) as usize;
    let mut out = Vec::with_capacity(frames);
    let mut last = 0.0f32;
    for f in 1..=frames {
        let u = f as f32 / frames as f32;
        let (u2, u3) = (u * u, u * u * u);
        let h = u3 * (10.0 - 15.0 * u + 6.0 * u2);
        let h0 = u - 6.0 * u3 + 8.0 * u3 * u - 3.0 * u3 * u2;
        let h1 = -4.0 * u3 + 7.0 * u3 * u - 3.0 * u3 * u2;
        // Monotonic along the path even for boundary speeds the time cannot carry.
        let s = (length * h + secs * (v0 * h0 + v1 * h1)).clamp(last, length);
        last = s;
        let x = s / DS;
        let i = (x.floor() as usize).min(n - 2);
        let t = x - i as f32;
        out.push([
            d[i][0] + t * (d[i + 1][0] - d[i][0]),
            d[i][1] + t * (d[i + 1][1] - d[i][1]),
        ]);
    }
    out
}

/// Where the hand hangs at rest, body frame.
const REST: [f32; 2] = [0.6, 1.7];

/// Builds a stream's points: the hand's state while it makes ordinary movement.
struct Mover<'a, R: Rng> {
    rng: &'a mut R,
    cfg: &'a StreamConfig,
    points: Vec<[f32; 2]>,
    /// The hand's speed at the last point (shoulder widths / s)…
    speed: f32,
    /// …and its direction (unit vector), which the next movement continues when the
    /// hand has not stopped: a moving hand cannot turn on the spot.
    dir: [f32; 2],
    /// The reaches in which the person may point ([`SyntheticStream::pointing`]).
    pointing: Vec<(u64, u64, f64)>,
}

fn unit(v: [f32; 2]) -> Option<[f32; 2]> {
    let l = (v[0] * v[0] + v[1] * v[1]).sqrt();
    (l > 1e-6).then(|| [v[0] / l, v[1] / l])
}

/// The direction in which a path leaves its first point (`rev`: arrives at its last).
fn end_direction(path: &[[f32; 2]], rev: bool) -> Option<[f32; 2]> {
    let n = path.len();
    let at = |i: usize| if rev { path[n - 1 - i] } else { path[i] };
    let p0 = at(0);
    (1..n).map(at).find_map(|p| {
        let d = [p[0] - p0[0], p[1] - p0[1]];
        ((d[0] * d[0] + d[1] * d[1]).sqrt() > 0.05)
            .then(|| unit(if rev { [-d[0], -d[1]] } else { d }))
            .flatten()
    })
}

impl<R: Rng> Mover<'_, R> {
    fn pos(&self) -> [f32; 2] {
        *self.points.last().unwrap_or(&REST)
    }

    fn set_dir_from(&mut self, path: &[[f32; 2]]) {
        if let Some(d) = end_direction(path, true) {
            self.dir = d;
        }
    }

    /// Draws along `path` (from the current position) at the given mean and exit speed.
    fn draw(&mut self, path: &[[f32; 2]], mean: f32, v1: f32) {
        let pts = timed_path(path, mean, self.speed, v1, self.cfg.fps);
        self.points.extend(pts);
        self.speed = v1;
        self.set_dir_from(path);
    }

    /// A curved path (cubic Bezier) from the hand to `to`: it leaves along the hand's
    /// direction if the hand is moving, and arrives along `arrive` if given.
    fn curve(&mut self, to: [f32; 2], arrive: Option<[f32; 2]>) -> Vec<[f32; 2]> {
        let from = self.pos();
        let d = [to[0] - from[0], to[1] - from[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let Some(u) = unit(d) else {
            return vec![from, to];
        };
        let normal = [-u[1], u[0]];
        let bent = |rng: &mut R, at: [f32; 2], along: f32| {
            let b = rng.gen_range(-0.5..0.5) * len;
            let f = rng.gen_range(0.2..0.4) * len * along;
            [
                at[0] + u[0] * f + normal[0] * b,
                at[1] + u[1] * f + normal[1] * b,
            ]
        };
        let c1 = if self.speed > 0.05 {
            let f = self.rng.gen_range(0.2..0.45) * len;
            [from[0] + self.dir[0] * f, from[1] + self.dir[1] * f]
        } else {
            bent(self.rng, from, 1.0)
        };
        let c2 = match arrive {
            Some(a) => {
                let f = self.rng.gen_range(0.2..0.45) * len;
                [to[0] - a[0] * f, to[1] - a[1] * f]
            }
            None => bent(self.rng, to, -1.0),
        };
        (0..=32)
            .map(|k| {
                let t = k as f32 / 32.0;
                let v = 1.0 - t;
                let (a, b, c, e) = (v * v * v, 3.0 * v * v * t, 3.0 * v * t * t, t * t * t);
                [
                    a * from[0] + b * c1[0] + c * c2[0] + e * to[0],
                    a * from[1] + b * c1[1] + c * c2[1] + e * to[1],
                ]
            })
            .collect()
    }

    /// Reaches along `path` at about the given mean speed, leaving at `v1`.
    fn reach(&mut self, path: &[[f32; 2]], mean: f32, v1: f32) {
        let length: f32 = path
            .windows(2)
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .sum();
        let secs = (length / mean).max(0.2);
        let pts = reach_path(path, secs, self.speed, v1, self.cfg.fps);
        self.points.extend(pts);
        self.speed = v1;
        self.set_dir_from(path);
    }

    /// Rests for `secs` with a slow drift of a centimetre or so.
    fn rest(&mut self, secs: f32) {
        let p = self.pos();
        let n = (secs * self.cfg.fps).round().max(1.0) as usize;
        let (ax, ay) = (
            self.rng.gen_range(-0.02..0.02f32),
            self.rng.gen_range(-0.02..0.02f32),
        );
        for i in 1..=n {
            let f = i as f32 / n as f32;
            let s = f * f * (3.0 - 2.0 * f);
            self.points.push([p[0] + ax * s, p[1] + ay * s]);
        }
        self.speed = 0.0;
    }

    /// One ordinary movement: a reach (to the drawing area, the rest position, the
    /// face or chest, anywhere), a small fidget, or a rest.
    fn ordinary(&mut self) {
        let r: f32 = self.rng.gen();
        if r < 0.2 {
            let secs = self.rng.gen_range(0.2..1.2);
            self.rest(secs);
            return;
        }
        let from = self.pos();
        let (to, mean) = if r < 0.35 {
            // Fidget: a short, slow movement.
            let a = self.rng.gen_range(0.0..std::f32::consts::TAU);
            let l = self.rng.gen_range(0.1..0.35);
            let to = [from[0] + l * a.cos(), from[1] + l * a.sin()];
            (to, self.rng.gen_range(0.3..0.8))
        } else {
            let to = match self.rng.gen_range(0..4) {
                0 => [self.rng.gen_range(-0.4..1.0), self.rng.gen_range(-0.4..0.9)],
                1 => [
                    REST[0] + self.rng.gen_range(-0.1..0.1),
                    REST[1] + self.rng.gen_range(-0.1..0.1),
                ],
                2 => [self.rng.gen_range(-0.2..0.4), self.rng.gen_range(-0.9..0.3)],
                _ => [self.rng.gen_range(-1.2..1.6), self.rng.gen_range(-0.8..1.9)],
            };
            let (lo, hi) = self.cfg.reach_speed;
            (to, self.rng.gen_range(lo..hi))
        };
        let path = self.curve(to, None);
        // A reach mostly ends at rest, sometimes flows into the next movement.
        let v1 = if self.rng.gen_bool(0.6) {
            0.0
        } else {
            self.rng.gen_range(0.0..0.6) * mean
        };
        let first = self.points.len() as u64;
        self.reach(&path, mean, v1);
        // One reach in ten that is not a fidget may be to point at something (the
        // generator's movement does not know; the posture signal decides).
        if r >= 0.35 {
            let last = self.points.len().saturating_sub(1) as u64;
            self.pointing.push((first, last.max(first), 0.1));
        }
    }
}

/// Builds one stream from the samples, in the given order.
pub fn build_stream<R: Rng>(
    samples: &[&Sample],
    cfg: &StreamConfig,
    rng: &mut R,
) -> SyntheticStream {
    let start = [rng.gen_range(-0.2..0.9), rng.gen_range(0.3..1.7)];
    let mut m = Mover {
        rng,
        cfg,
        points: vec![start],
        speed: 0.0,
        dir: [1.0, 0.0],
        pointing: Vec::new(),
    };
    let mut truth = Vec::new();
    for sample in samples {
        let t = sample.trajectory();
        // Normalized (larger side 1, centred) at a high resolution, then placed.
        let r = resample(&t, 200);
        let size = m.rng.gen_range(cfg.size.0..=cfg.size.1);
        let centre = [m.rng.gen_range(0.0..0.6), m.rng.gen_range(0.0..0.6)];
        let g: Vec<[f32; 2]> = r
            .points
            .iter()
            .map(|p| [centre[0] + p[0] * size, centre[1] + p[1] * size])
            .collect();
        for _ in 0..m.rng.gen_range(cfg.moves.0..=cfg.moves.1) {
            m.ordinary();
        }
        let draw_speed = cfg.speed * m.rng.gen_range(0.75..1.3);
        let v_in = m.rng.gen_range(0.0..=cfg.flow) * draw_speed;
        let v_out = m.rng.gen_range(0.0..=cfg.flow) * draw_speed;
        let approach_speed = m.rng.gen_range(cfg.reach_speed.0..cfg.reach_speed.1);
        // Flowing in, the hand arrives along the gesture's first direction.
        let arrive = end_direction(&g, false).filter(|_| v_in > 0.05);
        let path = m.curve(g[0], arrive);
        m.reach(&path, approach_speed, v_in);
        if m.rng.gen_bool(cfg.pause_prob) {
            let secs = m.rng.gen_range(0.1..0.5);
            m.rest(secs);
        }
        let first = m.points.len() as u64;
        if m.rng.gen_bool(cfg.one_movement) {
            m.reach(&g, draw_speed, v_out);
        } else {
            m.draw(&g, draw_speed, v_out);
        }
        let last = m.points.len().saturating_sub(1) as u64;
        truth.push(TruthGesture {
            label: sample.label.clone(),
            subject: sample.subject.clone(),
            start: first,
            end: last.max(first),
        });
        if m.rng.gen_bool(cfg.pause_prob) {
            let secs = m.rng.gen_range(0.1..0.5);
            m.rest(secs);
        }
    }
    // Movement after the last gesture.
    m.ordinary();
    let (mut points, pointing) = (m.points, m.pointing);
    add_noise(&mut points, cfg.noise, rng);
    SyntheticStream {
        points,
        truth,
        body: None,
        pointing,
    }
}

fn add_noise<R: Rng>(points: &mut [[f32; 2]], noise: f32, rng: &mut R) {
    if noise > 0.0 {
        for p in points {
            p[0] += rng.gen_range(-noise..noise);
            p[1] += rng.gen_range(-noise..noise);
        }
    }
}

/// Streams more varied than the evaluation's defaults, for training (the verifier, and
/// the classifier with `stream_augment`), so that what is trained does not learn one way
/// of moving: mean drawing speed 1.2–1.8 shoulder widths a second, a third of the symbols
/// drawn in one smooth movement, entering and leaving at 0.3–0.7 × the drawing speed,
/// reaches up to twice as fast.
pub fn training_stream<R: Rng>(rng: &mut R) -> StreamConfig {
    StreamConfig {
        speed: rng.gen_range(1.2..1.8),
        pause_prob: rng.gen_range(0.1..0.6),
        flow: rng.gen_range(0.3..0.7),
        one_movement: 0.3,
        reach_speed: (0.8, 4.0),
        ..StreamConfig::default()
    }
}

/// A trajectory as the spotter sees it when it is drawn in a stream: approached from a
/// resting hand, drawn with the stream's timing (`cfg`), with tracking noise, through
/// the hand tracker's One Euro filter (`tracker`'s settings), and cut at the frames it
/// was drawn in. For training the classifier on what the stream does to a symbol: the
/// filter lags and rounds its corners (gesture README, "What the stream does to a
/// symbol").
pub fn drawn_in_stream<R: Rng>(
    t: &Trajectory,
    cfg: &StreamConfig,
    tracker: &TrackerConfig,
    rng: &mut R,
) -> Trajectory {
    if t.has_depth() {
        // The streams are drawn in the frontal plane: a stream would lose the depth.
        return t.clone();
    }
    let sample = Sample {
        label: String::new(),
        subject: String::new(),
        strokes: vec![t.points.clone()],
        depth: None,
    };
    // No ordinary movement before the approach: the filter forgets within a few frames.
    let cfg = StreamConfig {
        moves: (0, 0),
        ..*cfg
    };
    let s = build_stream(&[&sample], &cfg, rng);
    let Some(truth) = s.truth.first() else {
        return t.clone();
    };
    let mut hand = HandFilter::new(tracker);
    let filtered: Vec<[f32; 2]> = s
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let time = i as f64 / cfg.fps as f64;
            hand.filter([p[0] as f64, p[1] as f64], time)
                .map(|c| c as f32)
        })
        .collect();
    let (a, b) = (truth.start as usize, truth.end as usize);
    Trajectory::from_points(filtered[a..=b].to_vec())
}

/// A stream of ordinary movement only (`seconds` long).
pub fn random_movement<R: Rng>(seconds: f32, cfg: &StreamConfig, rng: &mut R) -> SyntheticStream {
    let frames = (seconds * cfg.fps) as usize;
    let mut m = Mover {
        rng,
        cfg,
        points: vec![REST],
        speed: 0.0,
        dir: [1.0, 0.0],
        pointing: Vec::new(),
    };
    while m.points.len() < frames {
        m.ordinary();
    }
    let (mut points, pointing) = (m.points, m.pointing);
    points.truncate(frames);
    add_noise(&mut points, cfg.noise, rng);
    let pointing = pointing.into_iter().filter(|p| p.0 < frames as u64);
    SyntheticStream {
        points,
        truth: Vec::new(),
        body: None,
        pointing: pointing.collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Mean distance between two paths resampled and normalized alike.
    fn shape_distance(a: &Trajectory, b: &Trajectory) -> f32 {
        let (ra, rb) = (resample(a, 64), resample(b, 64));
        ra.points
            .iter()
            .zip(&rb.points)
            .map(|(p, q)| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
            .sum::<f32>()
            / 64.0
    }

    #[test]
    fn a_symbol_drawn_in_a_stream_keeps_its_shape() {
        // An "L" 0.4 × 0.6 units large: down, then right.
        let l = Trajectory::from_points(vec![[0.0, 0.0], [0.0, 0.6], [0.4, 0.6]]);
        let cfg = StreamConfig::default();
        let tracker = TrackerConfig::default();
        for seed in 0..8 {
            let drawn = drawn_in_stream(&l, &cfg, &tracker, &mut ChaCha8Rng::seed_from_u64(seed));
            // Drawn 0.8–1.2 shoulder widths large (path 1.3–2 long) at about 1.5 a
            // second, 30 frames a second: 15–80 frames.
            assert!((15..=80).contains(&drawn.len()), "{} frames", drawn.len());
            // The filter rounds the corner a little; the symbol stays an "L".
            let d = shape_distance(&l, &drawn);
            assert!(d < 0.05, "seed {seed}: shape moved by {d}");
        }
    }
}
