//! The verifier: a network that judges a stretch of the hand's path between two breaks
//! — a whole gesture (and which), or movement, part of a gesture, a gesture with
//! movement around it — from its coarse shape, size, place, timing, the hand's path
//! just before and after it, the classifier's posterior and Lee & Kim's ratio. Its
//! training, on the stretches the spotter itself cuts from synthetic streams, is the
//! lab's (`lab::train`).

use crate::features::{arc_lengths, feature_vector, locate, FeatureConfig};
use crate::mlp::Mlp;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Points of context the verifier sees on each side of a segment…
pub const CONTEXT_POINTS: usize = 6;
/// …one every this much of the hand's path (gesture sizes)…
pub const CONTEXT_ARC: f32 = 0.08;
/// …looking at most this far in time: so the context tells the way the hand came and
/// went, and whether it was still, however fast it moved.
pub const CONTEXT_SECONDS: f64 = 0.4;

/// The points a segment's context walks at most from either end, for a path sampled at
/// `fps` ([`CONTEXT_SECONDS`]): how far the path must be kept, and how long a break
/// waits before its candidates are judged.
pub fn context_steps(fps: f64) -> usize {
    (CONTEXT_SECONDS * fps).round() as usize
}

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
    /// The segment's points.
    pub segment: Vec<[f32; 2]>,
    /// When the hand was at each point of `segment`, seconds from its first.
    pub times: Vec<f32>,
    /// Where the hand was before the segment (`context`)…
    pub before: [[f32; 2]; CONTEXT_POINTS],
    /// …and after it.
    pub after: [[f32; 2]; CONTEXT_POINTS],
    /// The classifier's posterior of the segment (model label order), when the
    /// verifier uses it.
    pub posterior: Vec<f32>,
    /// Lee & Kim's ratio of the segment (Lee & Kim's threshold model, in the spotter).
    pub ratio: f64,
}

impl VerifierInput {
    /// The segment `path[s..=e]`, timed by `times` (seconds from its first point), with
    /// its context cut from the hand's `path` sampled at `fps`; posterior and ratio are
    /// left for the caller.
    pub fn cut(path: &[[f32; 2]], s: usize, e: usize, times: Vec<f32>, fps: f64) -> Self {
        let steps = context_steps(fps);
        VerifierInput {
            segment: path[s..=e].to_vec(),
            times,
            before: context(path, s, true, steps),
            after: context(path, e, false, steps),
            posterior: Vec::new(),
            ratio: 0.0,
        }
    }
}

/// A network telling a whole gesture from movement around, before, after or inside
/// one, and naming it. It sees the segment's coarse shape (the classifier has the fine
/// one: a verifier that sees every detail learns its training writers by heart), its
/// size and place in the body frame, the hand's path just before and after it (a
/// stroke followed by more drawing is part of a larger gesture), how its speed varied
/// along it (a reach into a symbol is not drawn like one), the classifier's
/// posterior and Lee & Kim's ratio; it answers "not a whole gesture" or "a whole
/// gesture of label L".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verifier {
    /// What it sees of the segment's shape.
    pub features: FeatureConfig,
    /// Labels of outputs 1…; output 0 is "not a whole gesture".
    pub classes: Vec<String>,
    /// Points of the segment's timing profile the network sees (`timing_profile`);
    /// 0 in models trained before it existed.
    #[serde(default)]
    pub timing: usize,
    /// Networks trained apart (each on its own streams, from its own seed) whose
    /// probabilities are averaged: one network's verdicts on unseen writers vary with
    /// its seed by a point or two of spotting reliability. Models trained before hold
    /// one, under `net`.
    #[serde(alias = "net", deserialize_with = "one_or_many")]
    pub nets: Vec<Mlp>,
    /// Labels whose whole-gesture probability must reach more than
    /// [`Verifier::min_gesture_prob`]: those ordinary movement passes for often (a
    /// straight reach for a "1"), calibrated on streams of the training samples
    /// (`lab::calibrate_label_bars`). Empty in models trained before.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub label_bars: BTreeMap<String, f64>,
}

/// A network or a list of them.
fn one_or_many<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<Mlp>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        One(Mlp),
        Many(Vec<Mlp>),
    }
    Ok(match OneOrMany::deserialize(d)? {
        OneOrMany::One(n) => vec![n],
        OneOrMany::Many(v) => v,
    })
}

impl Verifier {
    /// Input size: segment features, log size, context, posterior, ratio, place,
    /// timing profile.
    pub fn dim(&self) -> usize {
        // Saturating: a verifier whose sizes overflow never matches its networks.
        self.features
            .dim()
            .saturating_add(1 + 4 * CONTEXT_POINTS + 1 + 2)
            .saturating_add(self.classes.len())
            .saturating_add(self.timing)
    }

    /// The smallest probability of a whole gesture the spotter accepts by default. The
    /// timing profile makes the verifier reject fewer whole symbols of unseen writers
    /// and accept a little more ordinary movement; at 0.3 the held-out digits keep the
    /// gain with fewer false alarms (gesture README, "Spotting"). Verifiers without it
    /// (the models trained before) keep the 0.2 they were tuned at.
    pub fn min_gesture_prob(&self) -> f64 {
        if self.timing > 0 {
            0.3
        } else {
            0.2
        }
    }

    /// The smallest probability of a whole gesture the spotter accepts for output
    /// `class` (0-based label index) when the bar for every label is `base`: `base`,
    /// or the label's calibrated bar if higher.
    pub fn bar(&self, class: usize, base: f64) -> f64 {
        self.classes
            .get(class)
            .and_then(|l| self.label_bars.get(l))
            .map_or(base, |&b| b.max(base))
    }

    /// Probabilities: [not a gesture, label 0, label 1, …].
    pub fn probs(&self, input: &VerifierInput) -> Vec<f64> {
        let mut f = Vec::with_capacity(self.dim());
        verifier_features(input, self, &mut f);
        let mut probs = vec![0.0; self.classes.len() + 1];
        for net in &self.nets {
            for (p, l) in probs.iter_mut().zip(net.log_probs(&f)) {
                *p += (l as f64).exp() / self.nets.len() as f64;
            }
        }
        probs
    }
}

/// The network's input: the segment's features, log size, context, posterior, ratio,
/// place and timing profile.
pub(crate) fn verifier_features(input: &VerifierInput, v: &Verifier, out: &mut Vec<f32>) {
    let t = Trajectory::from_points(input.segment.clone());
    feature_vector(&t, &v.features, out);
    let (x0, y0, x1, y1) = crate::features::bbox(&input.segment);
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
    out.extend(timing_profile(&input.segment, &input.times, v.timing));
}

/// When the hand passed `n` points spread evenly along the segment's path, as
/// fractions of the segment's duration (the first and last, always 0 and 1, left out).
/// It tells how the speed varied along the path whatever the overall pace: a reach
/// into a symbol is fast in its middle, a symbol slows in its curves and corners.
fn timing_profile(segment: &[[f32; 2]], times: &[f32], n: usize) -> Vec<f32> {
    if n == 0 {
        return Vec::new();
    }
    let uniform = |k: usize| (k + 1) as f32 / (n + 1) as f32;
    let duration = times.last().copied().unwrap_or(0.0);
    if segment.len() < 2 || times.len() != segment.len() || duration <= 0.0 {
        return (0..n).map(uniform).collect();
    }
    let arc = arc_lengths(segment);
    let total = arc.last().copied().unwrap_or(0.0);
    if total <= 0.0 {
        return (0..n).map(uniform).collect();
    }
    let mut i = 1;
    (0..n)
        .map(|k| {
            let f = locate(&arc, total * uniform(k), &mut i);
            (times[i - 1] + f * (times[i] - times[i - 1])) / duration
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::mlp::Layer;

    /// A verifier's coarse shape and timing profile as training makes them.
    const SHAPE: FeatureConfig = FeatureConfig {
        pen_up: false,
        points: 12,
        grid: 3,
        depth: false,
    };
    const TIMING_POINTS: usize = 4;

    /// A verifier over two labels whose single-layer networks answer `biases` (as
    /// log-odds) whatever they see.
    pub(crate) fn constant_verifier(biases: &[[f32; 3]]) -> Verifier {
        let mut v = Verifier {
            features: SHAPE,
            classes: vec!["a".into(), "b".into()],
            timing: TIMING_POINTS,
            nets: Vec::new(),
            label_bars: BTreeMap::new(),
        };
        let dim = v.dim();
        v.nets = biases
            .iter()
            .map(|b| Mlp {
                mean: vec![0.0; dim],
                std: vec![1.0; dim],
                layers: vec![Layer {
                    inputs: dim,
                    outputs: 3,
                    w: vec![0.0; 3 * dim],
                    b: b.to_vec(),
                }],
            })
            .collect();
        v
    }

    #[test]
    fn several_networks_are_averaged_and_one_stored_alone_still_loads() {
        let input = VerifierInput {
            segment: vec![[0.0, 0.0], [0.5, 0.2], [1.0, 1.0]],
            times: vec![0.0, 0.2, 0.5],
            before: [[0.0, 0.0]; CONTEXT_POINTS],
            after: [[1.0, 1.0]; CONTEXT_POINTS],
            posterior: vec![0.9, 0.1],
            ratio: 1.0,
        };
        // ln 3: "not a gesture" three times as likely as each label; ln 0.5: half as.
        let (a, b) = ([3f32.ln(), 0.0, 0.0], [0.5f32.ln(), 0.0, 0.0]);
        let both = constant_verifier(&[a, b]).probs(&input);
        let (pa, pb) = (
            constant_verifier(&[a]).probs(&input),
            constant_verifier(&[b]).probs(&input),
        );
        assert!((pa[0] - 0.6).abs() < 1e-6 && (pb[0] - 0.2).abs() < 1e-6);
        for k in 0..3 {
            assert!((both[k] - (pa[k] + pb[k]) / 2.0).abs() < 1e-6, "{both:?}");
        }
        // A model file written before ensembles holds its one network under `net`.
        let one = constant_verifier(&[a]);
        let mut json = serde_json::to_value(&one).unwrap();
        let nets = json.as_object_mut().unwrap().remove("nets").unwrap();
        json["net"] = nets[0].clone();
        let old: Verifier = serde_json::from_value(json).unwrap();
        assert_eq!(old, one);
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
    fn timing_profile_shows_where_the_hand_was_slow() {
        let line: Vec<[f32; 2]> = (0..=10).map(|i| [i as f32 * 0.1, 0.0]).collect();
        // Constant speed: time goes with the path.
        let even: Vec<f32> = (0..=10).map(|i| i as f32 * 0.1).collect();
        for (k, t) in timing_profile(&line, &even, 4).iter().enumerate() {
            assert!((t - (k + 1) as f32 / 5.0).abs() < 1e-4);
        }
        // Slow over the first half (0.8 s), fast over the second (0.2 s): the middle
        // of the path is reached at 80 % of the time.
        let slow_first: Vec<f32> = (0..=10)
            .map(|i| {
                if i <= 5 {
                    i as f32 * 0.16
                } else {
                    0.8 + (i - 5) as f32 * 0.04
                }
            })
            .collect();
        let p = timing_profile(&line, &slow_first, 1);
        assert!((p[0] - 0.8).abs() < 1e-4, "{p:?}");
        // Without times (or a still hand), the even profile.
        assert_eq!(timing_profile(&line, &[], 1), vec![0.5]);
        assert!(timing_profile(&line, &even, 0).is_empty());
    }

    #[test]
    fn label_bars_raise_only_their_own_label() {
        let mut v = constant_verifier(&[[0.0, 0.0, 0.0]]);
        v.label_bars.insert("b".into(), 0.6);
        assert_eq!(v.bar(0, 0.3), 0.3);
        assert_eq!(v.bar(1, 0.3), 0.6);
        // A bar below the common one does not lower it.
        assert_eq!(v.bar(1, 0.7), 0.7);
    }
}
