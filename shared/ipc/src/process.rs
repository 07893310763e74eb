//! What every airglyph process does around its work.

/// The `main` of an airglyph process: logs to stderr (level from RUST_LOG, default info),
/// SIGINT/SIGTERM turned into [`crate::shutdown::requested`], and a failure reported as
/// one line naming the process, with a non-zero exit status.
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
            eprintln!("{name}: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
