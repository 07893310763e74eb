//! `airglyph`: the front door. Starts and supervises the three stages, and carries the
//! offline tools. Each subcommand lives in its own module under `cmd/`.

mod cmd;

use clap::{Parser, Subcommand};

/// Recognize gestures drawn in the air in front of a depth camera.
#[derive(Parser)]
#[command(name = "airglyph", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    // One line a subcommand; its arguments and `run` live in `cmd/<name>.rs`.
}

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    let result: anyhow::Result<()> = match cli.command {};
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("airglyph: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
