//! The user-dependent protocol of Wobbrock's $1 recognizer, on writers of pen data: for
//! each writer, K training samples of every label from that writer, tested on the
//! writer's other samples of those labels. A new user's own vocabulary from a few
//! samples, measured on data the project did not make.
//!
//! A writer's vocabulary is the labels it wrote at least K + 1 times (K to train on, one
//! at least to test), and a writer takes part when that vocabulary holds enough labels;
//! the data's writers are split into two fixed groups by a hash of their name, one to
//! choose settings on and one to report.

use crate::lab::data::Sample;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;

/// Which writers take part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriterGroup {
    /// Every writer.
    All,
    /// One writer in three (by [`writer_hash`]): where settings are chosen.
    Tune,
    /// The other two in three: where results are reported.
    Report,
}

impl WriterGroup {
    /// The group a name on the command line means (`all`, `tune`, `report`).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "all" => Some(Self::All),
            "tune" => Some(Self::Tune),
            "report" => Some(Self::Report),
            _ => None,
        }
    }

    /// Whether the writer is in the group.
    pub fn holds(self, subject: &str) -> bool {
        let tune = writer_hash(subject).is_multiple_of(3);
        match self {
            Self::All => true,
            Self::Tune => tune,
            Self::Report => !tune,
        }
    }
}

/// A stable hash of a writer's name (FNV-1a): the same groups in every build and run.
pub fn writer_hash(subject: &str) -> u64 {
    subject.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// One writer's draw: what a model is trained on and what it is tested on.
#[derive(Debug, Clone)]
pub struct WriterSplit {
    /// The writer.
    pub subject: String,
    /// K samples of every label of its vocabulary…
    pub train: Vec<Sample>,
    /// …and the rest of its samples of those labels.
    pub test: Vec<Sample>,
}

/// For every writer of the group whose vocabulary (labels written at least `k + 1`
/// times) holds at least `min_labels` labels, `draws` random splits of its samples
/// (each label's samples shuffled, the first `k` to train on), drawn from `seed`.
pub fn writer_splits(
    samples: &[Sample],
    k: usize,
    min_labels: usize,
    group: WriterGroup,
    draws: usize,
    seed: u64,
) -> Vec<WriterSplit> {
    let mut by_writer: BTreeMap<&str, BTreeMap<&str, Vec<&Sample>>> = BTreeMap::new();
    for s in samples.iter().filter(|s| group.holds(&s.subject)) {
        by_writer
            .entry(&s.subject)
            .or_default()
            .entry(&s.label)
            .or_default()
            .push(s);
    }
    let mut out = Vec::new();
    for (subject, labels) in by_writer {
        let vocabulary: Vec<&Vec<&Sample>> = labels.values().filter(|v| v.len() > k).collect();
        if vocabulary.len() < min_labels.max(2) {
            continue;
        }
        for d in 0..draws {
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ writer_hash(subject) ^ (d as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            );
            let mut split = WriterSplit {
                subject: subject.to_string(),
                train: Vec::new(),
                test: Vec::new(),
            };
            for v in &vocabulary {
                let mut v: Vec<&Sample> = v.to_vec();
                v.shuffle(&mut rng);
                split.train.extend(v[..k].iter().map(|s| (*s).clone()));
                split.test.extend(v[k..].iter().map(|s| (*s).clone()));
            }
            out.push(split);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(label: &str, subject: &str, i: usize) -> Sample {
        Sample {
            label: label.into(),
            subject: subject.into(),
            strokes: vec![vec![[0.0, 0.0], [i as f32, 1.0]]],
            depth: None,
        }
    }

    #[test]
    fn a_writer_trains_on_k_of_each_label_it_wrote_often_enough_and_tests_on_the_rest() {
        let mut data = Vec::new();
        for i in 0..5 {
            data.push(sample("a", "w1", i));
            data.push(sample("b", "w1", i));
        }
        // Too few "c"s to train on 3 and test on one: not in w1's vocabulary.
        for i in 0..3 {
            data.push(sample("c", "w1", i));
        }
        // w2 has one label often enough: no vocabulary.
        for i in 0..9 {
            data.push(sample("a", "w2", i));
        }
        data.push(sample("b", "w2", 0));
        let splits = writer_splits(&data, 3, 2, WriterGroup::All, 2, 7);
        assert_eq!(splits.len(), 2);
        for s in &splits {
            assert_eq!(s.subject, "w1");
            assert_eq!(s.train.len(), 6);
            assert_eq!(s.test.len(), 4);
            assert!(s.train.iter().chain(&s.test).all(|x| x.label != "c"));
            for x in &s.test {
                assert!(!s
                    .train
                    .iter()
                    .any(|t| t.strokes == x.strokes && t.label == x.label));
            }
        }
        assert_ne!(
            splits[0]
                .test
                .iter()
                .map(|s| &s.strokes)
                .collect::<Vec<_>>(),
            splits[1]
                .test
                .iter()
                .map(|s| &s.strokes)
                .collect::<Vec<_>>(),
            "two draws, two splits"
        );
    }

    #[test]
    fn the_tune_and_report_groups_part_the_writers() {
        let names: Vec<String> = (0..60).map(|i| format!("inst/w{i}")).collect();
        let tune = names.iter().filter(|n| WriterGroup::Tune.holds(n)).count();
        let report = names
            .iter()
            .filter(|n| WriterGroup::Report.holds(n))
            .count();
        assert_eq!(tune + report, 60);
        assert!((10..=30).contains(&tune), "{tune}");
    }
}
