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
//!    those with the stretch's coarse shape, size, place, timing and the hand's path
//!    just before and after it, and tells a whole gesture from movement, part of a
//!    gesture or a gesture with movement around it.
//! 3. Overlapping accepted candidates compete, ranked by the verifier's probability of
//!    a whole gesture of the classifier's label times the classifier's confidence
//!    ([`RankBy`]); the winner is published once nothing better has come for
//!    `hold_seconds` or the hand rests.

mod calibrate;
mod segmenter;
mod threshold;
mod verifier;

pub use calibrate::{calibrate_label_bars, BAR_STEPS};
pub use segmenter::Segmenter;
pub use threshold::{sample_codes, LeeKim, Quantizer, ThresholdModel, REST_CODE, STREAM_SYMBOLS};
pub use verifier::{
    context, context_steps, stream_examples, Verifier, VerifierInput, CONTEXT_ARC, CONTEXT_POINTS,
    CONTEXT_SECONDS,
};

use crate::data::{Sample, Trajectory};
use crate::hmm::{DiscreteHmm, HmmTrainConfig};
use crate::model::{LabelledHmm, Model};
use crate::tracker::{Hand, HandPoint, HandTracker, TrackerConfig};
use airglyph_core::Skeleton;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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

/// Whether a segment's size (larger side, gesture-size units) can be a gesture's.
fn size_ok(pts: &[[f32; 2]], cfg: &SpotterConfig) -> bool {
    let (x0, y0, x1, y1) = crate::features::bbox(pts);
    let size = (x1 - x0).max(y1 - y0);
    size >= cfg.min_size && size <= cfg.max_size
}

impl SpottingModel {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.step > 0.0 && self.step < 1.0) {
            return Err(format!("spotting step {} is not in (0, 1)", self.step));
        }
        if let Some(v) = &self.verifier {
            if v.nets.is_empty() {
                return Err("spotting verifier has no network".into());
            }
            use crate::limits::{within, MAX_NETS, MAX_TIMING};
            v.features.validate("spotting verifier's features")?;
            within("spotting verifier's timing points", v.timing, 0, MAX_TIMING)?;
            within("spotting verifier's networks", v.nets.len(), 1, MAX_NETS)?;
            for net in &v.nets {
                net.validate()
                    .map_err(|e| format!("spotting verifier: {e}"))?;
                if net.inputs() != v.dim() || net.outputs() != v.classes.len() + 1 {
                    return Err("spotting verifier has the wrong dimensions".into());
                }
            }
            for (label, bar) in &v.label_bars {
                if !v.classes.contains(label) {
                    return Err(format!(
                        "spotting verifier has a bar for label {label:?}, which the model does not have"
                    ));
                }
                if !(0.0..=1.0).contains(bar) {
                    return Err(format!(
                        "spotting verifier's bar {bar} for label {label:?} is not a probability"
                    ));
                }
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
    /// with the same labels; its spotting part is not used) and has `verifiers`
    /// networks (at least one); then calibrates the verifier's per-label bars
    /// ([`calibrate_label_bars`]).
    pub fn train(
        samples: &[Sample],
        classifier: &Model,
        step: f64,
        states: usize,
        verifiers: usize,
    ) -> Self {
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
        // Seed 7 first: a one-network verifier is the one trained before ensembles.
        let seeds: Vec<u64> = (7..).take(verifiers.max(1)).collect();
        model.verifier = Some(Verifier::train(samples, classifier, &model, &seeds));
        let mut whole = classifier.clone();
        whole.spotting = Some(model.clone());
        let bars = calibrate_label_bars(&whole, samples, CALIBRATION_SEED, &|_, _| {});
        if let Some(v) = model.verifier.as_mut() {
            v.label_bars = bars;
        }
        model
    }
}

/// Seed of the streams the label bars are calibrated on: other streams than the
/// verifier's (seeds 7…) and the evaluation's (1–3).
pub const CALIBRATION_SEED: u64 = 101;

/// What overlapping accepted candidates are ranked by: the classifier's confidence
/// times the verifier's probability of…
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RankBy {
    /// …a whole gesture of any label (what acceptance tests).
    Gesture,
    /// …a whole gesture of the classifier's label: a stretch the verifier takes for a
    /// whole gesture, but less surely for the one the classifier names, ranks lower
    /// (an approach and a "1" that the classifier calls a "7"). The held-out digits
    /// lose fewer competitions (gesture README, "Spotting").
    #[default]
    Label,
}

impl RankBy {
    /// The log of the evidence that ranks a candidate among overlapping ones.
    pub fn rank(self, p_gesture: f64, p_label: f64, score: f64) -> f64 {
        let verifier = match self {
            RankBy::Gesture => p_gesture,
            RankBy::Label => p_label,
        };
        verifier.max(1e-9).ln() + score.max(1e-9).ln()
    }
}

/// Run-time settings of the spotter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
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
    /// Smallest verifier probability that the segment is a whole gesture (None: the
    /// verifier's own, [`Verifier::min_gesture_prob`]).
    pub min_gesture_prob: Option<f64>,
    /// Whether the labels the model's calibration found ordinary movement passing for
    /// must reach their higher bars ([`Verifier::label_bars`]).
    pub label_bars: bool,
    /// How long after a candidate's end to wait for a longer, better one (seconds);
    /// a rest of `rest_seconds` after it decides at once.
    pub hold_seconds: f64,
    pub rest_seconds: f64,
    pub rank_by: RankBy,
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
            min_gesture_prob: None,
            label_bars: true,
            // Held-out writers in synthetic streams, seeds 1–3, at 1.5 s and at 2.5 s:
            // digits 89.7, 91.1, 88.5 and 90.1, 91.1, 89.7 %; uppercase 81.6, 82.4, 83.2
            // and 84.7, 85.8, 85.9 %; all 36 78.0, 78.9, 76.8 and 81.5, 80.8, 80.8 %
            // (fewer substitutions and insertions: a better candidate overlapping the
            // pending one may end more than 1.5 s after it). 3 s is no better (digits,
            // uppercase).
            hold_seconds: 2.5,
            rest_seconds: 0.4,
            rank_by: RankBy::default(),
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
    /// The hand's path over the gesture as the spotter classified it: body frame, x to
    /// the person's right, y down, shoulder widths.
    #[serde(skip)]
    pub points: Vec<[f32; 2]>,
}

/// Why a spotter cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum SpotError {
    #[error("the model has no spotting HMMs (train it with `airglyph train`, which adds them)")]
    NoSpottingModel,
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
    /// Verifier probability of a whole gesture…
    pub p_gesture: f64,
    /// …and of a whole gesture of the classifier's label.
    pub p_label: f64,
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
    /// The smallest verifier probability of a whole gesture accepted, per label.
    bars: Vec<f64>,
}

impl Spotter {
    pub fn new(model: Model, cfg: SpotterConfig) -> Result<Spotter, SpotError> {
        let sm = model.spotting.as_ref().ok_or(SpotError::NoSpottingModel)?;
        let lee_kim = LeeKim::new(sm);
        // Without a verifier (a model trained without one), every segment the
        // classifier is sure of passes: boundaries then rest on the breaks alone.
        let bars = (0..model.labels.len())
            .map(|class| {
                sm.verifier.as_ref().map_or(0.0, |v| {
                    let base = cfg.min_gesture_prob.unwrap_or(v.min_gesture_prob());
                    if cfg.label_bars {
                        v.bar(class, base)
                    } else {
                        base
                    }
                })
            })
            .collect();
        Ok(Spotter {
            bars,
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
        self.push_tracked(skeleton, seq, time_ns).1
    }

    /// Feeds one skeleton like [`Spotter::push`], and tells the body-frame hand point
    /// the tracker made of it, the one the spotter went on (None for an unusable
    /// skeleton): what the gesture stage publishes for others to draw.
    pub fn push_tracked(
        &mut self,
        skeleton: &Skeleton,
        seq: u64,
        time_ns: u64,
    ) -> (Option<HandPoint>, Option<SpottedGesture>) {
        let Some(p) = self.tracker.update(skeleton, time_ns) else {
            return (None, None);
        };
        (Some(p), self.push_point(p, seq, time_ns))
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
        let after = context_steps(self.seg.fps());
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
        let class = (0..post.len())
            .max_by(|&a, &b| post[a].total_cmp(&post[b]))
            .unwrap_or(0);
        let (p_gesture, p_label) = sm.verifier.as_ref().map_or((1.0, 1.0), |v| {
            let probs = v.probs(&input);
            (1.0 - probs[0], probs.get(class + 1).copied().unwrap_or(0.0))
        });
        let score = post.get(class).copied().unwrap_or(0.0);
        let accepted = self.cfg.margin.is_none_or(|m| ratio > m)
            && score >= self.cfg.min_score
            && p_gesture >= self.bars.get(class).copied().unwrap_or(0.0);
        Some(Candidate {
            start: s,
            end: e,
            start_seq: self.seg.point(s)?.1,
            end_seq: self.seg.point(e)?.1,
            class,
            score,
            p_gesture,
            p_label,
            ratio,
            rank: self.cfg.rank_by.rank(p_gesture, p_label, score),
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
        let after = context_steps(fps);
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
        // Back from gesture sizes, the segmenter's unit, to shoulder widths.
        let size = self.cfg.gesture_size.max(1e-3);
        let points = self.seg.points(c.start, c.end)?;
        Some(SpottedGesture {
            label: self.model.labels[c.class].clone(),
            class: c.class,
            score: c.score * c.p_gesture,
            start_seq: a.1,
            end_seq: b.1,
            start_ns: a.2,
            end_ns: b.2,
            hand: self.hand,
            points: points.iter().map(|p| p.map(|v| v * size)).collect(),
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

    #[test]
    fn ranking_by_label_prefers_the_stretch_the_verifier_names_as_the_classifier_does() {
        // Both whole gestures to the verifier, equally sure to the classifier; the first
        // the verifier reads as the classifier's label, the second mostly as another.
        let (named, other) = ((0.9, 0.88, 0.99), (0.95, 0.6, 0.99));
        let rank = |by: RankBy, (g, l, s): (f64, f64, f64)| by.rank(g, l, s);
        assert!(rank(RankBy::Gesture, other) > rank(RankBy::Gesture, named));
        assert!(rank(RankBy::Label, named) > rank(RankBy::Label, other));
        // Nothing is -inf.
        assert!(RankBy::Label.rank(1.0, 0.0, 0.0).is_finite());
    }

    #[test]
    fn settings_without_the_ranking_field_still_load() {
        let mut v = serde_json::to_value(SpotterConfig::default()).unwrap();
        v.as_object_mut().unwrap().remove("rank_by");
        let cfg: SpotterConfig = serde_json::from_value(v).unwrap();
        assert_eq!(cfg.rank_by, RankBy::Label);
    }
}
