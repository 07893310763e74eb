//! The stages' processes: `airglyph stage capture|pose|gesture|viewer`. Each wires a
//! stage's library to the pipeline's shared memory.
//!
//! They are subcommands of the one `airglyph` executable, so whatever builds or installs
//! `airglyph` can run the whole pipeline, and the supervisor starts each stage from its
//! own executable (`airglyph::supervisor::StagePlan::own`). Each still runs as a process of its own: it can be
//! restarted, replaced, profiled or killed alone, and run by hand beside a pipeline.

pub mod capture;
pub mod gesture;
pub mod pose;
pub mod postures;
pub mod viewer;

use airglyph_ipc::Stage;
use std::ffi::OsString;

/// One stage's process. Started by `airglyph run` (or a systemd unit), not by hand
/// except to run one stage alone.
#[derive(clap::Subcommand, Debug)]
pub enum StageCommand {
    Capture(capture::Args),
    Pose(pose::Args),
    Gesture(gesture::Args),
    Viewer(viewer::Args),
}

impl StageCommand {
    pub fn stage(&self) -> Stage {
        match self {
            StageCommand::Capture(_) => Stage::Capture,
            StageCommand::Pose(_) => Stage::Pose,
            StageCommand::Gesture(_) => Stage::Gesture,
            StageCommand::Viewer(_) => Stage::Viewer,
        }
    }

    pub fn run(self) -> anyhow::Result<()> {
        match self {
            StageCommand::Capture(a) => capture::run(a),
            StageCommand::Pose(a) => pose::run(a),
            StageCommand::Gesture(a) => gesture::run(a),
            StageCommand::Viewer(a) => viewer::run(a),
        }
    }
}

/// Extra arguments for one stage: `--stage-args STAGE=ARGS`, ARGS split as a shell
/// splits them (quotes keep spaces: `gesture=--model 'my model.json'`).
#[derive(Debug, Clone, PartialEq)]
pub struct StageArgs {
    pub stage: Stage,
    pub args: Vec<String>,
}

impl std::str::FromStr for StageArgs {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let names = || Stage::ALL.map(Stage::name).join(", ");
        let (name, args) = s
            .split_once('=')
            .ok_or_else(|| format!("expected STAGE=ARGS, one of the stages {}", names()))?;
        let stage = Stage::from_name(name)
            .ok_or_else(|| format!("unknown stage {name:?}: the stages are {}", names()))?;
        let args = shlex::split(args).ok_or_else(|| format!("{args:?}: a quote is not closed"))?;
        Ok(Self { stage, args })
    }
}

/// `stage` with `args`, parsed as its process will parse them.
fn parse_args(stage: Stage, args: &[OsString]) -> Result<StageCommand, String> {
    #[derive(clap::Parser)]
    #[command(name = "airglyph stage")]
    struct Stages {
        #[command(subcommand)]
        stage: StageCommand,
    }
    let argv = ["airglyph stage", stage.name()].map(OsString::from);
    <Stages as clap::Parser>::try_parse_from(argv.into_iter().chain(args.iter().cloned()))
        .map(|s| s.stage)
        .map_err(|e| e.to_string().trim_end().to_owned())
}

/// Whether `stage` takes `args`, as its process would when started with them: a bad one
/// is refused before the pipeline starts, not by a stage dying again and again.
pub fn check_args(stage: Stage, args: &[OsString]) -> Result<(), String> {
    parse_args(stage, args).map(drop)
}

/// The address a viewer started with `args` serves on (whatever `--stage-args` made
/// of `--listen`), for the supervisor's health check.
pub fn viewer_address(args: &[OsString]) -> Result<std::net::SocketAddr, String> {
    match parse_args(Stage::Viewer, args)? {
        StageCommand::Viewer(a) => Ok(a.listen),
        _ => unreachable!("parsed as the viewer's arguments"),
    }
}
