//! What every airglyph process does around its work.

use crate::shutdown::Interrupted;
use std::io::Write;

/// The `main` of an airglyph process: logs to stderr (level from RUST_LOG, default info),
/// SIGINT/SIGTERM turned into [`crate::shutdown::requested`], and a failure reported as
/// one line naming the process, with a non-zero exit status: 128 + the signal for work
/// a signal stopped ([`Interrupted`]), else 1.
pub fn main(name: &str, run: impl FnOnce() -> anyhow::Result<()>) -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
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
