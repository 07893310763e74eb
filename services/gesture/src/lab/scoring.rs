//! Spotted gestures scored against the drawn ones: which matched, and the counts.

use crate::lab::stream::TruthGesture;
use crate::spot::SpottedGesture;
use serde::Serialize;

/// Spotting result counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct SpottingScore {
    /// Drawn gestures…
    pub gestures: usize,
    /// …spotted with their label…
    pub correct: usize,
    /// …spotted with another…
    pub substitutions: usize,
    /// …or not at all.
    pub deletions: usize,
    /// Spotted gestures that match none drawn.
    pub insertions: usize,
    /// correct / (gestures + insertions).
    pub reliability: f64,
}

impl SpottingScore {
    /// Adds another stream's counts.
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
    matched(truth, spotted).score
}

/// How a stream's spotted gestures matched its drawn ones.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Matching {
    /// The counts.
    pub score: SpottingScore,
    /// For each drawn gesture, whether it was spotted with its own label.
    pub correct: Vec<bool>,
    /// For each spotted gesture, whether it matched a drawn one (if not, an insertion).
    pub matched: Vec<bool>,
}

/// [`score`], with what matched what.
pub fn matched(truth: &[TruthGesture], spotted: &[SpottedGesture]) -> Matching {
    let mut used = vec![false; spotted.len()];
    let mut sc = SpottingScore {
        gestures: truth.len(),
        ..Default::default()
    };
    let mut correct = Vec::with_capacity(truth.len());
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
        let right = found.is_some_and(|i| spotted[i].label == t.label);
        match found {
            Some(i) => {
                used[i] = true;
                if right {
                    sc.correct += 1;
                } else {
                    sc.substitutions += 1;
                }
            }
            None => sc.deletions += 1,
        }
        correct.push(right);
    }
    sc.insertions = used.iter().filter(|u| !**u).count();
    sc.reliability = sc.correct as f64 / (sc.gestures + sc.insertions).max(1) as f64;
    Matching {
        score: sc,
        correct,
        matched: used,
    }
}
