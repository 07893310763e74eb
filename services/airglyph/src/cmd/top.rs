//! `airglyph top`: each stage's telemetry, live.

use airglyph_ipc::options;
use airglyph_ipc::{shutdown, Pipeline, Receiver, Stage, StageStatsMsg};
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

/// Show each running stage's frame rate, drops and latency percentiles, refreshed every
/// second from the stages' `airglyph/stats/<stage>` services.
///
/// On a terminal the table is redrawn in place; piped or redirected, it is a filter:
/// the header once, then every stage's row each second, plain text
/// (`airglyph top | grep pose`).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Print one snapshot as a JSON object and exit.
    #[arg(long)]
    json: bool,
    /// With --json: how long to wait for every stage to report (seconds, up to an hour).
    #[arg(long, default_value_t = 2.5, value_parser = options::seconds(3600.0), allow_negative_numbers = true)]
    wait: f64,
}

fn ms(ns: u64) -> f64 {
    ns as f64 * 1e-6
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Whoever reads the output has gone (`top | head`): stop as a filter does, quietly.
    match show(&args) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other.map_err(Into::into),
    }
}

fn show(args: &Args) -> std::io::Result<()> {
    let pipeline = Pipeline::join("top").map_err(std::io::Error::other)?;
    let mut receivers: Vec<(Stage, Receiver<StageStatsMsg>)> = Stage::PIPELINE
        .iter()
        .map(|&s| Ok((s, pipeline.stats_receiver(s)?)))
        .collect::<anyhow::Result<_>>()
        .map_err(std::io::Error::other)?;
    // On a terminal the table is redrawn in place; into a pipe or a file it is a
    // filter's output: the header once, then each stage's row every second.
    let on_terminal = std::io::stdout().is_terminal();
    let mut out = std::io::stdout().lock();
    let mut latest: BTreeMap<&'static str, (Instant, StageStatsMsg)> = BTreeMap::new();
    let started = Instant::now();
    let mut rounds = 0u64;
    loop {
        for (stage, rx) in receivers.iter_mut() {
            while let Some(r) = rx.try_recv().map_err(std::io::Error::other)? {
                latest.insert(stage.name(), (Instant::now(), r.msg));
            }
        }
        if args.json {
            if latest.len() == receivers.len() || started.elapsed().as_secs_f64() >= args.wait {
                let stages: serde_json::Map<String, serde_json::Value> = latest
                    .iter()
                    .map(|(k, (_, s))| (k.to_string(), airglyph_ipc::json::stats(s)))
                    .collect();
                return writeln!(out, "{}", serde_json::json!({ "stages": stages }));
            }
        } else {
            if on_terminal {
                write!(out, "\x1b[2J\x1b[H")?;
            }
            if on_terminal || rounds == 0 {
                writeln!(
                    out,
                    "{:<8} {:>6} {:>9} {:>8} {:>8}   {:>27}   {:>27}",
                    "stage",
                    "fps",
                    "frames",
                    "dropped",
                    "rejected",
                    "processing p50/p99/max ms",
                    "capture→out p50/p99/max ms"
                )?;
            }
            for stage in Stage::PIPELINE {
                match latest.get(stage.name()) {
                    Some((at, s)) if at.elapsed() < Duration::from_secs(3) => writeln!(
                        out,
                        "{:<8} {:>6.1} {:>9} {:>8} {:>8}   {:>9.2}{:>9.2}{:>9.2}   {:>9.2}{:>9.2}{:>9.2}",
                        stage.name(),
                        s.fps,
                        s.frames_out,
                        s.frames_dropped,
                        s.frames_rejected,
                        ms(s.processing.p50),
                        ms(s.processing.p99),
                        ms(s.processing.max),
                        ms(s.latency.p50),
                        ms(s.latency.p99),
                        ms(s.latency.max),
                    )?,
                    _ => writeln!(out, "{:<8} (not running)", stage.name())?,
                }
            }
            if on_terminal {
                writeln!(out, "\nCtrl-C to quit")?;
            }
            out.flush()?;
            rounds += 1;
        }
        if shutdown::requested() {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(if args.json { 50 } else { 1000 }));
    }
}
