//! Training a model from samples: the seed's HMMs, the CRF, or the default network
//! ensemble; spotting HMMs are added to every model.

mod calibrate;
mod crf;
mod few_shot;
mod hmm;
mod look_alike;
mod mlp;
mod reuse;
mod share;
mod spotting;
mod verifier;

pub use calibrate::{calibrate_label_bars, BAR_STEPS};
pub use crf::CrfTrainConfig;
pub use few_shot::{FewShotConfig, FewShotPlan};
pub use hmm::HmmTrainConfig;
pub use look_alike::{look_alikes, LookAlike, LOOK_ALIKE_THRESHOLD};
pub use mlp::MlpTrainConfig;
pub use reuse::{recalibrate, retrain_spotting, Recalibrated};
pub use spotting::CALIBRATION_SEED;

use crate::bezier::{trajectory_codes, Directions};
use crate::crf::Crf;
use crate::features::{feature_vector, FeatureConfig};
use crate::hmm::DiscreteHmm;
use crate::lab::augment::augment;
use crate::lab::data::{labels_of, Sample};
use crate::lab::movement::Generator;
use crate::lab::stream::{drawn_in_stream, training_stream};
use crate::mlp::Mlp;
use crate::model::{
    code_count, Classifier, LabelledHmm, Model, SpottingModel, TrainingInfo, MAX_LABEL_BYTES,
    MODEL_FORMAT, MODEL_VERSION,
};
use crate::tracker::TrackerConfig;
use crate::trajectory::Trajectory;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::sync::OnceLock;

/// Which classifier to train.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClassifierKind {
    /// The seed's pipeline.
    Hmm,
    /// A linear-chain CRF over the seed's codes.
    Crf,
    /// The default.
    Mlp,
}

impl ClassifierKind {
    /// The kind a name on the command line means (`hmm` or `seed`, `crf`, `mlp` or
    /// `default`).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "hmm" | "seed" => Some(Self::Hmm),
            "crf" => Some(Self::Crf),
            "mlp" | "default" => Some(Self::Mlp),
            _ => None,
        }
    }

    /// Its name in model files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Hmm => "hmm",
            Self::Crf => "crf",
            Self::Mlp => "mlp",
        }
    }
}

/// Everything `train` needs besides the samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// What to train.
    pub classifier: ClassifierKind,
    /// Bezier points of the seed's descriptor (`hmm`, `crf`).
    pub bezier_points: usize,
    /// Resting code for the Bezier codes (fraction of the diagonal; 0 = none).
    pub zero_frac: f64,
    /// How the HMMs are trained…
    pub hmm: HmmTrainConfig,
    /// …the CRF…
    pub crf: CrfTrainConfig,
    /// …and each network.
    pub mlp: MlpTrainConfig,
    /// What the networks see of a trajectory.
    pub features: FeatureConfig,
    /// Networks in the ensemble.
    pub ensemble: usize,
    /// Augmentation strength (0 = none).
    pub augment: f32,
    /// Fraction of the augmented training samples (network classifier) that are also
    /// drawn in a synthetic stream and seen as the spotter sees them, through the hand
    /// tracker's filter ([`drawn_in_stream`]). 0 in models trained before it.
    #[serde(default)]
    pub stream_augment: f32,
    /// Add spotting HMMs.
    pub spotting: bool,
    /// Chord step of the spotting HMMs' codes, a fraction of the gesture's larger side.
    pub spotting_step: f64,
    /// States of each spotting HMM.
    pub spotting_states: usize,
    /// Networks in the spotting verifier, each trained on streams of its own.
    #[serde(default = "one")]
    pub verifiers: usize,
    /// What a vocabulary with few samples a label gets (network classifier). Models
    /// trained before it get the defaults, which change nothing for vocabularies of
    /// more than a few samples a label.
    #[serde(default)]
    pub few_shot: FewShotConfig,
    /// Which synthetic streams the spotting part's verifier and label bars learn from
    /// (models trained before it, and those of the lab generator, do not name it).
    #[serde(default, skip_serializing_if = "Generator::is_lab")]
    pub generator: Generator,
    /// Every random draw of training follows from it.
    pub seed: u64,
    /// Data file names, recorded in the model.
    pub data: Vec<String>,
}

/// What models trained before a field existed had.
fn one() -> usize {
    1
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            classifier: ClassifierKind::Mlp,
            bezier_points: 15,
            zero_frac: 0.0,
            hmm: HmmTrainConfig::default(),
            crf: CrfTrainConfig::default(),
            mlp: MlpTrainConfig::default(),
            features: FeatureConfig::default(),
            ensemble: 3,
            augment: 1.0,
            stream_augment: 0.0,
            spotting: true,
            spotting_step: 0.1,
            spotting_states: 10,
            verifiers: 3,
            few_shot: FewShotConfig::default(),
            generator: Generator::Lab,
            seed: 1,
            data: Vec::new(),
        }
    }
}

impl TrainConfig {
    /// Every size and count within [`crate::limits`], every rate a finite number in
    /// range: checked before anything is allocated, so that no size from a command line
    /// overflows a capacity or asks for terabytes. The message names the setting as
    /// `airglyph train` spells it.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::*;
        within("--bezier-points", self.bezier_points, 2, MAX_BEZIER_POINTS)?;
        finite_within("the resting code fraction", self.zero_frac, 0.0, 1.0)?;
        within("--states", self.hmm.states, 1, MAX_STATES)?;
        within(
            "the HMM's training iterations",
            self.hmm.iterations,
            0,
            MAX_EPOCHS,
        )?;
        within("the HMM's band", self.hmm.band, 0, MAX_STATES)?;
        within("the CRF's time bins", self.crf.time_bins, 1, MAX_TIME_BINS)?;
        within("the CRF's iterations", self.crf.iterations, 0, MAX_EPOCHS)?;
        within("--hidden", self.mlp.hidden, 2, MAX_HIDDEN)?;
        within("--epochs", self.mlp.epochs, 1, MAX_EPOCHS)?;
        within("the batch size", self.mlp.batch, 1, MAX_BATCH)?;
        finite_within(
            "the learning rate",
            self.mlp.learning_rate as f64,
            0.0,
            10.0,
        )?;
        finite_within("the momentum", self.mlp.momentum as f64, 0.0, 1.0)?;
        finite_within("the weight decay", self.mlp.weight_decay as f64, 0.0, 1.0)?;
        self.features.validate("features")?;
        within("--ensemble", self.ensemble, 1, MAX_NETS)?;
        finite_within("the augmentation", self.augment as f64, 0.0, 10.0)?;
        finite_within("--stream-augment", self.stream_augment as f64, 0.0, 1.0)?;
        if !(self.spotting_step > 0.0 && self.spotting_step < 1.0) {
            return Err(format!(
                "the spotting step is {}; it must be in (0, 1)",
                self.spotting_step
            ));
        }
        within("the spotting states", self.spotting_states, 1, MAX_STATES)?;
        within("--verifiers", self.verifiers, 1, MAX_NETS)?;
        self.few_shot.validate()?;
        Ok(())
    }
}

/// Why training failed.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A setting out of its range ([`TrainConfig::validate`]).
    #[error("{0}")]
    Config(String),
    /// Nothing to train on.
    #[error("no training samples")]
    NoSamples,
    /// A vocabulary of one label.
    #[error("only one label ({0:?}); a classifier needs at least two")]
    OneLabel(String),
    /// A label a gesture event cannot carry.
    #[error("label {label:?} is {bytes} bytes long; labels are at most {MAX_LABEL_BYTES} bytes (UTF-8), the size of a gesture event's label")]
    LabelTooLong {
        /// The label.
        label: String,
        /// Its length in UTF-8.
        bytes: usize,
    },
    /// A model reused for data without one of its labels…
    #[error("its labels differ from the data's: {0:?} is in the model, not in the data")]
    OnlyInModel(String),
    /// …or with a label it does not know.
    #[error("its labels differ from the data's: {0:?} is in the data, not in the model")]
    OnlyInData(String),
    /// A network's weights left the finite numbers while it learnt: written, the model
    /// would read back as not a model.
    #[error("network {network} of the ensemble diverged ({why}); if the data's depth is nearly the same at every point, train without it (--flat)")]
    Diverged {
        /// Which network, from 1.
        network: usize,
        /// What the network's check found.
        why: String,
    },
    /// A model recalibrated that has no verifier whose bars could be calibrated.
    #[error("it has no spotting verifier to calibrate; train its spotting part first (`airglyph train --reuse-classifier`)")]
    NoVerifier,
}

/// Progress of training: (units done, units total).
pub type Progress<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// What training the network classifier on these samples does for their smallest
/// label, and why ([`FewShotPlan`]'s text).
pub fn few_shot_plan(samples: &[Sample], cfg: &TrainConfig) -> FewShotPlan {
    FewShotPlan::new(samples, &labels_of(samples), &cfg.few_shot)
}

/// Trains a model on the samples.
pub fn train(
    samples: &[Sample],
    cfg: &TrainConfig,
    progress: Progress,
) -> Result<Model, TrainError> {
    cfg.validate().map_err(TrainError::Config)?;
    if samples.is_empty() {
        return Err(TrainError::NoSamples);
    }
    let labels = labels_of(samples);
    if let Some(l) = labels.iter().find(|l| l.len() > MAX_LABEL_BYTES) {
        return Err(TrainError::LabelTooLong {
            label: l.clone(),
            bytes: l.len(),
        });
    }
    if labels.len() < 2 {
        return Err(TrainError::OneLabel(labels[0].clone()));
    }
    let class_of: Vec<usize> = samples
        .iter()
        .map(|s| labels.iter().position(|l| *l == s.label).unwrap_or(0))
        .collect();
    let subjects: BTreeSet<&str> = samples.iter().map(|s| s.subject.as_str()).collect();
    // Data with depth gets classifiers that read it; pen data the 2-D ones, unchanged.
    let depth = samples.iter().any(Sample::has_depth);
    let directions = if depth {
        Directions::Sphere26
    } else {
        Directions::Circle8
    };
    let mut template_share = None;
    let classifier = match cfg.classifier {
        ClassifierKind::Hmm => {
            let codes = seed_codes(samples, cfg, directions);
            let symbols = code_count(directions, cfg.zero_frac);
            let hcfg = HmmTrainConfig { symbols, ..cfg.hmm };
            let done = std::sync::atomic::AtomicU64::new(0);
            let models = labels
                .par_iter()
                .enumerate()
                .map(|(c, l)| {
                    let seqs: Vec<Vec<usize>> = codes
                        .iter()
                        .zip(&class_of)
                        .filter(|(_, &k)| k == c)
                        .map(|(s, _)| s.clone())
                        .collect();
                    let hmm = DiscreteHmm::train(&seqs, &hcfg);
                    let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    progress(d, labels.len() as u64);
                    LabelledHmm {
                        label: l.clone(),
                        hmm,
                    }
                })
                .collect();
            Classifier::Hmm {
                bezier_points: cfg.bezier_points,
                zero_frac: cfg.zero_frac,
                directions,
                models,
                cache: OnceLock::new(),
            }
        }
        ClassifierKind::Crf => {
            let codes = seed_codes(samples, cfg, directions);
            let symbols = code_count(directions, cfg.zero_frac);
            let total = cfg.crf.iterations as u64;
            let crf = Crf::train(&codes, &class_of, labels.len(), symbols, &cfg.crf, |it| {
                progress(it as u64 + 1, total)
            });
            Classifier::Crf {
                bezier_points: cfg.bezier_points,
                zero_frac: cfg.zero_frac,
                directions,
                classes: labels.clone(),
                crf,
            }
        }
        ClassifierKind::Mlp => {
            let trajs: Vec<_> = samples.iter().map(|s| s.trajectory()).collect();
            let plan = FewShotPlan::new(samples, &labels, &cfg.few_shot);
            let fcfg = FeatureConfig {
                depth,
                ..cfg.features
            };
            let ensemble = cfg.ensemble.max(1);
            // Leaving people out trains an ensemble a fold before the model's.
            let folds = match plan {
                FewShotPlan::ByPerson { people, .. } => people.min(share::MAX_FOLDS),
                _ => 0,
            };
            let total = ((folds + 1) * ensemble * cfg.mlp.epochs) as u64;
            let data = Labelled {
                samples,
                trajs: &trajs,
                class_of: &class_of,
                classes: labels.len(),
            };
            let share = match plan {
                FewShotPlan::ByPerson { .. } => Some(share::choose(&data, &fcfg, cfg, &|done| {
                    progress(done, total)
                })?),
                _ => None,
            };
            let nets = train_networks(
                &data,
                plan.copies(),
                &fcfg,
                cfg,
                (0..ensemble).map(|e| cfg.seed.wrapping_mul(1000).wrapping_add(e as u64)),
                &|done| progress((folds * ensemble * cfg.mlp.epochs) as u64 + done, total),
            )?;
            let templates = match (&plan, &share) {
                (FewShotPlan::WithTemplates { .. }, _) => Some(few_shot::template_member(
                    samples,
                    &class_of,
                    labels.len(),
                    depth,
                    &cfg.few_shot,
                )),
                (_, Some(choice)) if choice.share > 0.0 => Some(share::template_member(
                    samples,
                    &class_of,
                    labels.len(),
                    choice.share,
                    &cfg.few_shot,
                )),
                _ => None,
            };
            template_share = share;
            Classifier::Mlp {
                features: fcfg,
                classes: labels.clone(),
                nets,
                templates,
            }
        }
    };
    let parameters = serde_json::to_value(cfg).unwrap_or(serde_json::Value::Null);
    let mut model = Model {
        format: MODEL_FORMAT.to_string(),
        version: MODEL_VERSION,
        labels,
        training: TrainingInfo {
            classifier: cfg.classifier.name().to_string(),
            bezier_points: cfg.bezier_points,
            samples: samples.len(),
            subjects: subjects.len(),
            data: cfg.data.clone(),
            seed: cfg.seed,
            parameters,
            template_share,
        },
        classifier,
        spotting: None,
    };
    if cfg.spotting {
        model.spotting = Some(SpottingModel::train(samples, &model, cfg));
    }
    Ok(model)
}

/// Samples with what training reads of them: their trajectories and classes.
struct Labelled<'a> {
    samples: &'a [Sample],
    trajs: &'a [Trajectory],
    /// Index into the vocabulary's labels, a sample.
    class_of: &'a [usize],
    classes: usize,
}

/// One network for each of `seeds`, each on `copies` augmented copies of every
/// trajectory an epoch; `progress` gets the epochs done over all of them.
fn train_networks(
    data: &Labelled,
    copies: usize,
    fcfg: &FeatureConfig,
    cfg: &TrainConfig,
    seeds: impl Iterator<Item = u64>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Mlp>, TrainError> {
    let (trajs, class_of, classes) = (data.trajs, data.class_of, data.classes);
    // Copy `i` of sample `i % n` is augmented afresh (its own index seeds it); with
    // one copy this is the training of every model before few-shot ones.
    let n = trajs.len();
    let copy_class: Vec<usize> = (0..n * copies).map(|i| class_of[i % n]).collect();
    let depth = fcfg.depth;
    let tracker = TrackerConfig::default();
    let strength = cfg.augment;
    let mut nets = Vec::new();
    for (e, seed) in seeds.enumerate() {
        // `usize::MAX` asks for the copies the inputs are standardized on (and the
        // first epoch learns from): the data as drawn, for 2-D data. With depth,
        // augmented ones: a set drawn nearly in one plane has depth features that
        // hardly vary as drawn, and turned out of the plane by augmentation they would
        // stand thousands of deviations off.
        let feats = |epoch: usize, i: usize| {
            let mut f = Vec::with_capacity(fcfg.dim());
            if (epoch == usize::MAX && !depth) || strength <= 0.0 {
                feature_vector(&trajs[i % n], fcfg, &mut f);
            } else {
                let mut rng = ChaCha8Rng::seed_from_u64(
                    seed ^ ((epoch as u64) << 32) ^ (i as u64).wrapping_mul(0x9E37_79B9),
                );
                let mut t = augment(&trajs[i % n], &mut rng, strength);
                if cfg.stream_augment > 0.0 && rng.gen::<f32>() < cfg.stream_augment {
                    let scfg = training_stream(&mut rng);
                    t = drawn_in_stream(&t, &scfg, &tracker, &mut rng);
                }
                feature_vector(&t, fcfg, &mut f);
            }
            f
        };
        let mcfg = MlpTrainConfig { seed, ..cfg.mlp };
        let net = Mlp::train(
            copy_class.len(),
            fcfg.dim(),
            &copy_class,
            classes,
            &mcfg,
            feats,
            |ep| progress((e * cfg.mlp.epochs + ep + 1) as u64),
        );
        net.validate().map_err(|why| TrainError::Diverged {
            network: e + 1,
            why,
        })?;
        nets.push(net);
    }
    Ok(nets)
}

/// The seed's codes of every sample, with the directions `directions`.
fn seed_codes(samples: &[Sample], cfg: &TrainConfig, directions: Directions) -> Vec<Vec<usize>> {
    samples
        .par_iter()
        .map(|s| {
            trajectory_codes(
                &s.trajectory(),
                cfg.bezier_points,
                cfg.zero_frac,
                directions,
            )
        })
        .collect()
}
