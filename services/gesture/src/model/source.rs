//! Where a gesture model comes from: a file named on the command line or by
//! `$AIRGLYPH_MODEL`, or the shipped one built into the library.

use super::{Model, ModelError};
use std::path::{Path, PathBuf};

/// The shipped 36-symbol model (0–9, A–Z; `models/unipen-36.json`), built into the
/// library: an installed, copied or cross-built binary has it without any file beside
/// it. (The file lies outside this crate, which is built from its repository only.)
const SHIPPED_JSON: &str = include_str!("../../../../models/unipen-36.json");

/// The environment variable naming the model to use when a command is given none.
pub const MODEL_ENV: &str = "AIRGLYPH_MODEL";

/// Where a gesture model comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ModelSource {
    /// A model file (from `airglyph train`).
    File(PathBuf),
    /// The shipped 36-symbol model, built in.
    Shipped,
}

impl ModelSource {
    /// The model a command uses: `path` (its `--model`) when given, else the file
    /// `$AIRGLYPH_MODEL` names when it is set and not empty, else the shipped one.
    pub fn choose(path: Option<&Path>) -> Self {
        let named = path.map(Path::to_path_buf).or_else(|| {
            std::env::var_os(MODEL_ENV)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        });
        named.map_or(ModelSource::Shipped, ModelSource::File)
    }

    /// Reads and validates the model.
    pub fn load(&self) -> Result<Model, ModelError> {
        match self {
            ModelSource::File(path) => Model::load(path),
            ModelSource::Shipped => Model::from_json_str(SHIPPED_JSON, Path::new(SHIPPED_NAME)),
        }
    }
}

/// How the shipped model is named in logs and errors.
const SHIPPED_NAME: &str = "the built-in model unipen-36";

impl std::fmt::Display for ModelSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ModelSource::File(path) => write!(f, "{}", path.display()),
            ModelSource::Shipped => f.write_str(SHIPPED_NAME),
        }
    }
}
