//! `airglyph completions SHELL`: the shell's completions, generated from the clap
//! definitions of every command.

use std::io::Write;

/// Print the completions of airglyph's commands and options for a shell.
///
/// For bash, e.g. `airglyph completions bash > ~/.local/share/bash-completion/completions/airglyph`;
/// for zsh, a file `_airglyph` in a directory of $fpath; for fish,
/// `~/.config/fish/completions/airglyph.fish`.
#[derive(clap::Args, Debug)]
pub struct Args {
    shell: clap_complete::Shell,
}

pub fn run(args: Args, mut cli: clap::Command) -> anyhow::Result<()> {
    let mut out = Vec::new();
    clap_complete::generate(args.shell, &mut cli, "airglyph", &mut out);
    std::io::stdout().write_all(&out)?;
    Ok(())
}
