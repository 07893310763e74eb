//! `eval-gestures --per-writer K`: the user-dependent protocol of the $1 recognizer on
//! writers of pen data. Every method is trained per writer and draw on that writer's K
//! samples a label and tested on the writer's other samples; one result a K and method.

use super::{
    fit, model_config, plot_confusions, recall_json, with_few_shot, Args, Method, Predictor,
};
use crate::interrupt::unless_interrupted;
use airglyph_gesture::lab::{
    few_shot_plan, labels_of, load_many, writer_splits, Confusion, WriterGroup, WriterSplit,
};
use airglyph_gesture::Model;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::json;
use std::collections::BTreeMap;
use std::time::Instant;

/// What one method scored at one K.
struct Scored {
    k: usize,
    method: String,
    /// The name its confusion matrix is plotted under.
    file: String,
    conf: Confusion,
    /// Correct and tested, per writer (over its draws).
    by_writer: BTreeMap<String, (u64, u64)>,
    decisions: u64,
    seconds: f64,
    plan: Option<String>,
}

/// One writer's draw, trained and tested.
struct Tested {
    subject: String,
    /// (truth, prediction) as indices into the data's labels.
    pairs: Vec<(usize, usize)>,
    decisions: u64,
    seconds: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Nothing is printed until every result is in: a signal leaves it where it is.
    let results = unless_interrupted("nothing was printed", {
        let args = args.clone();
        move || evaluate(&args)
    })??;
    for r in &results {
        print(&args, r);
    }
    // The pictures after every figure: one that fails loses none of them.
    if let Some(dir) = &args.plots {
        plot_confusions(dir, results.iter().map(|r| (r.file.as_str(), &r.conf)))?;
    }
    Ok(())
}

fn evaluate(args: &Args) -> anyhow::Result<Vec<Scored>> {
    let model = Model::load(&args.model)?;
    let mut cfg = model_config(&model, args)?;
    with_few_shot(&mut cfg, args.few_shot.as_deref())?;
    let samples = load_many(&args.data)?;
    let labels = labels_of(&samples);
    let group = WriterGroup::parse(&args.writers).context("--writers: all, tune or report")?;
    let mut methods = vec![Method::Model(Box::new(cfg.clone()))];
    if args.baselines {
        // The template baseline only: the seed's HMMs and the CRF need many samples.
        methods.push(Method::Dtw);
    }
    let mut results = Vec::new();
    for &k in &args.per_writer {
        let splits = writer_splits(&samples, k, args.min_labels, group, args.draws, args.seed);
        let writers = splits
            .iter()
            .map(|s| s.subject.as_str())
            .collect::<std::collections::BTreeSet<_>>()
            .len();
        eprintln!(
            "{k} samples a label: {writers} writers ({} writers) with at least {} labels written {} times or more, {} draw(s) each",
            args.writers,
            args.min_labels,
            k + 1,
            args.draws
        );
        let plan = splits
            .first()
            .map(|s| few_shot_plan(&s.train, &cfg).to_string());
        for m in &methods {
            let bar = ProgressBar::new(splits.len() as u64);
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message(format!("{} K={k}", m.file_name()));
            let tested: Vec<Tested> = splits
                .par_iter()
                .map(|s| {
                    let t = fit(m, &s.train, &labels).map(|p| test(&p, s, &labels));
                    bar.inc(1);
                    t
                })
                .collect::<anyhow::Result<_>>()?;
            bar.finish_and_clear();
            let mut r = Scored {
                k,
                method: m.name(),
                file: format!("{}-per-writer-{k}", m.file_name()),
                conf: Confusion::new(labels.clone()),
                by_writer: BTreeMap::new(),
                decisions: 0,
                seconds: 0.0,
                plan: matches!(m, Method::Model(_))
                    .then(|| plan.clone())
                    .flatten(),
            };
            for t in tested {
                let w = r.by_writer.entry(t.subject).or_default();
                for (truth, pred) in t.pairs {
                    r.conf.add(truth, pred);
                    w.0 += u64::from(truth == pred);
                    w.1 += 1;
                }
                r.decisions += t.decisions;
                r.seconds += t.seconds;
            }
            results.push(r);
        }
    }
    Ok(results)
}

/// Decisions timed per draw: the first test samples, one after another on this thread.
const TIMED: usize = 20;

fn test(p: &Predictor, s: &WriterSplit, labels: &[String]) -> Tested {
    let index = |l: &str| labels.iter().position(|x| x == l).unwrap_or(0);
    let pairs = s
        .test
        .iter()
        .map(|x| (index(&x.label), p.predict(x)))
        .collect();
    let timed = s.test.len().min(TIMED);
    let t0 = Instant::now();
    for x in &s.test[..timed] {
        std::hint::black_box(p.predict(x));
    }
    Tested {
        subject: s.subject.clone(),
        pairs,
        decisions: timed as u64,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

fn print(args: &Args, r: &Scored) {
    let ms = 1e3 * r.seconds / r.decisions.max(1) as f64;
    let acc = |(c, n): (u64, u64)| c as f64 / n.max(1) as f64;
    let mean = r.by_writer.values().map(|&w| acc(w)).sum::<f64>() / r.by_writer.len().max(1) as f64;
    let worst = r
        .by_writer
        .iter()
        .min_by(|a, b| acc(*a.1).total_cmp(&acc(*b.1)));
    if args.json {
        println!(
            "{}",
            json!({
                "protocol": "per-writer",
                "train_per_label": r.k,
                "writers": args.writers,
                "subjects": r.by_writer.len(),
                "draws": args.draws,
                "classifier": r.method,
                "samples": r.conf.total(),
                "accuracy": r.conf.accuracy(),
                "mean_writer_accuracy": mean,
                "worst_writer": worst.map(|(w, &c)| json!({"subject": w, "accuracy": acc(c)})),
                "ms_per_decision": ms,
                "per_class_recall": recall_json(&r.conf),
                "plan": r.plan,
            })
        );
    } else {
        println!(
            "{} per writer, {} samples a label: accuracy {:.2} % on {} samples of {} writers (writers' mean {:.2} %{}), {ms:.3} ms per decision",
            r.method,
            r.k,
            100.0 * r.conf.accuracy(),
            r.conf.total(),
            r.by_writer.len(),
            100.0 * mean,
            worst.map_or(String::new(), |(w, &c)| format!(", lowest {w} {:.2} %", 100.0 * acc(c)))
        );
        if let Some(p) = &r.plan {
            println!("  {p}");
        }
        let top: Vec<String> = r
            .conf
            .top_confusions(8)
            .into_iter()
            .map(|(t, p, c)| format!("{t}->{p} {c}"))
            .collect();
        println!("  top confusions: {}", top.join(", "));
    }
}
