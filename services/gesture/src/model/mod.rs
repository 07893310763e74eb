//! Gesture models on disk: versioned JSON recording the training parameters, validated on
//! load (format, version, labels, shapes, probabilities), and the classification of one
//! trajectory.

mod source;
pub(crate) mod spotting;
pub(crate) mod verifier;

pub use crate::bezier::Directions;
pub use crate::crf::Crf;
pub use crate::features::FeatureConfig;
pub use crate::hmm::{DiscreteHmm, LogHmm};
pub use crate::mlp::{Layer, Mlp};
pub use crate::templates::{Template, Templates};
pub use source::{ModelSource, MODEL_ENV};
pub use spotting::SpottingModel;
pub use verifier::{Verifier, VerifierInput};

use crate::bezier::trajectory_codes;
use crate::features::feature_vector;
use crate::limits;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The `format` field of every model file.
pub const MODEL_FORMAT: &str = "airglyph-gesture-model";
/// The model file version this build reads and writes. Version 2: the spotting
/// verifier judges segments with their context and names their label.
pub const MODEL_VERSION: u32 = 2;
/// Longest label, in UTF-8 bytes: a label must fit the gesture event on the wire
/// (`airglyph_ipc::wire::LABEL_CAPACITY`, which a test holds it to; the library itself
/// knows nothing of the wire).
pub const MAX_LABEL_BYTES: usize = 32;

/// Why a model could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    // The reason is the source, which error reports print after this (`{:#}`).
    /// The file could not be read.
    #[error("{path}: cannot read model")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Not JSON, or not JSON of a model's shape.
    #[error("{path}: not a model JSON file: {msg}")]
    Json {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        msg: String,
    },
    /// JSON of something else.
    #[error("{path}: not an airglyph gesture model (format {found:?}, expected {MODEL_FORMAT:?})")]
    Format {
        /// The file.
        path: PathBuf,
        /// Its `format`.
        found: String,
    },
    /// A model of another version.
    #[error("{path}: model file version {found} is not supported (this build reads version {MODEL_VERSION}); retrain it with `airglyph train`")]
    Version {
        /// The file.
        path: PathBuf,
        /// Its `version`.
        found: String,
    },
    /// A model whose parts do not fit together or exceed the limits.
    #[error("{path}: invalid model: {msg}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
}

/// The training parameters recorded inside a model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingInfo {
    /// The classifier's name (`hmm`, `crf`, `mlp`).
    pub classifier: String,
    /// Bezier points of the seed's descriptor (what `hmm` and `crf` read).
    pub bezier_points: usize,
    /// Samples trained on…
    pub samples: usize,
    /// …and their writers.
    pub subjects: usize,
    /// The data files' names.
    pub data: Vec<String>,
    /// The training seed.
    pub seed: u64,
    /// Everything else (state counts, epochs, learning rate, …) as JSON.
    pub parameters: serde_json::Value,
    /// The template member's share, when chosen by leaving people out, and why.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub template_share: Option<TemplateShare>,
}

/// The template member's share of the decision as `airglyph train` chose it by leaving
/// people out, and what each share tried read of them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TemplateShare {
    /// The share kept (0: networks only).
    pub share: f32,
    /// People in the training data…
    pub people: usize,
    /// …and the folds they were left out in.
    pub folds: usize,
    /// Samples of the people left out…
    pub tested: usize,
    /// …and each share tried with how many of them it read right.
    pub correct: Vec<(f32, usize)>,
}

/// One HMM per label.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelledHmm {
    /// The label it models…
    pub label: String,
    /// …and the model.
    pub hmm: DiscreteHmm,
}

/// The classifier of a model.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Classifier {
    /// The seed's pipeline: Bezier points, 8 direction codes, one banded discrete HMM per
    /// label, decision by Viterbi.
    Hmm {
        /// Bezier points of the descriptor.
        bezier_points: usize,
        /// Resting code threshold (fraction of the diagonal; 0 = no resting code).
        zero_frac: f64,
        /// The directions the codes name (the circle unless trained on depth).
        #[serde(default, skip_serializing_if = "Directions::is_circle")]
        directions: Directions,
        /// One a label.
        models: Vec<LabelledHmm>,
        /// The models in logarithms, made on first use (not in the file).
        #[serde(skip)]
        cache: OnceLock<Vec<LogHmm>>,
    },
    /// A linear-chain CRF over the same codes.
    Crf {
        /// Bezier points of the descriptor.
        bezier_points: usize,
        /// Resting code threshold, as the HMMs'.
        zero_frac: f64,
        /// The directions the codes name, as the HMMs'.
        #[serde(default, skip_serializing_if = "Directions::is_circle")]
        directions: Directions,
        /// Label of each CRF class, in order.
        classes: Vec<String>,
        /// The CRF.
        crf: Crf,
    },
    /// The default: an ensemble of small neural networks over resampled trajectory
    /// features (positions, directions, pen-up) and 8-direction feature maps.
    Mlp {
        /// What the networks see of a trajectory.
        features: FeatureConfig,
        /// Label of each network output, in order.
        classes: Vec<String>,
        /// The ensemble, whose probabilities are averaged.
        nets: Vec<Mlp>,
        /// The template member, for vocabularies trained from a few samples a label:
        /// its posterior mixed with the networks' by its weight. Absent in models
        /// trained from many (and in every model before it), which decide as they did.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        templates: Option<Templates>,
    },
}

impl Classifier {
    /// Its name in model files and on the command line: `hmm`, `crf` or `mlp`.
    pub fn name(&self) -> &'static str {
        match self {
            Classifier::Hmm { .. } => "hmm",
            Classifier::Crf { .. } => "crf",
            Classifier::Mlp { .. } => "mlp",
        }
    }
}

/// A trained gesture model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Model {
    /// [`MODEL_FORMAT`].
    pub format: String,
    /// [`MODEL_VERSION`].
    pub version: u32,
    /// The vocabulary: any strings, unique.
    pub labels: Vec<String>,
    /// How it was trained.
    pub training: TrainingInfo,
    /// What names a whole trajectory.
    pub classifier: Classifier,
    /// HMMs over the stream's direction codes for spotting (absent: no spotting).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spotting: Option<SpottingModel>,
}

/// The decision on one trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct Classification {
    /// Index into `Model::labels`.
    pub class: usize,
    /// Posterior-like confidence of the decision in [0, 1].
    pub score: f64,
}

impl Model {
    /// Reads and validates a model file.
    pub fn load(path: &Path) -> Result<Model, ModelError> {
        let text = std::fs::read_to_string(path).map_err(|e| ModelError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        Self::from_json_str(&text, path)
    }

    /// Parses and validates model JSON; `path` names it in errors.
    pub fn from_json_str(text: &str, path: &Path) -> Result<Model, ModelError> {
        let p = || path.to_path_buf();
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| ModelError::Json {
            path: p(),
            msg: e.to_string(),
        })?;
        let format = v.get("format").and_then(|f| f.as_str()).unwrap_or("");
        if format != MODEL_FORMAT {
            return Err(ModelError::Format {
                path: p(),
                found: format.to_string(),
            });
        }
        match v.get("version") {
            Some(serde_json::Value::Number(n)) if n.as_u64() == Some(MODEL_VERSION as u64) => {}
            other => {
                return Err(ModelError::Version {
                    path: p(),
                    found: other.map_or("(none)".to_string(), |o| o.to_string()),
                })
            }
        }
        let model: Model = serde_json::from_value(v).map_err(|e| ModelError::Json {
            path: p(),
            msg: e.to_string(),
        })?;
        model
            .validate()
            .map_err(|msg| ModelError::Invalid { path: p(), msg })?;
        Ok(model)
    }

    /// The model file's text.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// Writes the model whole: a writer stopped half-way leaves the old file as it was.
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        airglyph_core::file::write_whole(path, self.to_json())
    }

    /// Whether its classifier reads the depth of trajectories (trained on 3-D data).
    pub fn reads_depth(&self) -> bool {
        match &self.classifier {
            Classifier::Hmm { directions, .. } | Classifier::Crf { directions, .. } => {
                !directions.is_circle()
            }
            Classifier::Mlp { features, .. } => features.depth,
        }
    }

    /// Index of a label.
    pub fn label_index(&self, label: &str) -> Option<usize> {
        self.labels.iter().position(|l| l == label)
    }

    /// Checks that the model is complete and consistent.
    pub fn validate(&self) -> Result<(), String> {
        if self.labels.is_empty() {
            return Err("the model has no labels".into());
        }
        limits::within(
            "the number of labels",
            self.labels.len(),
            1,
            limits::MAX_LABELS,
        )?;
        let mut seen = BTreeSet::new();
        for l in &self.labels {
            if l.is_empty() {
                return Err("the model has an empty label".into());
            }
            if l.len() > MAX_LABEL_BYTES {
                return Err(format!(
                    "label {l:?} is {} bytes long; labels are at most {MAX_LABEL_BYTES} bytes (UTF-8), the size of a gesture event's label",
                    l.len()
                ));
            }
            if !seen.insert(l.as_str()) {
                return Err(format!("label {l:?} appears twice"));
            }
        }
        let check_classes = |classes: &[&str], what: &str| -> Result<(), String> {
            let mut got = BTreeSet::new();
            for c in classes {
                if !seen.contains(c) {
                    return Err(format!(
                        "{what} refers to unknown label {c:?} (labels: {})",
                        self.labels.join(" ")
                    ));
                }
                if !got.insert(*c) {
                    return Err(format!("{what} has label {c:?} twice"));
                }
            }
            if let Some(missing) = self.labels.iter().find(|l| !got.contains(l.as_str())) {
                return Err(format!("{what} has no model for label {missing:?}"));
            }
            Ok(())
        };
        match &self.classifier {
            Classifier::Hmm {
                bezier_points,
                zero_frac,
                directions,
                models,
                ..
            } => {
                check_codes(*bezier_points, *zero_frac)?;
                let names: Vec<&str> = models.iter().map(|m| m.label.as_str()).collect();
                check_classes(&names, "the HMM classifier")?;
                // With a resting code the descriptor emits one code more.
                let symbols = code_count(*directions, *zero_frac);
                for m in models {
                    m.hmm
                        .validate()
                        .map_err(|e| format!("HMM of label {:?}: {e}", m.label))?;
                    if m.hmm.n_symbols() < symbols {
                        return Err(format!(
                            "HMM of label {:?} has {} symbols; its codes need {symbols}",
                            m.label,
                            m.hmm.n_symbols()
                        ));
                    }
                }
            }
            Classifier::Crf {
                bezier_points,
                zero_frac,
                directions,
                classes,
                crf,
            } => {
                check_codes(*bezier_points, *zero_frac)?;
                let names: Vec<&str> = classes.iter().map(String::as_str).collect();
                check_classes(&names, "the CRF classifier")?;
                crf.validate()?;
                if crf.labels != classes.len() || crf.symbols < directions.count() {
                    return Err("CRF dimensions do not match its classes".into());
                }
            }
            Classifier::Mlp {
                features,
                classes,
                nets,
                templates,
            } => {
                if let Some(t) = templates {
                    t.validate(classes.len())
                        .map_err(|e| format!("the template member: {e}"))?;
                }
                let names: Vec<&str> = classes.iter().map(String::as_str).collect();
                check_classes(&names, "the network classifier")?;
                if nets.is_empty() {
                    return Err("the network classifier has no networks".into());
                }
                limits::within("the number of networks", nets.len(), 1, limits::MAX_NETS)?;
                features.validate("features")?;
                for (i, n) in nets.iter().enumerate() {
                    n.validate().map_err(|e| format!("network {i}: {e}"))?;
                    if n.inputs() != features.dim() || n.outputs() != classes.len() {
                        return Err(format!(
                            "network {i} has {} inputs and {} outputs; expected {} and {}",
                            n.inputs(),
                            n.outputs(),
                            features.dim(),
                            classes.len()
                        ));
                    }
                }
            }
        }
        if let Some(s) = &self.spotting {
            let names: Vec<&str> = s.models.iter().map(|m| m.label.as_str()).collect();
            check_classes(&names, "the spotting model")?;
            if let Some(v) = &s.verifier {
                let names: Vec<&str> = v.classes.iter().map(String::as_str).collect();
                check_classes(&names, "the spotting verifier")?;
            }
            s.validate()?;
        }
        Ok(())
    }

    /// Classifies one trajectory (any units; normalized inside).
    pub fn classify(&self, t: &Trajectory) -> Classification {
        let post = self.posterior(t);
        let best = (0..post.len())
            .max_by(|&a, &b| post[a].total_cmp(&post[b]))
            .unwrap_or(0);
        Classification {
            class: best,
            score: post.get(best).copied().unwrap_or(0.0),
        }
    }

    /// The posterior-like confidence of every label (in the order of `labels`) for one
    /// trajectory; sums to 1.
    pub fn posterior(&self, t: &Trajectory) -> Vec<f64> {
        let (classes, post): (Vec<usize>, Vec<f64>) = match &self.classifier {
            Classifier::Hmm {
                bezier_points,
                zero_frac,
                directions,
                models,
                cache,
            } => {
                let logs = cache.get_or_init(|| models.iter().map(|m| m.hmm.to_log()).collect());
                let codes = trajectory_codes(t, *bezier_points, *zero_frac, *directions);
                let mut buf = Vec::new();
                let ll: Vec<f64> = logs
                    .iter()
                    .map(|h| h.viterbi_score(&codes, &mut buf))
                    .collect();
                let idx = models
                    .iter()
                    .map(|m| self.label_index(&m.label).unwrap_or(0))
                    .collect();
                (idx, softmax(&ll))
            }
            Classifier::Crf {
                bezier_points,
                zero_frac,
                directions,
                classes,
                crf,
            } => {
                let codes = trajectory_codes(t, *bezier_points, *zero_frac, *directions);
                let (_, marg) = crf.classify(&codes);
                let idx = classes
                    .iter()
                    .map(|c| self.label_index(c).unwrap_or(0))
                    .collect();
                (idx, marg)
            }
            Classifier::Mlp {
                features,
                classes,
                nets,
                templates,
            } => {
                let mut acc = vec![0.0f64; classes.len()];
                // The networks' share: all of it without templates, and none when the
                // templates decide alone (their weight 1: no network is run).
                let nets_share = templates.as_ref().map_or(1.0, |m| 1.0 - m.weight as f64);
                if nets_share > 0.0 {
                    acc = networks_posterior(nets, features, t, classes.len());
                }
                if let Some(m) = templates {
                    for (a, p) in acc.iter_mut().zip(m.posterior(t, classes.len())) {
                        *a = nets_share * *a + m.weight as f64 * p;
                    }
                }
                let idx = classes
                    .iter()
                    .map(|c| self.label_index(c).unwrap_or(0))
                    .collect();
                (idx, acc)
            }
        };
        let mut out = vec![0.0; self.labels.len()];
        for (c, p) in classes.into_iter().zip(post) {
            if let Some(o) = out.get_mut(c) {
                *o += p;
            }
        }
        out
    }
}

/// The mean posterior of an ensemble's networks for one trajectory, `classes` long.
pub(crate) fn networks_posterior(
    nets: &[Mlp],
    features: &FeatureConfig,
    t: &Trajectory,
    classes: usize,
) -> Vec<f64> {
    let mut acc = vec![0.0f64; classes];
    let mut f = Vec::with_capacity(features.dim());
    feature_vector(t, features, &mut f);
    for n in nets {
        for (a, lp) in acc.iter_mut().zip(n.log_probs(&f)) {
            *a += (lp as f64).exp() / nets.len() as f64;
        }
    }
    acc
}

/// The seed's descriptor settings: a Bezier point count within bounds and a resting
/// code fraction that is a fraction.
fn check_codes(bezier_points: usize, zero_frac: f64) -> Result<(), String> {
    limits::within("bezier_points", bezier_points, 2, limits::MAX_BEZIER_POINTS)?;
    limits::finite_within("zero_frac", zero_frac, 0.0, 1.0)?;
    Ok(())
}

/// The codes the seed's descriptor emits: a direction each, and the resting code.
pub fn code_count(directions: Directions, zero_frac: f64) -> usize {
    directions.count() + usize::from(zero_frac > 0.0)
}

fn softmax(ll: &[f64]) -> Vec<f64> {
    let m = ll.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if !m.is_finite() {
        return vec![1.0 / ll.len().max(1) as f64; ll.len()];
    }
    let e: Vec<f64> = ll.iter().map(|v| (v - m).exp()).collect();
    let s: f64 = e.iter().sum();
    e.iter().map(|v| v / s).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_label_of_the_longest_length_fits_a_gesture_event() {
        assert_eq!(MAX_LABEL_BYTES, airglyph_ipc::wire::LABEL_CAPACITY);
    }
}
