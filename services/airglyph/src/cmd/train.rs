//! `airglyph train`: trains a gesture model from trajectory JSONL files, or with
//! `--postures` a posture model from posture sample JSONL ([`postures`]).

mod postures;

use crate::interrupt::unless_interrupted;
use airglyph_gesture::lab::{
    few_shot_plan, load_many, look_alikes, recalibrate, retrain_spotting, train, ClassifierKind,
    Generator, TrainConfig, LOOK_ALIKE_THRESHOLD,
};
use airglyph_gesture::limits;
use airglyph_gesture::Model;
use airglyph_ipc::options;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

#[derive(clap::Args, Clone)]
pub struct Args {
    /// Trajectory JSONL files (.jsonl or .jsonl.gz).
    #[arg(long, num_args = 1.., required_unless_present = "postures")]
    pub data: Vec<PathBuf>,
    /// Train a posture model instead, from these posture sample JSONL files (`airglyph
    /// collect --posture`): k-NN and softmax in several settings are cross-validated
    /// with each subject's samples held out in turn (five folds by sample when there is
    /// one subject), the best is kept, and the pairs of postures it confuses are named.
    /// Only --out and --confusable apply.
    #[arg(long, num_args = 1.., value_name = "FILE", conflicts_with_all = ["data", "reuse_classifier", "recalibrate", "no_spotting"])]
    pub postures: Vec<PathBuf>,
    /// With --postures: warn about a posture whose held-out samples were read as one
    /// other at least this often (0–1).
    #[arg(long, default_value_t = 0.1, value_parser = options::within(0.0f64, 1.0), allow_negative_numbers = true, requires = "postures")]
    pub confusable: f64,
    /// Where to write the model JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// Classifier: mlp (default: network ensemble), hmm (the seed's pipeline) or crf.
    #[arg(long, default_value = "mlp")]
    pub classifier: String,
    /// Bezier points of the seed's descriptor (hmm, crf).
    #[arg(long, default_value_t = 15, value_parser = options::within(2, limits::MAX_BEZIER_POINTS), allow_negative_numbers = true)]
    pub bezier_points: usize,
    /// HMM states (hmm).
    #[arg(long, default_value_t = 14, value_parser = options::within(1, limits::MAX_STATES), allow_negative_numbers = true)]
    pub states: usize,
    /// Networks in the ensemble (mlp).
    #[arg(long, default_value_t = 3, value_parser = options::within(1, limits::MAX_NETS), allow_negative_numbers = true)]
    pub ensemble: usize,
    /// Training epochs (mlp).
    #[arg(long, default_value_t = 30, value_parser = options::within(1, limits::MAX_EPOCHS), allow_negative_numbers = true)]
    pub epochs: usize,
    /// Hidden units (mlp).
    #[arg(long, default_value_t = 192, value_parser = options::within(2, limits::MAX_HIDDEN), allow_negative_numbers = true)]
    pub hidden: usize,
    /// Networks in the spotting verifier, each trained on synthetic streams of its own
    /// (their probabilities are averaged; each takes about as long as the rest of the
    /// spotting part).
    #[arg(long, default_value_t = TrainConfig::default().verifiers, value_parser = options::within(1, limits::MAX_NETS), allow_negative_numbers = true)]
    pub verifiers: usize,
    /// Use the pen-up flag of the data (off: treat every sample as one air-drawn path).
    #[arg(long)]
    pub pen_up: bool,
    /// Drop the depth of 3-D samples (`"dims":3`, as `collect` records them) and train
    /// on what a 2-D camera would see: the classifiers of 2-D data, and a spotting part
    /// with its verifier (which a model of 3-D data does not have yet).
    #[arg(long)]
    pub flat: bool,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Fraction of the network's augmented training samples that are also drawn in a
    /// synthetic stream and seen through the hand tracker's filter, as the spotter sees
    /// them (mlp; 0 = never).
    #[arg(long, default_value_t = TrainConfig::default().stream_augment, value_parser = options::within(0.0f32, 1.0), allow_negative_numbers = true)]
    pub stream_augment: f32,
    /// Train the classifier only, without the spotting part (HMMs and verifier): quick,
    /// for comparing classifiers; such a model classifies but cannot spot.
    #[arg(long, conflicts_with = "reuse_classifier")]
    pub no_spotting: bool,
    /// Keep the classifier of this model (same labels) and retrain only the spotting
    /// part (HMMs, verifier and its label bars).
    #[arg(long, value_name = "MODEL")]
    pub reuse_classifier: Option<PathBuf>,
    /// Keep this model whole (classifier and spotting part) and only calibrate its
    /// per-label bars again: the higher whole-gesture probability the spotter asks of
    /// symbols that ordinary movement passes for often, found on synthetic streams of
    /// the data (2½ minutes for the 36 symbols' 29,528 samples on two cores; training
    /// does it too, so this is for models trained before).
    #[arg(long, value_name = "MODEL", conflicts_with_all = ["reuse_classifier", "no_spotting"])]
    pub recalibrate: Option<PathBuf>,
    /// Which synthetic streams the spotting part's verifier and label bars learn from:
    /// lab (the two-thirds power law, flowing in and out of symbols, reaches, fidgets
    /// and rests), everyday (one person a stream: constant speed or another power law,
    /// pauses at corners, slow and fast drawers, rest poses, everyday actions such as
    /// waving, pointing, scratching, touching the face), or mixed (a stream of each in
    /// turn; each label's bar calibrated on each generator's streams alone, the lower
    /// kept; the built-in model's spotting part is trained so). Mixed is the default:
    /// a spotter trained on one kind of mover loses more on the other kind's streams
    /// than one trained on both gives up on either (the gesture README has the
    /// figures). `airglyph eval-spotting --generator` measures on any of them.
    #[arg(long, default_value = "mixed", value_parser = ["lab", "everyday", "mixed"])]
    pub generator: String,
    /// After training, warn about labels the vocabulary cannot separate: a quick
    /// classifier (one network) trained on four writers in five reads the fifth's
    /// samples, and every label read as one other at least this often (and at least
    /// three times) is named (e.g.
    /// "0/O: 18 % of "0" read as "O""). 0 skips the check (as --recalibrate does).
    #[arg(long, default_value_t = LOOK_ALIKE_THRESHOLD, value_parser = options::within(0.0f64, 1.0), allow_negative_numbers = true)]
    pub look_alike: f64,
    /// Settings of the template member (vocabularies of a few samples a label, and of
    /// gestures in space drawn by three people or more), as a JSON object whose fields
    /// replace the defaults, e.g. '{"shares_by_person":[0,0,0]}' to train networks only
    /// without leaving people out (see `FewShotConfig`).
    #[arg(long, value_name = "JSON")]
    pub few_shot: Option<String>,
}

/// The training configuration the arguments describe (their ranges are checked as
/// they are parsed, and the whole by [`TrainConfig::validate`] before training).
pub fn config(args: &Args) -> anyhow::Result<TrainConfig> {
    let kind = ClassifierKind::parse(&args.classifier)
        .with_context(|| format!("unknown classifier {:?} (mlp, hmm or crf)", args.classifier))?;
    let mut cfg = TrainConfig {
        classifier: kind,
        bezier_points: args.bezier_points,
        ensemble: args.ensemble,
        seed: args.seed,
        data: args
            .data
            .iter()
            .map(|p| {
                p.file_name().map_or(p.display().to_string(), |f| {
                    f.to_string_lossy().into_owned()
                })
            })
            .collect(),
        ..TrainConfig::default()
    };
    cfg.hmm.states = args.states;
    cfg.mlp.epochs = args.epochs;
    cfg.mlp.hidden = args.hidden;
    cfg.features.pen_up = args.pen_up;
    cfg.stream_augment = args.stream_augment;
    cfg.verifiers = args.verifiers;
    cfg.spotting = !args.no_spotting;
    cfg.generator = Generator::parse(&args.generator)
        .with_context(|| format!("unknown generator {:?}", args.generator))?;
    if let Some(over) = &args.few_shot {
        cfg.few_shot = cfg
            .few_shot
            .overridden(over)
            .map_err(|e| anyhow::anyhow!("--few-shot: {e}"))?;
    }
    Ok(cfg)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !args.postures.is_empty() {
        // Quick (seconds for thousands of samples) and written whole at the end: an
        // interruption leaves the old file as it was.
        return postures::run(&args.postures, &args.out, args.confusable);
    }
    let cfg = config(&args)?;
    // Training writes nothing until it is done: a signal leaves it where it is.
    let kept = format!("no model was written ({} is as it was)", args.out.display());
    let model = unless_interrupted(&kept, {
        let (args, cfg) = (args.clone(), cfg.clone());
        move || model(&args, &cfg)
    })??;
    model
        .save(&args.out)
        .with_context(|| format!("{}: cannot write model", args.out.display()))?;
    eprintln!(
        "wrote {} ({} labels, {} bytes)",
        args.out.display(),
        model.labels.len(),
        std::fs::metadata(&args.out).map(|m| m.len()).unwrap_or(0)
    );
    if args.look_alike > 0.0 && args.recalibrate.is_none() {
        warn_look_alikes(&args, &cfg)?;
    }
    Ok(())
}

/// Warns about the labels the vocabulary cannot separate ([`look_alikes`]).
fn warn_look_alikes(args: &Args, cfg: &TrainConfig) -> anyhow::Result<()> {
    let mut samples = load_many(&args.data)?;
    if args.flat {
        samples = samples.iter().map(|s| s.flattened()).collect();
    }
    let pairs = unless_interrupted(
        "the model was written; the look-alike check was not done",
        {
            let cfg = cfg.clone();
            let threshold = args.look_alike;
            move || look_alikes(&samples, &cfg, threshold)
        },
    )?;
    match pairs {
        Ok(pairs) if pairs.is_empty() => eprintln!(
            "look-alikes: no label read as another {:.0} % of the time or more on writers left out of a quick check",
            100.0 * args.look_alike
        ),
        Ok(pairs) => {
            for p in pairs {
                eprintln!("warning: look-alike labels {p} on writers left out of a quick check: the vocabulary does not separate them");
            }
        }
        Err(e) => eprintln!("look-alikes: not checked ({e})"),
    }
    Ok(())
}

/// The model the arguments ask for, from their data.
fn model(args: &Args, cfg: &TrainConfig) -> anyhow::Result<Model> {
    let mut samples = load_many(&args.data)?;
    let deep = samples.iter().filter(|s| s.has_depth()).count();
    if args.flat {
        samples = samples.iter().map(|s| s.flattened()).collect();
    }
    eprintln!(
        "training {} on {} samples from {} file(s)",
        cfg.classifier.name(),
        samples.len(),
        args.data.len()
    );
    if deep > 0 && args.flat {
        eprintln!("{deep} samples drawn in 3-D, trained without their depth (--flat)");
    } else if deep > 0 {
        eprintln!(
            "{deep} samples drawn in 3-D: the classifier reads depth (codes on the sphere, 3-D features){}",
            if cfg.spotting {
                "; the spotting part has no verifier (its streams are drawn in the plane): the spotter takes stretches the classifier is sure of, drawn with the hand held out in front (--flat trains on the 2-D shadow with one)"
            } else {
                ""
            }
        );
    }
    // Which members the ensemble gets, and why: what a user training a vocabulary of
    // their own from a few samples needs to know.
    if cfg.classifier == ClassifierKind::Mlp
        && args.reuse_classifier.is_none()
        && args.recalibrate.is_none()
    {
        eprintln!("{}", few_shot_plan(&samples, cfg));
    }
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(cfg.classifier.name());
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let model = match (&args.reuse_classifier, &args.recalibrate) {
        (None, None) => train(&samples, cfg, &progress)?,
        (_, Some(path)) => {
            bar.set_message("calibrating the label bars");
            let r = recalibrate(Model::load(path)?, &samples, cfg.generator, &progress)
                .with_context(|| format!("{}: cannot recalibrate it", path.display()))?;
            eprintln!("label bars: {:?} → {:?}", r.before, r.after());
            r.model
        }
        (Some(path), None) => {
            bar.set_message("spotting");
            retrain_spotting(Model::load(path)?, &samples, cfg)
                .with_context(|| format!("{}: cannot reuse it", path.display()))?
        }
    };
    bar.finish_and_clear();
    if let Some(choice) = &model.training.template_share {
        eprintln!("{choice}");
    }
    Ok(model)
}
