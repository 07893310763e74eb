//! Spotting gestures in a continuous hand trajectory: where each one starts and ends,
//! and which it is, among ordinary movement.
//!
//! 1. Where a gesture can start or end ([`Segmenter`]): people slow down before and
//!    after drawing, and often rest; so the hand's path is cut at the local minima of
//!    its speed that lie well below the speed just before, and at rests. A gesture is
//!    a stretch between two such breaks (corners inside a symbol are breaks too).
//! 2. Which stretches are gestures: every stretch between breaks that is long and large
//!    enough is a candidate, judged by three pieces of evidence — the model's classifier
//!    (which symbol, how sure), Lee & Kim's threshold model ("An HMM-based threshold
//!    model approach for gesture recognition", PAMI 1999: one left-right HMM per label
//!    over the stretch's direction codes, against an ergodic non-gesture HMM made of all
//!    the gesture HMMs' states, [`LeeKim`]), and the [`Verifier`], a network that weighs
//!    those with the stretch's coarse shape, size, place and the hand's path just before
//!    and after it, and tells a whole gesture from movement, part of a gesture or a
//!    gesture with movement around it.
//! 3. Overlapping accepted candidates compete (verifier × classifier); the winner is
//!    published once nothing better has come for `hold_seconds` or the hand rests.

use crate::data::{Sample, Trajectory};
use crate::features::{feature_vector, FeatureConfig};
use crate::hmm::{DiscreteHmm, HmmTrainConfig, LogHmm};
use crate::mlp::{Mlp, MlpTrainConfig};
use crate::model::{LabelledHmm, Model};
use crate::tracker::{Hand, HandPoint, HandTracker, TrackerConfig};
use airglyph_core::Skeleton;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Symbols of the spotting HMMs: direction codes 0..8 and a resting code 8 (which a
/// segment between two breaks never holds: rests are breaks; it stays so that the
/// models keep their shape).
pub const STREAM_SYMBOLS: usize = 9;
pub const REST_CODE: usize = 8;

/// The HMMs over stream codes, stored in the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpottingModel {
    /// Chord step as a fraction of the gesture's larger side.
    pub step: f64,
    pub models: Vec<LabelledHmm>,
    /// Judge of candidate segments: not a gesture, or a whole gesture of which label.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verifier: Option<Verifier>,
}

/// Points of context the verifier sees on each side of a segment…
pub const CONTEXT_POINTS: usize = 6;
/// …one every this much of the hand's path (gesture sizes)…
pub const CONTEXT_ARC: f32 = 0.08;
/// …looking at most this far in time: so the context tells the way the hand came and
/// went, and whether it was still, however fast it moved.
pub const CONTEXT_SECONDS: f64 = 0.4;

/// The context of one end of a segment: walking from `points[at]` backwards (`back`)
/// or forwards, the points where the path has covered `k · CONTEXT_ARC`, k = 1…, within
/// `max_steps` points; beyond that, the last point looked at.
pub fn context(
    points: &[[f32; 2]],
    at: usize,
    back: bool,
    max_steps: usize,
) -> [[f32; 2]; CONTEXT_POINTS] {
    let mut out = [points[at]; CONTEXT_POINTS];
    let (mut i, mut walked, mut k) = (at, 0.0f32, 0usize);
    for _ in 0..max_steps {
        let j = if back {
            match i.checked_sub(1) {
                Some(j) => j,
                None => break,
            }
        } else if i + 1 < points.len() {
            i + 1
        } else {
            break;
        };
        let (a, b) = (points[i], points[j]);
        walked += ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        i = j;
        while k < CONTEXT_POINTS && walked >= (k + 1) as f32 * CONTEXT_ARC {
            out[k] = points[i];
            k += 1;
        }
        if k == CONTEXT_POINTS {
            return out;
        }
    }
    for o in &mut out[k..] {
        *o = points[i];
    }
    out
}

/// What the verifier judges: a segment of the hand's path and where the hand was just
/// before and just after it (nearest first), all in gesture-size units.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifierInput {
    pub segment: Vec<[f32; 2]>,
    pub before: [[f32; 2]; CONTEXT_POINTS],
    pub after: [[f32; 2]; CONTEXT_POINTS],
    /// The classifier's posterior of the segment (model label order), when the
    /// verifier uses it.
    pub posterior: Vec<f32>,
    /// Lee & Kim's ratio of the segment ([`LeeKim::ratio`]).
    pub ratio: f64,
}

/// A network telling a whole gesture from movement around, before, after or inside
/// one, and naming it. It sees the segment's coarse shape (the classifier has the fine
/// one: a verifier that sees every detail learns its training writers by heart), its
/// size and place in the body frame, the hand's path just before and after it (a
/// stroke followed by more drawing is part of a larger gesture), the classifier's
/// posterior and Lee & Kim's ratio; it answers "not a whole gesture" or "a whole
/// gesture of label L".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verifier {
    pub features: FeatureConfig,
    /// Labels of outputs 1…; output 0 is "not a whole gesture".
    pub classes: Vec<String>,
    pub net: Mlp,
}

/// Training examples for every drawn gesture (each sample is drawn this many times, in
/// different streams and a little distorted each time)…
const VERIFIER_REPEATS: usize = 3;
/// …and this many other segments for each whole gesture.
const VERIFIER_NEGATIVES: f64 = 4.0;
/// A segment is a whole gesture when it covers a drawn one this closely (intersection
/// over union)…
const WHOLE_IOU: f64 = 0.85;
/// …and not one below this.
const NOT_WHOLE_IOU: f64 = 0.6;

impl Verifier {
    /// Input size: segment features, log size, context, posterior, ratio, place.
    pub fn dim(&self) -> usize {
        self.features.dim() + 1 + 4 * CONTEXT_POINTS + self.classes.len() + 1 + 2
    }

    /// Probabilities: [not a gesture, label 0, label 1, …].
    pub fn probs(&self, input: &VerifierInput) -> Vec<f64> {
        let mut f = Vec::with_capacity(self.dim());
        verifier_features(input, self, &mut f);
        self.net
            .log_probs(&f)
            .iter()
            .map(|&l| (l as f64).exp())
            .collect()
    }

    /// Trains on the segments the spotter will judge: the samples are drawn in
    /// synthetic continuous streams (see [`crate::stream`]), the [`Segmenter`] cuts
    /// them, and every segment between two of its breaks is an example — a whole
    /// gesture of its label when it covers a drawn gesture closely (intersection over
    /// union ≥ 0.85), not a gesture when it does not (< 0.6: movement, part of a
    /// gesture, a gesture with movement before or after it); those in between are
    /// left out. `labels` are the model's labels.
    pub fn train(
        samples: &[Sample],
        classifier: &Model,
        spotting: &SpottingModel,
        seed: u64,
    ) -> Verifier {
        let features = FeatureConfig {
            pen_up: false,
            points: 12,
            grid: 3,
        };
        let mut shell = Verifier {
            features,
            classes: classifier.labels.clone(),
            net: Mlp::default(),
        };
        let lee_kim = LeeKim::new(spotting);
        let mut examples = stream_examples(samples, classifier, &lee_kim, seed);
        let pos = examples.iter().filter(|e| e.1 > 0).count().max(1);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED);
        let keep =
            (VERIFIER_NEGATIVES * pos as f64 / (examples.len() - pos).max(1) as f64).min(1.0);
        examples.retain(|e| e.1 > 0 || rng.gen_bool(keep));
        let targets: Vec<usize> = examples.iter().map(|e| e.1).collect();
        let cfg = MlpTrainConfig {
            hidden: 128,
            epochs: 20,
            seed,
            ..MlpTrainConfig::default()
        };
        let feats = |epoch: usize, i: usize| {
            let input = &examples[i].0;
            let mut f = Vec::new();
            if epoch == usize::MAX {
                verifier_features(input, &shell, &mut f);
                return f;
            }
            // A little rotation and scale, fresh every epoch.
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ ((epoch as u64).wrapping_mul(0x1000_0001))
                    ^ (i as u64).wrapping_mul(0x9E37_79B9),
            );
            let scale = rng.gen_range(0.85..1.15f32);
            let rot = rng.gen_range(-0.1..0.1f32);
            let (c, s) = (rot.cos(), rot.sin());
            let tf = |p: &[f32; 2]| [scale * (c * p[0] - s * p[1]), scale * (s * p[0] + c * p[1])];
            let moved = VerifierInput {
                segment: input.segment.iter().map(tf).collect(),
                before: input.before.map(|p| tf(&p)),
                after: input.after.map(|p| tf(&p)),
                posterior: input.posterior.clone(),
                ratio: input.ratio,
            };
            verifier_features(&moved, &shell, &mut f);
            f
        };
        let net = Mlp::train(
            examples.len(),
            shell.dim(),
            &targets,
            shell.classes.len() + 1,
            &cfg,
            feats,
            |_| {},
        );
        shell.net = net;
        shell
    }
}

fn verifier_features(input: &VerifierInput, v: &Verifier, out: &mut Vec<f32>) {
    let t = Trajectory::from_points(input.segment.clone());
    feature_vector(&t, &v.features, out);
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in &input.segment {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let size = (x1 - x0).max(y1 - y0).max(1e-3);
    out.push(size.ln());
    // Context relative to the segment's box, in its sizes (clamped: far is far).
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    for p in input.before.iter().chain(&input.after) {
        out.push(((p[0] - cx) / size).clamp(-3.0, 3.0));
        out.push(((p[1] - cy) / size).clamp(-3.0, 3.0));
    }
    // The classifier's posterior (zeros when it is not known).
    out.extend((0..v.classes.len()).map(|c| input.posterior.get(c).copied().unwrap_or(0.0)));
    // −∞ (no gesture HMM can end there) is as bad as a ratio gets.
    out.push(if input.ratio.is_finite() {
        input.ratio.clamp(-5.0, 5.0) as f32
    } else {
        -5.0
    });
    // Where in front of the body (people draw in front of the chest).
    out.push(cx.clamp(-3.0, 3.0));
    out.push(cy.clamp(-3.0, 3.0));
}

/// Candidate segments of synthetic streams of the samples, each with its verifier
/// target: 0 = not a whole gesture, 1 + i = a whole gesture of the classifier's label i
/// (see [`Verifier::train`]).
pub fn stream_examples(
    samples: &[Sample],
    classifier: &Model,
    lee_kim: &LeeKim,
    seed: u64,
) -> Vec<(VerifierInput, usize)> {
    use crate::stream::{build_stream, StreamConfig};
    use rand::seq::SliceRandom;
    let labels = &classifier.labels;
    let mut order: Vec<&Sample> = (0..VERIFIER_REPEATS).flat_map(|_| samples.iter()).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let chunks: Vec<(usize, Vec<&Sample>)> =
        order.chunks(20).map(|c| c.to_vec()).enumerate().collect();
    let scfg = SpotterConfig::default();
    chunks
        .par_iter()
        .flat_map_iter(|(k, chunk)| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(31).wrapping_add(*k as u64));
            // Streams more varied than the evaluation's defaults, so that the verifier
            // does not learn one way of moving: a third of the symbols drawn in one
            // smooth movement, reaches up to twice as fast.
            let cfg = StreamConfig {
                speed: rng.gen_range(1.2..1.8),
                pause_prob: rng.gen_range(0.1..0.6),
                flow: rng.gen_range(0.3..0.7),
                one_movement: 0.3,
                reach_speed: (0.8, 4.0),
                ..StreamConfig::default()
            };
            // Writer variation (as the classifier is trained with): every sample a
            // little rotated, sheared and stretched.
            let varied: Vec<Sample> = chunk
                .iter()
                .map(|s| {
                    let t = crate::features::augment(&s.trajectory(), &mut rng, 1.0);
                    Sample {
                        label: s.label.clone(),
                        subject: s.subject.clone(),
                        strokes: vec![t.points],
                    }
                })
                .collect();
            let refs: Vec<&Sample> = varied.iter().collect();
            let stream = build_stream(&refs, &cfg, &mut rng);
            let mut tracker = HandTracker::new(scfg.tracker);
            let mut seg = Segmenter::new(&scfg);
            let dt = (1e9 / cfg.fps as f64) as u64;
            let mut ends = Vec::new();
            for i in 0..stream.points.len() {
                let sk = stream.skeleton(i, cfg.distance);
                let Some(p) = tracker.update(&sk, i as u64 * dt) else {
                    continue;
                };
                ends.extend(seg.push([p.x, p.y], i as u64, i as u64 * dt));
            }
            let fps = cfg.fps as f64;
            let min_len = (scfg.min_seconds * fps) as usize;
            let max_len = (scfg.max_seconds * fps) as usize;
            let mut out = Vec::new();
            for e in ends {
                for s in seg.starts(e, 0, min_len, max_len) {
                    let Some(mut input) = seg.input(s, e, fps) else {
                        continue;
                    };
                    if !size_ok(&input.segment, &scfg) {
                        continue;
                    }
                    let t = Trajectory::from_points(input.segment.clone());
                    input.posterior = classifier.posterior(&t).iter().map(|&p| p as f32).collect();
                    input.ratio = lee_kim.ratio(&input.segment);
                    let (Some(a), Some(b)) = (seg.point(s), seg.point(e)) else {
                        continue;
                    };
                    // The drawn gesture it overlaps most (intersection over union).
                    let best = stream
                        .truth
                        .iter()
                        .map(|t| {
                            let inter = b.1.min(t.end) as f64 - a.1.max(t.start) as f64;
                            let union = b.1.max(t.end) as f64 - a.1.min(t.start) as f64;
                            ((inter / union.max(1.0)).max(0.0), t)
                        })
                        .max_by(|x, y| x.0.total_cmp(&y.0));
                    match best {
                        Some((iou, t)) if iou >= WHOLE_IOU => {
                            if let Some(c) = labels.iter().position(|l| *l == t.label) {
                                out.push((input, 1 + c));
                            }
                        }
                        Some((iou, _)) if iou >= NOT_WHOLE_IOU => {}
                        _ => out.push((input, 0)),
                    }
                }
            }
            out
        })
        .collect()
}

/// Whether a segment's size (larger side, gesture-size units) can be a gesture's.
fn size_ok(pts: &[[f32; 2]], cfg: &SpotterConfig) -> bool {
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in pts {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let size = (x1 - x0).max(y1 - y0);
    size >= cfg.min_size && size <= cfg.max_size
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
            if v.net.inputs() != v.dim() || v.net.outputs() != v.classes.len() + 1 {
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
    /// so that its larger side is 1), and the verifier, which uses `classifier` (a model
    /// with the same labels; its spotting part is not used).
    pub fn train(samples: &[Sample], classifier: &Model, step: f64, states: usize) -> Self {
        let labels = &classifier.labels;
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
        let mut model = Self {
            step,
            models,
            verifier: None,
        };
        model.verifier = Some(Verifier::train(samples, classifier, &model, 7));
        model
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
    /// A break is a local minimum of the hand's speed over this many frames each side…
    pub min_window: usize,
    /// …below this fraction of the fastest speed of the last `peak_seconds`.
    pub break_ratio: f32,
    pub peak_seconds: f64,
    /// Below this speed (gesture sizes a second) the hand is at rest.
    pub rest_speed: f32,
    /// Shortest and longest gesture, seconds.
    pub min_seconds: f64,
    pub max_seconds: f64,
    /// Smallest and largest gesture (larger side), in gesture sizes.
    pub min_size: f32,
    pub max_size: f32,
    /// Lee & Kim as a hard test: the best gesture HMM must beat the threshold model
    /// by this log-likelihood margin per code (None: the ratio is only evidence for
    /// the verifier).
    pub margin: Option<f64>,
    /// Smallest classifier confidence to publish a gesture.
    pub min_score: f64,
    /// Smallest verifier probability that the segment is a whole gesture.
    pub min_gesture_prob: f64,
    /// How long after a candidate's end to wait for a longer, better one (seconds);
    /// a rest of `rest_seconds` after it decides at once.
    pub hold_seconds: f64,
    pub rest_seconds: f64,
    pub tracker: TrackerConfig,
}

impl Default for SpotterConfig {
    fn default() -> Self {
        Self {
            gesture_size: 1.0,
            min_window: 3,
            break_ratio: 0.6,
            peak_seconds: 0.5,
            rest_speed: 0.15,
            min_seconds: 0.3,
            max_seconds: 4.0,
            min_size: 0.3,
            max_size: 2.5,
            margin: None,
            min_score: 0.5,
            min_gesture_prob: 0.2,
            hold_seconds: 1.5,
            rest_seconds: 0.4,
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

/// The threshold (non-gesture) model of Lee & Kim: every state of every gesture HMM,
/// each keeping its emissions and self-transition and moving to any other state with
/// equal probability. It explains any sequence of gesture pieces in any order, so a
/// gesture model beats it only on a whole gesture of its own.
#[derive(Debug, Clone)]
pub struct ThresholdModel {
    stay: Vec<f64>,
    leave: Vec<f64>,
    log_b: Vec<f64>,
}

impl ThresholdModel {
    pub fn new(models: &[LabelledHmm]) -> Self {
        let (mut stay, mut leave, mut log_b) = (Vec::new(), Vec::new(), Vec::new());
        for lm in models {
            let h = &lm.hmm;
            for i in 0..h.n_states() {
                let s = h.a[i][i].clamp(0.05, 0.95);
                stay.push(s.ln());
                leave.push((1.0 - s).ln());
                log_b.extend(h.b[i].iter().map(|p| p.ln()));
            }
        }
        Self { stay, leave, log_b }
    }

    /// Viterbi log-likelihood of the codes.
    pub fn log_likelihood(&self, codes: &[usize]) -> f64 {
        let n = self.stay.len();
        let m = STREAM_SYMBOLS;
        if n == 0 || codes.is_empty() {
            return 0.0;
        }
        let ljump = -((n - 1).max(1) as f64).ln();
        let mut d: Vec<f64> = (0..n)
            .map(|j| -(n as f64).ln() + self.log_b[j * m + codes[0]])
            .collect();
        for &o in &codes[1..] {
            // The best and second best "leave" scores give every state's best jump in
            // O(n) (a state cannot jump to itself).
            let (mut b1, mut b1i, mut b2) = (NEG, usize::MAX, NEG);
            for i in 0..n {
                let v = d[i] + self.leave[i];
                if v > b1 {
                    b2 = b1;
                    b1 = v;
                    b1i = i;
                } else if v > b2 {
                    b2 = v;
                }
            }
            for j in 0..n {
                let other = if j == b1i { b2 } else { b1 };
                d[j] = (d[j] + self.stay[j]).max(other + ljump) + self.log_b[j * m + o];
            }
        }
        d.iter().cloned().fold(NEG, f64::max)
    }
}

/// Viterbi log-likelihood of the codes ending in the model's last state (a whole
/// gesture, as Lee & Kim score it).
fn whole_gesture_ll(h: &LogHmm, codes: &[usize], buf: &mut Vec<f64>) -> f64 {
    let n = h.n;
    if codes.is_empty() || n == 0 {
        return NEG;
    }
    buf.clear();
    buf.extend((0..n).map(|i| h.log_pi[i] + h.log_b[i * h.m + codes[0]]));
    let mut next = vec![NEG; n];
    for &o in &codes[1..] {
        for j in 0..n {
            // Left-right: only a state at most two behind can lead here.
            let mut best = NEG;
            for i in j.saturating_sub(2)..=j {
                best = best.max(buf[i] + h.log_a[i * n + j]);
            }
            next[j] = best + h.log_b[j * h.m + o];
        }
        buf.copy_from_slice(&next);
    }
    buf[n - 1]
}

/// Lee & Kim's test of a segment: how much better the best gesture HMM explains its
/// direction codes than the threshold model does.
#[derive(Debug, Clone)]
pub struct LeeKim {
    step: f64,
    threshold: ThresholdModel,
    gestures: Vec<LogHmm>,
}

impl LeeKim {
    pub fn new(sm: &SpottingModel) -> Self {
        Self {
            step: sm.step,
            threshold: ThresholdModel::new(&sm.models),
            gestures: sm.models.iter().map(|m| m.hmm.to_log()).collect(),
        }
    }

    /// log P(codes | best gesture HMM, ending in its last state) − log P(codes |
    /// threshold model), per code; −∞ when no gesture HMM can end there.
    pub fn ratio(&self, points: &[[f32; 2]]) -> f64 {
        let codes = sample_codes(&Trajectory::from_points(points.to_vec()), self.step);
        if codes.is_empty() {
            return NEG;
        }
        let thr = self.threshold.log_likelihood(&codes);
        let mut buf = Vec::new();
        let best = self
            .gestures
            .iter()
            .map(|h| whole_gesture_ll(h, &codes, &mut buf))
            .fold(NEG, f64::max);
        (best - thr) / codes.len() as f64
    }
}

/// A place where a gesture may end (`end`) and the next begin (`start`): a dip of the
/// hand's speed (both the same point) or a rest (its first and last point).
#[derive(Debug, Clone, Copy)]
struct Break {
    end: usize,
    /// None while the rest goes on.
    start: Option<usize>,
}

/// Cuts the hand's path where a gesture can start or end: where the hand slows down
/// (a local minimum of its speed well below the fastest speed just before) or rests.
/// Points are numbered from the first one pushed (or since `reset`).
#[derive(Debug, Clone)]
pub struct Segmenter {
    cfg: SpotterConfig,
    /// Point index of the first element of `pts`.
    base: usize,
    /// Hand points (gesture-size units) with their frame sequence and time.
    pts: Vec<([f32; 2], u64, u64)>,
    /// `speed[k]`: the speed of point k − 2 (gesture sizes a second), centred over
    /// five points, so known two points late.
    speed: Vec<f32>,
    breaks: Vec<Break>,
    /// First point of the rest going on, if the hand rests.
    rest_from: Option<usize>,
}

impl Segmenter {
    pub fn new(cfg: &SpotterConfig) -> Self {
        Self {
            cfg: *cfg,
            base: 0,
            pts: Vec::new(),
            speed: Vec::new(),
            breaks: Vec::new(),
            rest_from: None,
        }
    }

    /// Forgets the path; numbering goes on.
    pub fn reset(&mut self) {
        self.base += self.pts.len();
        self.pts.clear();
        self.speed.clear();
        self.breaks.clear();
        self.rest_from = None;
    }

    /// Index the next point will get.
    pub fn next_index(&self) -> usize {
        self.base + self.pts.len()
    }

    /// Adds a point (gesture-size units); returns the point where a gesture may end,
    /// when one was found (a few points back).
    pub fn push(&mut self, p: [f32; 2], seq: u64, time_ns: u64) -> Option<usize> {
        self.pts.push((p, seq, time_ns));
        let k = self.pts.len() - 1;
        if k >= 4 {
            let (a, b) = (self.pts[k - 4], self.pts[k]);
            let dt = (b.2.saturating_sub(a.2) as f64 * 1e-9).max(1e-4) as f32;
            let d = ((b.0[0] - a.0[0]).powi(2) + (b.0[1] - a.0[1]).powi(2)).sqrt();
            self.speed.push(d / dt);
        } else {
            self.speed.push(f32::NAN);
        }
        // The newest point whose speed is known, less the local-minimum window.
        let j = (self.base + k).checked_sub(2 + self.cfg.min_window)?;
        self.detect(j)
    }

    fn speed_at(&self, i: usize) -> f32 {
        i.checked_sub(self.base)
            .and_then(|k| self.speed.get(k + 2))
            .copied()
            .unwrap_or(f32::NAN)
    }

    /// Frames a second, from the timestamps of the last second.
    pub fn fps(&self) -> f64 {
        let k = self.pts.len();
        if k < 2 {
            return 30.0;
        }
        let (a, b) = (self.pts[k.saturating_sub(30)], self.pts[k - 1]);
        let n = (k - 1 - k.saturating_sub(30)) as f64;
        let secs = (b.2.saturating_sub(a.2) as f64 * 1e-9).max(1e-3);
        (n / secs).clamp(5.0, 240.0)
    }

    fn detect(&mut self, j: usize) -> Option<usize> {
        let w = self.cfg.min_window;
        let v = self.speed_at(j);
        if v.is_nan() {
            return None;
        }
        let resting = v < self.cfg.rest_speed;
        match (resting, self.rest_from) {
            (true, None) => {
                self.rest_from = Some(j);
                self.breaks.push(Break {
                    end: j,
                    start: None,
                });
                return Some(j);
            }
            (true, Some(_)) => return None,
            (false, Some(_)) => {
                self.rest_from = None;
                if let Some(b) = self.breaks.last_mut() {
                    b.start = Some(j.saturating_sub(1).max(b.end));
                }
                return None;
            }
            (false, None) => {}
        }
        for i in j.saturating_sub(w).max(self.base)..=j + w {
            let u = self.speed_at(i);
            if (i < j && u <= v) || (i > j && u < v) {
                return None;
            }
        }
        let back = (self.cfg.peak_seconds * self.fps()) as usize;
        let peak = (j.saturating_sub(back).max(self.base)..=j + w)
            .map(|i| self.speed_at(i))
            .filter(|u| !u.is_nan())
            .fold(0.0f32, f32::max);
        if v > self.cfg.break_ratio * peak {
            return None;
        }
        self.breaks.push(Break {
            end: j,
            start: Some(j),
        });
        Some(j)
    }

    /// Points where a gesture ending at `end` may start: at least `from`, between
    /// `min_len` and `max_len` points before `end`.
    pub fn starts(&self, end: usize, from: usize, min_len: usize, max_len: usize) -> Vec<usize> {
        self.breaks
            .iter()
            .filter_map(|b| b.start)
            .filter(|&s| s >= from && s < end && end - s >= min_len && end - s <= max_len)
            .collect()
    }

    /// The point `i` with its frame sequence and time, while it is kept.
    pub fn point(&self, i: usize) -> Option<([f32; 2], u64, u64)> {
        self.pts.get(i.checked_sub(self.base)?).copied()
    }

    /// The points s..=e (gesture-size units), while they are kept.
    pub fn points(&self, s: usize, e: usize) -> Option<Vec<[f32; 2]>> {
        let (a, b) = (s.checked_sub(self.base)?, e.checked_sub(self.base)?);
        (a <= b && b < self.pts.len()).then(|| self.pts[a..=b].iter().map(|p| p.0).collect())
    }

    /// The verifier's input for the segment s..=e: its points, and the hand's path just
    /// before and after it ([`context`]; as far as kept).
    pub fn input(&self, s: usize, e: usize, fps: f64) -> Option<VerifierInput> {
        let segment = self.points(s, e)?;
        let (i0, i1) = (s - self.base, e - self.base);
        let all: Vec<[f32; 2]> = self.pts.iter().map(|p| p.0).collect();
        let steps = (CONTEXT_SECONDS * fps).round() as usize;
        let before = context(&all, i0, true, steps);
        let after = context(&all, i1, false, steps);
        Some(VerifierInput {
            segment,
            before,
            after,
            posterior: Vec::new(),
            ratio: 0.0,
        })
    }

    /// The first point of the rest going on, if the hand rests.
    pub fn resting_since(&self) -> Option<usize> {
        self.rest_from
    }

    /// Forgets points before `keep_from`.
    pub fn forget_before(&mut self, keep_from: usize) {
        let cut = keep_from.saturating_sub(self.base).min(self.pts.len());
        if cut == 0 {
            return;
        }
        self.pts.drain(..cut);
        self.speed.drain(..cut.min(self.speed.len()));
        self.base += cut;
        let base = self.base;
        self.breaks
            .retain(|b| b.start.is_none_or(|s| s >= base) && b.end >= base);
    }

    pub fn len(&self) -> usize {
        self.pts.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pts.is_empty()
    }
}

/// A scored segment of the stream (point indices, inclusive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub start: usize,
    pub end: usize,
    /// Frame sequence numbers of `start` and `end`.
    pub start_seq: u64,
    pub end_seq: u64,
    pub class: usize,
    /// Classifier confidence.
    pub score: f64,
    /// Verifier probability of a whole gesture.
    pub p_gesture: f64,
    /// Lee & Kim: best gesture HMM minus threshold model, log-likelihood.
    pub ratio: f64,
    /// What candidates are ranked by.
    pub rank: f64,
    pub accepted: bool,
}

/// The streaming spotter: feed it skeletons (or body-frame points), get gestures.
///
/// The [`Segmenter`] cuts the hand's path where a gesture may start or end. Every
/// stretch between two such breaks that is long and large enough to be a gesture is a
/// candidate; it is accepted when the best gesture HMM beats the threshold model on its
/// direction codes (Lee & Kim), the verifier network calls it a whole gesture, and the
/// classifier is confident. Overlapping accepted candidates compete (the best verifier
/// and classifier evidence wins); the winner is published once no better one has
/// appeared for `hold_seconds`, or the hand rests.
pub struct Spotter {
    model: Model,
    cfg: SpotterConfig,
    tracker: HandTracker,
    seg: Segmenter,
    lee_kim: LeeKim,
    /// Breaks (gesture ends) waiting for the context after them.
    waiting: std::collections::VecDeque<usize>,
    pending: Option<Candidate>,
    /// Points before this may not start a gesture (the end of the last one published).
    barrier: usize,
    hand: Hand,
    trace: Option<Vec<Candidate>>,
}

const NEG: f64 = f64::NEG_INFINITY;

impl Spotter {
    pub fn new(model: Model, cfg: SpotterConfig) -> Result<Spotter, SpotError> {
        let sm = model.spotting.as_ref().ok_or(SpotError::NoSpottingModel)?;
        let lee_kim = LeeKim::new(sm);
        Ok(Spotter {
            tracker: HandTracker::new(cfg.tracker),
            seg: Segmenter::new(&cfg),
            lee_kim,
            model,
            cfg,
            waiting: Default::default(),
            pending: None,
            barrier: 0,
            hand: Hand::Right,
            trace: None,
        })
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn config(&self) -> &SpotterConfig {
        &self.cfg
    }

    /// Records every candidate the spotter scores (for evaluation tools).
    pub fn set_trace(&mut self, on: bool) {
        self.trace = on.then(Vec::new);
    }

    /// The candidates scored since the last call.
    pub fn take_trace(&mut self) -> Vec<Candidate> {
        self.trace.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// Forgets the stream (e.g. the person was lost).
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.seg.reset();
        self.waiting.clear();
        self.pending = None;
        self.barrier = self.seg.next_index();
    }

    /// The stream has ended: judges what waits for more context and publishes what is
    /// pending (at most two gestures).
    pub fn finish(&mut self) -> Vec<SpottedGesture> {
        let mut out = Vec::new();
        while let Some(e) = self.waiting.pop_front() {
            out.extend(self.candidates_ending(e));
        }
        if let Some(p) = self.pending.take() {
            out.extend(self.publish(p));
        }
        out
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
            // The other hand's path does not continue this one.
            let hand = p.hand;
            self.reset();
            self.hand = hand;
        }
        let inv = 1.0 / self.cfg.gesture_size.max(1e-3);
        let now = self.seg.next_index();
        self.waiting
            .extend(self.seg.push([p.x * inv, p.y * inv], seq, time_ns));
        let mut out = None;
        // A break's candidates are judged once the context after it is in.
        let after = (CONTEXT_SECONDS * self.seg.fps()).round() as usize;
        while let Some(&e) = self.waiting.front() {
            if e + after > now {
                break;
            }
            self.waiting.pop_front();
            if let Some(g) = self.candidates_ending(e) {
                out = Some(g);
            }
        }
        if out.is_none() {
            out = self.decide(now);
        }
        self.trim();
        out
    }

    /// Scores the segments from every earlier break to `e`, keeps the best accepted one
    /// pending, and publishes a pending gesture that this one does not overlap.
    fn candidates_ending(&mut self, e: usize) -> Option<SpottedGesture> {
        let fps = self.seg.fps();
        let min_len = (self.cfg.min_seconds * fps) as usize;
        let max_len = (self.cfg.max_seconds * fps) as usize;
        let mut best: Option<Candidate> = None;
        for s in self.seg.starts(e, self.barrier, min_len, max_len) {
            let Some(c) = self.score(s, e) else { continue };
            if let Some(t) = self.trace.as_mut() {
                t.push(c);
            }
            if c.accepted && best.is_none_or(|b| c.rank > b.rank) {
                best = Some(c);
            }
        }
        let c = best?;
        let mut out = None;
        match self.pending {
            Some(p) if c.start >= p.end => {
                out = self.publish(p);
                self.pending = Some(c);
            }
            Some(p) if c.rank <= p.rank => {}
            _ => self.pending = Some(c),
        }
        out
    }

    /// Scores the segment of points s..=e.
    fn score(&mut self, s: usize, e: usize) -> Option<Candidate> {
        let mut input = self.seg.input(s, e, self.seg.fps())?;
        if !size_ok(&input.segment, &self.cfg) {
            return None;
        }
        let sm = self.model.spotting.as_ref()?;
        let t = Trajectory::from_points(input.segment.clone());
        let post = self.model.posterior(&t);
        input.posterior = post.iter().map(|&p| p as f32).collect();
        let ratio = self.lee_kim.ratio(&input.segment);
        input.ratio = ratio;
        // Without a verifier (a model trained without one), every segment the
        // classifier is sure of passes: boundaries then rest on the breaks alone.
        let p_gesture = sm
            .verifier
            .as_ref()
            .map_or(1.0, |v| 1.0 - v.probs(&input)[0]);
        let class = (0..post.len())
            .max_by(|&a, &b| post[a].total_cmp(&post[b]))
            .unwrap_or(0);
        let score = post.get(class).copied().unwrap_or(0.0);
        let accepted = self.cfg.margin.is_none_or(|m| ratio > m)
            && score >= self.cfg.min_score
            && p_gesture >= self.cfg.min_gesture_prob;
        Some(Candidate {
            start: s,
            end: e,
            start_seq: self.seg.point(s)?.1,
            end_seq: self.seg.point(e)?.1,
            class,
            score,
            p_gesture,
            ratio,
            rank: p_gesture.max(1e-9).ln() + score.max(1e-9).ln(),
            accepted,
        })
    }

    /// Publishes the pending gesture when it has waited long enough.
    fn decide(&mut self, now: usize) -> Option<SpottedGesture> {
        let p = self.pending?;
        let fps = self.seg.fps();
        let hold = (self.cfg.hold_seconds * fps) as usize;
        // A break within the hold still waits for its context: it may end a longer,
        // better gesture.
        if self.waiting.iter().any(|&e| e <= p.end + hold) {
            return None;
        }
        // Breaks are judged this many points late.
        let after = (CONTEXT_SECONDS * fps).round() as usize;
        let judged = now.saturating_sub(after);
        let rested = self
            .seg
            .resting_since()
            .is_some_and(|r| r >= p.end && (now - r) as f64 / fps >= self.cfg.rest_seconds);
        if judged >= p.end + hold || rested {
            self.pending = None;
            return self.publish(p);
        }
        None
    }

    fn publish(&mut self, c: Candidate) -> Option<SpottedGesture> {
        self.barrier = self.barrier.max(c.end);
        let (a, b) = (self.seg.point(c.start)?, self.seg.point(c.end)?);
        Some(SpottedGesture {
            label: self.model.labels[c.class].clone(),
            class: c.class,
            score: c.score * c.p_gesture,
            start_seq: a.1,
            end_seq: b.1,
            start_ns: a.2,
            end_ns: b.2,
            hand: self.hand,
        })
    }

    /// Forgets what no candidate can reach any more.
    fn trim(&mut self) {
        let fps = self.seg.fps();
        let keep = ((self.cfg.max_seconds + self.cfg.hold_seconds + 1.0) * fps) as usize;
        if self.seg.len() < 2 * keep.max(64) {
            return;
        }
        let mut from = self.seg.next_index() - keep;
        if let Some(p) = self.pending {
            from = from.min(p.start);
        }
        self.seg.forget_before(from);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points one a frame at 30 fps; times in ns.
    fn feed(seg: &mut Segmenter, pts: &[[f32; 2]]) -> Vec<usize> {
        let mut ends = Vec::new();
        for (i, p) in pts.iter().enumerate() {
            ends.extend(seg.push(*p, i as u64, i as u64 * 33_333_333));
        }
        ends
    }

    /// A minimum-jerk stroke from a to b in n frames (bell-shaped speed).
    fn stroke(a: [f32; 2], b: [f32; 2], n: usize) -> Vec<[f32; 2]> {
        (1..=n)
            .map(|i| {
                let t = i as f32 / n as f32;
                let s = t * t * t * (10.0 - 15.0 * t + 6.0 * t * t);
                [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]
            })
            .collect()
    }

    #[test]
    fn breaks_fall_where_the_hand_slows_down_or_rests() {
        let mut seg = Segmenter::new(&SpotterConfig::default());
        // Rest, three strokes (two corners, where the hand stops an instant), rest.
        let mut pts = vec![[0.0, 0.0]; 20];
        pts.extend(stroke([0.0, 0.0], [1.0, 0.0], 15));
        pts.extend(stroke([1.0, 0.0], [1.0, 1.0], 15));
        pts.extend(stroke([1.0, 1.0], [0.0, 1.0], 15));
        pts.extend(vec![[0.0, 1.0]; 30]);
        let ends = feed(&mut seg, &pts);
        // A rest's first point, each corner (frames 34 and 49, ±2), the last rest.
        let near = |want: usize| ends.iter().any(|&e| e.abs_diff(want) <= 2);
        assert!(near(34) && near(49) && near(64), "{ends:?}");
        assert!(ends.len() <= 5, "{ends:?}");
        // The first rest ended where the first stroke starts: a gesture may start there.
        let starts = seg.starts(64, 0, 10, 100);
        assert!(starts.iter().any(|&s| s.abs_diff(19) <= 2), "{starts:?}");
    }

    #[test]
    fn context_walks_the_path_by_arc_length_within_its_time() {
        let pts: Vec<[f32; 2]> = (0..40).map(|i| [i as f32 * 0.02, 0.0]).collect();
        // 0.02 a point: the k-th context point is the first at least 0.08 k back.
        let c = context(&pts, 30, true, 100);
        for (k, p) in c.iter().enumerate() {
            let back = 0.6 - p[0];
            let want = 0.08 * (k + 1) as f32;
            assert!(back > want - 1e-4 && back < want + 0.02 + 1e-4, "{c:?}");
        }
        // Only 6 steps allowed: the path is not long enough, the rest is its end.
        let c = context(&pts, 30, false, 6);
        assert!(c[0][0] > 0.68 - 1e-4 && c[0][0] < 0.70 + 1e-4, "{c:?}");
        assert!((c[5][0] - 0.72).abs() < 1e-4, "{c:?}");
        // A resting hand: all at the same point.
        let still = vec![[0.3f32, 0.4]; 20];
        assert_eq!(context(&still, 10, true, 12), [[0.3, 0.4]; CONTEXT_POINTS]);
    }

    #[test]
    fn the_threshold_model_beats_gesture_models_on_a_shuffled_gesture() {
        let models = ["A", "B"]
            .iter()
            .enumerate()
            .map(|(k, l)| {
                // A: right then down; B: left then up (codes 0 and 2, 4 and 6).
                let seqs = vec![
                    if k == 0 {
                        [vec![0; 6], vec![2; 6]].concat()
                    } else {
                        [vec![4; 6], vec![6; 6]].concat()
                    };
                    5
                ];
                let cfg = HmmTrainConfig {
                    states: 4,
                    symbols: STREAM_SYMBOLS,
                    band: 1,
                    iterations: 5,
                    emission_prior: 0.1,
                    transition_prior: 0.5,
                    floor: 1e-3,
                };
                LabelledHmm {
                    label: l.to_string(),
                    hmm: DiscreteHmm::train(&seqs, &cfg),
                }
            })
            .collect::<Vec<_>>();
        let thr = ThresholdModel::new(&models);
        let a = models[0].hmm.to_log();
        let mut buf = Vec::new();
        let whole = [vec![0; 6], vec![2; 6]].concat();
        let shuffled = [vec![2; 6], vec![0; 6]].concat();
        assert!(whole_gesture_ll(&a, &whole, &mut buf) > thr.log_likelihood(&whole));
        assert!(whole_gesture_ll(&a, &shuffled, &mut buf) < thr.log_likelihood(&shuffled));
    }
}
