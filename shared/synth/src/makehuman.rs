//! The MakeHuman CC0 body.

use crate::body::Body;
use crate::error::SynthError;
use std::path::{Path, PathBuf};

/// Where the asset cache is looked for.
pub fn default_assets_dir() -> PathBuf {
    PathBuf::from(".cache/assets")
}

pub fn load(dir: &Path) -> Result<Body, SynthError> {
    Err(SynthError::MissingAssets {
        missing: dir.join("mpfb2"),
    })
}
