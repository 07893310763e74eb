//! `airglyph eval-spotting`: continuous streams of the data's samples joined by random
//! non-gesture hand movement, fed as skeletons through the spotter; counts correct,
//! substituted, deleted and inserted gestures. Also runs pure random movement, where
//! every spotted gesture is an insertion.

use airglyph_gesture::data::{load_many, Sample};
use airglyph_gesture::stream::{build_stream, random_movement, score, SpottingScore, StreamConfig};
use airglyph_gesture::{Model, Spotter, SpotterConfig};
use anyhow::bail;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The gesture model (with spotting HMMs).
    #[arg(long)]
    pub model: PathBuf,
    /// Trajectory JSONL samples to draw in the streams.
    #[arg(long, num_args = 1.., required = true)]
    pub data: Vec<PathBuf>,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// One JSON object a line.
    #[arg(long)]
    pub json: bool,
    /// Gestures in all streams together (samples drawn at random).
    #[arg(long, default_value_t = 500)]
    pub gestures: usize,
    /// Gestures per stream.
    #[arg(long, default_value_t = 20)]
    pub per_stream: usize,
    /// Seconds of pure random movement to test for insertions.
    #[arg(long, default_value_t = 300.0)]
    pub random_seconds: f32,
    /// Probability that the hand pauses briefly before and after each gesture.
    #[arg(long, default_value_t = 0.3)]
    pub pause_prob: f64,
    /// Print every drawn and spotted gesture (to stderr).
    #[arg(long)]
    pub verbose: bool,
    /// Spotter settings as JSON (fields of SpotterConfig), e.g. '{"margin":3.0}'.
    #[arg(long)]
    pub spotter: Option<String>,
}

fn run_stream(
    model: &Model,
    scfg: &SpotterConfig,
    points_stream: &airglyph_gesture::stream::SyntheticStream,
    cfg: &StreamConfig,
) -> anyhow::Result<Vec<airglyph_gesture::SpottedGesture>> {
    let mut sp = Spotter::new(model.clone(), *scfg)?;
    let mut out = Vec::new();
    let dt = (1e9 / cfg.fps as f64) as u64;
    for i in 0..points_stream.points.len() {
        let sk = points_stream.skeleton(i, cfg.distance);
        if let Some(g) = sp.push(&sk, i as u64, i as u64 * dt) {
            out.push(g);
        }
    }
    Ok(out)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let model = Model::load(&args.model)?;
    if model.spotting.is_none() {
        bail!(
            "{}: the model has no spotting HMMs; retrain it with `airglyph train`",
            args.model.display()
        );
    }
    let samples = load_many(&args.data)?;
    let mut known: Vec<&Sample> = samples
        .iter()
        .filter(|s| model.label_index(&s.label).is_some())
        .collect();
    if known.is_empty() {
        bail!(
            "{}: no sample has a label the model knows",
            args.data[0].display()
        );
    }
    let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
    known.shuffle(&mut rng);
    known.truncate(args.gestures.max(1));
    if !(0.0..=1.0).contains(&args.pause_prob) {
        bail!("--pause-prob {} is not in [0, 1]", args.pause_prob);
    }
    let cfg = StreamConfig {
        pause_prob: args.pause_prob,
        ..StreamConfig::default()
    };
    let scfg = spotter_config(args.spotter.as_deref())?;
    let per = args.per_stream.max(1);
    let chunks: Vec<(u64, Vec<&Sample>)> = known
        .chunks(per)
        .enumerate()
        .map(|(i, c)| {
            (
                args.seed.wrapping_mul(7919).wrapping_add(i as u64),
                c.to_vec(),
            )
        })
        .collect();
    let scores: Vec<anyhow::Result<(SpottingScore, usize)>> = chunks
        .par_iter()
        .map(|(seed, c)| {
            let mut r = ChaCha8Rng::seed_from_u64(*seed);
            let s = build_stream(c, &cfg, &mut r);
            let spotted = run_stream(&model, &scfg, &s, &cfg)?;
            if args.verbose {
                let mut tr = airglyph_gesture::HandTracker::new(Default::default());
                let dt = (1e9 / cfg.fps as f64) as u64;
                let filtered: Vec<[f32; 2]> = (0..s.points.len())
                    .map(|i| {
                        let p = tr.update(&s.skeleton(i, cfg.distance), i as u64 * dt);
                        p.map_or([0.0, 0.0], |p| [p.x, p.y])
                    })
                    .collect();
                for t in &s.truth {
                    let seg = &filtered[t.start as usize..=t.end as usize];
                    let oracle = model.classify(&airglyph_gesture::stream::trajectory(seg));
                    let v = model.spotting.as_ref().and_then(|m| m.verifier.as_ref());
                    let pg = |a: i64, b: i64| {
                        let a = (t.start as i64 + a).max(0) as usize;
                        let b = ((t.end as i64 + b).max(0) as usize).min(filtered.len() - 1);
                        v.map_or(0.0, |v| v.log_p_gesture(&filtered[a..=b.max(a + 1)]).exp())
                    };
                    eprintln!(
                        "drawn   {:>4} {:>6}..{:<6} (classified alone: {}) pg {:.2} | s-10 {:.2} s+10 {:.2} e-10 {:.2} e+10 {:.2} s-20 {:.2} e+20 {:.2}",
                        t.label, t.start, t.end, model.labels[oracle.class],
                        pg(0, 0), pg(-10, 0), pg(10, 0), pg(0, -10), pg(0, 10), pg(-20, 0), pg(0, 20)
                    );
                }
                for g in &spotted {
                    eprintln!("spotted {:>4} {:>6}..{:<6} {:.2}", g.label, g.start_seq, g.end_seq, g.score);
                }
            }
            Ok((score(&s.truth, &spotted), s.points.len()))
        })
        .collect();
    let mut total = SpottingScore::default();
    let mut frames = 0;
    for s in scores {
        let (s, f) = s?;
        total.add(&s);
        frames += f;
    }
    // Pure random movement.
    let mut r = ChaCha8Rng::seed_from_u64(args.seed ^ 0xABCD);
    let rm = random_movement(args.random_seconds, &cfg, &mut r);
    let false_alarms = run_stream(&model, &scfg, &rm, &cfg)?.len();
    if args.json {
        println!(
            "{}",
            json!({
                "gestures": total.gestures,
                "correct": total.correct,
                "substitutions": total.substitutions,
                "deletions": total.deletions,
                "insertions": total.insertions,
                "reliability": total.reliability,
            })
        );
        println!(
            "{}",
            json!({"random_movement_seconds": args.random_seconds, "insertions": false_alarms})
        );
    } else {
        println!(
            "{} gestures in {:.0} s of stream: {} correct, {} substituted, {} deleted, {} inserted; reliability {:.2} %",
            total.gestures,
            frames as f32 / cfg.fps,
            total.correct,
            total.substitutions,
            total.deletions,
            total.insertions,
            100.0 * total.reliability
        );
        println!(
            "{:.0} s of random movement only: {false_alarms} gestures spotted (insertions)",
            args.random_seconds
        );
    }
    Ok(())
}

/// The default spotter settings with the given JSON fields replaced.
pub fn spotter_config(json: Option<&str>) -> anyhow::Result<SpotterConfig> {
    let mut v = serde_json::to_value(SpotterConfig::default())?;
    if let Some(j) = json {
        let o: serde_json::Value = serde_json::from_str(j)
            .map_err(|e| anyhow::anyhow!("--spotter {j:?}: not JSON: {e}"))?;
        let (Some(dst), Some(src)) = (v.as_object_mut(), o.as_object()) else {
            bail!("--spotter {j:?}: expected a JSON object");
        };
        for (k, x) in src {
            if !dst.contains_key(k) {
                bail!("--spotter: unknown setting {k:?}");
            }
            dst.insert(k.clone(), x.clone());
        }
    }
    Ok(serde_json::from_value(v)?)
}
