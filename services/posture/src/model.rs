//! A posture model file: a trained classifier, the segmentation settings it was trained
//! with (a hand cut otherwise has other features) and the version of the features, as
//! versioned JSON. Loading checks everything a classifier relies on, so that a bad file
//! is refused with its name and the reason instead of misclassifying.

use crate::classify::{Classifier, Method, Model, Parts, Prediction};
use crate::features::{FEATURE_LEN, FEATURE_VERSION};
use crate::segment::{ArmJoints, NoHand, SegmentParams};
use airglyph_core::{DepthView, Intrinsics};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `format` of a posture model file.
pub const POSTURE_MODEL_FORMAT: &str = "airglyph-posture-model";
/// The version of the file's layout this build reads and writes.
pub const POSTURE_MODEL_VERSION: u32 = 1;
/// The longest label, in UTF-8 bytes: labels travel in 16 bytes on the wire.
pub const MAX_POSTURE_LABEL_BYTES: usize = 16;

/// The built-in model (`models/postures-6.json`): the six postures of the synthetic
/// hands, trained on synthetic bodies by `examples/train-builtin.rs`. Built into the
/// library so that an installed binary needs no file beside it.
const BUILTIN_JSON: &str = include_str!("../../../models/postures-6.json");
/// How the built-in model is named in errors.
const BUILTIN_NAME: &str = "the built-in posture model postures-6";

/// Why a posture model file was refused; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum PostureModelError {
    /// The file could not be read.
    #[error("{path}: cannot read posture model: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not JSON, or not JSON of a model's shape.
    #[error("{path}: not a posture model JSON file: {msg}")]
    Json {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        msg: String,
    },
    /// JSON of something else.
    #[error("{path}: not an airglyph posture model (format {found:?}, expected {POSTURE_MODEL_FORMAT:?})")]
    Format {
        /// The file.
        path: PathBuf,
        /// Its `format`.
        found: String,
    },
    /// Another version of the file or of the features.
    #[error("{path}: {what} version {found} is not supported (this build reads version {expected}); retrain it with `airglyph train --postures`")]
    Version {
        /// The file.
        path: PathBuf,
        /// Which version: the file's or the features'.
        what: &'static str,
        /// What the file says.
        found: String,
        /// What this build reads.
        expected: u32,
    },
    /// JSON of the right shape that no classifier can use.
    #[error("{path}: invalid posture model: {msg}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
}

/// A trained posture classifier with the segmentation settings it was trained with.
#[derive(Debug, Clone, PartialEq)]
pub struct PostureModel {
    classifier: Classifier,
    params: SegmentParams,
    training: serde_json::Value,
}

impl PostureModel {
    /// A model of `classifier`, trained on hands cut with `params`; `training` says
    /// how it was made (free JSON, kept in the file; `null` for nothing).
    pub fn new(classifier: Classifier, params: SegmentParams, training: serde_json::Value) -> Self {
        Self {
            classifier,
            params,
            training,
        }
    }

    /// The built-in model of the six postures of the synthetic hands (open, fist,
    /// point, thumb-up, v, pinch).
    pub fn builtin() -> PostureModel {
        // The file is part of the source and a test loads it: it cannot be invalid in
        // a build whose tests passed.
        Self::from_json_str(BUILTIN_JSON, Path::new(BUILTIN_NAME)).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Reads and checks a model file.
    pub fn load(path: &Path) -> Result<PostureModel, PostureModelError> {
        let text = std::fs::read_to_string(path).map_err(|source| PostureModelError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_json_str(&text, path)
    }

    /// Parses and checks model JSON; `name` names it in errors.
    pub fn from_json_str(s: &str, name: &Path) -> Result<PostureModel, PostureModelError> {
        let path = || name.to_path_buf();
        let json = |e: serde_json::Error| PostureModelError::Json {
            path: path(),
            msg: e.to_string(),
        };
        let v: serde_json::Value = serde_json::from_str(s).map_err(json)?;
        let format = v.get("format").and_then(|f| f.as_str()).unwrap_or("");
        if format != POSTURE_MODEL_FORMAT {
            return Err(PostureModelError::Format {
                path: path(),
                found: format.to_string(),
            });
        }
        for (key, what, expected) in [
            ("version", "posture model file", POSTURE_MODEL_VERSION),
            ("feature_version", "feature", FEATURE_VERSION),
        ] {
            let found = v.get(key);
            if found.and_then(|n| n.as_u64()) != Some(expected as u64) {
                return Err(PostureModelError::Version {
                    path: path(),
                    what,
                    found: found.map_or("(none)".to_string(), |f| f.to_string()),
                    expected,
                });
            }
        }
        let file: File = serde_json::from_value(v).map_err(json)?;
        file.into_model()
            .map_err(|msg| PostureModelError::Invalid { path: path(), msg })
    }

    /// The model file's text.
    pub fn to_json(&self) -> String {
        // Only numbers, strings and the training note, which is JSON already: this
        // cannot fail.
        serde_json::to_string(&File::of(self)).unwrap_or_default()
    }

    /// Writes the model whole: a writer stopped half-way leaves the old file as it was.
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        airglyph_core::file::write_whole(path, self.to_json())
    }

    /// The postures it tells apart, by label index.
    pub fn labels(&self) -> &[String] {
        self.classifier.labels()
    }

    /// How it classifies.
    pub fn method(&self) -> Method {
        self.classifier.method()
    }

    /// The classifier.
    pub fn classifier(&self) -> &Classifier {
        &self.classifier
    }

    /// How it cuts hands out (as in its training).
    pub fn params(&self) -> &SegmentParams {
        &self.params
    }

    /// How it was made, as its trainer wrote it.
    pub fn training(&self) -> &serde_json::Value {
        &self.training
    }

    /// The posture of the hand of `arm` in `depth`.
    pub fn classify(
        &self,
        depth: DepthView<'_>,
        k: &Intrinsics,
        arm: ArmJoints,
    ) -> Result<Prediction, NoHand> {
        let hand = crate::describe(depth, k, arm, &self.params)?;
        Ok(self.classifier.predict(&hand.features))
    }
}

/// The file's layout.
#[derive(Serialize, Deserialize)]
struct File {
    format: String,
    version: u32,
    feature_version: u32,
    labels: Vec<String>,
    segment: SegmentParams,
    classifier: Stored,
    #[serde(default)]
    training: serde_json::Value,
}

/// The classifier as stored: the standardization and the model, on standardized
/// features.
#[derive(Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum Stored {
    Knn {
        k: usize,
        mean: Vec<f32>,
        scale: Vec<f32>,
        /// Each training sample: its label index and features.
        samples: Vec<(usize, Vec<f32>)>,
    },
    Softmax {
        l2: f32,
        mean: Vec<f32>,
        scale: Vec<f32>,
        /// One row of weights per label.
        w: Vec<Vec<f32>>,
        b: Vec<f32>,
    },
}

impl File {
    fn of(m: &PostureModel) -> File {
        let p = m.classifier.to_parts();
        let s = &m.params;
        let (mean, scale) = (p.mean.to_vec(), p.scale.to_vec());
        // `Classifier::train` builds the model of its method, so the other arm of
        // each inner match is never taken.
        let classifier = match p.model {
            Model::Knn(samples) => Stored::Knn {
                k: match p.method {
                    Method::Knn { k } => k,
                    Method::Softmax { .. } => 1,
                },
                mean,
                scale,
                samples: samples.into_iter().map(|(x, l)| (l, x.to_vec())).collect(),
            },
            Model::Softmax { w, b } => Stored::Softmax {
                l2: match p.method {
                    Method::Softmax { l2 } => l2,
                    Method::Knn { .. } => 0.0,
                },
                mean,
                scale,
                w: w.into_iter().map(|r| r.to_vec()).collect(),
                b,
            },
        };
        File {
            format: POSTURE_MODEL_FORMAT.into(),
            version: POSTURE_MODEL_VERSION,
            feature_version: FEATURE_VERSION,
            labels: p.labels,
            segment: *s,
            classifier,
            training: m.training.clone(),
        }
    }

    /// The model, or what is wrong with the file.
    fn into_model(self) -> Result<PostureModel, String> {
        check_labels(&self.labels)?;
        let n = self.labels.len();
        let s = &self.segment;
        for (name, v) in [
            ("window_m", s.window_m),
            ("reach_m", s.reach_m),
            ("band_m", s.band_m),
            ("seed_radius_m", s.seed_radius_m),
            ("wrist_back", s.wrist_back),
            ("min_area_m2", s.min_area_m2),
            ("palm_back", s.palm_back),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("segment.{name} is {v}, not a positive number"));
            }
        }
        let params = self.segment;
        let (method, mean, scale, model) = match self.classifier {
            Stored::Knn {
                k,
                mean,
                scale,
                samples,
            } => {
                if k == 0 {
                    return Err("classifier.k is 0: at least one neighbour votes".into());
                }
                if samples.is_empty() {
                    return Err("the k-NN has no samples".into());
                }
                let mut kept = Vec::with_capacity(samples.len());
                for (i, (label, x)) in samples.into_iter().enumerate() {
                    if label >= n {
                        return Err(format!(
                            "classifier.samples[{i}] has label index {label}, but there are {n} labels"
                        ));
                    }
                    kept.push((vector(&format!("classifier.samples[{i}]"), &x)?, label));
                }
                (Method::Knn { k }, mean, scale, Model::Knn(kept))
            }
            Stored::Softmax {
                l2,
                mean,
                scale,
                w,
                b,
            } => {
                if !l2.is_finite() {
                    return Err(format!("classifier.l2 is {l2}, not a finite number"));
                }
                if w.len() != n || b.len() != n {
                    return Err(format!(
                        "the softmax has {} weight rows and {} biases for {n} labels",
                        w.len(),
                        b.len()
                    ));
                }
                if let Some(i) = b.iter().position(|v| !v.is_finite()) {
                    return Err(format!("classifier.b[{i}] is {}, not finite", b[i]));
                }
                let w = w
                    .iter()
                    .enumerate()
                    .map(|(i, r)| vector(&format!("classifier.w[{i}]"), r))
                    .collect::<Result<Vec<_>, _>>()?;
                (Method::Softmax { l2 }, mean, scale, Model::Softmax { w, b })
            }
        };
        let mean = vector("classifier.mean", &mean)?;
        let scale = vector("classifier.scale", &scale)?;
        Ok(PostureModel {
            classifier: Classifier::from_parts(Parts {
                labels: self.labels,
                method,
                mean,
                scale,
                model,
            }),
            params,
            training: self.training,
        })
    }
}

/// Labels a model or a sample file may carry: at least two, none empty, none longer
/// than [`MAX_POSTURE_LABEL_BYTES`], no two alike.
pub fn check_labels(labels: &[String]) -> Result<(), String> {
    if labels.len() < 2 {
        return Err(format!(
            "{} label(s): a posture model tells two at least apart",
            labels.len()
        ));
    }
    for (i, l) in labels.iter().enumerate() {
        check_label(l)?;
        if labels[..i].contains(l) {
            return Err(format!("label {l:?} appears twice"));
        }
    }
    Ok(())
}

/// One label: not empty, at most [`MAX_POSTURE_LABEL_BYTES`] UTF-8 bytes.
pub fn check_label(label: &str) -> Result<(), String> {
    if label.is_empty() {
        return Err("a label is empty".into());
    }
    if label.len() > MAX_POSTURE_LABEL_BYTES {
        return Err(format!(
            "label {label:?} is {} bytes long; labels travel in {MAX_POSTURE_LABEL_BYTES} bytes",
            label.len()
        ));
    }
    Ok(())
}

/// A stored feature-length vector of finite numbers.
fn vector(what: &str, x: &[f32]) -> Result<[f32; FEATURE_LEN], String> {
    let v: [f32; FEATURE_LEN] = x.try_into().map_err(|_| {
        format!(
            "{what} has {} numbers, features have {FEATURE_LEN}",
            x.len()
        )
    })?;
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(format!("{what}[{i}] is {}, not finite", v[i]));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::TrainingSet;
    use crate::features::Features;
    use serde_json::{json, Value};

    /// A model of `method` over three labels, trained on made-up feature vectors
    /// (enough for the file's checks, which do not look at what the numbers mean).
    fn model(method: Method) -> PostureModel {
        let labels = vec!["open".to_string(), "fist".into(), "ünïcode".into()];
        let mut set = TrainingSet::new(labels);
        for i in 0..30 {
            let label = i % 3;
            let values: Vec<f32> = (0..FEATURE_LEN)
                .map(|j| label as f32 + ((i * 7 + j * 13) % 10) as f32 * 0.05)
                .collect();
            let f = Features::from_slice(&values).unwrap();
            set.add(&f, label, (i / 10) as u32).unwrap();
        }
        let c = Classifier::train(&set, method).unwrap();
        PostureModel::new(c, SegmentParams::default(), json!({"by": "test"}))
    }

    fn knn_json() -> Value {
        serde_json::from_str(&model(Method::Knn { k: 3 }).to_json()).unwrap()
    }

    /// The message loading `v` gives; it must name the file.
    fn refusal(v: &Value) -> String {
        let e = PostureModel::from_json_str(&v.to_string(), Path::new("my-model.json"))
            .expect_err("accepted a bad model");
        let msg = e.to_string();
        assert!(msg.starts_with("my-model.json: "), "{msg}");
        msg
    }

    #[test]
    fn a_model_saved_and_loaded_is_the_same_model() {
        let dir = tempfile::tempdir().unwrap();
        for method in [Method::Knn { k: 3 }, Method::Softmax { l2: 1e-3 }] {
            let m = model(method);
            let path = dir.path().join("m.json");
            m.save(&path).unwrap();
            let back = PostureModel::load(&path).unwrap();
            assert_eq!(back, m);
            assert_eq!(back.labels(), ["open", "fist", "ünïcode"]);
            assert_eq!(back.training()["by"], "test");
        }
    }

    #[test]
    fn the_builtin_model_loads() {
        let m = PostureModel::builtin();
        assert_eq!(
            m.labels(),
            ["open", "fist", "point", "thumb-up", "v", "pinch"]
        );
    }

    #[test]
    fn a_file_that_is_not_there_or_not_json_is_refused_by_name() {
        let e = PostureModel::load(Path::new("/nonexistent/p.json")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("/nonexistent/p.json: cannot read"),
            "{e}"
        );
        let e =
            PostureModel::from_json_str("{\"format\": ", Path::new("my-model.json")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("my-model.json: not a posture model JSON"),
            "{e}"
        );
        let mut v = knn_json();
        v["format"] = json!("airglyph-gesture-model");
        assert!(refusal(&v).contains("not an airglyph posture model"));
    }

    #[test]
    fn another_version_is_refused() {
        let mut v = knn_json();
        v["version"] = json!(2);
        assert!(refusal(&v).contains("posture model file version 2 is not supported"));
        let mut v = knn_json();
        v["feature_version"] = json!(0);
        assert!(refusal(&v).contains("feature version 0 is not supported"));
        let mut v = knn_json();
        v.as_object_mut().unwrap().remove("version");
        assert!(refusal(&v).contains("version (none)"));
    }

    #[test]
    fn a_feature_vector_of_the_wrong_length_is_refused() {
        let mut v = knn_json();
        v["classifier"]["samples"][4][1]
            .as_array_mut()
            .unwrap()
            .pop();
        let msg = refusal(&v);
        let says = format!(
            "classifier.samples[4] has {} numbers, features have {FEATURE_LEN}",
            FEATURE_LEN - 1
        );
        assert!(msg.contains(&says), "{msg}");
        let mut v = knn_json();
        v["classifier"]["mean"]
            .as_array_mut()
            .unwrap()
            .push(json!(0.0));
        let says = format!("classifier.mean has {} numbers", FEATURE_LEN + 1);
        assert!(refusal(&v).contains(&says));
        let mut v: Value =
            serde_json::from_str(&model(Method::Softmax { l2: 1e-3 }).to_json()).unwrap();
        v["classifier"]["w"][1].as_array_mut().unwrap().truncate(10);
        assert!(refusal(&v).contains("classifier.w[1] has 10 numbers"));
    }

    #[test]
    fn a_number_that_is_not_finite_is_refused() {
        // JSON has no infinity, but a number past f32's range reads as one.
        let text = knn_json().to_string();
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["classifier"]["scale"][7] = json!(1e39);
        let msg = refusal(&v);
        assert!(
            msg.contains("classifier.scale[7] is inf, not finite"),
            "{msg}"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["classifier"]["samples"][0][1][3] = json!(-1e300);
        assert!(refusal(&v).contains("classifier.samples[0][3] is -inf"));
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segment"]["reach_m"] = json!(1e40);
        assert!(refusal(&v).contains("segment.reach_m is inf"));
        // What a writer makes of NaN.
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["classifier"]["mean"][0] = Value::Null;
        assert!(refusal(&v).contains("not a posture model JSON"));
    }

    #[test]
    fn bad_labels_are_refused() {
        let cases: [(Value, &str); 5] = [
            (
                json!(["open"]),
                "1 label(s): a posture model tells two at least apart",
            ),
            (json!(["open", "", "fist"]), "a label is empty"),
            (
                json!(["open", "seventeen-bytes!!", "fist"]),
                "label \"seventeen-bytes!!\" is 17 bytes long",
            ),
            // Sixteen bytes in eight letters: the limit is bytes, not letters.
            (json!(["open", "ääääääääa", "fist"]), "is 17 bytes long"),
            (
                json!(["open", "fist", "open"]),
                "label \"open\" appears twice",
            ),
        ];
        for (labels, says) in cases {
            let mut v = knn_json();
            v["labels"] = labels;
            let msg = refusal(&v);
            assert!(msg.contains(says), "{msg}");
        }
        let mut v = knn_json();
        v["labels"] = json!(["open", "fist", "ääääääää"]);
        assert!(PostureModel::from_json_str(&v.to_string(), Path::new("x")).is_ok());
    }

    #[test]
    fn a_knn_without_samples_or_with_unknown_labels_is_refused() {
        let mut v = knn_json();
        v["classifier"]["samples"] = json!([]);
        assert!(refusal(&v).contains("the k-NN has no samples"));
        let mut v = knn_json();
        v["classifier"]["samples"][2][0] = json!(3);
        assert!(refusal(&v).contains("label index 3, but there are 3 labels"));
        let mut v = knn_json();
        v["classifier"]["k"] = json!(0);
        assert!(refusal(&v).contains("classifier.k is 0"));
        let mut v: Value =
            serde_json::from_str(&model(Method::Softmax { l2: 1e-3 }).to_json()).unwrap();
        v["classifier"]["b"].as_array_mut().unwrap().pop();
        assert!(refusal(&v).contains("3 weight rows and 2 biases for 3 labels"));
    }
}
