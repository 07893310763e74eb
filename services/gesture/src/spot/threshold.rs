//! Lee & Kim's threshold model ("An HMM-based threshold model approach for gesture
//! recognition", PAMI 1999): over a stretch's direction codes, one left-right HMM per
//! label against the ergodic non-gesture HMM made of all their states.

use crate::bezier::Directions;
use crate::hmm::LogHmm;
use crate::model::spotting::sample_codes;
use crate::model::{LabelledHmm, SpottingModel};
use crate::trajectory::Trajectory;

const NEG: f64 = f64::NEG_INFINITY;

/// The threshold (non-gesture) model of Lee & Kim: every state of every gesture HMM,
/// each keeping its emissions and self-transition and moving to any other state with
/// equal probability. It explains any sequence of gesture pieces in any order, so a
/// gesture model beats it only on a whole gesture of its own.
#[derive(Debug, Clone)]
pub struct ThresholdModel {
    /// Symbols of the gesture HMMs (all alike: `SpottingModel::validate`).
    symbols: usize,
    stay: Vec<f64>,
    leave: Vec<f64>,
    log_b: Vec<f64>,
}

impl ThresholdModel {
    pub fn new(models: &[LabelledHmm]) -> Self {
        let (mut stay, mut leave, mut log_b) = (Vec::new(), Vec::new(), Vec::new());
        let symbols = models.first().map_or(0, |m| m.hmm.n_symbols());
        for lm in models {
            let h = &lm.hmm;
            for i in 0..h.n_states() {
                let s = h.a[i][i].clamp(0.05, 0.95);
                stay.push(s.ln());
                leave.push((1.0 - s).ln());
                log_b.extend(h.b[i].iter().map(|p| p.ln()));
            }
        }
        Self {
            symbols,
            stay,
            leave,
            log_b,
        }
    }

    /// Viterbi log-likelihood of the codes.
    pub fn log_likelihood(&self, codes: &[usize]) -> f64 {
        let n = self.stay.len();
        let m = self.symbols;
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
    directions: Directions,
    threshold: ThresholdModel,
    gestures: Vec<LogHmm>,
}

impl LeeKim {
    pub fn new(sm: &SpottingModel) -> Self {
        Self {
            step: sm.step,
            directions: sm.directions,
            threshold: ThresholdModel::new(&sm.models),
            gestures: sm.models.iter().map(|m| m.hmm.to_log()).collect(),
        }
    }

    /// log P(codes | best gesture HMM, ending in its last state) − log P(codes |
    /// threshold model), per code; −∞ when no gesture HMM can end there.
    /// The codes are taken in space when the model's are (and the segment has depth).
    pub fn ratio(&self, segment: &Trajectory) -> f64 {
        let codes = sample_codes(segment, self.step, self.directions);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hmm::DiscreteHmm;
    use crate::model::spotting::stream_symbols;

    /// A left-right HMM of four states over the stream's symbols: the first two emit
    /// `first`, the last two `then` (every other code with a small floor), as a
    /// trained one of a two-stroke gesture does.
    fn two_strokes(label: &str, first: usize, then: usize) -> LabelledHmm {
        let symbols = stream_symbols(Directions::Circle8);
        let emit = |code: usize| {
            let mut row = vec![0.01; symbols];
            row[code] = 1.0 - 0.01 * (symbols - 1) as f64;
            row
        };
        let hmm = DiscreteHmm {
            pi: vec![1.0, 0.0, 0.0, 0.0],
            a: vec![
                vec![0.7, 0.3, 0.0, 0.0],
                vec![0.0, 0.7, 0.3, 0.0],
                vec![0.0, 0.0, 0.7, 0.3],
                vec![0.0, 0.0, 0.0, 1.0],
            ],
            b: vec![emit(first), emit(first), emit(then), emit(then)],
        };
        hmm.validate().unwrap();
        LabelledHmm {
            label: label.into(),
            hmm,
        }
    }

    #[test]
    fn the_threshold_model_beats_gesture_models_on_a_shuffled_gesture() {
        // A: right then down; B: left then up (codes 0 and 2, 4 and 6).
        let models = [two_strokes("A", 0, 2), two_strokes("B", 4, 6)];
        let thr = ThresholdModel::new(&models);
        let a = models[0].hmm.to_log();
        let mut buf = Vec::new();
        let whole = [vec![0; 6], vec![2; 6]].concat();
        let shuffled = [vec![2; 6], vec![0; 6]].concat();
        assert!(whole_gesture_ll(&a, &whole, &mut buf) > thr.log_likelihood(&whole));
        assert!(whole_gesture_ll(&a, &shuffled, &mut buf) < thr.log_likelihood(&shuffled));
    }
}
