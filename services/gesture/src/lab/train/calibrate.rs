//! Per-label bars on the verifier's probability of a whole gesture, calibrated on
//! synthetic streams of the training samples.
//!
//! Ordinary movement passes for some symbols far more often than for others: of the
//! digits' false alarms, over half are a "1" (a straight reach), and those have a lower
//! whole-gesture probability than the "1"s drawn (gesture README, "Where ordinary
//! movement passes for a symbol"). One bar for every label either lets those through or
//! rejects whole symbols of every label. So each label the calibration streams show
//! ordinary movement passing for gets a bar of its own, raised step by step while the
//! streams' reliability rises.
//!
//! The streams are drawn from the training samples, whose writers the verifier has
//! seen; so the drawn symbols' probabilities are a little higher than an unseen
//! writer's, and the bars are capped at [`BAR_STEPS`]' last.

use super::Progress;
use crate::lab::data::Sample;
use crate::lab::movement::Generator;
use crate::lab::scoring::{matched, SpottingScore};
use crate::lab::stream::{StreamConfig, SyntheticStream};
use crate::model::Model;
use crate::spot::{Spotter, SpotterConfig};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The bars a label may get, tried in turn above the verifier's own.
pub const BAR_STEPS: [f64; 4] = [0.4, 0.5, 0.6, 0.7];
/// Samples drawn in the calibration streams (all of them when there are fewer)…
const GESTURES: usize = 2000;
/// …this many to a stream.
const PER_STREAM: usize = 20;
/// A label whose symbols ordinary movement passed for fewer times than this keeps the
/// common bar: one or two are chance.
const MIN_INSERTIONS: usize = 3;

/// The calibration's streams and what the spotter made of them.
struct Streams {
    streams: Vec<SyntheticStream>,
    cfg: StreamConfig,
}

impl Streams {
    fn new(model: &Model, samples: &[Sample], seed: u64, generator: Generator) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut chosen: Vec<&Sample> = samples
            .iter()
            .filter(|s| model.label_index(&s.label).is_some())
            .collect();
        chosen.shuffle(&mut rng);
        chosen.truncate(GESTURES);
        let cfg = StreamConfig::default();
        let streams = chosen
            .chunks(PER_STREAM)
            .enumerate()
            .map(|(i, c)| {
                let mut r =
                    ChaCha8Rng::seed_from_u64(seed.wrapping_mul(7919).wrapping_add(i as u64));
                generator.stream(c, &cfg, i, &mut r)
            })
            .collect();
        Streams { streams, cfg }
    }

    /// The streams' score with `bars`, and how often each label was inserted.
    fn run(
        &self,
        model: &Model,
        bars: &BTreeMap<String, f64>,
    ) -> (SpottingScore, BTreeMap<String, usize>) {
        let mut model = model.clone();
        if let Some(v) = model.spotting.as_mut().and_then(|s| s.verifier.as_mut()) {
            v.label_bars = bars.clone();
        }
        self.streams
            .par_iter()
            .map(|s| {
                let mut spotter = Spotter::new(model.clone(), SpotterConfig::default())
                    .expect("calibrated models have a spotting part");
                let spotted = s.spot(&mut spotter, &self.cfg);
                let m = matched(&s.truth, &spotted);
                let mut inserted = BTreeMap::new();
                for (g, _) in spotted.iter().zip(&m.matched).filter(|(_, used)| !**used) {
                    *inserted.entry(g.label.clone()).or_insert(0) += 1;
                }
                (m.score, inserted)
            })
            .reduce(
                || (SpottingScore::default(), BTreeMap::new()),
                |(mut a, mut ai), (b, bi)| {
                    a.add(&b);
                    for (l, n) in bi {
                        *ai.entry(l).or_insert(0) += n;
                    }
                    (a, ai)
                },
            )
    }
}

/// Bars for the labels ordinary movement passes for, calibrated on streams of
/// `samples` (drawn from `seed` by `generator`) spotted by `model` (which must have a verifier; its
/// own bars are ignored); `progress` counts spotter runs over the streams. A label's
/// bar is raised through [`BAR_STEPS`] and kept where the streams' reliability is
/// highest, if higher than without it; labels are taken from the most inserted down.
///
/// For [`Generator::Mixed`] each generator's streams are calibrated alone and a label
/// keeps the lower of its two bars (none where either raises none). Calibrated on both
/// together, the movement of one kind of mover that passes for a label (the everyday
/// generator's straight reaches from a stop, for a "1") raised a bar that then rejected
/// the label's symbols as the other kind draws them: a bar has to hold for both.
pub fn calibrate_label_bars(
    model: &Model,
    samples: &[Sample],
    seed: u64,
    generator: Generator,
    progress: Progress,
) -> BTreeMap<String, f64> {
    if generator != Generator::Mixed {
        return calibrate_on(model, samples, seed, generator, progress);
    }
    // Both halves' runs counted together, so that progress ends with the later one.
    let counts = std::sync::Mutex::new([(0, 0); 2]);
    let half = |i: usize| {
        let counts = &counts;
        move |done, total| {
            let mut c = counts.lock().unwrap_or_else(|e| e.into_inner());
            c[i] = (done, total);
            progress(c[0].0 + c[1].0, c[0].1 + c[1].1);
        }
    };
    let (lab, everyday) = rayon::join(
        || calibrate_on(model, samples, seed, Generator::Lab, &half(0)),
        || calibrate_on(model, samples, seed, Generator::Everyday, &half(1)),
    );
    lower_of_both(&lab, &everyday)
}

/// Each label both sets of bars raise, at the lower of its two bars.
fn lower_of_both(a: &BTreeMap<String, f64>, b: &BTreeMap<String, f64>) -> BTreeMap<String, f64> {
    a.iter()
        .filter_map(|(label, &x)| b.get(label).map(|&y| (label.clone(), x.min(y))))
        .collect()
}

/// [`calibrate_label_bars`] on one kind of stream.
fn calibrate_on(
    model: &Model,
    samples: &[Sample],
    seed: u64,
    generator: Generator,
    progress: Progress,
) -> BTreeMap<String, f64> {
    let Some(base) = model
        .spotting
        .as_ref()
        .and_then(|s| s.verifier.as_ref())
        .map(|v| v.min_gesture_prob())
    else {
        return BTreeMap::new();
    };
    let streams = Streams::new(model, samples, seed, generator);
    let mut bars = BTreeMap::new();
    let (mut best, inserted) = streams.run(model, &bars);
    let mut labels: Vec<(String, usize)> = inserted
        .into_iter()
        .filter(|(_, n)| *n >= MIN_INSERTIONS)
        .collect();
    labels.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    let steps: Vec<f64> = BAR_STEPS.into_iter().filter(|&b| b > base).collect();
    let total = (1 + labels.len() * steps.len()) as u64;
    let mut done = 1;
    progress(done, total);
    for (label, _) in labels {
        let mut chosen = None;
        for &bar in &steps {
            let mut trial = bars.clone();
            trial.insert(label.clone(), bar);
            let (s, _) = streams.run(model, &trial);
            done += 1;
            progress(done, total);
            if s.reliability > best.reliability {
                best = s;
                chosen = Some(bar);
            }
        }
        if let Some(bar) = chosen {
            bars.insert(label, bar);
        }
    }
    bars
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixed_bars_keep_only_what_both_generators_raise_at_the_lower() {
        let bars = |v: &[(&str, f64)]| -> BTreeMap<String, f64> {
            v.iter().map(|(l, b)| (l.to_string(), *b)).collect()
        };
        let lab = bars(&[("1", 0.5), ("U", 0.7), ("V", 0.4)]);
        let everyday = bars(&[("1", 0.7), ("I", 0.7), ("V", 0.6)]);
        assert_eq!(
            lower_of_both(&lab, &everyday),
            bars(&[("1", 0.5), ("V", 0.4)])
        );
        assert!(lower_of_both(&lab, &BTreeMap::new()).is_empty());
    }
}
