//! Files written whole.

use std::path::Path;

/// Writes `contents` to `path` whole: into `PATH.part` first, then renamed over `path`
/// (atomic within a file system). A writer stopped half-way, by a signal or a full
/// disk, leaves the old file as it was and no half of a new one.
pub fn write_whole(path: &Path, contents: impl AsRef<[u8]>) -> std::io::Result<()> {
    let mut part = path.as_os_str().to_owned();
    part.push(".part");
    std::fs::write(&part, contents)
        .and_then(|()| std::fs::rename(&part, path))
        .inspect_err(|_| {
            let _ = std::fs::remove_file(&part);
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_that_fails_leaves_the_old_file_and_no_part() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.json");
        write_whole(&path, "old").unwrap();
        write_whole(&path, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        // A directory where the part file would go: the write fails, the file stays.
        std::fs::create_dir(dir.path().join("model.json.part")).unwrap();
        assert!(write_whole(&path, "newer").is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
    }
}
