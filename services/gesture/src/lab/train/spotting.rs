//! Training a model's spotting part: the HMMs over stream codes, the verifier and its
//! per-label bars.

use super::calibrate::calibrate_label_bars;
use super::TrainConfig;
use crate::bezier::Directions;
use crate::hmm::DiscreteHmm;
use crate::lab::data::Sample;
use crate::lab::train::hmm::HmmTrainConfig;
use crate::model::spotting::{sample_codes, stream_symbols};
use crate::model::{LabelledHmm, Model, SpottingModel, Verifier};
use rayon::prelude::*;

/// Seed of the streams the label bars are calibrated on: other streams than the
/// verifier's (seeds 7…) and the evaluation's (1–3).
pub const CALIBRATION_SEED: u64 = 101;

impl SpottingModel {
    /// Trains one banded HMM per label on the stream codes of the samples (each scaled
    /// so that its larger side is 1; `spotting_step`, `spotting_states` of `train`),
    /// and the verifier, which uses `classifier` (a model with the same labels; its
    /// spotting part is not used) and has `train.verifiers` networks (at least one);
    /// then calibrates the verifier's per-label bars ([`calibrate_label_bars`]).
    pub fn train(samples: &[Sample], classifier: &Model, train: &TrainConfig) -> Self {
        let (step, verifiers) = (train.spotting_step, train.verifiers);
        let labels = &classifier.labels;
        // Codes on the sphere for gestures drawn in space: on the circle a push is a
        // hand standing still.
        let directions = if samples.iter().any(Sample::has_depth) {
            Directions::Sphere26
        } else {
            Directions::Circle8
        };
        let cfg = HmmTrainConfig {
            states: train.spotting_states,
            symbols: stream_symbols(directions),
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
                    .map(|s| sample_codes(&s.trajectory(), step, directions))
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
            directions,
            models,
            verifier: None,
        };
        if samples.iter().any(Sample::has_depth) {
            // The verifier learns from synthetic streams, which are drawn in the frontal
            // plane: it would judge 3-D gestures by a shadow of them. Without it the
            // spotter takes what the classifier is sure of (`Spotter::new`).
            return model;
        }
        // Seed 7 first: a one-network verifier is the one trained before ensembles.
        let seeds: Vec<u64> = (7..).take(verifiers.max(1)).collect();
        model.verifier = Some(Verifier::train(
            samples,
            classifier,
            &model,
            &seeds,
            train.generator,
        ));
        let mut whole = classifier.clone();
        whole.spotting = Some(model.clone());
        let bars = calibrate_label_bars(
            &whole,
            samples,
            CALIBRATION_SEED,
            train.generator,
            &|_, _| {},
        );
        if let Some(v) = model.verifier.as_mut() {
            v.label_bars = bars;
        }
        model
    }
}
