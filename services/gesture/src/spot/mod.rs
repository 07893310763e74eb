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
//!    gesture or a gesture with movement around it. A model without a verifier (every
//!    model of 3-D gestures) instead holds a stretch to Lee & Kim's test on codes in
//!    space ([`SpotterConfig::margin_without_verifier`]) and to the hand held out in
//!    front of the body ([`SpotterConfig::min_forward`]).
//! 3. Overlapping accepted candidates compete, ranked by the verifier's probability of
//!    a whole gesture of the classifier's label times the classifier's confidence
//!    ([`RankBy`]); the winner is published once nothing better has come for
//!    `hold_seconds` or the hand rests. Without a verifier, a stretch that holds the
//!    pending gesture whole and is nearly as sure takes its place
//!    ([`SpotterConfig::whole_over_part`]): the classifier alone is surer of a part.
//!
//! With the pen by posture ([`Pen::Posture`]) the posture of the drawing hand, read by
//! a posture classifier each frame, marks the gestures instead: the stretch between the
//! pen put down (the hand takes the posture, "point") and lifted is classified and
//! published at once, if it is long, large and sure enough. The gated pen
//! ([`Pen::Gated`]) spots by motion and accepts a stretch only when the drawing hand held
//! the pen's posture over enough of it. In every mode a gesture carries the posture its
//! hand held over most of it.

mod config;
mod pen;
mod segmenter;
mod threshold;

pub use config::{RankBy, SettingsError, SpotterConfig};
pub use pen::{
    GatedPen, HandPosture, Pen, PenParseError, PostureLabel, PostureLabelError, PosturePen,
    Postures, MAX_POSTURE_LABEL_BYTES,
};
use pen::{PenState, PostureTrack};
pub(crate) use segmenter::Segmenter;
pub(crate) use threshold::LeeKim;

use crate::model::verifier::{context_steps, VerifierInput};
use crate::model::Model;
use crate::tracker::{Hand, HandPoint, HandTracker};
use crate::trajectory::Trajectory;
use airglyph_core::Skeleton;
use serde::Serialize;

/// Whether a segment's size (larger side, gesture-size units) can be a gesture's.
pub(crate) fn size_ok(pts: &[[f32; 2]], cfg: &SpotterConfig) -> bool {
    let (x0, y0, x1, y1) = crate::features::bbox(pts);
    let size = (x1 - x0).max(y1 - y0);
    size >= cfg.min_size && size <= cfg.max_size
}

/// [`size_ok`] in space: the larger of the frontal size and the depth's extent.
fn size_ok_in_depth(pts: &[[f32; 2]], depth: &[f32], cfg: &SpotterConfig) -> bool {
    let (x0, y0, x1, y1) = crate::features::bbox(pts);
    let (z0, z1) = depth
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    let size = (x1 - x0).max(y1 - y0).max(z1 - z0);
    size >= cfg.min_size && size <= cfg.max_size
}

/// Whether a stretch in the plane was drawn facing the camera: the hand's depth
/// (non-finite values skipped) spans at most `ratio` times the larger frontal side.
fn faces_the_camera(pts: &[[f32; 2]], depth: &[f32], ratio: f32) -> bool {
    let (x0, y0, x1, y1) = crate::features::bbox(pts);
    let (z0, z1) = depth
        .iter()
        .filter(|z| z.is_finite())
        .fold((f32::MAX, f32::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    z1 <= z0 || z1 - z0 <= ratio * (x1 - x0).max(y1 - y0)
}

/// A gesture found in the stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpottedGesture {
    /// Its label…
    pub label: String,
    /// Index into the model's labels.
    pub class: usize,
    /// The classifier's confidence in [0, 1].
    pub score: f64,
    /// The frame sequence numbers of its first and last point…
    pub start_seq: u64,
    /// See `start_seq`.
    pub end_seq: u64,
    /// …and their times, as given to [`Spotter::push`].
    pub start_ns: u64,
    /// See `start_ns`.
    pub end_ns: u64,
    /// The hand that drew it.
    pub hand: Hand,
    /// The posture that hand held over most of the gesture's frames (None when no
    /// posture was known for most of them).
    pub posture: Option<PostureLabel>,
    /// The hand's path over the gesture as the spotter classified it: body frame, x to
    /// the person's right, y down, shoulder widths.
    #[serde(skip)]
    pub points: Vec<[f32; 2]>,
}

/// Why a spotter cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum SpotError {
    /// The model can classify but not spot: it was trained without its spotting part.
    #[error("the model has no spotting HMMs (train it with `airglyph train`, which adds them)")]
    NoSpottingModel,
}

/// A scored segment of the stream (point indices, inclusive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Its first point…
    pub start: usize,
    /// …and its last, numbered from the stream's first.
    pub end: usize,
    /// Frame sequence numbers of `start` and `end`.
    pub start_seq: u64,
    /// See `start_seq`.
    pub end_seq: u64,
    /// The classifier's label (an index into the model's labels).
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
    /// Whether it passed every test and may be published.
    pub accepted: bool,
}

/// The spotter's evidence on one stretch of the hand's path ([`Spotter::explain`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judgement {
    /// The classifier's label for the stretch (an index into the model's labels)…
    pub class: usize,
    /// …and its confidence.
    pub score: f64,
    /// The verifier's probability that the stretch is a whole gesture (1 without a
    /// verifier)…
    pub p_gesture: f64,
    /// …and a whole gesture of the classifier's label.
    pub p_label: f64,
    /// Lee & Kim's ratio: the best gesture HMM against the threshold model, per code.
    pub ratio: f64,
}

/// The streaming spotter: feed it skeletons (or body-frame points), get gestures.
///
/// The segmenter cuts the hand's path where a gesture may start or end. Every
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
    /// Whether the model reads depth: then the hand's depth is kept, counts in its
    /// speed and size, and goes to the classifier.
    in_depth: bool,
    /// The drawing hand's posture at every point kept.
    postures: PostureTrack,
    /// Where the pen by posture is (always up with the pen by motion).
    pen: PenState,
    /// Frames in a row without the drawing hand ([`Spotter::no_hand`]).
    unseen: u32,
}

impl Spotter {
    /// A spotter over `model`'s spotting part, which it must have.
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
        let in_depth = model.reads_depth();
        let mut seg = Segmenter::new(&cfg);
        seg.set_in_depth(in_depth);
        Ok(Spotter {
            bars,
            in_depth,
            tracker: HandTracker::new(cfg.tracker),
            seg,
            lee_kim,
            model,
            cfg,
            waiting: Default::default(),
            pending: None,
            barrier: 0,
            hand: Hand::Right,
            trace: None,
            postures: PostureTrack::default(),
            pen: PenState::Up,
            unseen: 0,
        })
    }

    /// The model it spots with.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Its settings.
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
        self.postures.clear();
        self.pen = PenState::Up;
        self.unseen = 0;
    }

    /// A frame without the drawing hand: no person, or the skeleton unusable. With the
    /// pen by posture, a pen down that many frames in a row (`up_frames`) is lifted at
    /// the hand's last point and what was drawn is judged: a hand dropped out of view
    /// to rest has let go of the pen, and its symbol must not wait for it to return.
    pub fn no_hand(&mut self) -> Option<SpottedGesture> {
        let Pen::Posture(pen) = self.cfg.pen else {
            return None;
        };
        self.unseen = self.unseen.saturating_add(1);
        if self.unseen < pen.up_frames.max(1) {
            return None;
        }
        let last = self.seg.next_index().checked_sub(1)?;
        let span = self.pen.open_span(last);
        self.pen = PenState::Up;
        span.and_then(|(s, e)| self.pen_span(s, e, pen))
    }

    /// The stream has ended: judges what waits for more context and publishes what is
    /// pending (at most two gestures).
    pub fn finish(&mut self) -> Vec<SpottedGesture> {
        let mut out = Vec::new();
        let last = self.seg.next_index().checked_sub(1);
        let open = last.and_then(|last| self.pen.open_span(last));
        self.pen = PenState::Up;
        if let (Some((s, e)), Pen::Posture(pen)) = (open, self.cfg.pen) {
            out.extend(self.pen_span(s, e, pen));
        }
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

    /// [`Spotter::push_tracked`] with the frame's hand postures: the spotter goes on the
    /// drawing hand's (for the pen by posture, and the posture a gesture is drawn in).
    pub fn push_posed(
        &mut self,
        skeleton: &Skeleton,
        postures: &Postures,
        seq: u64,
        time_ns: u64,
    ) -> (Option<HandPoint>, Option<SpottedGesture>) {
        let Some(p) = self.tracker.update(skeleton, time_ns) else {
            return (None, self.no_hand());
        };
        (
            Some(p),
            self.push_point_posed(p, postures.of(p.hand), seq, time_ns),
        )
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
        self.push_posed(skeleton, &Postures::NONE, seq, time_ns)
    }

    /// Feeds one body-frame hand point (shoulder widths, x right, y down).
    pub fn push_point(&mut self, p: HandPoint, seq: u64, time_ns: u64) -> Option<SpottedGesture> {
        self.push_point_posed(p, None, seq, time_ns)
    }

    /// Feeds one body-frame hand point with its hand's posture (None: not known).
    pub fn push_point_posed(
        &mut self,
        p: HandPoint,
        posture: Option<HandPosture>,
        seq: u64,
        time_ns: u64,
    ) -> Option<SpottedGesture> {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return self.no_hand();
        }
        self.unseen = 0;
        if p.hand != self.hand {
            // The other hand's path does not continue this one.
            let hand = p.hand;
            self.reset();
            self.hand = hand;
        }
        let inv = self.inverse_size();
        let now = self.seg.next_index();
        // A model in the plane keeps the depth only to tell stretches drawn facing the
        // camera from movement towards or away from it (`max_depth_ratio`).
        let z = match (self.in_depth, p.z.is_finite()) {
            (_, true) => p.z * inv,
            (true, false) => 0.0,
            (false, false) => f32::NAN,
        };
        self.postures.push(now, posture);
        let cut = self.seg.push([p.x * inv, p.y * inv], z, seq, time_ns);
        let out = match self.cfg.pen {
            Pen::Motion | Pen::Gated(_) => {
                self.waiting.extend(cut);
                self.by_motion(now)
            }
            Pen::Posture(pen) => {
                let debounce = (pen.down_frames, pen.up_frames);
                let (state, span) = self.pen.step(now, pen.holds(posture), debounce);
                self.pen = state;
                span.and_then(|(s, e)| self.pen_span(s, e, pen))
            }
        };
        self.trim();
        out
    }

    /// The pen by motion after point `now`: judges the breaks whose context is in, and
    /// publishes what has waited long enough.
    fn by_motion(&mut self, now: usize) -> Option<SpottedGesture> {
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
        out
    }

    /// The pen by posture was down over points s..=e: the gesture drawn there, if the
    /// span is long, large and sure enough, published at once.
    fn pen_span(&mut self, s: usize, e: usize, pen: PosturePen) -> Option<SpottedGesture> {
        let fps = self.seg.fps();
        let (min_len, max_len) = (
            (self.cfg.min_seconds * fps) as usize,
            (self.cfg.max_seconds * fps) as usize,
        );
        if e - s < min_len || e - s > max_len || s < self.barrier {
            return None;
        }
        let mut c = self.score(s, e)?;
        // The posture says where a gesture is; the verifier, which tells a whole
        // gesture from movement by the motion, only when asked.
        let verified = !pen.verify || c.p_gesture >= self.bars.get(c.class).copied().unwrap_or(0.0);
        c.accepted =
            self.margin().is_none_or(|m| c.ratio > m) && c.score >= self.cfg.min_score && verified;
        if let Some(t) = self.trace.as_mut() {
            t.push(c);
        }
        if c.accepted {
            self.publish(c)
        } else {
            None
        }
    }

    /// Scores the segments from every earlier break to `e`, keeps the best accepted one
    /// pending, and publishes a pending gesture that this one does not overlap.
    fn candidates_ending(&mut self, e: usize) -> Option<SpottedGesture> {
        let fps = self.seg.fps();
        let min_len = (self.cfg.min_seconds * fps) as usize;
        let max_len = (self.cfg.max_seconds * fps) as usize;
        let mut best: Option<Candidate> = None;
        // The best stretch that holds the pending gesture whole.
        let mut whole: Option<Candidate> = None;
        for s in self.seg.starts(e, self.barrier, min_len, max_len) {
            let Some(c) = self.score(s, e) else { continue };
            if let Some(t) = self.trace.as_mut() {
                t.push(c);
            }
            if !c.accepted {
                continue;
            }
            if best.is_none_or(|b| c.rank > b.rank) {
                best = Some(c);
            }
            let holds = self.pending.is_some_and(|p| c.start <= p.start);
            if holds && whole.is_none_or(|w| c.rank > w.rank) {
                whole = Some(c);
            }
        }
        let c = best?;
        let margin = self.cfg.whole_over_part.filter(|_| !self.has_verifier());
        if let (Some(w), Some(m)) = (whole, margin) {
            if w.rank >= c.rank + m.max(1e-9).ln() {
                self.pending = Some(w);
                return None;
            }
        }
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
        let input = self.seg.input(s, e, self.seg.fps())?;
        let depth = if self.in_depth {
            let z = self.seg.depths(s, e)?;
            if !size_ok_in_depth(&input.segment, &z, &self.cfg) {
                return None;
            }
            let held_out = self.cfg.min_forward * self.inverse_size();
            if !self.has_verifier() && z.iter().any(|&v| v < held_out) {
                return None;
            }
            Some(z)
        } else {
            if !size_ok(&input.segment, &self.cfg) {
                return None;
            }
            if let Some(ratio) = self.cfg.max_depth_ratio {
                if !faces_the_camera(&input.segment, &self.seg.depths(s, e)?, ratio) {
                    return None;
                }
            }
            None
        };
        let j = self.judge(input, depth);
        // The gate is part of acceptance, so a stretch it stops does not outrank one it
        // lets through.
        let gated = match self.cfg.pen {
            Pen::Gated(pen) => self.postures.lets_through(s, e, &pen),
            _ => true,
        };
        let accepted = self.margin().is_none_or(|m| j.ratio > m)
            && j.score >= self.cfg.min_score
            && j.p_gesture >= self.bars.get(j.class).copied().unwrap_or(0.0)
            && gated;
        Some(Candidate {
            start: s,
            end: e,
            start_seq: self.seg.point(s)?.1,
            end_seq: self.seg.point(e)?.1,
            class: j.class,
            score: j.score,
            p_gesture: j.p_gesture,
            p_label: j.p_label,
            ratio: j.ratio,
            rank: self.cfg.rank_by.rank(j.p_gesture, j.p_label, j.score),
            accepted,
        })
    }

    /// The evidence on one segment with its context: the classifier's posterior, Lee &
    /// Kim's ratio, and the verifier, which sees both.
    /// `depth`: the segment's depth, for a model that reads it.
    fn judge(&self, mut input: VerifierInput, depth: Option<Vec<f32>>) -> Judgement {
        let mut t = Trajectory::from_points(input.segment.clone());
        if let Some(z) = depth {
            t = t.with_depth(z);
        }
        let post = self.model.posterior(&t);
        input.posterior = post.iter().map(|&p| p as f32).collect();
        let ratio = self.lee_kim.ratio(&t);
        input.ratio = ratio;
        let class = (0..post.len())
            .max_by(|&a, &b| post[a].total_cmp(&post[b]))
            .unwrap_or(0);
        let verifier = self
            .model
            .spotting
            .as_ref()
            .and_then(|s| s.verifier.as_ref());
        let (p_gesture, p_label) = verifier.map_or((1.0, 1.0), |v| {
            let probs = v.probs(&input);
            (1.0 - probs[0], probs.get(class + 1).copied().unwrap_or(0.0))
        });
        Judgement {
            class,
            score: post.get(class).copied().unwrap_or(0.0),
            p_gesture,
            p_label,
            ratio,
        }
    }

    /// How the spotter weighs the stretch `path[s..=e]` of a hand's path (body-frame
    /// points, shoulder widths, one a frame at `fps`), whether or not its breaks would
    /// cut it there: for tools that ask why a drawn symbol was or was not spotted. The
    /// same computation as a candidate's, on the same context. None when `s..=e` is not
    /// a stretch of `path`.
    pub fn explain(&self, path: &[[f32; 2]], s: usize, e: usize, fps: f64) -> Option<Judgement> {
        if s > e || e >= path.len() {
            return None;
        }
        // Only the context's reach around the stretch, in gesture sizes, as the
        // segmenter keeps it.
        let reach = context_steps(fps);
        let (from, to) = (s.saturating_sub(reach), (e + reach + 1).min(path.len()));
        let inv = self.inverse_size();
        let window: Vec<[f32; 2]> = path[from..to]
            .iter()
            .map(|p| [p[0] * inv, p[1] * inv])
            .collect();
        let times = (0..=e - s).map(|i| i as f32 / fps as f32).collect();
        Some(self.judge(
            VerifierInput::cut(&window, s - from, e - from, times, fps),
            None,
        ))
    }

    /// Lee & Kim's test as a hard one: the least margin a segment's best gesture HMM
    /// must have over the threshold model. `margin_without_verifier` holds for a model
    /// without a verifier whose HMMs read codes in space.
    fn margin(&self) -> Option<f64> {
        let in_space = self
            .model
            .spotting
            .as_ref()
            .is_some_and(|s| !s.directions.is_circle());
        let fallback = self.cfg.margin_without_verifier;
        self.cfg
            .margin
            .or(fallback.filter(|_| in_space && !self.has_verifier()))
    }

    fn has_verifier(&self) -> bool {
        self.model
            .spotting
            .as_ref()
            .is_some_and(|s| s.verifier.is_some())
    }

    /// Gesture sizes a shoulder width: the segmenter's unit.
    fn inverse_size(&self) -> f32 {
        1.0 / self.cfg.gesture_size.max(1e-3)
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
        let score = match self.cfg.pen {
            Pen::Motion | Pen::Gated(_) => c.score * c.p_gesture,
            Pen::Posture(_) => c.score,
        };
        Some(SpottedGesture {
            label: self.model.labels[c.class].clone(),
            class: c.class,
            score,
            start_seq: a.1,
            end_seq: b.1,
            start_ns: a.2,
            end_ns: b.2,
            hand: self.hand,
            posture: self.postures.most_of(c.start, c.end),
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
        self.postures.forget_before(from);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stretch_faces_the_camera_unless_it_moves_more_in_depth_than_across() {
        // A "1" 0.6 tall, drawn on a plane turned 30° away: its depth spans 0.35.
        let stroke: Vec<[f32; 2]> = (0..=10).map(|i| [0.0, i as f32 * 0.06]).collect();
        let tilted: Vec<f32> = (0..=10).map(|i| i as f32 * 0.06 * 0.577).collect();
        assert!(faces_the_camera(&stroke, &tilted, 0.7));
        // The same shadow made by a reach from a hanging arm, 0.9 towards the camera.
        let reach: Vec<f32> = (0..=10).map(|i| i as f32 * 0.09).collect();
        assert!(!faces_the_camera(&stroke, &reach, 0.7));
        assert!(faces_the_camera(&stroke, &reach, 2.0));
        // A constant depth (a tracker that has none, the lab generator's streams), and a
        // depth the camera lost at some frames, which is skipped.
        assert!(faces_the_camera(&stroke, &[0.35; 11], 0.0));
        let mut lost = tilted.clone();
        lost[4] = f32::NAN;
        assert!(faces_the_camera(&stroke, &lost, 0.7));
        assert!(faces_the_camera(&stroke, &[f32::NAN; 11], 0.7));
    }
}
