//! What every airglyph process does around its work.

use crate::shutdown::Interrupted;
use std::io::{IsTerminal, Write};

/// The `main` of an airglyph process: logs to stderr (level from RUST_LOG, default info;
/// coloured only on a terminal and without NO_COLOR), SIGINT/SIGTERM turned into
/// [`crate::shutdown::requested`], and a failure reported as one line naming the
/// process, with a non-zero exit status: 128 + the signal for work a signal stopped
/// ([`Interrupted`]), else 1.
pub fn main(name: &str, run: impl FnOnce() -> anyhow::Result<()>) -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(colours(std::io::stderr().is_terminal()))
        .init();
    crate::shutdown::install();
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // Not eprintln!, which panics when stderr is gone.
            let _ = writeln!(std::io::stderr(), "{name}: {e:#}");
            match e.downcast_ref::<Interrupted>() {
                Some(stopped) => std::process::ExitCode::from(stopped.exit_code()),
                None => std::process::ExitCode::FAILURE,
            }
        }
    }
}

/// Whether to colour what goes to a terminal (`on_terminal`) or not: never into a pipe,
/// a file or the journal, and never when NO_COLOR is set and not empty
/// (<https://no-color.org>).
pub fn colours(on_terminal: bool) -> bool {
    on_terminal && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
}
