//! `airglyph`: the front door. Starts and supervises the three stages, and carries the
//! offline tools. Each subcommand lives in its own module under `cmd/`, which parses its
//! arguments and calls the libraries; no command imports another. The supervisor that
//! `run`, `demo` and `collect` share is this package's library (`lib.rs`), the options of
//! the pipeline they start are in `pipeline.rs` (with `run --export`'s in `export.rs`),
//! and the stages' processes, which the supervisor starts as `airglyph stage NAME`, are
//! under `stage/`.

mod cmd;
mod export;
mod interrupt;
mod pipeline;
mod stage;

use clap::{CommandFactory, Parser, Subcommand};

/// `airglyph --version`: the package's version and the commit it was built from.
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (",
    env!("AIRGLYPH_COMMIT"),
    ")"
);

/// What the environment changes, for `--help`.
const ENVIRONMENT: &str = "\
Environment:
  RUST_LOG          what is logged to stderr: a level or a filter (default info;
                    e.g. RUST_LOG=debug, RUST_LOG=warn,airglyph::supervisor=debug)
  NO_COLOR          no colours in the logs (there are none off a terminal anyway)
  AIRGLYPH_MODEL    the gesture model when no --model is given (default: built in)
  AIRGLYPH_ASSETS   the MakeHuman body (default: ~/.cache/airglyph/assets, or
                    $XDG_CACHE_HOME/airglyph/assets; `airglyph fetch-assets`)
  AIRGLYPH_IPC_ROOT, AIRGLYPH_IPC_PREFIX, AIRGLYPH_CONFIG
                    which pipeline to join (several run side by side; a TOML file
                    with [ipc] root and prefix)";

/// Recognize gestures drawn in the air in front of a depth camera.
#[derive(Parser)]
#[command(name = "airglyph", version = VERSION, after_help = ENVIRONMENT)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    // One variant a subcommand; its arguments and `run` live in `cmd/<name>.rs`. A
    // variant's doc comment replaces its Args' (which `--help` then loses): the long
    // ones stay on the Args.
    Demo(cmd::demo::Args),
    Run(cmd::run::Args),
    /// Find the gestures drawn in a recording, offline (pose, then the spotter).
    Spot(cmd::spot::Args),
    /// Write a recording (depth PNGs, frames.csv) from any source.
    Record(cmd::record::Args),
    /// List depth cameras (V4L2, OpenNI2) and their depth modes.
    Devices(cmd::devices::Args),
    /// Show each stage's frame rate, drops and latency, live.
    Top(cmd::top::Args),
    Echo(cmd::echo::Args),
    /// Write the viewer's picture of the running pipeline (depth, skeleton, trail, gestures) to a PNG.
    Snapshot(cmd::snapshot::Args),
    /// Measure each stage's latency frame by frame; write CSV, JSON and histograms.
    Profile(cmd::profile::Args),
    /// Render a synthetic person into a recording with exact ground-truth joints.
    Synth(cmd::synth::Args),
    /// Fetch the MakeHuman body for `synth --body makehuman` into the asset cache.
    FetchAssets(cmd::fetch_assets::Args),
    #[cfg(feature = "lab")]
    Collect(cmd::collect::Args),
    #[cfg(feature = "lab")]
    /// Train a gesture model from trajectory JSONL files (or, with --postures, a hand
    /// posture model from posture sample JSONL).
    Train(cmd::train::Args),
    #[cfg(feature = "lab")]
    /// Accuracy, per-class recall and confusion matrices of a gesture model.
    EvalGestures(cmd::eval_gestures::Args),
    #[cfg(feature = "lab")]
    EvalSpotting(cmd::eval_spotting::Args),
    #[cfg(feature = "lab")]
    /// Write the 3-D vocabulary drawn by synthetic people as trajectory JSONL.
    SynthGestures(cmd::synth_gestures::Args),
    /// Estimate the skeleton of every frame of a recording.
    Pose(cmd::pose::Args),
    #[cfg(feature = "lab")]
    /// Pose error against a recording's ground truth (e_m, e_j, within 10 cm, mAP, fps).
    EvalPose(cmd::eval_pose::Args),
    Completions(cmd::completions::Args),
    Man(cmd::man::Args),
    /// Run one stage's process (what `airglyph run` starts; by hand, to run a stage alone).
    #[command(subcommand, hide = true)]
    Stage(stage::StageCommand),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    if cli.command.is_filter() {
        die_quietly_on_a_closed_pipe();
    }
    let name = match &cli.command {
        Command::Stage(s) => airglyph::supervisor::invocation(s.stage()),
        _ => "airglyph".to_owned(),
    };
    airglyph_ipc::process::main(&name, || dispatch(cli))
}

impl Command {
    /// An offline tool that only reads files and writes stdout, used in pipes
    /// (`airglyph pose DIR --json | head`). The commands that run stages are not:
    /// when their reader goes they stop their stages and clean up first.
    fn is_filter(&self) -> bool {
        #[cfg(feature = "lab")]
        if matches!(
            self,
            Command::Train(_)
                | Command::EvalGestures(_)
                | Command::EvalSpotting(_)
                | Command::EvalPose(_)
        ) {
            return true;
        }
        matches!(
            self,
            Command::Spot(_)
                | Command::Completions(_)
                | Command::Man(_)
                | Command::Devices(_)
                | Command::Synth(_)
                | Command::Pose(_)
        )
    }
}

/// Rust ignores SIGPIPE, so `println!` to a pipe whose reader has gone panics. A filter
/// should end the way `cat` or `grep` do: quietly, by the signal.
fn die_quietly_on_a_closed_pipe() {
    // SAFETY: called before any other thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(a) => cmd::demo::run(a),
        Command::Run(a) => cmd::run::run(a),
        Command::Spot(a) => cmd::spot::run(a),
        Command::Record(a) => cmd::record::run(a),
        Command::Devices(a) => cmd::devices::run(a),
        Command::Top(a) => cmd::top::run(a),
        Command::Echo(a) => cmd::echo::run(a),
        Command::Snapshot(a) => cmd::snapshot::run(a),
        Command::Profile(a) => cmd::profile::run(a),
        Command::Synth(a) => cmd::synth::run(a),
        Command::FetchAssets(a) => cmd::fetch_assets::run(a),
        #[cfg(feature = "lab")]
        Command::Collect(a) => cmd::collect::run(a),
        #[cfg(feature = "lab")]
        Command::Train(a) => cmd::train::run(a),
        #[cfg(feature = "lab")]
        Command::EvalGestures(a) => cmd::eval_gestures::run(a),
        #[cfg(feature = "lab")]
        Command::EvalSpotting(a) => cmd::eval_spotting::run(a),
        #[cfg(feature = "lab")]
        Command::SynthGestures(a) => cmd::synth_gestures::run(a),
        Command::Pose(a) => cmd::pose::run(a),
        #[cfg(feature = "lab")]
        Command::EvalPose(a) => cmd::eval_pose::run(a),
        Command::Completions(a) => cmd::completions::run(a, Cli::command()),
        Command::Man(a) => cmd::man::run(a, Cli::command()),
        Command::Stage(s) => s.run(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every command with its numeric options at their defaults and at a value in
    /// range: a range-checked option's parser must hand clap the field's own type
    /// (a `u64` parser for a `usize` field parses, then panics on access).
    #[test]
    fn every_command_parses_its_defaults_and_values_in_range() {
        Cli::command().debug_assert();
        let lines: &[&[&str]] = &[
            &["run", "--max-restarts", "3", "--crash-window", "30"],
            &[
                "run",
                "--export",
                "zenoh",
                "--export-listen",
                "tcp/0.0.0.0:7447",
                "--export-domain",
                "lab",
            ],
            &["demo"],
            &["top", "--json", "--wait", "1"],
            &[
                "echo",
                "skeleton",
                "--json",
                "--max-rate",
                "10",
                "--count",
                "3",
            ],
            &[
                "snapshot",
                "--out",
                "x.png",
                "--timeout",
                "1",
                "--watch",
                "0",
            ],
            &["profile", "--out", "d", "--seconds", "1", "--warmup", "0"],
            &["collect", "--label", "a", "--count", "3", "--out", "x"],
            &[
                "train",
                "--data",
                "x",
                "--out",
                "y",
                "--hidden",
                "8",
                "--stream-augment",
                "0.5",
            ],
            &[
                "eval-gestures",
                "--model",
                "m",
                "--data",
                "d",
                "--folds",
                "3",
                "--seed-points",
                "9,15",
            ],
            &[
                "eval-spotting",
                "--model",
                "m",
                "--data",
                "d",
                "--gestures",
                "5",
                "--flow",
                "0.2",
            ],
            &["eval-pose", "dir", "--overlay-every", "10"],
            &["synth", "--out", "x", "--frames", "3", "--fps", "15"],
            &[
                "synth",
                "--out",
                "x",
                "--body",
                "makehuman",
                "--body-shape",
                "gender=0,weight=0.8,height=0.3",
            ],
            &[
                "synth",
                "--out",
                "x",
                "--hand-posture",
                "right=point,left=open",
                "--hand-roll",
                "right=-45",
                "--hand-pitch",
                "both=30",
            ],
            &[
                "record",
                "--source",
                "synthetic",
                "--out",
                "x",
                "--frames",
                "3",
            ],
            &["stage", "capture", "--frames", "3"],
            &["stage", "pose"],
            &["stage", "gesture", "--delay-ms", "5"],
            &[
                "stage",
                "viewer",
                "--max-fps",
                "2",
                "--quality",
                "50",
                "--nice",
                "5",
            ],
        ];
        // Commands of the lab, which a build without it does not have.
        let lab = [
            "collect",
            "train",
            "eval-gestures",
            "eval-spotting",
            "eval-pose",
        ];
        for line in lines {
            if !cfg!(feature = "lab") && lab.contains(&line[0]) {
                continue;
            }
            let argv = std::iter::once("airglyph").chain(line.iter().copied());
            if let Err(e) = Cli::try_parse_from(argv) {
                panic!("{line:?}: {e}");
            }
        }
    }

    /// A body shape is read when the line is parsed: a bad one is refused, naming what
    /// is wrong.
    #[test]
    fn a_bad_body_shape_is_refused() {
        for (shape, says) in [
            ("weight=1.2", "0–1"),
            ("size=1", "gender"),
            ("weight", "NAME=VALUE"),
        ] {
            let argv = ["airglyph", "synth", "--out", "x", "--body", "makehuman"];
            let e = Cli::try_parse_from(argv.into_iter().chain(["--body-shape", shape]))
                .err()
                .unwrap_or_else(|| panic!("{shape} was taken"));
            assert!(e.to_string().contains(says), "{shape}: {e}");
        }
    }

    /// A bad hand posture is refused when the line is parsed, naming it and listing the
    /// postures there are.
    #[test]
    fn a_bad_hand_posture_is_refused() {
        for (arg, value, says) in [
            ("--hand-posture", "right=peace", "\"peace\" is not a hand posture: expected one of open, fist, point, thumb-up, v, pinch"),
            ("--hand-posture", "middle=open", "left, right or both"),
            ("--pen-posture", "point", "expected DRAWING,BETWEEN"),
            ("--pen-posture", "point,palm", "\"palm\" is not a hand posture"),
            ("--hand-roll", "right=sideways", "\"sideways\" is not an angle"),
            ("--hand-pitch", "left=-400", "within ±360"),
        ] {
            let argv = ["airglyph", "synth", "--out", "x", arg, value];
            let e = Cli::try_parse_from(argv)
                .err()
                .unwrap_or_else(|| panic!("{arg} {value} was taken"));
            assert!(e.to_string().contains(says), "{arg} {value}: {e}");
        }
    }
}
