//! Spotting gestures in a continuous hand trajectory (Lee & Kim, "An HMM-based threshold
//! model approach for gesture recognition", PAMI 1999).
//!
//! The hand's body-frame path is quantized into direction codes at equal chord steps
//! (plus a resting code when the hand stays still). One left-right HMM per label scores
//! the codes; the threshold (non-gesture) model is an ergodic HMM made of all the gesture
//! models' states — each keeps its emissions and self-transition, and moves to any other
//! state with equal probability — plus one resting state. A single Viterbi pass over
//! the threshold model and all gesture models (entered from the threshold model) runs on
//! the stream; where a gesture model's final state beats the threshold model, a gesture
//! may end there; its start comes from the token that entered the model. When the
//! candidates stop, the best one is classified by the model's classifier on the hand
//! points between its start and end (boundaries refined by a few steps) and published.

use crate::data::{Sample, Trajectory};
use crate::features::{feature_vector, resample, FeatureConfig};
use crate::hmm::{DiscreteHmm, HmmTrainConfig};
use crate::mlp::{Mlp, MlpTrainConfig};
use crate::model::{LabelledHmm, Model};
use crate::tracker::{Hand, HandPoint, HandTracker, TrackerConfig};
use airglyph_core::Skeleton;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Direction codes 0..8 and the resting code 8.
pub const STREAM_SYMBOLS: usize = 9;
pub const REST_CODE: usize = 8;

/// The HMMs over stream codes, stored in the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpottingModel {
    /// Chord step as a fraction of the gesture's larger side.
    pub step: f64,
    pub models: Vec<LabelledHmm>,
    /// Gesture / non-gesture verifier of candidate segments (features, then the log of
    /// the segment's size in gesture sizes); output 1 = gesture.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verifier: Option<Verifier>,
}

/// A small network telling a whole gesture from movement around, before, after or
/// inside one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verifier {
    pub features: FeatureConfig,
    pub net: Mlp,
}

impl Verifier {
    /// log P(gesture) of a segment given in gesture-size units.
    pub fn log_p_gesture(&self, points: &[[f32; 2]]) -> f64 {
        let mut f = Vec::with_capacity(self.features.dim() + 1);
        verifier_features(points, &self.features, &mut f);
        self.net
            .log_probs(&f)
            .get(1)
            .copied()
            .unwrap_or(f32::NEG_INFINITY) as f64
    }

    /// Trains on the samples (positives) and movement around them (negatives).
    pub fn train(samples: &[Sample], seed: u64) -> Verifier {
        let features = FeatureConfig {
            pen_up: false,
            ..FeatureConfig::default()
        };
        let shapes: Vec<Vec<[f32; 2]>> = samples
            .par_iter()
            .map(|s| resample(&s.trajectory(), 80).points)
            .collect();
        let n = shapes.len() * 2;
        let labels: Vec<usize> = (0..n).map(|i| usize::from(i % 2 == 0)).collect();
        let cfg = MlpTrainConfig {
            hidden: 128,
            epochs: 20,
            seed,
            ..MlpTrainConfig::default()
        };
        let feats = |epoch: usize, i: usize| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ ((epoch as u64).wrapping_mul(0x1000_0001))
                    ^ (i as u64).wrapping_mul(0x9E37_79B9),
            );
            let pts = verifier_example(&shapes, i / 2, i.is_multiple_of(2), &mut rng);
            let mut f = Vec::new();
            verifier_features(&pts, &features, &mut f);
            f
        };
        let net = Mlp::train(n, features.dim() + 1, &labels, 2, &cfg, feats, |_| {});
        Verifier { features, net }
    }
}

fn verifier_features(points: &[[f32; 2]], cfg: &FeatureConfig, out: &mut Vec<f32>) {
    let t = Trajectory::from_points(points.to_vec());
    feature_vector(&t, cfg, out);
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in points {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let size = (x1 - x0).max(y1 - y0).max(1e-3);
    out.push(size.ln());
}

/// One training example for the verifier, in gesture-size units: a whole gesture
/// (`positive`), or random movement, a gesture with a long lead-in or tail, or part of
/// a gesture.
fn verifier_example(
    shapes: &[Vec<[f32; 2]>],
    k: usize,
    positive: bool,
    rng: &mut ChaCha8Rng,
) -> Vec<[f32; 2]> {
    let shape = &shapes[k % shapes.len()];
    let scale = rng.gen_range(0.75..1.3f32);
    let rot = rng.gen_range(-0.15..0.15f32);
    let (c, s) = (rot.cos(), rot.sin());
    let g: Vec<[f32; 2]> = shape
        .iter()
        .map(|p| [scale * (c * p[0] - s * p[1]), scale * (s * p[0] + c * p[1])])
        .collect();
    let lead = |rng: &mut ChaCha8Rng, at: [f32; 2], len: f32| {
        let a = rng.gen_range(0.0..std::f32::consts::TAU);
        let from = [at[0] + len * a.cos(), at[1] + len * a.sin()];
        crate::stream::random_path(rng, from, at, 1)
    };
    let first = g[0];
    let last = g[g.len() - 1];
    let kind = if positive { 0 } else { rng.gen_range(1..5) };
    match kind {
        0 => {
            let mut v = Vec::new();
            if rng.gen_bool(0.5) {
                let l = rng.gen_range(0.0..0.12);
                v.extend(lead(rng, first, l));
            }
            v.extend(&g);
            if rng.gen_bool(0.5) {
                let l = rng.gen_range(0.0..0.12);
                let mut t = lead(rng, last, l);
                t.reverse();
                v.extend(t);
            }
            v
        }
        1 => {
            let from = [rng.gen_range(-1.5..1.5), rng.gen_range(-1.5..1.5)];
            let to = [rng.gen_range(-1.5..1.5), rng.gen_range(-1.5..1.5)];
            let k = rng.gen_range(1..4);
            crate::stream::random_path(rng, from, to, k)
        }
        2 => {
            let l = rng.gen_range(0.2..1.2);
            let mut v = lead(rng, first, l);
            v.extend(&g);
            v
        }
        3 => {
            let l = rng.gen_range(0.2..1.2);
            let mut t = lead(rng, last, l);
            t.reverse();
            let mut v = g.clone();
            v.extend(t);
            v
        }
        _ => {
            let n = g.len();
            let keep = ((n as f32) * rng.gen_range(0.3..0.85)) as usize;
            let keep = keep.clamp(2, n);
            let part = if rng.gen_bool(0.5) {
                g[..keep].to_vec()
            } else {
                g[n - keep..].to_vec()
            };
            // Part of a gesture, sometimes with movement before or after it.
            match rng.gen_range(0..3) {
                0 => part,
                1 => {
                    let l = rng.gen_range(0.1..0.8);
                    let mut v = lead(rng, part[0], l);
                    v.extend(part);
                    v
                }
                _ => {
                    let l = rng.gen_range(0.1..0.8);
                    let mut t = lead(rng, part[part.len() - 1], l);
                    t.reverse();
                    let mut v = part;
                    v.extend(t);
                    v
                }
            }
        }
    }
}

impl SpottingModel {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.step > 0.0 && self.step < 1.0) {
            return Err(format!("spotting step {} is not in (0, 1)", self.step));
        }
        if let Some(v) = &self.verifier {
            v.net
                .validate()
                .map_err(|e| format!("spotting verifier: {e}"))?;
            if v.net.inputs() != v.features.dim() + 1 || v.net.outputs() != 2 {
                return Err("spotting verifier has the wrong dimensions".into());
            }
        }
        for m in &self.models {
            m.hmm
                .validate()
                .map_err(|e| format!("spotting HMM of label {:?}: {e}", m.label))?;
            if m.hmm.n_symbols() != STREAM_SYMBOLS {
                return Err(format!(
                    "spotting HMM of label {:?} has {} symbols, expected {STREAM_SYMBOLS}",
                    m.label,
                    m.hmm.n_symbols()
                ));
            }
        }
        Ok(())
    }

    /// Trains one banded HMM per label on the stream codes of the samples (each scaled
    /// so that its larger side is 1).
    pub fn train(samples: &[Sample], labels: &[String], step: f64, states: usize) -> Self {
        let cfg = HmmTrainConfig {
            states,
            symbols: STREAM_SYMBOLS,
            band: 1,
            iterations: 12,
            emission_prior: 0.3,
            transition_prior: 0.5,
            floor: 1e-3,
        };
        let models = labels
            .par_iter()
            .map(|l| {
                let seqs: Vec<Vec<usize>> = samples
                    .iter()
                    .filter(|s| &s.label == l)
                    .map(|s| sample_codes(&s.trajectory(), step))
                    .filter(|c| !c.is_empty())
                    .collect();
                LabelledHmm {
                    label: l.clone(),
                    hmm: DiscreteHmm::train(&seqs, &cfg),
                }
            })
            .collect();
        let verifier = Some(Verifier::train(samples, 7));
        Self {
            step,
            models,
            verifier,
        }
    }
}

/// Quantizes a path into direction codes at equal chord steps.
#[derive(Debug, Clone)]
pub struct Quantizer {
    pub step: f32,
    anchor: Option<[f32; 2]>,
}

impl Quantizer {
    pub fn new(step: f32) -> Self {
        Self { step, anchor: None }
    }

    pub fn reset(&mut self) {
        self.anchor = None;
    }

    /// Feeds a point; calls `emit(code)` for every full step the path made.
    pub fn push(&mut self, p: [f32; 2], mut emit: impl FnMut(usize)) {
        let Some(mut a) = self.anchor else {
            self.anchor = Some(p);
            return;
        };
        loop {
            let (dx, dy) = (p[0] - a[0], p[1] - a[1]);
            let d = (dx * dx + dy * dy).sqrt();
            if d < self.step {
                break;
            }
            emit(crate::bezier::direction_code(dx as f64, dy as f64, 8, 0.0));
            a = [a[0] + dx / d * self.step, a[1] + dy / d * self.step];
        }
        self.anchor = Some(a);
    }
}

/// The stream codes of a whole trajectory scaled so that its larger side is 1.
pub fn sample_codes(t: &Trajectory, step: f64) -> Vec<usize> {
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in &t.points {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let s = (x1 - x0).max(y1 - y0).max(1e-6);
    let mut q = Quantizer::new(step as f32);
    let mut out = Vec::new();
    for p in &t.points {
        q.push([(p[0] - x0) / s, (p[1] - y0) / s], |c| out.push(c));
    }
    out
}

/// Run-time settings of the spotter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpotterConfig {
    /// Expected size of a drawn gesture (its larger side) in shoulder widths.
    pub gesture_size: f32,
    /// A resting code is emitted for every this long without a step.
    pub rest_seconds: f64,
    /// Log-probability of entering a gesture model from the threshold model.
    pub enter_log_prob: f64,
    /// A gesture model must beat the threshold model by this log-likelihood margin.
    pub margin: f64,
    /// Cost of every code spent inside a gesture model (log space): tightens the
    /// boundaries, since movement before and after a gesture no longer comes free.
    pub code_penalty: f64,
    /// Codes to wait after the last candidate before deciding.
    pub hangover: usize,
    /// Shortest and longest gesture in codes.
    pub min_codes: usize,
    pub max_codes: usize,
    /// Smallest classifier confidence to publish a gesture.
    pub min_score: f64,
    /// Smallest verifier probability that the segment is a whole gesture.
    pub min_gesture_prob: f64,
    /// Boundary search: starts up to 3 × this many codes around the candidate's.
    pub refine: usize,
    /// Log-score bonus per code in the boundary search (prefers the longer of two
    /// segments that both look like whole gestures).
    pub length_bonus: f64,
    pub tracker: TrackerConfig,
}

impl Default for SpotterConfig {
    fn default() -> Self {
        Self {
            gesture_size: 1.0,
            rest_seconds: 0.3,
            enter_log_prob: -2.0,
            margin: 1.0,
            code_penalty: 0.1,
            hangover: 8,
            min_codes: 6,
            max_codes: 120,
            min_score: 0.5,
            min_gesture_prob: 0.7,
            refine: 6,
            length_bonus: 0.02,
            tracker: TrackerConfig::default(),
        }
    }
}

/// A gesture found in the stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpottedGesture {
    pub label: String,
    /// Index into the model's labels.
    pub class: usize,
    /// The classifier's confidence in [0, 1].
    pub score: f64,
    pub start_seq: u64,
    pub end_seq: u64,
    pub start_ns: u64,
    pub end_ns: u64,
    pub hand: Hand,
}

/// Why a spotter cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum SpotError {
    #[error("the model has no spotting HMMs (train it with `airglyph train`, which adds them)")]
    NoSpottingModel,
}

#[derive(Debug, Clone, Copy)]
struct Obs {
    /// Index of the hand point at which the code was emitted.
    point: usize,
}

#[derive(Debug, Clone, Copy)]
struct Candidate {
    model: usize,
    margin: f64,
    start: usize,
    end: usize,
}

/// One gesture model in the Viterbi network.
struct GestureNet {
    log_stay: Vec<f64>,
    log_next: Vec<f64>,
    log_b: Vec<f64>,
    score: Vec<f64>,
    start: Vec<usize>,
}

/// The streaming spotter: feed it skeletons (or body-frame points), get gestures.
pub struct Spotter {
    model: Model,
    cfg: SpotterConfig,
    tracker: HandTracker,
    quant: Quantizer,
    // Threshold model.
    thr_stay: Vec<f64>,
    thr_leave: Vec<f64>,
    thr_log_b: Vec<f64>,
    thr: Vec<f64>,
    nets: Vec<GestureNet>,
    /// Stream index of the first element of `obs`.
    obs_base: usize,
    obs: Vec<Obs>,
    /// Hand points with their frame sequence and time; index offset `pts_base`.
    pts_base: usize,
    pts: Vec<([f32; 2], u64, u64)>,
    best: Option<Candidate>,
    last_step_ns: Option<u64>,
    hand: Hand,
    /// Codes before this stream index may not start a gesture (after a publication).
    barrier: usize,
}

const NEG: f64 = f64::NEG_INFINITY;

impl Spotter {
    pub fn new(model: Model, cfg: SpotterConfig) -> Result<Spotter, SpotError> {
        let sm = model.spotting.clone().ok_or(SpotError::NoSpottingModel)?;
        let m = STREAM_SYMBOLS;
        let mut thr_stay = Vec::new();
        let mut thr_leave = Vec::new();
        let mut thr_log_b = Vec::new();
        let mut nets = Vec::new();
        for lm in &sm.models {
            let h = &lm.hmm;
            let n = h.n_states();
            let mut log_stay = Vec::with_capacity(n);
            let mut log_next = Vec::with_capacity(n);
            for i in 0..n {
                let stay = h.a[i][i];
                log_stay.push(stay.ln());
                log_next.push(if i + 1 < n { h.a[i][i + 1].ln() } else { NEG });
                let s = stay.clamp(0.05, 0.9);
                thr_stay.push(s.ln());
                thr_leave.push((1.0 - s).ln());
                for k in 0..m {
                    thr_log_b.push(h.b[i][k].ln());
                }
            }
            let mut log_b = Vec::with_capacity(n * m);
            for i in 0..n {
                for k in 0..m {
                    log_b.push(h.b[i][k].ln());
                }
            }
            nets.push(GestureNet {
                log_stay,
                log_next,
                log_b,
                score: vec![NEG; n],
                start: vec![0; n],
            });
        }
        // The resting state.
        thr_stay.push(0.9f64.ln());
        thr_leave.push(0.1f64.ln());
        for k in 0..m {
            thr_log_b.push(if k == REST_CODE {
                0.9f64.ln()
            } else {
                (0.1 / 8.0f64).ln()
            });
        }
        let nthr = thr_stay.len();
        let step = (sm.step as f32) * cfg.gesture_size;
        Ok(Spotter {
            tracker: HandTracker::new(cfg.tracker),
            quant: Quantizer::new(step),
            thr: vec![0.0; nthr],
            thr_stay,
            thr_leave,
            thr_log_b,
            nets,
            model,
            cfg,
            obs_base: 0,
            obs: Vec::new(),
            pts_base: 0,
            pts: Vec::new(),
            best: None,
            last_step_ns: None,
            hand: Hand::Right,
            barrier: 0,
        })
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn config(&self) -> &SpotterConfig {
        &self.cfg
    }

    /// Forgets the stream (e.g. the person was lost).
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.quant.reset();
        self.thr.iter_mut().for_each(|v| *v = 0.0);
        for n in &mut self.nets {
            n.score.iter_mut().for_each(|v| *v = NEG);
        }
        self.best = None;
        self.last_step_ns = None;
        self.barrier = self.obs_base + self.obs.len();
    }

    /// Feeds one skeleton (frame `seq`, capture time `time_ns`). Unusable skeletons
    /// (no person, non-finite joints) are skipped.
    pub fn push(&mut self, skeleton: &Skeleton, seq: u64, time_ns: u64) -> Option<SpottedGesture> {
        let p = self.tracker.update(skeleton, time_ns)?;
        self.push_point(p, seq, time_ns)
    }

    /// Feeds one body-frame hand point (shoulder widths, x right, y down).
    pub fn push_point(&mut self, p: HandPoint, seq: u64, time_ns: u64) -> Option<SpottedGesture> {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return None;
        }
        if p.hand != self.hand {
            self.hand = p.hand;
            self.quant.reset();
        }
        self.pts.push(([p.x, p.y], seq, time_ns));
        let pidx = self.pts_base + self.pts.len() - 1;
        let mut codes = Vec::new();
        self.quant.push([p.x, p.y], |c| codes.push(c));
        if codes.is_empty() {
            let last = *self.last_step_ns.get_or_insert(time_ns);
            if time_ns.saturating_sub(last) as f64 * 1e-9 >= self.cfg.rest_seconds {
                codes.push(REST_CODE);
            }
        }
        let mut out = None;
        for c in codes {
            self.last_step_ns = Some(time_ns);
            if let Some(g) = self.step(c, pidx) {
                out = Some(g);
            }
        }
        self.trim();
        out
    }

    fn trim(&mut self) {
        let keep = self.cfg.max_codes + 4 * self.cfg.hangover + 32;
        if self.obs.len() > 2 * keep {
            let drop = self.obs.len() - keep;
            self.obs.drain(..drop);
            self.obs_base += drop;
        }
        let first_pt = self
            .obs
            .first()
            .map_or(self.pts_base + self.pts.len().saturating_sub(1), |o| {
                o.point
            })
            .saturating_sub(1);
        if first_pt > self.pts_base + 256 {
            let drop = first_pt - self.pts_base;
            self.pts.drain(..drop.min(self.pts.len()));
            self.pts_base += drop.min(self.pts.len() + drop);
        }
    }

    /// One Viterbi step over the network with code `o`.
    fn step(&mut self, o: usize, pidx: usize) -> Option<SpottedGesture> {
        let m = STREAM_SYMBOLS;
        let t = self.obs_base + self.obs.len();
        self.obs.push(Obs { point: pidx });
        let g_prev = self.thr.iter().cloned().fold(NEG, f64::max);
        // Threshold model: self-transition or a uniform jump from any other state.
        let nthr = self.thr.len();
        let (mut b1, mut b1i, mut b2) = (NEG, usize::MAX, NEG);
        for i in 0..nthr {
            let v = self.thr[i] + self.thr_leave[i];
            if v > b1 {
                b2 = b1;
                b1 = v;
                b1i = i;
            } else if v > b2 {
                b2 = v;
            }
        }
        let ljump = -((nthr - 1).max(1) as f64).ln();
        for j in 0..nthr {
            let other = if j == b1i { b2 } else { b1 };
            let v = (self.thr[j] + self.thr_stay[j]).max(other + ljump);
            self.thr[j] = v + self.thr_log_b[j * m + o];
        }
        let g = self.thr.iter().cloned().fold(NEG, f64::max);
        // Gesture models, entered from the threshold model.
        let enter = g_prev + self.cfg.enter_log_prob;
        let mut cand: Option<Candidate> = None;
        for (mi, net) in self.nets.iter_mut().enumerate() {
            let n = net.score.len();
            for s in (0..n).rev() {
                let stay = net.score[s] + net.log_stay[s];
                let (from, fstart) = if s > 0 {
                    (net.score[s - 1] + net.log_next[s - 1], net.start[s - 1])
                } else if o != REST_CODE && t >= self.barrier {
                    (enter, t)
                } else {
                    (NEG, t)
                };
                let (v, st) = if stay >= from {
                    (stay, net.start[s])
                } else {
                    (from, fstart)
                };
                net.score[s] = v + net.log_b[s * m + o] - self.cfg.code_penalty;
                net.start[s] = st;
            }
            // Prune tokens that are too long.
            for s in 0..n {
                if t - net.start[s] > self.cfg.max_codes {
                    net.score[s] = NEG;
                }
            }
            let margin = net.score[n - 1] - g;
            let len = t + 1 - net.start[n - 1];
            if margin > self.cfg.margin
                && len >= self.cfg.min_codes
                && cand.is_none_or(|c| margin > c.margin)
            {
                cand = Some(Candidate {
                    model: mi,
                    margin,
                    start: net.start[n - 1],
                    end: t,
                });
            }
        }
        // Keep scores bounded.
        for v in self.thr.iter_mut() {
            *v -= g;
        }
        for net in self.nets.iter_mut() {
            net.score.iter_mut().for_each(|v| *v -= g);
        }
        if let Some(c) = cand {
            if self.best.is_none_or(|b| c.margin > b.margin) {
                self.best = Some(c);
            }
        }
        let b = self.best?;
        if t < b.end + self.cfg.hangover {
            return None;
        }
        self.best = None;
        let (g, used_end) = self.publish(b);
        // A published gesture blocks its codes; a rejected candidate only its start.
        let block = if g.is_some() { used_end } else { b.start };
        self.barrier = self.barrier.max(block + 1);
        for net in self.nets.iter_mut() {
            for s in 0..net.score.len() {
                if net.start[s] <= block {
                    net.score[s] = NEG;
                }
            }
        }
        g
    }

    /// The hand points of codes start..=end (stream indices), or None if trimmed.
    fn segment(&self, start: usize, end: usize) -> Option<(usize, usize)> {
        let o0 = start.checked_sub(self.obs_base)?;
        let o1 = end.checked_sub(self.obs_base)?;
        // The code at `start` describes the step that ended at its point; the segment
        // starts at the previous code's point.
        let p0 = if o0 > 0 {
            self.obs[o0 - 1].point
        } else {
            self.obs.get(o0)?.point.saturating_sub(1)
        };
        let p1 = self.obs.get(o1)?.point;
        let i0 = p0.checked_sub(self.pts_base)?;
        let i1 = p1.checked_sub(self.pts_base)?;
        (i1 < self.pts.len() && i0 < i1).then_some((i0, i1))
    }

    /// The hand points of codes s..=e in gesture-size units, with their point range.
    fn segment_points(&self, s: usize, e: usize) -> Option<(Vec<[f32; 2]>, usize, usize)> {
        if e <= s || e >= self.obs_base + self.obs.len() || e + 1 - s < self.cfg.min_codes {
            return None;
        }
        let (i0, i1) = self.segment(s, e)?;
        let inv = 1.0 / self.cfg.gesture_size.max(1e-3);
        let pts = self.pts[i0..=i1]
            .iter()
            .map(|p| [p.0[0] * inv, p.0[1] * inv])
            .collect();
        Some((pts, i0, i1))
    }

    /// Classifies a candidate with its boundaries refined: the verifier scores segments
    /// starting around the candidate's start and ending anywhere up to now (coarse grid,
    /// then a fine one around the best); the best few are classified, and the segment
    /// with the largest log P(gesture) + log P(class) wins.
    /// Returns the gesture (if accepted) and the last code it used.
    fn publish(&self, c: Candidate) -> (Option<SpottedGesture>, usize) {
        let r = self.cfg.refine as isize;
        let verifier = self
            .model
            .spotting
            .as_ref()
            .and_then(|m| m.verifier.as_ref());
        let now = (self.obs_base + self.obs.len()) as isize - 1;
        // Verifier log-probability plus a small bonus per code: of two segments that
        // both look whole, the longer explains more (a "4" rather than its last stroke).
        let bonus = self.cfg.length_bonus;
        let lpg = |s: isize, e: isize| -> Option<f64> {
            if s < self.barrier as isize || e < 0 {
                return None;
            }
            let (pts, _, _) = self.segment_points(s as usize, e as usize)?;
            Some(verifier.map_or(0.0, |v| v.log_p_gesture(&pts)) + bonus * (e - s) as f64)
        };
        // (log P(gesture), start, end)
        // Verifier scores on a grid (stride 2), smoothed over the four grid neighbours
        // so that a single spurious peak does not win.
        let s_lo = c.start as isize - 3 * r;
        let s_hi = c.start as isize + 3 * r;
        let e_lo = s_lo + self.cfg.min_codes as isize;
        let ns = ((s_hi - s_lo) / 2 + 1).max(0) as usize;
        let ne = ((now - e_lo) / 2 + 1).max(0) as usize;
        let mut grid = vec![f64::NAN; ns * ne];
        for si in 0..ns {
            for ei in 0..ne {
                let (s, e) = (s_lo + 2 * si as isize, e_lo + 2 * ei as isize);
                if let Some(v) = lpg(s, e) {
                    grid[si * ne + ei] = v;
                }
            }
        }
        let mut scored: Vec<(f64, isize, isize)> = Vec::new();
        for si in 0..ns {
            for ei in 0..ne {
                let v = grid[si * ne + ei];
                if v.is_nan() {
                    continue;
                }
                let mut acc = v;
                let mut n = 1.0;
                for (dsi, dei) in [(-1isize, 0isize), (1, 0), (0, -1), (0, 1)] {
                    let (a, b) = (si as isize + dsi, ei as isize + dei);
                    if a >= 0 && b >= 0 && (a as usize) < ns && (b as usize) < ne {
                        let w = grid[a as usize * ne + b as usize];
                        if !w.is_nan() {
                            acc += w;
                            n += 1.0;
                        }
                    }
                }
                scored.push((acc / n, s_lo + 2 * si as isize, e_lo + 2 * ei as isize));
            }
        }
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        let Some(&(_, bs, be)) = scored.first() else {
            return (None, c.end);
        };
        // The fine step keeps the smoothed optimum and adds its unsmoothed neighbours.
        scored.truncate(1);
        for ds in -1..=1isize {
            for de in -1..=1isize {
                if (ds, de) != (0, 0) {
                    if let Some(v) = lpg(bs + ds, be + de) {
                        scored.push((v, bs + ds, be + de));
                    }
                }
            }
        }
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        // (combined, P(gesture), class, score, i0, i1, end code)
        let mut best: Option<(f64, f64, usize, f64, usize, usize, usize)> = None;
        for &(v, s, e) in scored.iter().take(if verifier.is_some() { 3 } else { 1 }) {
            let Some((pts, i0, i1)) = self.segment_points(s as usize, e as usize) else {
                continue;
            };
            let cl = self.model.classify(&Trajectory::from_points(pts));
            let comb = v + cl.score.max(1e-12).ln();
            let p_gesture = (v - bonus * (e - s) as f64).exp();
            if best.is_none_or(|b| comb > b.0) {
                best = Some((comb, p_gesture, cl.class, cl.score, i0, i1, e as usize));
            }
        }
        let Some((_, p_gesture, class, score, i0, i1, used_end)) = best else {
            return (None, c.end);
        };
        if score < self.cfg.min_score || p_gesture < self.cfg.min_gesture_prob {
            return (None, c.end);
        }
        let _ = c.model;
        (
            Some(SpottedGesture {
                label: self.model.labels[class].clone(),
                class,
                score: score * p_gesture,
                start_seq: self.pts[i0].1,
                end_seq: self.pts[i1].1,
                start_ns: self.pts[i0].2,
                end_ns: self.pts[i1].2,
                hand: self.hand,
            }),
            used_end,
        )
    }
}
