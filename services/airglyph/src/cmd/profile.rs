//! `airglyph profile`: per-stage latency of a running pipeline, frame by frame.

use crate::interrupt::Interrupted;
use airglyph_capture::SourceSpec;
use airglyph_ipc::{options, shutdown, LatencyChain, Pipeline, Stage, StageStatsMsg};
#[cfg(feature = "lab")]
use airglyph_plot::PlotError;
use anyhow::Context;
#[cfg(feature = "lab")]
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Profile the pipeline: for each stage, p50/p90/p99/max of its processing time and of
/// the time frames wait for it; end-to-end capture→skeleton and capture→gesture-decision
/// latency; drops. Writes profile.json, summary.csv, frames.csv (one row a frame) and a
/// latency histogram PNG per measure into OUT (in a build with plots, the feature `lab`).
///
/// Attaches to the running pipeline, or with --source starts one first.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// How long to measure (seconds, up to a day: the report keeps every frame).
    #[arg(long, default_value_t = 10.0, value_parser = options::seconds(options::MAX_SECONDS), allow_negative_numbers = true)]
    seconds: f64,
    /// Directory for the report (created).
    #[arg(long)]
    out: PathBuf,
    /// Start the pipeline on this source (synthetic, recording:DIR, …) and stop it after.
    #[arg(long)]
    source: Option<SourceSpec>,
    /// With --source: seconds to let the pipeline settle before measuring (up to an hour).
    #[arg(long, default_value_t = 3.0, value_parser = options::seconds_or_zero(3600.0), allow_negative_numbers = true)]
    warmup: f64,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

/// One frame's times, CLOCK_MONOTONIC ns (0 = not seen).
#[derive(Default, Clone, Copy)]
struct FrameTimes {
    capture: u64,
    capture_publish: u64,
    pose_receive: u64,
    pose_publish: u64,
    skeleton_seen: u64,
    gesture_receive: u64,
    gesture_publish: u64,
}

/// A measure of the report: its name and how to take it from one frame's times.
type Measure = (&'static str, fn(&FrameTimes) -> Option<u64>);

/// The measures of the report, each a difference of two frame times.
const MEASURES: [Measure; 7] = [
    ("capture_processing", |f| span(f.capture, f.capture_publish)),
    ("pose_waiting", |f| span(f.capture_publish, f.pose_receive)),
    ("pose_processing", |f| span(f.pose_receive, f.pose_publish)),
    ("gesture_waiting", |f| {
        span(f.pose_publish, f.gesture_receive)
    }),
    ("gesture_processing", |f| {
        span(f.gesture_receive, f.gesture_publish)
    }),
    ("capture_to_skeleton", |f| span(f.capture, f.skeleton_seen)),
    ("capture_to_decision", |f| {
        span(f.capture, f.gesture_publish)
    }),
];

impl FrameTimes {
    /// The times a message's latency chain carries (those not reached yet stay 0).
    fn take(&mut self, c: &LatencyChain) {
        self.capture = c.capture_ns;
        self.capture_publish = c.capture_publish_ns;
        self.pose_receive = c.pose_receive_ns;
        self.pose_publish = c.pose_publish_ns;
        self.gesture_receive = self.gesture_receive.max(c.gesture_receive_ns);
        self.gesture_publish = self.gesture_publish.max(c.gesture_publish_ns);
    }
}

fn span(from: u64, to: u64) -> Option<u64> {
    (from != 0 && to >= from).then(|| to - from)
}

fn quantile(sorted: &[u64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize] as f64 * 1e-6
}

pub fn run(args: Args) -> anyhow::Result<()> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut pipeline_child = match &args.source {
        Some(source) => Some(
            airglyph::supervisor::own_executable()
                .args(["run", "--source", &source.to_string(), "--loop"])
                .stdout(std::process::Stdio::null())
                .spawn()
                .context("cannot start the pipeline")?,
        ),
        None => None,
    };
    let settled = pipeline_child.is_none() || settle(Duration::from_secs_f64(args.warmup));
    let result = if settled {
        measure(&args)
    } else {
        Err(Interrupted::new("nothing was measured").into())
    };
    if let Some(child) = pipeline_child.as_mut() {
        // SAFETY: kill(2) on our own, unreaped child.
        unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        let _ = child.wait();
    }
    result
}

/// Lets a pipeline just started settle for `warmup`; false when a signal came first.
fn settle(warmup: Duration) -> bool {
    let until = Instant::now() + warmup;
    while Instant::now() < until {
        if shutdown::requested() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    true
}

fn measure(args: &Args) -> anyhow::Result<()> {
    let pipeline = Pipeline::join("profile")?;
    let mut skeletons = pipeline.skeleton_receiver()?;
    let mut decisions = pipeline.decision_receiver()?;
    let mut stats: Vec<_> = Stage::PIPELINE
        .iter()
        .map(|&s| Ok((s, pipeline.stats_receiver(s)?)))
        .collect::<anyhow::Result<_>>()?;
    let mut frames: BTreeMap<(u64, u64), FrameTimes> = BTreeMap::new();
    let mut first_stats: BTreeMap<&str, StageStatsMsg> = BTreeMap::new();
    let mut last_stats: BTreeMap<&str, StageStatsMsg> = BTreeMap::new();
    eprintln!("measuring for {} s", args.seconds);
    let started = Instant::now();
    let bar = indicatif::ProgressBar::new((args.seconds * 10.0) as u64);
    while started.elapsed().as_secs_f64() < args.seconds && !shutdown::requested() {
        bar.set_position((started.elapsed().as_secs_f64() * 10.0) as u64);
        if let Some(r) = skeletons.recv(Duration::from_millis(20))? {
            let f = frames.entry((r.msg.session, r.msg.sequence)).or_default();
            f.take(&r.msg.chain);
            f.skeleton_seen = r.receive_ns;
        }
        while let Some(r) = decisions.try_recv()? {
            let f = frames.entry((r.msg.session, r.msg.sequence)).or_default();
            f.take(&r.msg.chain);
        }
        for (stage, rx) in stats.iter_mut() {
            while let Some(r) = rx.try_recv()? {
                first_stats.entry(stage.name()).or_insert(r.msg);
                last_stats.insert(stage.name(), r.msg);
            }
        }
    }
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();
    if frames.is_empty() && shutdown::requested() {
        return Err(Interrupted::new("nothing was measured").into());
    }
    if frames.is_empty() {
        anyhow::bail!("no skeletons arrived in {elapsed:.1} s: is a pipeline running? (start one with `airglyph run`, or pass --source)");
    }

    let mut summary = serde_json::Map::new();
    let mut csv = String::from("measure,count,p50_ms,p90_ms,p99_ms,max_ms\n");
    let mut measured = Vec::new();
    for (name, of) in MEASURES {
        let mut v: Vec<u64> = frames.values().filter_map(of).collect();
        if v.is_empty() {
            continue;
        }
        v.sort_unstable();
        let (p50, p90, p99, max) = (
            quantile(&v, 0.5),
            quantile(&v, 0.9),
            quantile(&v, 0.99),
            quantile(&v, 1.0),
        );
        csv += &format!("{name},{},{p50:.3},{p90:.3},{p99:.3},{max:.3}\n", v.len());
        summary.insert(
            name.into(),
            serde_json::json!({"count": v.len(), "p50_ms": p50, "p90_ms": p90, "p99_ms": p99, "max_ms": max}),
        );
        measured.push((name, v));
    }
    let mut drops = serde_json::Map::new();
    for (stage, last) in &last_stats {
        let first = first_stats[stage];
        drops.insert(
            stage.to_string(),
            serde_json::json!({
                "frames_out": last.frames_out - first.frames_out,
                "frames_dropped": last.frames_dropped - first.frames_dropped,
                "frames_rejected": last.frames_rejected - first.frames_rejected,
                "fps": (last.frames_out - first.frames_out) as f64 / ((last.time_ns - first.time_ns).max(1) as f64 * 1e-9),
            }),
        );
    }
    let report = serde_json::json!({
        "seconds": elapsed,
        "frames": frames.len(),
        "latency": summary,
        "stages": drops,
    });
    std::fs::write(
        args.out.join("profile.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    std::fs::write(args.out.join("summary.csv"), csv.as_bytes())?;
    write_frames_csv(&args.out.join("frames.csv"), &frames)?;
    if args.json {
        println!("{report}");
    } else {
        print!("{csv}");
        println!("{}", serde_json::to_string_pretty(&report["stages"])?);
        eprintln!("report in {}", args.out.display());
    }
    // The pictures last: one that fails loses none of the figures written above.
    #[cfg(feature = "lab")]
    for (name, v) in &measured {
        histogram_png(&args.out.join(format!("{name}.png")), name, v)?;
    }
    #[cfg(not(feature = "lab"))]
    if !args.json {
        eprintln!("no histograms: this build has no plots (the feature `lab`)");
    }
    if shutdown::requested() {
        return Err(Interrupted::new(format!(
            "the report in {} covers the {elapsed:.1} s measured",
            args.out.display()
        ))
        .into());
    }
    Ok(())
}

fn write_frames_csv(path: &Path, frames: &BTreeMap<(u64, u64), FrameTimes>) -> anyhow::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    write!(w, "session,sequence")?;
    for (name, _) in MEASURES {
        write!(w, ",{name}_ms")?;
    }
    writeln!(w)?;
    for ((session, seq), f) in frames {
        write!(w, "{session},{seq}")?;
        for (_, of) in MEASURES {
            match of(f) {
                Some(ns) => write!(w, ",{:.3}", ns as f64 * 1e-6)?,
                None => write!(w, ",")?,
            }
        }
        writeln!(w)?;
    }
    Ok(())
}

#[cfg(feature = "lab")]
fn histogram_png(path: &Path, title: &str, sorted_ns: &[u64]) -> Result<(), PlotError> {
    let ms: Vec<f64> = sorted_ns.iter().map(|&n| n as f64 * 1e-6).collect();
    let hi = quantile(sorted_ns, 0.999).max(0.01) * 1.05;
    let bins = 60usize;
    let width = hi / bins as f64;
    let mut counts = vec![0u32; bins];
    for &v in &ms {
        counts[((v / width) as usize).min(bins - 1)] += 1;
    }
    let top = *counts.iter().max().unwrap_or(&1) as f64 * 1.1;
    airglyph_plot::png(path, (800, 400), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(format!("{title} (n = {})", ms.len()), ("sans-serif", 22))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..hi, 0.0..top)?;
        chart
            .configure_mesh()
            .x_desc("ms")
            .y_desc("frames")
            .draw()?;
        chart.draw_series(counts.iter().enumerate().map(|(i, &c)| {
            let x0 = i as f64 * width;
            Rectangle::new([(x0, 0.0), (x0 + width, c as f64)], BLUE.mix(0.6).filled())
        }))?;
        for (q, color) in [(0.5, GREEN), (0.99, RED)] {
            let x = quantile(sorted_ns, q);
            chart
                .draw_series(LineSeries::new([(x, 0.0), (x, top)], color.stroke_width(2)))?
                .label(format!("p{} = {x:.2} ms", (q * 100.0) as u32))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    })
}
