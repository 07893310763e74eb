//! Which labels of a vocabulary look alike to the classifier on writers it did not see
//! (0 and O, 1 and I, 5 and S): a quick classifier trained on four writers in five and
//! tested on the fifth, so that `train` can warn about pairs no spotter setting will
//! keep apart.

use super::{train, TrainConfig, TrainError};
use crate::lab::data::Sample;
use crate::lab::user_dependent::writer_hash;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

/// Labels whose held-out samples the classifier reads as another label this often or
/// more are reported by default.
pub const LOOK_ALIKE_THRESHOLD: f64 = 0.1;
/// A label read as another fewer times than this is not reported: one or two are
/// chance.
const MIN_CONFUSIONS: usize = 3;

/// A label the classifier reads as another on writers it did not train on.
#[derive(Debug, Clone, PartialEq)]
pub struct LookAlike {
    /// The drawn label…
    pub label: String,
    /// …the one it was read as…
    pub read_as: String,
    /// …how many of its held-out samples were…
    pub count: usize,
    /// …of how many.
    pub of: usize,
}

impl LookAlike {
    /// The fraction of the label's held-out samples read as the other.
    pub fn rate(&self) -> f64 {
        self.count as f64 / self.of.max(1) as f64
    }
}

impl fmt::Display for LookAlike {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}/{}: {:.0} % of {:?} read as {:?} ({} of {})",
            self.label,
            self.read_as,
            100.0 * self.rate(),
            self.label,
            self.read_as,
            self.count,
            self.of
        )
    }
}

/// The pairs of labels the vocabulary cannot separate: a classifier of `cfg`'s kind
/// (one network, no spotting part) is trained on the samples of four writers in five
/// (by a stable hash of the writer; every fifth sample when there are fewer than five
/// writers) and classifies the others; each label whose held-out samples are read as
/// one other label at least `threshold` of the time (and at least three times) is
/// reported, the most confused first. Labels without held-out samples, or without training samples, are not judged.
pub fn look_alikes(
    samples: &[Sample],
    cfg: &TrainConfig,
    threshold: f64,
) -> Result<Vec<LookAlike>, TrainError> {
    let writers: BTreeSet<&str> = samples.iter().map(|s| s.subject.as_str()).collect();
    let split = |by_writer: bool| {
        let (mut fit, mut test) = (Vec::new(), Vec::new());
        for (i, s) in samples.iter().enumerate() {
            let held = if by_writer {
                writer_hash(&s.subject).is_multiple_of(5)
            } else {
                i % 5 == 4
            };
            if held {
                test.push(s);
            } else {
                fit.push(s.clone());
            }
        }
        (fit, test)
    };
    let (mut fit, mut test) = split(writers.len() >= 5);
    if fit.is_empty() || test.is_empty() {
        (fit, test) = split(false);
    }
    let quick = TrainConfig {
        ensemble: 1,
        spotting: false,
        ..cfg.clone()
    };
    let model = train(&fit, &quick, &|_, _| {})?;
    let mut read = BTreeMap::<(&str, usize), usize>::new();
    let mut drawn = BTreeMap::<&str, usize>::new();
    for s in test {
        if model.label_index(&s.label).is_none() {
            continue;
        }
        let c = model.classify(&s.trajectory()).class;
        *drawn.entry(&s.label).or_default() += 1;
        *read.entry((&s.label, c)).or_default() += 1;
    }
    let mut out: Vec<LookAlike> = read
        .into_iter()
        .filter(|((label, c), _)| model.labels[*c] != *label)
        .map(|((label, c), count)| LookAlike {
            label: label.to_string(),
            read_as: model.labels[c].clone(),
            count,
            of: drawn[label],
        })
        .filter(|l| l.rate() >= threshold && l.count >= MIN_CONFUSIONS)
        .collect();
    out.sort_by(|a, b| b.rate().total_cmp(&a.rate()));
    Ok(out)
}
