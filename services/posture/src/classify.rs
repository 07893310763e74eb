//! Classifiers for a few labelled hands per posture, on standardized features: k
//! nearest neighbours, and a linear softmax (multinomial logistic regression) trained
//! by gradient descent with an L2 penalty. Their settings are chosen by
//! cross-validation over groups of the training samples (a group is, say, one body),
//! never on the data a classifier is tested on.

use crate::features::{Features, FEATURE_LEN};
use std::fmt;

/// Labelled feature vectors, each in a group (a body, a person, a session) that
/// cross-validation keeps together.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingSet {
    labels: Vec<String>,
    samples: Vec<Sample>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    x: [f32; FEATURE_LEN],
    label: usize,
    group: u32,
}

/// Why a classifier could not be trained or a sample not added.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TrainError {
    /// The label's index is not one of the set's labels.
    UnknownLabel(usize),
    /// No samples, or fewer than two labels among them.
    TooFewSamples,
}

impl fmt::Display for TrainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrainError::UnknownLabel(i) => write!(f, "label {i} is not one of the set's"),
            TrainError::TooFewSamples => write!(f, "too few samples: two labels at least"),
        }
    }
}

impl std::error::Error for TrainError {}

impl TrainingSet {
    /// An empty set over these labels (index = position).
    pub fn new(labels: Vec<String>) -> Self {
        Self {
            labels,
            samples: Vec::new(),
        }
    }

    /// Adds a sample of label index `label` in `group`.
    pub fn add(&mut self, features: &Features, label: usize, group: u32) -> Result<(), TrainError> {
        if label >= self.labels.len() {
            return Err(TrainError::UnknownLabel(label));
        }
        self.samples.push(Sample {
            x: *features.values(),
            label,
            group,
        });
        Ok(())
    }

    /// The labels.
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// How many samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    fn subset(&self, keep: impl Fn(&Sample) -> bool) -> TrainingSet {
        TrainingSet {
            labels: self.labels.clone(),
            samples: self.samples.iter().copied().filter(|s| keep(s)).collect(),
        }
    }
}

/// A classifier and its setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// The `k` nearest training samples vote, each by the inverse of its distance.
    Knn {
        /// How many neighbours vote.
        k: usize,
    },
    /// A linear softmax with this L2 penalty on its weights.
    Softmax {
        /// The penalty.
        l2: f32,
    },
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::Knn { k } => write!(f, "k-NN (k={k})"),
            Method::Softmax { l2 } => write!(f, "softmax (L2 {l2})"),
        }
    }
}

/// A posture and how sure the classifier is of it, in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The label's index.
    pub label: usize,
    /// The winning share of the vote (k-NN) or the probability (softmax).
    pub confidence: f32,
}

/// A trained classifier.
#[derive(Debug, Clone, PartialEq)]
pub struct Classifier {
    labels: Vec<String>,
    method: Method,
    mean: [f32; FEATURE_LEN],
    scale: [f32; FEATURE_LEN],
    model: Model,
}

/// What a trained classifier keeps, on standardized features: the k-NN's samples with
/// their label indices, or the softmax's weights and biases (one row per label). Open
/// to the crate so that a model file can store and restore it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Model {
    Knn(Vec<([f32; FEATURE_LEN], usize)>),
    Softmax {
        w: Vec<[f32; FEATURE_LEN]>,
        b: Vec<f32>,
    },
}

/// A classifier taken apart: what a model file stores.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Parts {
    pub labels: Vec<String>,
    pub method: Method,
    pub mean: [f32; FEATURE_LEN],
    pub scale: [f32; FEATURE_LEN],
    pub model: Model,
}

impl Classifier {
    /// Trains `method` on every sample of `set`.
    pub fn train(set: &TrainingSet, method: Method) -> Result<Self, TrainError> {
        let classes = set.labels.len();
        let mut present = vec![false; classes];
        for s in &set.samples {
            present[s.label] = true;
        }
        if present.iter().filter(|&&p| p).count() < 2 {
            return Err(TrainError::TooFewSamples);
        }
        let n = set.samples.len() as f32;
        let mut mean = [0.0f32; FEATURE_LEN];
        for s in &set.samples {
            for (m, x) in mean.iter_mut().zip(&s.x) {
                *m += x / n;
            }
        }
        let mut scale = [0.0f32; FEATURE_LEN];
        for s in &set.samples {
            for ((v, x), m) in scale.iter_mut().zip(&s.x).zip(&mean) {
                *v += (x - m).powi(2) / n;
            }
        }
        // A feature that never varies in training carries nothing: weight it zero
        // rather than divide by zero.
        let scale = scale.map(|v| if v > 1e-12 { 1.0 / v.sqrt() } else { 0.0 });
        let standard = |x: &[f32; FEATURE_LEN]| standardize(x, &mean, &scale);
        let data: Vec<([f32; FEATURE_LEN], usize)> = set
            .samples
            .iter()
            .map(|s| (standard(&s.x), s.label))
            .collect();
        let model = match method {
            Method::Knn { .. } => Model::Knn(data),
            Method::Softmax { l2 } => train_softmax(&data, classes, l2),
        };
        Ok(Self {
            labels: set.labels.clone(),
            method,
            mean,
            scale,
            model,
        })
    }

    /// The labels, by index.
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// How it classifies.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Its pieces, to be stored.
    pub(crate) fn to_parts(&self) -> Parts {
        Parts {
            labels: self.labels.clone(),
            method: self.method,
            mean: self.mean,
            scale: self.scale,
            model: self.model.clone(),
        }
    }

    /// Puts a classifier together from stored pieces. The caller has checked that they
    /// fit: the method is the model's kind, every label index names a label, and the
    /// softmax has one row per label.
    pub(crate) fn from_parts(p: Parts) -> Self {
        Self {
            labels: p.labels,
            method: p.method,
            mean: p.mean,
            scale: p.scale,
            model: p.model,
        }
    }

    /// The posture of one hand.
    pub fn predict(&self, features: &Features) -> Prediction {
        let x = standardize(features.values(), &self.mean, &self.scale);
        let classes = self.labels.len();
        match (&self.model, self.method) {
            (Model::Knn(train), Method::Knn { k }) => {
                let mut d: Vec<(f32, usize)> =
                    train.iter().map(|(t, l)| (sq_dist(t, &x), *l)).collect();
                let k = k.clamp(1, d.len());
                d.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
                let mut votes = vec![0.0f32; classes];
                for &(dd, l) in &d[..k] {
                    votes[l] += 1.0 / (dd.sqrt() + 1e-3);
                }
                best_of(&votes)
            }
            (Model::Softmax { w, b }, _) => {
                let p = softmax_probs(w, b, &x);
                best_of(&p)
            }
            // Built together in `train`: a k-NN model always has a k-NN method.
            (Model::Knn(_), _) => Prediction {
                label: 0,
                confidence: 0.0,
            },
        }
    }
}

fn standardize(
    x: &[f32; FEATURE_LEN],
    mean: &[f32; FEATURE_LEN],
    scale: &[f32; FEATURE_LEN],
) -> [f32; FEATURE_LEN] {
    let mut out = [0.0; FEATURE_LEN];
    for i in 0..FEATURE_LEN {
        out[i] = (x[i] - mean[i]) * scale[i];
    }
    out
}

fn sq_dist(a: &[f32; FEATURE_LEN], b: &[f32; FEATURE_LEN]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The largest score's index and its share of the total.
fn best_of(scores: &[f32]) -> Prediction {
    let total: f32 = scores.iter().sum();
    let (label, best) =
        scores.iter().enumerate().fold(
            (0, f32::NEG_INFINITY),
            |b, (i, &s)| if s > b.1 { (i, s) } else { b },
        );
    Prediction {
        label,
        confidence: if total > 0.0 { best / total } else { 0.0 },
    }
}

fn softmax_probs(w: &[[f32; FEATURE_LEN]], b: &[f32], x: &[f32; FEATURE_LEN]) -> Vec<f32> {
    let z: Vec<f32> = w
        .iter()
        .zip(b)
        .map(|(wc, bc)| bc + wc.iter().zip(x).map(|(a, c)| a * c).sum::<f32>())
        .collect();
    let m = z.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f32> = z.iter().map(|v| (v - m).exp()).collect();
    let s: f32 = e.iter().sum();
    e.iter().map(|v| v / s).collect()
}

/// Full-batch gradient descent on the mean cross-entropy plus `l2` × |W|²/2: the
/// features are standardized, so one fixed step size suits every training set.
fn train_softmax(data: &[([f32; FEATURE_LEN], usize)], classes: usize, l2: f32) -> Model {
    const EPOCHS: usize = 300;
    const STEP: f32 = 0.5;
    let mut w = vec![[0.0f32; FEATURE_LEN]; classes];
    let mut b = vec![0.0f32; classes];
    let n = data.len().max(1) as f32;
    for _ in 0..EPOCHS {
        let mut gw = vec![[0.0f32; FEATURE_LEN]; classes];
        let mut gb = vec![0.0f32; classes];
        for (x, y) in data {
            let p = softmax_probs(&w, &b, x);
            for c in 0..classes {
                let e = p[c] - if c == *y { 1.0 } else { 0.0 };
                gb[c] += e / n;
                for (g, xi) in gw[c].iter_mut().zip(x) {
                    *g += e * xi / n;
                }
            }
        }
        for c in 0..classes {
            b[c] -= STEP * gb[c];
            for (wi, g) in w[c].iter_mut().zip(&gw[c]) {
                *wi -= STEP * (g + l2 * *wi);
            }
        }
    }
    Model::Softmax { w, b }
}

/// Which samples one fold of cross-validation holds out.
enum Fold {
    /// Every sample of a group.
    Group(u32),
    /// Every fifth sample by index, from this one.
    Index(usize),
}

impl Fold {
    fn holds(&self, i: usize, s: &Sample) -> bool {
        match *self {
            Fold::Group(g) => s.group == g,
            Fold::Index(f) => i % 5 == f,
        }
    }
}

/// The accuracy of `method` when each group in turn is left out of training and
/// classified (leave-one-group-out); with a single group, five folds by index.
pub fn cross_validate(set: &TrainingSet, method: Method) -> Option<f32> {
    let mut groups: Vec<u32> = set.samples.iter().map(|s| s.group).collect();
    groups.sort_unstable();
    groups.dedup();
    let folds: Vec<Fold> = if groups.len() >= 2 {
        groups.iter().map(|&g| Fold::Group(g)).collect()
    } else {
        (0..5).map(Fold::Index).collect()
    };
    let (mut right, mut total) = (0usize, 0usize);
    for held in &folds {
        let idx: Vec<usize> = (0..set.samples.len()).collect();
        let train = TrainingSet {
            labels: set.labels.clone(),
            samples: idx
                .iter()
                .filter(|&&i| !held.holds(i, &set.samples[i]))
                .map(|&i| set.samples[i])
                .collect(),
        };
        let Ok(c) = Classifier::train(&train, method) else {
            continue;
        };
        for (i, s) in set.samples.iter().enumerate() {
            if held.holds(i, s) {
                total += 1;
                let f = Features::from_values(s.x);
                right += (c.predict(&f).label == s.label) as usize;
            }
        }
    }
    (total > 0).then(|| right as f32 / total as f32)
}

/// Of `candidates`, the one with the best cross-validated accuracy on `set`, and that
/// accuracy (the first on ties).
pub fn choose(set: &TrainingSet, candidates: &[Method]) -> Option<(Method, f32)> {
    let mut best: Option<(Method, f32)> = None;
    for &m in candidates {
        if let Some(a) = cross_validate(set, m) {
            if best.is_none_or(|b| a > b.1) {
                best = Some((m, a));
            }
        }
    }
    best
}

impl TrainingSet {
    /// The samples of these groups only.
    pub fn groups(&self, keep: &[u32]) -> TrainingSet {
        self.subset(|s| keep.contains(&s.group))
    }
}
