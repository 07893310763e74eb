//! Names the commit `airglyph --version` was built from (AIRGLYPH_COMMIT: its short
//! hash and date, or "commit unknown" outside a git checkout).

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?.trim().to_owned();
    (out.status.success() && !text.is_empty()).then_some(text)
}

fn main() {
    let commit = git(&["log", "-1", "--format=%h %cs"]);
    println!(
        "cargo:rustc-env=AIRGLYPH_COMMIT={}",
        commit.as_deref().unwrap_or("commit unknown")
    );
    // Run again when HEAD moves: HEAD itself, the branch it names, the packed refs.
    println!("cargo:rerun-if-changed=build.rs");
    let branch = git(&["symbolic-ref", "-q", "HEAD"]);
    for name in ["HEAD", "packed-refs"].into_iter().chain(branch.as_deref()) {
        if let Some(path) = git(&["rev-parse", "--git-path", name]) {
            println!("cargo:rerun-if-changed={path}");
        }
    }
}
