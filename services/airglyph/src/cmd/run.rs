//! `airglyph run`: starts the stages as child processes, supervises them, prints gestures.

use crate::pipeline::PipelineArgs;
use airglyph::supervisor::{supervise_gestures, NODE};
use airglyph_ipc::Pipeline;

/// Start the pipeline and print each gesture it recognizes.
///
/// The stages (capture → pose → gesture) run as child processes; one that dies is
/// restarted after 100 ms, and one that dies again within 2 s of its start waits twice
/// as long each time (up to 5 s). A stage that dies more than --max-restarts times
/// within --crash-window seconds, however long each run lasted, is in a crash loop: the
/// pipeline stops and says which stage and why.
/// With --view the viewer stage runs too (a web page of what the camera sees, on
/// http://127.0.0.1:8080/ unless --listen says otherwise); it is supervised the same
/// way, except that a viewer in a crash loop is given up alone and the pipeline runs on.
/// With --export zenoh, `airglyph-zenoh export` starts once the stages run and carries
/// gestures, decisions, skeletons and stats to another host (which runs `airglyph-zenoh
/// import`): restarted as a stage is, and given up alone, like the viewer, when it keeps
/// dying. It reads this pipeline (the same AIRGLYPH_IPC_ROOT and AIRGLYPH_IPC_PREFIX).
/// SIGINT/SIGTERM stop every stage cleanly.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    #[command(flatten)]
    pipeline: PipelineArgs,
    /// Print each gesture as one JSON object a line instead of plain text:
    /// {"event":"gesture","label","score","start_frame","end_frame","hand","start_ns",
    /// "end_ns","latency_ms"} (README, "JSON output").
    #[arg(long)]
    json: bool,
}

/// Runs the stages until SIGINT/SIGTERM, a finished source, or a crash loop.
pub fn run(args: Args) -> anyhow::Result<()> {
    let plan = args.pipeline.plan()?;
    supervise_gestures(&plan, Pipeline::join(NODE)?, |event| {
        crate::cmd::print_gesture(event, args.json)
    })?;
    Ok(())
}
