//! The machine's own iceoryx2 settings: the file iceoryx2 itself reads, from its usual
//! places, so that a site's iceoryx2 configuration holds for airglyph too and iceoryx2's
//! tools (`iox2`) and airglyph can be pointed at the same pipeline by one file.
//!
//! iceoryx2 0.10 looks in this order and takes the first file that exists
//! (`Config::global_config`): `config/iceoryx2.toml` under the working directory,
//! `~/.config/iceoryx2/iceoryx2.toml`, `/etc/iceoryx2/iceoryx2.toml`. We look in the
//! same places but read the file ourselves: `Config::global_config` falls back to the
//! defaults on a file it cannot read, logging through iceoryx2's own logger, where a
//! broken site file should stop the process and say which file.

use crate::IpcError;
use iceoryx2::config::Config;
use iceoryx2::prelude::{FilePath, SemanticString};
use std::path::{Path, PathBuf};

/// iceoryx2's file name and the folders it is looked for in, relative to the working
/// directory, the user's configuration folder and the system's (`iceoryx2-pal-
/// configuration` 0.10: `config`, `.config/iceoryx2` under the home folder, `/etc/iceoryx2`).
const FILE_NAME: &str = "iceoryx2.toml";
const LOCAL_DIR: &str = "config";
const USER_DIR: &str = ".config/iceoryx2";
const SYSTEM_DIR: &str = "/etc/iceoryx2";

/// The places iceoryx2 looks for its configuration, in its order.
pub fn candidates() -> Vec<PathBuf> {
    let mut out = vec![Path::new(LOCAL_DIR).join(FILE_NAME)];
    if let Some(home) = std::env::var_os("HOME").filter(|h| !h.is_empty()) {
        out.push(Path::new(&home).join(USER_DIR).join(FILE_NAME));
    }
    out.push(Path::new(SYSTEM_DIR).join(FILE_NAME));
    out
}

/// The first iceoryx2 configuration file that exists, if any.
pub fn file() -> Option<PathBuf> {
    candidates().into_iter().find(|p| p.is_file())
}

/// The site's iceoryx2 configuration: the first file iceoryx2 would read, or iceoryx2's
/// defaults when there is none. A file that exists but cannot be read or parsed is an
/// error naming it.
pub fn config() -> Result<(Config, Option<PathBuf>), IpcError> {
    let Some(path) = file() else {
        return Ok((Config::default(), None));
    };
    let config = read(&path)?;
    Ok((config, Some(path)))
}

/// A configuration as the TOML iceoryx2 reads: what to put in one of [`candidates`] so
/// that iceoryx2's tools (`iox2 service list`) see the pipeline it names.
pub fn to_toml(config: &Config) -> Result<String, IpcError> {
    toml::to_string(config).map_err(|e| IpcError::Config(format!("cannot write it as TOML: {e}")))
}

fn read(path: &Path) -> Result<Config, IpcError> {
    let name = path
        .to_str()
        .and_then(|p| FilePath::new(p.as_bytes()).ok())
        .ok_or_else(|| {
            IpcError::Config(format!(
                "{}: not a path iceoryx2 can read (too long, or not UTF-8)",
                path.display()
            ))
        })?;
    Config::from_file(&name).map_err(|e| {
        IpcError::Config(format!(
            "{}: iceoryx2 cannot read it: {e:?}",
            path.display()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iceoryx2_looks_where_we_look() {
        // The local file's place is iceoryx2's own constant: if an upgrade moves it, this
        // fails here rather than leaving a site's file unread.
        let local = Config::default_config_file_path();
        assert_eq!(
            local.as_bytes(),
            format!("{LOCAL_DIR}/{FILE_NAME}").as_bytes()
        );
        let user = Config::default_user_config_file_path();
        assert_eq!(user.as_bytes(), format!("iceoryx2/{FILE_NAME}").as_bytes());
        assert!(USER_DIR.ends_with("iceoryx2"));
    }

    #[test]
    fn a_site_file_is_read_and_a_broken_one_is_named() {
        let dir = std::env::temp_dir().join(format!("airglyph-site-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        std::fs::write(
            &path,
            "[global]\ncreation-timeout = { secs = 7, nanos = 0 }\n",
        )
        .unwrap();
        let config = read(&path).unwrap();
        assert_eq!(config.global.creation_timeout.as_secs(), 7);
        std::fs::write(&path, "[global\n").unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(err.contains(&*path.to_string_lossy()), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_written_configuration_reads_back_the_same() {
        let mut config = Config::default();
        config.global.prefix = iceoryx2::prelude::FileName::new(b"xy_").unwrap();
        let dir = std::env::temp_dir().join(format!("airglyph-site-w-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        std::fs::write(&path, to_toml(&config).unwrap()).unwrap();
        assert_eq!(read(&path).unwrap(), config);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
