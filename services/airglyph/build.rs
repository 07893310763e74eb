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
    // Run again when HEAD moves: HEAD, its log (written at every move), the branch it
    // names and the packed refs. Only files that exist: cargo reruns a build script
    // that watches a missing file at every build, and a fresh clone has no loose ref.
    println!("cargo:rerun-if-changed=build.rs");
    let branch = git(&["symbolic-ref", "-q", "HEAD"]);
    let watched = ["HEAD", "logs/HEAD", "packed-refs"]
        .into_iter()
        .chain(branch.as_deref());
    for name in watched {
        if let Some(path) = git(&["rev-parse", "--git-path", name]) {
            if std::path::Path::new(&path).exists() {
                println!("cargo:rerun-if-changed={path}");
            }
        }
    }
}
