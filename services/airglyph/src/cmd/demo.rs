//! `airglyph demo`: the synthetic person draws symbols in front of a virtual camera; the
//! full three-process pipeline names them.

use crate::pipeline::PipelineArgs;
use airglyph::supervisor::{supervise_gestures, NODE};
use airglyph_capture::synthetic::{scene, DEMO_SYMBOLS};
use airglyph_capture::SourceSpec;
use airglyph_core::gestures::drawn_for;
use airglyph_ipc::json::GestureLine;
use airglyph_ipc::{GestureEventMsg, Pipeline};
use airglyph_synth::Synthesizer;
use anyhow::Context;
use std::io::Write;

/// The 3-D vocabulary's model (`models/air3d-14.json`, trained on synthetic people's
/// 3-D gestures; models/README.md says how), built in like the 36-symbol one.
const AIR3D_JSON: &str = include_str!("../../../../models/air3d-14.json");

/// What the person draws.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Vocabulary {
    /// The symbols 0–9 and A–Z, on a pane in front of the body.
    Symbols,
    /// Gestures in three dimensions (push, pull, circles facing up and sideways,
    /// helices, 3-D zigzag and corners), with their own model.
    #[value(name = "3d")]
    ThreeD,
}

/// A synthetic person draws symbols; the full pipeline names them (no camera needed).
///
/// The synthetic person draws symbols in the air, with ordinary movement between them,
/// in front of a virtual depth camera at 30 fps.
/// Capture, pose and gesture run as separate processes, exactly as with a real camera.
/// Each recognized symbol is printed beside the one drawn, then a summary.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The symbols to draw, in order (0–9, A–Z; with --vocabulary 3d, names separated
    /// by commas; default: the whole vocabulary).
    #[arg(long)]
    symbols: Option<String>,
    /// `symbols` (0–9, A–Z) or `3d` (gestures towards and away from the camera and in
    /// other planes, with the built-in 3-D model unless --model is given).
    #[arg(long, value_enum, default_value = "symbols")]
    vocabulary: Vocabulary,
    /// One JSON object a line: each gesture ({"event":"gesture","label":…,"drawn":…,…};
    /// README, "JSON output"), then the summary {"event":"summary","drawn":N,"correct":…}.
    #[arg(long)]
    json: bool,
    /// The gesture model (default: $AIRGLYPH_MODEL, else the built-in 36-symbol model).
    #[arg(long, value_name = "FILE")]
    model: Option<std::path::PathBuf>,
    /// Also start the viewer: watch the person, skeleton and gestures in a browser.
    #[arg(long)]
    view: bool,
    /// With --view: the viewer's address (default 127.0.0.1:8080).
    #[arg(long, value_name = "ADDR", requires = "view")]
    listen: Option<std::net::SocketAddr>,
    /// Skip pose estimation: the gesture stage gets the synthetic person's exact
    /// skeleton from the capture stage (to tell pose errors from gesture errors).
    #[arg(long)]
    truth: bool,
}

pub fn run(mut args: Args) -> anyhow::Result<()> {
    let symbols = match (&args.symbols, args.vocabulary) {
        (Some(s), _) => s.clone(),
        (None, Vocabulary::Symbols) => DEMO_SYMBOLS.to_string(),
        (None, Vocabulary::ThreeD) => airglyph_synth::shapes3d::VOCABULARY.join(","),
    };
    // The stages load the model from a file: the built-in 3-D one goes to a temporary
    // file for as long as the demo runs.
    let mut written = None;
    if args.vocabulary == Vocabulary::ThreeD && args.model.is_none() {
        let path =
            std::env::temp_dir().join(format!("airglyph-air3d-14-{}.json", std::process::id()));
        std::fs::write(&path, AIR3D_JSON)
            .with_context(|| format!("{}: cannot write the 3-D model", path.display()))?;
        args.model = Some(path.clone());
        written = Some(path);
    }
    let outcome = demo(args, &symbols);
    if let Some(path) = written {
        let _ = std::fs::remove_file(path);
    }
    outcome
}

fn demo(args: Args, symbols: &str) -> anyhow::Result<()> {
    let script = format!("draw:{symbols}");
    let truth = Synthesizer::new(scene(Some(&script), false)?)
        .context("cannot build the synthetic scene")?
        .gestures();
    let seconds = truth.last().map_or(0.0, |t| t.end_frame as f64 / 30.0);
    if !args.json {
        println!(
            "drawing {} symbols (about {seconds:.0} s at 30 fps); recognized symbols appear as they are spotted",
            truth.len()
        );
    }
    let mut recognized: Vec<Option<(String, f32)>> = vec![None; truth.len()];
    let mut stray = 0usize;
    let json = args.json;
    let mut on_event = |e: &GestureEventMsg| -> std::io::Result<()> {
        let mut out = std::io::stdout().lock();
        let label = e.label().unwrap_or("?").to_owned();
        match drawn_for(&truth, e.start_sequence, e.end_sequence) {
            Some(i) if recognized[i].is_none() => {
                let drawn = &truth[i].label;
                if json {
                    writeln!(out, "{}", GestureLine::live(e).drawn(Some(drawn)).line())?;
                } else {
                    let mark = if *drawn == label { "✓" } else { "✗" };
                    writeln!(
                        out,
                        "drew {drawn}  →  recognized {label}  {mark}  (score {:.2})",
                        e.score
                    )?;
                }
                recognized[i] = Some((label, e.score));
            }
            _ => {
                stray += 1;
                if json {
                    writeln!(out, "{}", GestureLine::live(e).drawn(None).line())?;
                } else {
                    writeln!(out, "(spotted {label} while no symbol was drawn)")?;
                }
            }
        }
        Ok(())
    };
    let plan = PipelineArgs {
        model: args.model,
        view: args.view,
        listen: args.listen,
        truth: args.truth,
        ..PipelineArgs::with_source(SourceSpec::Synthetic(Some(script)))
    }
    .plan()?;
    supervise_gestures(&plan, Pipeline::join(NODE)?, &mut on_event)?;
    let correct = truth
        .iter()
        .zip(&recognized)
        .filter(|(t, r)| r.as_ref().is_some_and(|(l, _)| *l == t.label))
        .count();
    let missed: Vec<&str> = truth
        .iter()
        .zip(&recognized)
        .filter(|(_, r)| r.is_none())
        .map(|(t, _)| t.label.as_str())
        .collect();
    if args.json {
        println!(
            "{}",
            serde_json::json!({"event": "summary", "drawn": truth.len(), "correct": correct,
                "missed": missed.len(), "stray": stray})
        );
    } else {
        println!(
            "{correct} of {} symbols recognized{}{}",
            truth.len(),
            if missed.is_empty() {
                String::new()
            } else {
                format!("; not spotted: {}", missed.join(" "))
            },
            if stray > 0 {
                format!("; {stray} spotted between symbols")
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
