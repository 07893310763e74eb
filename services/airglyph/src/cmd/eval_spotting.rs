//! `airglyph eval-spotting`: continuous streams of the data's samples joined by ordinary
//! hand movement, fed as skeletons through the spotter; counts correct, substituted,
//! deleted and inserted gestures. Also runs ordinary movement alone, where every
//! spotted gesture is an insertion.

use crate::interrupt::unless_interrupted;
use airglyph_gesture::lab::{
    load_many, matched, measured_error_rate, plot_timeline, posture_signal, Generator,
    PostureNoise, Sample, Span, SpottingScore, StreamConfig, SyntheticStream, POSTURES,
};
use airglyph_gesture::{
    Candidate, Model, Pen, Postures, SpottedGesture, Spotter, SpotterConfig, Trajectory,
};
use airglyph_ipc::options;
use anyhow::{bail, Context};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Spotting reliability on continuous streams of gestures and ordinary movement.
///
/// The data's samples are drawn one after another in continuous streams of ordinary
/// hand movement, fed as skeletons through the spotter.
///
/// How a stream is made (body frame, shoulder widths, 30 fps): a symbol is drawn at
/// 1.5 shoulder widths a second on average (×0.75–1.3 per symbol), its timing following
/// the two-thirds power law (slower in curves, nearly stopping at sharp corners and
/// where strokes join), 0.8–1.2 shoulder widths large, somewhere in front of the chest.
/// Between two symbols the hand makes 1–3 ordinary movements: curved reaches (to the
/// drawing area, the lowered rest position, the face, anywhere; bell-shaped speed,
/// mostly ending at rest), small slow fidgets, rests with a slow drift. It reaches each
/// symbol's first point and leaves its last one at a speed between 0 and --flow × the
/// drawing's mean speed, along the symbol's own direction when it does not stop; with
/// --pause-prob it also rests there 0.1–0.5 s. Tracking noise of ±0.004 shoulder widths
/// is added. A spotted gesture matches a drawn one when their frames overlap by half
/// of the shorter; reliability = correct / (gestures + insertions).
///
/// With --pen posture the pen is down while the drawing hand points, and each frame's
/// postures are simulated beside the same streams (the paths do not change): the hand
/// points while drawing (formed up to 0.3 s before the symbol's first frame or 0.1 s
/// after it, released 0.1 s before its last or up to 0.3 s after), and in ordinary
/// movement is open or a fist, changing every 0.5–3 s, but points at something in one
/// in ten of the lab generator's reaches and in every pointing action of the everyday
/// generator; the other hand rests open or as a fist. A posture classifier reads them
/// with the errors the posture crate's k-NN makes on bodies it was not trained on (its
/// measured confusion matrix, scaled to --posture-error misread frames) in runs of
/// --posture-runs frames on average; its confidence is not modelled. These are
/// assumptions, not measurements of people (airglyph-gesture NOTES.md, "The pen by
/// posture").
#[derive(clap::Args, Clone)]
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
    /// Gestures in all streams together: the samples in a random order, each again (in
    /// another order) when there are fewer samples than this.
    #[arg(long, default_value_t = 500, value_parser = options::within(1usize, 1_000_000), allow_negative_numbers = true)]
    pub gestures: usize,
    /// Gestures per stream.
    #[arg(long, default_value_t = 20, value_parser = options::within(1usize, 10_000), allow_negative_numbers = true)]
    pub per_stream: usize,
    /// Seconds of ordinary movement alone, to count insertions in (and which symbols
    /// it passes for).
    #[arg(long, default_value_t = 300.0, value_parser = options::within(0.0f32, 36_000.0), allow_negative_numbers = true)]
    pub random_seconds: f32,
    /// Probability that the hand rests (0.1–0.5 s) before and after each gesture.
    #[arg(long, default_value_t = 0.3, value_parser = options::within(0.0f64, 1.0), allow_negative_numbers = true)]
    pub pause_prob: f64,
    /// Largest speed at which the hand enters or leaves a gesture, as a fraction of the
    /// drawing's mean speed (each boundary draws one from 0 to this).
    #[arg(long, default_value_t = 0.5, value_parser = options::within(0.0f32, 1.0), allow_negative_numbers = true)]
    pub flow: f32,
    /// Mean hand speed while drawing, shoulder widths a second (each symbol ×0.75–1.3).
    #[arg(long, default_value_t = 1.5, value_parser = options::within(0.2f32, 10.0), allow_negative_numbers = true)]
    pub speed: f32,
    /// Print every drawn and spotted gesture (to stderr).
    #[arg(long)]
    pub verbose: bool,
    /// Write every stream's drawn symbols (with the classifier's label of each alone),
    /// scored candidates and spotted gestures to this file, one JSON object a line (for
    /// analysis tools such as scripts/spot-competitions).
    #[arg(long)]
    pub dump: Option<PathBuf>,
    /// Spotter settings as JSON (fields of SpotterConfig), e.g. '{"min_score":0.6}'.
    #[arg(long)]
    pub spotter: Option<String>,
    /// Draw a stretch of one stream (hand x, y, speed; drawn and spotted gestures) into
    /// this PNG: stream --plot-stream, from --plot-from for --plot-seconds seconds.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[arg(long, default_value_t = 0)]
    pub plot_stream: usize,
    #[arg(long, default_value_t = 0.0, value_parser = options::within(0.0f32, 86_400.0), allow_negative_numbers = true)]
    pub plot_from: f32,
    #[arg(long, default_value_t = 30.0, value_parser = options::within(0.1f32, 600.0), allow_negative_numbers = true)]
    pub plot_seconds: f32,
    /// Which model of how people move makes the streams: lab (as described above),
    /// everyday (written apart from it: one person a stream at 1.8–3.2 m, with a rest
    /// pose — arm hanging, hands clasped, hand on the hip — drawing at constant speed
    /// or speed ∝ radius^β with β 0.15–0.45, slow or fast, pausing at sharp corners or
    /// not, starting and ending each symbol from a stop; between symbols everyday
    /// actions: rests, reaches and holds, touching the face or chest, waving, pointing,
    /// scratching, gesticulating, a hand to the pocket; Gaussian tracking noise; the
    /// other hand rests too, and the tracker may take it), or mixed (a stream of each
    /// in turn). --pause-prob, --flow and --speed are the lab generator's.
    #[arg(long, default_value = "lab", value_parser = ["lab", "everyday", "mixed"])]
    pub generator: String,
    /// What puts the pen down: motion (the spotter finds gestures in the motion alone)
    /// or posture[:LABEL] (while the drawing hand holds LABEL, default point: one of
    /// open, fist, point, thumb-up, v, pinch, which the simulated person draws with;
    /// the postures simulated as above) or gated[:LABEL] (the pen by motion, a stretch
    /// published only when the hand held LABEL over at least min_share of the frames
    /// its posture was read in; the person draws with LABEL). Overrides a "pen" in
    /// --spotter but for its min_confidence, down_frames, up_frames, verify and
    /// min_share.
    #[arg(long, default_value = "motion", value_name = "motion|posture[:LABEL]|gated[:LABEL]", value_parser = parse_pen)]
    pub pen: Pen,
    /// With --pen posture or gated: the fraction of frames the posture classifier misreads, on
    /// average over the postures (0: the true posture; 0.053: the posture crate's k-NN
    /// on held-out bodies, all settings; 0.089: with the sensor model).
    #[arg(long, default_value_t = 0.053, value_parser = options::within(0.0f64, 0.9), allow_negative_numbers = true)]
    pub posture_error: f64,
    /// With --pen posture or gated: the mean length of a run of misread frames.
    #[arg(long, default_value_t = 4.0, value_parser = options::within(1.0f64, 300.0), allow_negative_numbers = true)]
    pub posture_runs: f64,
}

fn parse_pen(s: &str) -> Result<Pen, String> {
    Pen::parse(s).map_err(|e| e.to_string())
}

/// The spotter's pen: --pen, with the posture pen's other settings from --spotter when
/// it gives a posture pen too.
fn pen_of(args: &Args, from_json: Pen) -> Pen {
    match (args.pen, from_json) {
        (Pen::Posture(mut p), Pen::Posture(json)) => {
            p.min_confidence = json.min_confidence;
            p.down_frames = json.down_frames;
            p.up_frames = json.up_frames;
            p.verify = json.verify;
            Pen::Posture(p)
        }
        (Pen::Gated(mut p), Pen::Gated(json)) => {
            p.min_confidence = json.min_confidence;
            p.min_share = json.min_share;
            Pen::Gated(p)
        }
        (pen, _) => pen,
    }
}

/// The hands' postures a frame for stream `s` (none with the pen by motion, which
/// looks at none: its streams and figures are those of before).
fn postures_for(
    s: &SyntheticStream,
    drawing: Option<usize>,
    noise: &PostureNoise,
    seed: u64,
) -> Vec<Postures> {
    match drawing {
        None => Vec::new(),
        // Their own random numbers: the stream is the same with either pen.
        Some(d) => posture_signal(s, d, noise, &mut ChaCha8Rng::seed_from_u64(seed ^ 0x705E)),
    }
}

/// The simulated posture the person draws with: the pen's (None with the pen by
/// motion), which must be one the simulated hands take.
fn drawing_posture(pen: Pen) -> anyhow::Result<Option<usize>> {
    let (mode, label) = match pen {
        Pen::Motion => return Ok(None),
        Pen::Posture(p) => ("posture", p.label),
        Pen::Gated(p) => ("gated", p.label),
    };
    match POSTURES.iter().position(|&name| name == label.as_str()) {
        Some(i) => Ok(Some(i)),
        None => bail!(
            "--pen {mode}:{label}: the simulated hands take only {}",
            POSTURES.join(", ")
        ),
    }
}

/// How often the streams' symbols of one label were spotted with it.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
struct LabelCount {
    drawn: usize,
    correct: usize,
}

impl LabelCount {
    fn recall(&self) -> f64 {
        self.correct as f64 / self.drawn.max(1) as f64
    }
}

/// What the spotter finds in one stream.
fn run_stream(
    model: &Model,
    scfg: &SpotterConfig,
    points_stream: &SyntheticStream,
    cfg: &StreamConfig,
    postures: &[Postures],
) -> anyhow::Result<Vec<SpottedGesture>> {
    let mut sp = Spotter::new(model.clone(), *scfg)?;
    Ok(points_stream.spot_posed(&mut sp, cfg, postures))
}

/// For each drawn gesture: how the spotter weighs its true segment, and the scored
/// candidate closest to it (why it was or was not published).
fn explain(
    stream: usize,
    spotter: &Spotter,
    s: &SyntheticStream,
    cfg: &StreamConfig,
    spotted: &[SpottedGesture],
    cands: &[Candidate],
) {
    let model = spotter.model();
    let filtered = filtered(s, cfg);
    let mut lines = Vec::new();
    for t in &s.truth {
        let (start, end) = (t.start as usize, t.end as usize);
        let Some(alone) = spotter.explain(&filtered, start, end, cfg.fps as f64) else {
            continue;
        };
        let iou = |c: &Candidate| {
            let lo = c.start_seq.max(t.start);
            let hi = c.end_seq.min(t.end);
            let inter = hi.saturating_sub(lo) as f64;
            let uni = (c.end_seq.max(t.end) - c.start_seq.min(t.start)).max(1) as f64;
            inter / uni
        };
        let near = cands.iter().max_by(|a, b| iou(a).total_cmp(&iou(b)));
        let desc = near.map_or("no candidate".to_string(), |c| {
            format!(
                "closest candidate {}..{} (IoU {:.2} Δ {:+} {:+}) {} score {:.2} p_g {:.2} ratio {:.1} {}",
                c.start_seq,
                c.end_seq,
                iou(c),
                c.start_seq as i64 - t.start as i64,
                c.end_seq as i64 - t.end as i64,
                model.labels[c.class],
                c.score,
                c.p_gesture,
                c.ratio,
                if c.accepted { "accepted" } else { "rejected" }
            )
        });
        lines.push((
            t.start,
            format!(
                "drawn   {:>4} {:>6}..{:<6} alone: {} {:.2} p_g {:.2} | {desc} | stream {stream}",
                t.label, t.start, t.end, model.labels[alone.class], alone.score, alone.p_gesture
            ),
        ));
    }
    for g in spotted {
        lines.push((
            g.start_seq,
            format!(
                "spotted {:>4} {:>6}..{:<6} {:.2} | stream {stream}",
                g.label, g.start_seq, g.end_seq, g.score
            ),
        ));
    }
    lines.sort_by_key(|l| l.0);
    let text: Vec<String> = lines.into_iter().map(|l| l.1).collect();
    eprintln!("{}", text.join("\n"));
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // The evaluation writes nothing until it is done: a signal leaves it where it is.
    let e = unless_interrupted("nothing was written or printed", {
        let args = args.clone();
        move || evaluate(&args)
    })??;
    if let Some(path) = &args.dump {
        std::fs::write(path, e.dump.join("\n") + "\n")?;
    }
    let total = e.total;
    let false_alarms = e.alarms.len();
    // Which symbols ordinary movement passes for: the vocabulary's weak spots.
    let mut alarms_by_label = BTreeMap::<&str, usize>::new();
    for g in &e.alarms {
        *alarms_by_label.entry(g.label.as_str()).or_default() += 1;
    }
    if args.json {
        let mut streams = json!({
                "gestures": total.gestures,
                "correct": total.correct,
                "substitutions": total.substitutions,
                "deletions": total.deletions,
                "insertions": total.insertions,
                "reliability": total.reliability,
                "by_label": e.by_label,
        });
        if let Some(o) = streams.as_object_mut() {
            o.extend(pen_fields(&args, &e));
        }
        println!("{streams}");
        println!(
            "{}",
            json!({
                "random_movement_seconds": args.random_seconds,
                "insertions": false_alarms,
                "insertions_by_label": alarms_by_label,
            })
        );
    } else {
        println!(
            "{}{} gestures in {:.0} s of stream: {} correct, {} substituted, {} deleted, {} inserted; reliability {:.2} %",
            match e.scfg.pen {
                Pen::Motion => String::new(),
                Pen::Posture(p) => format!(
                    "pen by posture \"{}\" ({:.1} % of postures misread): ",
                    p.label,
                    100.0 * args.posture_error
                ),
                Pen::Gated(p) => format!(
                    "pen by motion gated by posture \"{}\" ({:.0} % of the read frames; {:.1} % of postures misread): ",
                    p.label,
                    100.0 * p.min_share,
                    100.0 * args.posture_error
                ),
            },
            total.gestures,
            e.frames as f32 / e.cfg.fps,
            total.correct,
            total.substitutions,
            total.deletions,
            total.insertions,
            100.0 * total.reliability
        );
        let mut hardest: Vec<(&String, &LabelCount)> = e.by_label.iter().collect();
        hardest.sort_by(|a, b| a.1.recall().total_cmp(&b.1.recall()));
        let hardest: Vec<String> = hardest
            .iter()
            .take(3)
            .map(|(l, n)| format!("\"{l}\" {} of {}", n.correct, n.drawn))
            .collect();
        println!("found least often: {}", hardest.join(", "));
        let labels: Vec<String> = alarms_by_label
            .iter()
            .map(|(l, n)| format!("{n} × \"{l}\""))
            .collect();
        println!(
            "{:.0} s of random movement only: {false_alarms} gestures spotted (insertions){}",
            args.random_seconds,
            if labels.is_empty() {
                String::new()
            } else {
                format!(": {}", labels.join(", "))
            }
        );
    }
    // The picture after every figure: if it fails, none of them is lost.
    if let (Some(path), Some((s, spotted))) = (&args.plot, &e.plotted) {
        plot(path, s, spotted, &e.cfg, args.plot_from, args.plot_seconds)?;
    }
    Ok(())
}

/// What the streams and the ordinary movement gave.
struct Evaluation {
    cfg: StreamConfig,
    scfg: SpotterConfig,
    total: SpottingScore,
    by_label: BTreeMap<String, LabelCount>,
    /// The streams' length, frames.
    frames: usize,
    /// The lines of --dump.
    dump: Vec<String>,
    /// The stream --plot draws and what was spotted in it.
    plotted: Option<(SyntheticStream, Vec<SpottedGesture>)>,
    /// What was spotted in ordinary movement alone: every one an insertion.
    alarms: Vec<SpottedGesture>,
}

/// Draws the streams and the ordinary movement and spots in them.
fn evaluate(args: &Args) -> anyhow::Result<Evaluation> {
    let model = Model::load(&args.model)?;
    if model.spotting.is_none() {
        bail!(
            "{}: the model has no spotting HMMs; retrain it with `airglyph train`",
            args.model.display()
        );
    }
    let samples = load_many(&args.data)?;
    // The streams move in the frontal plane: a 3-D gesture would be drawn as its shadow
    // and a model that reads depth would see none.
    if samples.iter().any(Sample::has_depth) || model.reads_depth() {
        bail!(
            "{}: eval-spotting draws its streams in the frontal plane and cannot yet measure gestures in three dimensions (data with \"dims\":3, or a model trained on it); `airglyph demo --vocabulary 3d` spots them through the pipeline",
            args.data[0].display()
        );
    }
    let pool: Vec<&Sample> = samples
        .iter()
        .filter(|s| model.label_index(&s.label).is_some())
        .collect();
    if pool.is_empty() {
        bail!(
            "{}: no sample has a label the model knows",
            args.data[0].display()
        );
    }
    let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
    let known = draw(&pool, args.gestures, &mut rng);
    let cfg = StreamConfig {
        pause_prob: args.pause_prob,
        flow: args.flow,
        speed: args.speed,
        ..StreamConfig::default()
    };
    let mut scfg = SpotterConfig::with_overrides(args.spotter.as_deref()).context("--spotter")?;
    scfg.pen = pen_of(args, scfg.pen);
    let drawing = drawing_posture(scfg.pen)?;
    let noise = PostureNoise {
        error_rate: args.posture_error,
        run_frames: args.posture_runs,
        fps: cfg.fps,
    };
    let generator = Generator::parse(&args.generator).context("--generator")?;
    let per = args.per_stream;
    let chunks: Vec<(usize, u64, Vec<&Sample>)> = known
        .chunks(per)
        .enumerate()
        .map(|(i, c)| {
            (
                i,
                args.seed.wrapping_mul(7919).wrapping_add(i as u64),
                c.to_vec(),
            )
        })
        .collect();
    if args.plot.is_some() && args.plot_stream >= chunks.len() {
        bail!(
            "--plot-stream {}: there are {} streams (0–{})",
            args.plot_stream,
            chunks.len(),
            chunks.len() - 1
        );
    }
    eprintln!(
        "spotting {} gestures in {} streams, then in {} s of ordinary movement alone",
        known.len(),
        chunks.len(),
        args.random_seconds
    );
    let scores: Vec<anyhow::Result<StreamResult>> = chunks
        .par_iter()
        .map(|(index, seed, c)| {
            let mut r = ChaCha8Rng::seed_from_u64(*seed);
            let s = generator.stream(c, &cfg, *index, &mut r);
            let postures = postures_for(&s, drawing, &noise, *seed);
            let mut spotter = Spotter::new(model.clone(), scfg)?;
            spotter.set_trace(args.verbose || args.dump.is_some());
            let mut cands = Vec::new();
            let spotted = s.spot_traced_posed(&mut spotter, &cfg, &postures, |c| cands.extend(c));
            if args.verbose {
                explain(*index, &spotter, &s, &cfg, &spotted, &cands);
            }
            let dumped = if args.dump.is_some() {
                dump_lines(*index, &model, &s, &cfg, &spotted, &cands)
            } else {
                Vec::new()
            };
            let m = matched(&s.truth, &spotted);
            let drawn = s.truth.iter().map(|t| t.label.clone()).zip(m.correct);
            Ok(StreamResult {
                score: m.score,
                drawn: drawn.collect(),
                frames: s.points.len(),
                dump: dumped,
                plotted: (args.plot.is_some() && *index == args.plot_stream)
                    .then_some((s, spotted)),
            })
        })
        .collect();
    let mut total = SpottingScore::default();
    let mut by_label = BTreeMap::<String, LabelCount>::new();
    let mut frames = 0;
    let mut dump = Vec::new();
    let mut plotted = None;
    for r in scores {
        let r = r?;
        total.add(&r.score);
        for (label, right) in r.drawn {
            let e = by_label.entry(label).or_default();
            e.drawn += 1;
            e.correct += usize::from(right);
        }
        frames += r.frames;
        dump.extend(r.dump);
        plotted = plotted.or(r.plotted);
    }
    // Pure random movement.
    let mut r = ChaCha8Rng::seed_from_u64(args.seed ^ 0xABCD);
    let mut alarms = Vec::new();
    for (i, rm) in generator
        .movement(args.random_seconds, &cfg, &mut r)
        .iter()
        .enumerate()
    {
        let postures = postures_for(rm, drawing, &noise, args.seed ^ 0xABCD ^ i as u64);
        alarms.extend(run_stream(&model, &scfg, rm, &cfg, &postures)?);
    }
    Ok(Evaluation {
        cfg,
        scfg,
        total,
        by_label,
        frames,
        dump,
        plotted,
        alarms,
    })
}

/// What the JSON line of the streams says of the pen, with the pen by posture or gated (nothing
/// with the pen by motion: its lines are those of before).
fn pen_fields(args: &Args, e: &Evaluation) -> serde_json::Map<String, serde_json::Value> {
    let mut m = serde_json::Map::new();
    if let Pen::Gated(p) = e.scfg.pen {
        m.insert("pen".into(), json!(format!("gated:{}", p.label)));
        m.insert("min_share".into(), json!(p.min_share));
    }
    if let Pen::Posture(p) = e.scfg.pen {
        m.insert("pen".into(), json!(format!("posture:{}", p.label)));
        m.insert("down_frames".into(), json!(p.down_frames));
        m.insert("up_frames".into(), json!(p.up_frames));
        m.insert("verify".into(), json!(p.verify));
    }
    if matches!(e.scfg.pen, Pen::Posture(_) | Pen::Gated(_)) {
        m.insert("posture_error".into(), json!(args.posture_error));
        m.insert("posture_runs".into(), json!(args.posture_runs));
        m.insert(
            "measured_posture_error".into(),
            json!(measured_error_rate()),
        );
    }
    m
}

/// `count` samples of `pool` in a random order: each once, and again in another order
/// while more are wanted (the first `pool.len()` are as a plain shuffle would have them).
fn draw<'a>(pool: &[&'a Sample], count: usize, rng: &mut ChaCha8Rng) -> Vec<&'a Sample> {
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let mut round = pool.to_vec();
        round.shuffle(rng);
        out.extend(round.into_iter().take(count - out.len()));
    }
    out
}

/// What one stream gave.
struct StreamResult {
    score: SpottingScore,
    /// Each drawn symbol's label and whether it was spotted right.
    drawn: Vec<(String, bool)>,
    frames: usize,
    /// Its lines of --dump.
    dump: Vec<String>,
    /// The stream and what was spotted in it, when it is the one --plot draws.
    plotted: Option<(SyntheticStream, Vec<SpottedGesture>)>,
}

/// One stream as JSON lines: each drawn symbol (and the classifier's label of its own
/// frames), each scored candidate, each spotted gesture.
fn dump_lines(
    stream: usize,
    model: &Model,
    s: &SyntheticStream,
    cfg: &StreamConfig,
    spotted: &[SpottedGesture],
    cands: &[Candidate],
) -> Vec<String> {
    let filtered = filtered(s, cfg);
    let truth = s.truth.iter().map(|t| {
        let seg = &filtered[t.start as usize..=t.end as usize];
        let alone = model.classify(&Trajectory::from_points(seg.to_vec()));
        json!({"stream": stream, "kind": "drawn", "label": t.label, "subject": t.subject, "start": t.start,
               "end": t.end, "alone": model.labels[alone.class], "alone_score": alone.score})
    });
    let cands = cands.iter().map(|c| {
        json!({"stream": stream, "kind": "candidate", "label": model.labels[c.class],
               "start": c.start_seq, "end": c.end_seq, "score": c.score,
               "p_gesture": c.p_gesture, "p_label": c.p_label, "ratio": c.ratio, "rank": c.rank,
               "accepted": c.accepted})
    });
    let spotted = spotted.iter().map(|g| {
        json!({"stream": stream, "kind": "spotted", "label": g.label, "start": g.start_seq,
               "end": g.end_seq, "score": g.score})
    });
    truth
        .chain(cands)
        .chain(spotted)
        .map(|v| v.to_string())
        .collect()
}

/// The hand as the spotter sees it (after the tracker's filter).
fn filtered(s: &SyntheticStream, cfg: &StreamConfig) -> Vec<[f32; 2]> {
    let mut tr = airglyph_gesture::HandTracker::new(Default::default());
    let dt = (1e9 / cfg.fps as f64) as u64;
    (0..s.points.len())
        .map(|i| {
            let p = tr.update(&s.skeleton(i, cfg.distance), i as u64 * dt);
            p.map_or([0.0, 0.0], |p| [p.x, p.y])
        })
        .collect()
}

fn plot(
    path: &std::path::Path,
    s: &SyntheticStream,
    spotted: &[SpottedGesture],
    cfg: &StreamConfig,
    from: f32,
    seconds: f32,
) -> anyhow::Result<()> {
    let pts = filtered(s, cfg);
    let a = ((from * cfg.fps) as usize).min(pts.len().saturating_sub(2));
    let b = (a + (seconds * cfg.fps) as usize).clamp(a + 2, pts.len());
    let drawn: Vec<Span> = s
        .truth
        .iter()
        .map(|t| Span {
            label: t.label.clone(),
            start: t.start,
            end: t.end,
        })
        .collect();
    let found: Vec<Span> = spotted
        .iter()
        .map(|g| Span {
            label: g.label.clone(),
            start: g.start_seq,
            end: g.end_seq,
        })
        .collect();
    plot_timeline(
        path,
        "eval-spotting: one stream",
        &pts[a..b],
        a as u64,
        cfg.fps,
        &drawn,
        &found,
    )?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
