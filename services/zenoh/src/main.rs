//! `airglyph-zenoh`: a pipeline's gestures, decisions, skeletons and stats carried to
//! another host over Zenoh, and republished there into a pipeline of that host's own,
//! where `airglyph echo` and every other subscriber read them as if they were local.
//!
//! ```text
//!  device:   pipeline ──iceoryx2──▶ airglyph-zenoh export ══Zenoh (TCP)══╗
//!  another host:  airglyph echo ◀──iceoryx2── airglyph-zenoh import ◀═════╝
//! ```
//!
//! iceoryx2's own host-to-host tunnel is not published for iceoryx2 0.10 (crates.io has
//! its Zenoh backend only up to 0.8), so the messages go through Zenoh directly: each
//! service's `#[repr(C)]` message as it is in shared memory, on the key
//! `airglyph/<domain>/<service>`, with zenoh-ext's advanced publisher and subscriber
//! numbering them, caching the last gestures for recovery after a broken link, and
//! reporting what could not be recovered. Depth frames are not carried (18 MB/s).

mod export;
mod import;
mod link;
mod streams;

use clap::{Parser, Subcommand};

/// Carry a pipeline's messages to another host over Zenoh (TCP), or take them in there.
///
/// On the device: `airglyph-zenoh export --listen tcp/0.0.0.0:7447` beside the
/// pipeline, or `airglyph run --export zenoh --export-listen tcp/0.0.0.0:7447`, which
/// starts and supervises the exporter with the stages. On the other host: `airglyph-zenoh import --connect tcp/DEVICE:7447`, then
/// `airglyph echo gesture` (or any subscriber) as on the device. Both join the pipeline
/// the environment names (AIRGLYPH_IPC_ROOT / AIRGLYPH_IPC_PREFIX), as every airglyph
/// process does.
///
/// The link has no authentication and no encryption: gestures and skeletons (where a
/// person stands, how they move) go in the clear to whoever connects. Listen on an
/// address of a network you trust, or carry the port through a VPN or an SSH tunnel.
#[derive(Parser)]
#[command(name = "airglyph-zenoh", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Export(export::Args),
    Import(import::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let name = match cli.command {
        Command::Export(_) => "airglyph-zenoh export",
        Command::Import(_) => "airglyph-zenoh import",
    };
    airglyph_ipc::process::main(name, || match cli.command {
        Command::Export(a) => export::run(a),
        Command::Import(a) => import::run(a),
    })
}
