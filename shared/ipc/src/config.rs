//! Where a pipeline's shared memory lives. Two pipelines with different prefixes (and
//! root paths) never see each other, which is how tests run side by side.
//!
//! Settings come, in order of precedence, from the environment (`AIRGLYPH_IPC_ROOT`,
//! `AIRGLYPH_IPC_PREFIX`), from a config file named by `AIRGLYPH_CONFIG`, then defaults:
//!
//! ```toml
//! [ipc]
//! root = "/tmp/airglyph/"   # iceoryx2's node and service directory
//! prefix = "airglyph_"      # prefix of every file under /dev/shm and root
//! ```
//!
//! The rest of the iceoryx2 settings come from iceoryx2's own configuration file, where
//! iceoryx2 looks for it ([`crate::site`]).
//!
//! The root is the pipeline's own folder (iceoryx2's default, /tmp/iceoryx2/, is shared
//! with every other iceoryx2 program on the machine), made closed to other users: see
//! [`crate::ownership`].

use crate::IpcError;
use iceoryx2::prelude::*;
use serde::Deserialize;
use std::path::PathBuf;

/// Names the pipeline's root folder, beside [`DEFAULT_ROOT`].
pub const ENV_ROOT: &str = "AIRGLYPH_IPC_ROOT";
/// Names the pipeline's file prefix in `/dev/shm`, beside [`DEFAULT_PREFIX`].
pub const ENV_PREFIX: &str = "AIRGLYPH_IPC_PREFIX";
/// Names a TOML file with `[ipc] root` and `prefix`.
pub const ENV_CONFIG: &str = "AIRGLYPH_CONFIG";
/// The root folder when nothing names one.
pub const DEFAULT_ROOT: &str = "/tmp/airglyph/";
/// The file prefix when nothing names one.
pub const DEFAULT_PREFIX: &str = "airglyph_";

/// The iceoryx2 root path and file prefix of one pipeline.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IpcConfig {
    /// The folder of the pipeline's iceoryx2 files (ending in `/`).
    pub root: String,
    /// The prefix of its files in `/dev/shm`: pipelines with other prefixes never meet.
    pub prefix: String,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileConfig {
    ipc: Option<FileIpc>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileIpc {
    root: Option<String>,
    prefix: Option<String>,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            root: DEFAULT_ROOT.into(),
            prefix: DEFAULT_PREFIX.into(),
        }
    }
}

impl IpcConfig {
    /// Reads the config file named by `AIRGLYPH_CONFIG` (if any), then the environment.
    pub fn from_env() -> Result<Self, IpcError> {
        let mut cfg = Self::default();
        if let Some(path) = std::env::var_os(ENV_CONFIG) {
            cfg = cfg.with_file(&PathBuf::from(path))?;
        }
        if let Ok(root) = std::env::var(ENV_ROOT) {
            cfg.root = root;
        }
        if let Ok(prefix) = std::env::var(ENV_PREFIX) {
            cfg.prefix = prefix;
        }
        cfg.validate()?;
        Ok(cfg)
    }

    fn with_file(mut self, path: &std::path::Path) -> Result<Self, IpcError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| IpcError::Config(format!("{}: {e}", path.display())))?;
        let file: FileConfig = toml::from_str(&text)
            .map_err(|e| IpcError::Config(format!("{}: {}", path.display(), e.message())))?;
        if let Some(ipc) = file.ipc {
            if let Some(root) = ipc.root {
                self.root = root;
            }
            if let Some(prefix) = ipc.prefix {
                self.prefix = prefix;
            }
        }
        Ok(self)
    }

    fn validate(&self) -> Result<(), IpcError> {
        let ok = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.';
        if self.prefix.is_empty() || self.prefix.len() > 32 || !self.prefix.chars().all(ok) {
            return Err(IpcError::Config(format!(
                "prefix {:?} must be 1-32 characters of [A-Za-z0-9_.-]",
                self.prefix
            )));
        }
        if !self.root.starts_with('/') {
            return Err(IpcError::Config(format!(
                "root {:?} must be an absolute path",
                self.root
            )));
        }
        Ok(())
    }

    /// The iceoryx2 configuration for this pipeline: the machine's own iceoryx2 file
    /// when there is one ([`crate::site`]: a site's settings hold), with this pipeline's
    /// root and prefix on top.
    pub fn iceoryx2(&self) -> Result<Config, IpcError> {
        self.validate()?;
        let (mut config, _) = crate::site::config()?;
        // The node counter's name is what `crate::ownership` guards: a site file must
        // not move it where the check does not look.
        config.global.node.global_mgmt_suffix = Config::default().global.node.global_mgmt_suffix;
        let mut root = self.root.clone();
        if !root.ends_with('/') {
            root.push('/');
        }
        let root = Path::new(root.as_bytes())
            .map_err(|e| IpcError::Config(format!("root {:?}: {e:?}", self.root)))?;
        config.global.set_root_path(&root);
        config.global.prefix = FileName::new(self.prefix.as_bytes())
            .map_err(|e| IpcError::Config(format!("prefix {:?}: {e:?}", self.prefix)))?;
        Ok(config)
    }

    /// The environment variables that make a child process join this pipeline.
    pub fn env(&self) -> [(&'static str, String); 2] {
        [
            (ENV_ROOT, self.root.clone()),
            (ENV_PREFIX, self.prefix.clone()),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_prefix_is_refused_by_name() {
        let cfg = IpcConfig {
            root: DEFAULT_ROOT.into(),
            prefix: "no/slashes".into(),
        };
        let err = cfg.iceoryx2().unwrap_err().to_string();
        assert!(err.contains("no/slashes"), "{err}");
    }

    #[test]
    fn the_file_sets_root_and_prefix() {
        let dir = std::env::temp_dir().join(format!("airglyph-cfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("airglyph.toml");
        std::fs::write(&path, "[ipc]\nroot = \"/tmp/x/\"\nprefix = \"t1_\"\n").unwrap();
        let cfg = IpcConfig::default().with_file(&path).unwrap();
        assert_eq!(
            cfg,
            IpcConfig {
                root: "/tmp/x/".into(),
                prefix: "t1_".into()
            }
        );
        std::fs::write(&path, "[ipc]\nprefx = \"t1_\"\n").unwrap();
        let err = IpcConfig::default()
            .with_file(&path)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("airglyph.toml") && err.contains("prefx"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
