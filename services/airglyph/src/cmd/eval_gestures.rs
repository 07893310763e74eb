//! `airglyph eval-gestures`: accuracy, per-class recall, confusion matrices and decision
//! time of a gesture model; with `--folds K`, writer-independent cross-validation
//! (retraining the model's classifier with its recorded parameters on the other folds);
//! with `--baselines`, the template baseline (DTW 1-NN), the seed's pipeline and the CRF
//! trained on the same data in the same run; with `--train-data`, every method trained on
//! those files and tested on `--data` (a public set's own split by person); with
//! `--per-writer K`, the user-dependent
//! protocol of the $1 recognizer (each writer's own K samples a label, tested on that
//! writer's other samples; `per_writer`).

mod per_writer;

use crate::interrupt::unless_interrupted;
use airglyph_gesture::lab::{
    folds_by_subject, labels_of, load_many, train, ClassifierKind, Confusion, Dtw3dClassifier,
    DtwClassifier, Sample, TrainConfig,
};
use airglyph_gesture::Model;
use airglyph_ipc::options;
use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Clone)]
pub struct Args {
    /// The model (its classifier and training parameters).
    #[arg(long)]
    pub model: PathBuf,
    /// Trajectory JSONL test data (with --folds: the data to cross-validate on).
    #[arg(long, num_args = 1.., required = true)]
    pub data: Vec<PathBuf>,
    /// One JSON object a line.
    #[arg(long)]
    pub json: bool,
    /// Write confusion-matrix PNGs here.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Also evaluate the template baseline (DTW 1-NN), the seed's pipeline and the CRF.
    #[arg(long)]
    pub baselines: bool,
    /// Cross-validation by subject with K folds, retraining on the other folds.
    #[arg(long, value_parser = options::within(2usize, 1000), allow_negative_numbers = true)]
    pub folds: Option<usize>,
    /// Train the model's classifier (with its recorded parameters) and the baselines on
    /// these trajectory JSONL files, and test them on --data: a split fixed by the data
    /// set, such as some people to train on and the others to test.
    #[arg(long, num_args = 1.., conflicts_with_all = ["folds", "per_writer"])]
    pub train_data: Vec<PathBuf>,
    /// Bezier points of the seed's pipeline among the baselines.
    #[arg(long, value_delimiter = ',', default_value = "15", value_parser = options::within(2, airglyph_gesture::limits::MAX_BEZIER_POINTS), allow_negative_numbers = true)]
    pub seed_points: Vec<usize>,
    /// Evaluate DTW on every S-th test sample only (it is slow).
    #[arg(long, default_value_t = 1, value_parser = options::within(1usize, 1_000_000), allow_negative_numbers = true)]
    pub dtw_stride: usize,
    /// Skip the CRF among the baselines.
    #[arg(long)]
    pub no_crf: bool,
    /// Fold assignment seed (with --per-writer: the draws' seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The user-dependent protocol instead of cross-validation: for every writer, K of
    /// its own samples of each label to train on, the rest of its samples to test (one
    /// run for each K given).
    #[arg(long, value_delimiter = ',', value_parser = options::within(1usize, 1000), allow_negative_numbers = true, conflicts_with = "folds")]
    pub per_writer: Vec<usize>,
    /// --per-writer: a writer takes part when it wrote at least K + 1 samples of this
    /// many labels (its vocabulary).
    #[arg(long, default_value_t = 10, value_parser = options::within(2usize, 10_000), allow_negative_numbers = true)]
    pub min_labels: usize,
    /// --per-writer: which writers, by a fixed hash of their names: all, tune (one in
    /// three, to choose settings on) or report (the others).
    #[arg(long, default_value = "all", value_parser = ["all", "tune", "report"])]
    pub writers: String,
    /// --per-writer: random draws of the training samples per writer.
    #[arg(long, default_value_t = 1, value_parser = options::within(1usize, 1000), allow_negative_numbers = true)]
    pub draws: usize,
    /// Settings for vocabularies with few samples a label, as a JSON object whose fields
    /// replace the model's (e.g. '{"weight":0.7}'; see `FewShotConfig`).
    #[arg(long, value_name = "JSON")]
    pub few_shot: Option<String>,
}

/// The few-shot settings of `cfg` with the fields of the JSON object `over` replaced
/// (an unknown field is an error).
fn with_few_shot(cfg: &mut TrainConfig, over: Option<&str>) -> anyhow::Result<()> {
    if let Some(over) = over {
        cfg.few_shot = cfg
            .few_shot
            .overridden(over)
            .map_err(|e| anyhow::anyhow!("--few-shot: {e}"))?;
    }
    Ok(())
}

#[derive(Clone)]
pub(crate) enum Method {
    Model(Box<TrainConfig>),
    Dtw,
    Seed(usize),
    Crf(usize),
}

impl Method {
    fn name(&self) -> String {
        match self {
            Method::Model(c) => c.classifier.name().to_string(),
            Method::Dtw => "dtw".into(),
            Method::Seed(_) => "seed-hmm".into(),
            Method::Crf(_) => "crf".into(),
        }
    }

    fn file_name(&self) -> String {
        match self {
            Method::Seed(n) => format!("seed-hmm-n{n}"),
            Method::Crf(n) => format!("crf-n{n}"),
            m => m.name(),
        }
    }

    fn bezier_points(&self, model_n: usize) -> usize {
        match self {
            Method::Seed(n) | Method::Crf(n) => *n,
            _ => model_n,
        }
    }
}

/// A trained predictor of class indices into `labels`.
pub(crate) enum Predictor {
    Model(Box<Model>, Vec<usize>),
    Dtw(DtwClassifier),
    Dtw3d(Dtw3dClassifier),
}

impl Predictor {
    pub(crate) fn predict(&self, s: &Sample) -> usize {
        match self {
            Predictor::Model(m, map) => map[m.classify(&s.trajectory()).class],
            Predictor::Dtw(d) => d.classify(&s.trajectory()).unwrap_or(0),
            Predictor::Dtw3d(d) => d.classify(&s.trajectory()).unwrap_or(0),
        }
    }
}

fn fit(method: &Method, train_set: &[Sample], labels: &[String]) -> anyhow::Result<Predictor> {
    let base = |kind, n| TrainConfig {
        classifier: kind,
        bezier_points: n,
        spotting: false,
        ..TrainConfig::default()
    };
    let cfg = match method {
        // Data with depth: the same baseline on points in space.
        Method::Dtw if train_set.iter().any(Sample::has_depth) => {
            let mut d = Dtw3dClassifier::new(32, 4);
            for s in train_set {
                let c = labels.iter().position(|l| *l == s.label).unwrap_or(0);
                d.add(&s.trajectory(), c);
            }
            return Ok(Predictor::Dtw3d(d));
        }
        Method::Dtw => {
            let mut d = DtwClassifier::new(32, 4);
            for s in train_set {
                let c = labels.iter().position(|l| *l == s.label).unwrap_or(0);
                d.add(&s.trajectory(), c);
            }
            return Ok(Predictor::Dtw(d));
        }
        Method::Model(c) => TrainConfig {
            spotting: false,
            ..(**c).clone()
        },
        Method::Seed(n) => base(ClassifierKind::Hmm, *n),
        Method::Crf(n) => base(ClassifierKind::Crf, *n),
    };
    let model = train(train_set, &cfg, &|_, _| {})?;
    if let Some(choice) = &model.training.template_share {
        eprintln!("{choice}");
    }
    let map = model
        .labels
        .iter()
        .map(|l| labels.iter().position(|x| x == l).unwrap_or(0))
        .collect();
    Ok(Predictor::Model(Box::new(model), map))
}

struct Outcome {
    conf: Confusion,
    decisions: u64,
    seconds: f64,
}

fn test(p: &Predictor, test_set: &[Sample], labels: &[String], stride: usize, out: &mut Outcome) {
    let picked: Vec<&Sample> = test_set.iter().step_by(stride.max(1)).collect();
    let preds: Vec<usize> = picked.par_iter().map(|s| p.predict(s)).collect();
    for (s, pr) in picked.iter().zip(preds) {
        let t = labels.iter().position(|l| *l == s.label).unwrap_or(0);
        out.conf.add(t, pr);
    }
    // Decision time measured on one thread.
    let timed = picked.len().min(300);
    let t0 = Instant::now();
    for s in &picked[..timed] {
        std::hint::black_box(p.predict(s));
    }
    out.seconds += t0.elapsed().as_secs_f64();
    out.decisions += timed as u64;
}

/// The (training, test) pairs of `k`-fold cross-validation by subject; a fold with no
/// sample, or holding every sample, is left out.
fn by_fold(samples: &[Sample], k: usize, seed: u64) -> Vec<(Vec<Sample>, Vec<Sample>)> {
    let fold = folds_by_subject(samples, k, seed);
    (0..k)
        .map(|f| {
            let (mut train, mut test) = (Vec::new(), Vec::new());
            for (s, &g) in samples.iter().zip(&fold) {
                let side = if g == f { &mut test } else { &mut train };
                side.push(s.clone());
            }
            (train, test)
        })
        .filter(|(train, test)| !train.is_empty() && !test.is_empty())
        .collect()
}

/// One method's results: its name, its file name, its Bezier points, its outcome.
type Scored = (String, String, usize, Outcome);

pub fn run(args: Args) -> anyhow::Result<()> {
    if !args.per_writer.is_empty() {
        return per_writer::run(args);
    }
    // The evaluation writes nothing until it is done: a signal leaves it where it is.
    let results = unless_interrupted("nothing was printed or drawn", {
        let args = args.clone();
        move || evaluate(&args)
    })??;
    print_and_plot(&args, &results)
}

/// The model's recorded training parameters, to retrain with.
fn model_config(model: &Model, args: &Args) -> anyhow::Result<TrainConfig> {
    serde_json::from_value(model.training.parameters.clone()).with_context(|| {
        format!(
            "{}: the model's training parameters cannot be read back for retraining",
            args.model.display()
        )
    })
}

/// Trains and tests what the arguments ask for.
fn evaluate(args: &Args) -> anyhow::Result<Vec<Scored>> {
    let model = Model::load(&args.model)?;
    let samples = load_many(&args.data)?;
    let train_set = if args.train_data.is_empty() {
        Vec::new()
    } else {
        load_many(&args.train_data)?
    };
    let retrains = args.folds.is_some() || !train_set.is_empty();
    let labels = if train_set.is_empty() {
        labels_of(&samples)
    } else {
        let labels = labels_of(&train_set);
        if let Some(s) = samples.iter().find(|s| !labels.contains(&s.label)) {
            bail!(
                "{}: the test data hold label {:?}, which the training data ({}) do not",
                args.data[0].display(),
                s.label,
                args.train_data[0].display()
            );
        }
        labels
    };
    // Retraining learns the data's labels; otherwise the model must know them.
    let unknown = labels.iter().find(|l| model.label_index(l).is_none());
    if let (false, Some(l)) = (retrains, unknown) {
        bail!(
            "{}: the data hold label {l:?}, which the model {} does not know",
            args.data[0].display(),
            args.model.display()
        );
    }
    let model_n = model.training.bezier_points;
    let mut methods = Vec::new();
    if retrains {
        let mut cfg = model_config(&model, args)?;
        with_few_shot(&mut cfg, args.few_shot.as_deref())?;
        methods.push(Method::Model(Box::new(cfg)));
    }
    if args.baselines {
        if !retrains {
            bail!(
                "--baselines trains the baselines: add --folds K (cross-validation) or \
                 --train-data FILES (a fixed split)"
            );
        }
        methods.push(Method::Dtw);
        for &n in &args.seed_points {
            methods.push(Method::Seed(n));
        }
        if !args.no_crf {
            methods.push(Method::Crf(15));
        }
    }
    let mut results: Vec<Scored> = Vec::new();
    if retrains {
        let names = methods
            .iter()
            .map(Method::name)
            .collect::<Vec<_>>()
            .join(", ");
        // Every (training, test) pair, made once for all the methods.
        let splits = match args.folds {
            Some(k) => {
                let subjects: std::collections::BTreeSet<&str> =
                    samples.iter().map(|s| s.subject.as_str()).collect();
                if subjects.len() < k {
                    anyhow::bail!(
                        "--folds {k} holds out the samples of each subject in turn, and the data \
                         has {} subject(s){}: give each sample a \"subject\", use fewer folds, \
                         or name a split with --train-data",
                        subjects.len(),
                        if subjects.iter().all(|s| s.is_empty()) {
                            " (no sample names one)"
                        } else {
                            ""
                        }
                    );
                }
                eprintln!(
                    "cross-validating {names} over {k} folds by subject on {} samples",
                    samples.len()
                );
                by_fold(&samples, k, args.seed)
            }
            None => {
                eprintln!(
                    "training {names} on {} samples, testing on {}",
                    train_set.len(),
                    samples.len()
                );
                vec![(train_set, samples)]
            }
        };
        let bar = ProgressBar::new((splits.len() * methods.len()) as u64);
        bar.set_style(
            ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        for m in &methods {
            let mut out = Outcome {
                conf: Confusion::new(labels.clone()),
                decisions: 0,
                seconds: 0.0,
            };
            for (i, (tr, te)) in splits.iter().enumerate() {
                bar.set_message(format!(
                    "{} split {} of {}",
                    m.file_name(),
                    i + 1,
                    splits.len()
                ));
                let p = fit(m, tr, &labels)?;
                // DTW on every `dtw_stride`-th test sample only: it is slow.
                let stride = if matches!(m, Method::Dtw) {
                    args.dtw_stride
                } else {
                    1
                };
                test(&p, te, &labels, stride, &mut out);
                bar.inc(1);
            }
            results.push((m.name(), m.file_name(), m.bezier_points(model_n), out));
        }
        bar.finish_and_clear();
    } else {
        eprintln!(
            "classifying {} samples with {}",
            samples.len(),
            args.model.display()
        );
        // The model's own labels (a superset of the data's).
        let mut conf = Confusion::new(model.labels.clone());
        let preds: Vec<usize> = samples
            .par_iter()
            .map(|s| model.classify(&s.trajectory()).class)
            .collect();
        for (s, p) in samples.iter().zip(preds) {
            conf.add(model.label_index(&s.label).unwrap_or(0), p);
        }
        let timed = samples.len().min(500);
        let t0 = Instant::now();
        for s in &samples[..timed] {
            std::hint::black_box(model.classify(&s.trajectory()));
        }
        let name = model.classifier.name().to_string();
        results.push((
            name.clone(),
            name,
            model_n,
            Outcome {
                conf,
                decisions: timed as u64,
                seconds: t0.elapsed().as_secs_f64(),
            },
        ));
    }
    Ok(results)
}

/// Prints every result, then draws the confusion matrices.
fn print_and_plot(args: &Args, results: &[Scored]) -> anyhow::Result<()> {
    for (name, file, n, out) in results {
        let ms = 1e3 * out.seconds / out.decisions.max(1) as f64;
        let recall = recall_json(&out.conf);
        if args.json {
            println!(
                "{}",
                json!({
                    "classifier": name,
                    "bezier_points": n,
                    "samples": out.conf.total(),
                    "accuracy": out.conf.accuracy(),
                    "ms_per_decision": ms,
                    "per_class_recall": recall,
                })
            );
        } else {
            println!(
                "{file}: accuracy {:.2} % on {} samples, {ms:.3} ms per decision",
                100.0 * out.conf.accuracy(),
                out.conf.total()
            );
            let worst: Vec<String> = out
                .conf
                .recall()
                .into_iter()
                .map(|(l, r)| format!("{l}:{:.0}", 100.0 * r.unwrap_or(0.0)))
                .collect();
            println!("  recall %: {}", worst.join(" "));
            let top: Vec<String> = out
                .conf
                .top_confusions(8)
                .into_iter()
                .map(|(t, p, c)| format!("{t}->{p} {c}"))
                .collect();
            println!("  top confusions: {}", top.join(", "));
        }
    }
    // The pictures after every figure: one that fails loses none of them.
    if let Some(dir) = &args.plots {
        plot_confusions(
            dir,
            results
                .iter()
                .map(|(_, file, _, out)| (file.as_str(), &out.conf)),
        )?;
    }
    Ok(())
}

/// Each class's recall, by label (null for a class never tested).
fn recall_json(conf: &Confusion) -> serde_json::Map<String, serde_json::Value> {
    conf.recall()
        .into_iter()
        .map(|(l, r)| (l, r.map_or(serde_json::Value::Null, |v| json!(v))))
        .collect()
}

/// Writes `confusion-<name>.png` in `dir` for each named confusion matrix.
fn plot_confusions<'a>(
    dir: &std::path::Path,
    confusions: impl IntoIterator<Item = (&'a str, &'a Confusion)>,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create plot directory", dir.display()))?;
    for (name, conf) in confusions {
        let title = format!("{name}: {:.2} %", 100.0 * conf.accuracy());
        conf.plot(&dir.join(format!("confusion-{name}.png")), &title)?;
    }
    Ok(())
}
