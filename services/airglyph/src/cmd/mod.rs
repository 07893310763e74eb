//! One module a subcommand: its clap `Args` and a `run(args) -> anyhow::Result<()>`.
