//! Training again from a model already trained, on data of the same labels: keeping its
//! classifier and training its spotting part anew, or keeping it whole and calibrating
//! only its per-label bars again.

use super::calibrate::calibrate_label_bars;
use super::spotting::CALIBRATION_SEED;
use super::{Progress, TrainConfig, TrainError};
use crate::lab::data::{labels_of, Sample};
use crate::lab::movement::Generator;
use crate::model::{Model, SpottingModel};
use std::collections::BTreeMap;

/// `model` with its classifier kept and its spotting part (HMMs, verifier and its label
/// bars) trained anew on `samples` with `cfg`'s spotting settings. The parameters the
/// model records are its classifier's; those of the spotting part are written over them.
pub fn retrain_spotting(
    mut model: Model,
    samples: &[Sample],
    cfg: &TrainConfig,
) -> Result<Model, TrainError> {
    cfg.validate().map_err(TrainError::Config)?;
    same_labels(&model, samples)?;
    model.spotting = Some(SpottingModel::train(samples, &model, cfg));
    if let Some(p) = model.training.parameters.as_object_mut() {
        p.insert("spotting_step".into(), cfg.spotting_step.into());
        p.insert("spotting_states".into(), cfg.spotting_states.into());
        p.insert("verifiers".into(), cfg.verifiers.into());
        if !cfg.generator.is_lab() {
            p.insert("generator".into(), cfg.generator.name().into());
        }
    }
    Ok(model)
}

/// A model whose label bars were calibrated again, and the bars it had before.
#[derive(Debug, Clone)]
pub struct Recalibrated {
    /// The model with its new bars.
    pub model: Model,
    /// Its bars before.
    pub before: BTreeMap<String, f64>,
}

impl Recalibrated {
    /// The bars now.
    pub fn after(&self) -> BTreeMap<String, f64> {
        self.model
            .spotting
            .as_ref()
            .and_then(|s| s.verifier.as_ref())
            .map(|v| v.label_bars.clone())
            .unwrap_or_default()
    }
}

/// `model` kept whole (classifier and spotting part) with its per-label bars calibrated
/// again on streams of `samples` ([`calibrate_label_bars`]): for models trained before
/// the calibration, which training now does itself; `generator` makes the streams.
/// `progress` counts spotter runs.
pub fn recalibrate(
    mut model: Model,
    samples: &[Sample],
    generator: Generator,
    progress: Progress,
) -> Result<Recalibrated, TrainError> {
    same_labels(&model, samples)?;
    let before = model
        .spotting
        .as_ref()
        .and_then(|s| s.verifier.as_ref())
        .map(|v| v.label_bars.clone())
        .ok_or(TrainError::NoVerifier)?;
    let bars = calibrate_label_bars(&model, samples, CALIBRATION_SEED, generator, progress);
    if let Some(v) = model.spotting.as_mut().and_then(|s| s.verifier.as_mut()) {
        v.label_bars = bars;
    }
    Ok(Recalibrated { model, before })
}

/// A model's parts are kept only for data of its own labels.
fn same_labels(model: &Model, samples: &[Sample]) -> Result<(), TrainError> {
    let data = labels_of(samples);
    if let Some(l) = model.labels.iter().find(|l| !data.contains(l)) {
        return Err(TrainError::OnlyInModel(l.clone()));
    }
    if let Some(l) = data.iter().find(|l| !model.labels.contains(l)) {
        return Err(TrainError::OnlyInData(l.clone()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModelSource;

    /// One tiny sample of each label.
    fn samples(labels: &[String]) -> Vec<Sample> {
        labels
            .iter()
            .map(|l| Sample {
                label: l.clone(),
                subject: String::new(),
                strokes: vec![vec![[0.0, 0.0], [1.0, 1.0]]],
                depth: None,
            })
            .collect()
    }

    #[test]
    fn a_model_is_reused_only_for_its_labels_and_recalibrated_only_with_a_verifier() {
        let model = ModelSource::Shipped.load().unwrap();
        let mut labels = model.labels.clone();
        let last = labels.pop().unwrap();
        let e =
            recalibrate(model.clone(), &samples(&labels), Generator::Lab, &|_, _| {}).unwrap_err();
        assert!(
            matches!(&e, TrainError::OnlyInModel(l) if *l == last),
            "{e}"
        );
        labels.extend([last, "é".to_string()]);
        let e = retrain_spotting(model.clone(), &samples(&labels), &TrainConfig::default())
            .unwrap_err();
        assert!(matches!(&e, TrainError::OnlyInData(l) if l == "é"), "{e}");
        let mut bare = model;
        if let Some(s) = bare.spotting.as_mut() {
            s.verifier = None;
        }
        let own = samples(&bare.labels);
        let e = recalibrate(bare, &own, Generator::Lab, &|_, _| {}).unwrap_err();
        assert!(matches!(e, TrainError::NoVerifier), "{e}");
    }
}
