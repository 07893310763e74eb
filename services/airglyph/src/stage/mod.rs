//! The stages' processes: `airglyph stage capture|pose|gesture|viewer`. Each wires a
//! stage's library to the pipeline's shared memory.
//!
//! They are subcommands of the one `airglyph` executable, so whatever builds or installs
//! `airglyph` can run the whole pipeline, and the supervisor starts each stage from its
//! own executable ([`command`]). Each still runs as a process of its own: it can be
//! restarted, replaced, profiled or killed alone, and run by hand beside a pipeline.

pub mod capture;
pub mod gesture;
pub mod pose;
pub mod viewer;

use airglyph_ipc::Stage;
use std::os::unix::process::CommandExt;

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

/// How a person runs `stage` by hand, for messages that send them there.
pub fn invocation(stage: Stage) -> String {
    format!("airglyph stage {}", stage.name())
}

/// A command that runs this very executable again (a stage, or a pipeline to profile)
/// as a child that ends with this process.
///
/// It runs `/proc/self/exe`, the image this process was started from, rather than the
/// file at its path: a stage restarted after that file was replaced (a `cargo build` or
/// an upgrade while the pipeline runs) is still the supervisor's own build, whose
/// message types its peers accept, and a file that was removed is no obstacle. The
/// path stays argv[0], for `ps`.
pub fn own_executable() -> std::process::Command {
    let mut cmd = std::process::Command::new("/proc/self/exe");
    if let Ok(path) = std::env::current_exe() {
        cmd.arg0(path);
    }
    // SAFETY: prctl is async-signal-safe; the closure touches nothing else.
    unsafe {
        // A child whose parent died (even by SIGKILL) stops too, instead of running on
        // unsupervised.
        cmd.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
            Ok(())
        });
    }
    cmd
}

/// A command that runs one stage from this executable.
pub fn command(stage: Stage) -> std::process::Command {
    let mut cmd = own_executable();
    cmd.args(["stage", stage.name()]);
    cmd
}
