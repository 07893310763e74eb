//! `airglyph man`: the man pages, generated from the clap definitions of every command.

use anyhow::Context;
use std::path::PathBuf;

/// Write airglyph's man pages: airglyph(1) to stdout, or with --dir one page a command
/// into DIR (airglyph.1, airglyph-demo.1, …), e.g.
/// `airglyph man --dir ~/.local/share/man/man1`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Write every page into this directory (created) instead of airglyph(1) to stdout.
    #[arg(long, value_name = "DIR")]
    dir: Option<PathBuf>,
}

pub fn run(args: Args, cli: clap::Command) -> anyhow::Result<()> {
    match args.dir {
        Some(dir) => {
            std::fs::create_dir_all(&dir)
                .and_then(|()| clap_mangen::generate_to(cli, &dir))
                .with_context(|| format!("cannot write the man pages into {}", dir.display()))?;
            eprintln!("wrote the man pages into {}", dir.display());
        }
        None => clap_mangen::Man::new(cli).render(&mut std::io::stdout())?,
    }
    Ok(())
}
