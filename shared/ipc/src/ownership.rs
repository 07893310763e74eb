//! Who may touch a pipeline's files: its user alone.
//!
//! iceoryx2 keeps a pipeline in two places: a root folder of its own (node and service
//! records, event sockets) and files in /dev/shm named after the pipeline's prefix. Both
//! live where any local user can create files, under names anyone can predict, and
//! iceoryx2 0.10 opens whatever file carries the name it looks for, whoever made it. Its
//! node counter (`<prefix><hash>_node.0_10_0.global_mgmt`) it even creates writable by
//! everyone (0666), and every new node reads it: sixteen bytes written there by anyone
//! stopped every stage from starting (`UnableToGenerateUniqueNodeId`, naming no file).
//!
//! So before a process joins a pipeline ([`prepare`]):
//! - the root folder is made with mode 0700, or must already be the user's own, a real
//!   folder (not a link), closed to other users;
//! - every /dev/shm file of the prefix must be the user's own regular file; one of the
//!   user's that others may open (the node counter of an older build) is closed (0600);
//! - the node counter is made by us, 0600, before iceoryx2 would make it 0666, and is
//!   never removed: a file that stays can neither be planted nor be swapped.
//!
//! Anything else is refused with its path and its owner, and nothing is deleted: a file
//! another user planted is theirs (or root's) to remove.

use crate::{IpcConfig, IpcError};
use std::fs::File;
use std::io::Write;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Where POSIX shared memory lives (iceoryx2's `SHARED_MEMORY_DIRECTORY` on Linux).
pub const SHM_DIR: &str = "/dev/shm";

/// The name of iceoryx2's node counter after the prefix: the SHA-1 (hex) of its
/// storage type's name, the counter's name, iceoryx2's version and its suffix
/// (`global_management_segment.rs` in iceoryx2 0.10.0). A test makes a node through
/// plain iceoryx2 and checks that this is the file it uses, so an upgrade of iceoryx2
/// that moves it fails there, not in the field.
pub const NODE_COUNTER_TAIL: &str =
    "9204dd183d1c4d8e1ff592a30766ffa6765aa8b5_node.0_10_0.global_mgmt";

/// The node counter's contents as iceoryx2 0.10.0 initializes them: its version
/// (major << 32 | minor << 16 | patch) in the first 8 bytes, the counter (u32) after,
/// padded to 16 bytes. Pinned by the same test.
const NODE_COUNTER_VERSION: u64 = 10 << 16;
const NODE_COUNTER_SIZE: usize = 16;

/// The user this process runs as.
fn euid() -> u32 {
    // SAFETY: geteuid(2) cannot fail and touches no memory.
    unsafe { libc::geteuid() }
}

/// "uid 65534 (nobody)", or "uid 1234" when the user has no name.
pub fn user_name(uid: u32) -> String {
    let mut pwd: libc::passwd = unsafe { std::mem::zeroed() };
    let mut buf = vec![0 as libc::c_char; 4096];
    let mut found: *mut libc::passwd = std::ptr::null_mut();
    // SAFETY: getpwuid_r(3) writes only into `pwd` and `buf`, both ours and large enough
    // (it says ERANGE otherwise); `found` points into them or is null.
    let rc = unsafe { libc::getpwuid_r(uid, &mut pwd, buf.as_mut_ptr(), buf.len(), &mut found) };
    if rc == 0 && !found.is_null() && !pwd.pw_name.is_null() {
        // SAFETY: a NUL-terminated string inside `buf`.
        let name = unsafe { std::ffi::CStr::from_ptr(pwd.pw_name) };
        return format!("uid {uid} ({})", name.to_string_lossy());
    }
    format!("uid {uid}")
}

fn refuse(path: &Path, reason: String) -> IpcError {
    IpcError::Unsafe {
        path: path.to_path_buf(),
        reason,
    }
}

/// A file or folder of the pipeline owned by someone else.
fn foreign(path: &Path, owner: u32, what: &str) -> IpcError {
    refuse(
        path,
        format!(
            "this {what} belongs to {}, not to {} who runs this process; a pipeline's files \
             are its user's alone. If that user runs the pipeline, join it as that user; \
             otherwise it was planted: have it removed, or choose another \
             AIRGLYPH_IPC_ROOT / AIRGLYPH_IPC_PREFIX",
            user_name(owner),
            user_name(euid()),
        ),
    )
}

/// Makes the pipeline's root folder (0700), or checks the one there is the user's own
/// and closed to everyone else.
fn private_root(root: &Path) -> Result<(), IpcError> {
    match std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(root)
    {
        Ok(()) => {}
        Err(e) => return Err(refuse(root, format!("cannot create the folder: {e}"))),
    }
    let meta = std::fs::symlink_metadata(root)
        .map_err(|e| refuse(root, format!("cannot look at the folder: {e}")))?;
    if !meta.file_type().is_dir() {
        return Err(refuse(
            root,
            "is not a folder (a symbolic link?): the pipeline's root must be a folder of its own"
                .into(),
        ));
    }
    if meta.uid() != euid() {
        return Err(foreign(root, meta.uid(), "folder"));
    }
    let mode = meta.mode() & 0o7777;
    if mode & 0o077 != 0 {
        return Err(refuse(
            root,
            format!(
                "other users may enter this folder (mode {mode:04o}): the pipeline's root \
                 must be closed to them (chmod 700 {}) or a folder of its own",
                root.display()
            ),
        ));
    }
    Ok(())
}

/// The pipeline's files under /dev/shm: every name that starts with its prefix.
fn shm_files(prefix: &str) -> Vec<PathBuf> {
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return Vec::new();
    };
    dir.filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .map(|e| e.path())
        .collect()
}

/// Checks that every /dev/shm file of the prefix is the user's own regular file, and
/// closes one of the user's that others could open.
pub(crate) fn check_shm(prefix: &str) -> Result<(), IpcError> {
    for path in shm_files(prefix) {
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue; // gone since it was listed: a process of the pipeline removed it
        };
        if !meta.file_type().is_file() {
            return Err(refuse(
                &path,
                "is not a shared-memory file (a link or a folder) but carries the pipeline's \
                 prefix: it was planted; have it removed or choose another AIRGLYPH_IPC_PREFIX"
                    .into(),
            ));
        }
        if meta.uid() != euid() {
            return Err(foreign(&path, meta.uid(), "shared-memory file"));
        }
        if meta.mode() & 0o077 != 0 {
            // The user's own file, open to others: iceoryx2's node counter as older
            // builds let iceoryx2 make it (0666). Ours to close.
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).map_err(
                |e| {
                    refuse(
                        &path,
                        format!("other users may write it and it cannot be closed: {e}"),
                    )
                },
            )?;
            tracing::warn!(file = %path.display(), "closed a shared-memory file other users could write (mode 0600 now)");
        }
    }
    Ok(())
}

/// The path of the pipeline's node counter.
pub fn node_counter(prefix: &str) -> PathBuf {
    Path::new(SHM_DIR).join(format!("{prefix}{NODE_COUNTER_TAIL}"))
}

/// Makes the node counter as iceoryx2 would, but readable and writable by the user
/// alone; checks the one there is whole.
fn own_node_counter(prefix: &str) -> Result<(), IpcError> {
    let path = node_counter(prefix);
    // Mode 0200 first: iceoryx2 takes a file it cannot read for one still being
    // initialized and waits, so a stage starting right now never reads half of it.
    match std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create_new(true)
        .mode(0o200)
        .custom_flags(libc::O_NOFOLLOW)
        .open(&path)
    {
        Ok(mut file) => {
            let mut bytes = [0u8; NODE_COUNTER_SIZE];
            bytes[..8].copy_from_slice(&NODE_COUNTER_VERSION.to_ne_bytes());
            file.write_all(&bytes)
                .and_then(|()| file.set_permissions(std::fs::Permissions::from_mode(0o600)))
                .map_err(|e| refuse(&path, format!("cannot write iceoryx2's node counter: {e}")))
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => check_node_counter(&path),
        Err(e) => Err(refuse(
            &path,
            format!("cannot create iceoryx2's node counter: {e}"),
        )),
    }
}

/// An existing node counter: the user's (checked by [`check_shm`] before), whole.
fn check_node_counter(path: &Path) -> Result<(), IpcError> {
    let meta = std::fs::symlink_metadata(path)
        .map_err(|e| refuse(path, format!("cannot look at iceoryx2's node counter: {e}")))?;
    if meta.uid() != euid() {
        return Err(foreign(path, meta.uid(), "node counter"));
    }
    if meta.mode() & 0o400 == 0 {
        // Being initialized by another process of the pipeline; iceoryx2 waits for it.
        return Ok(());
    }
    let mut version = [0u8; 8];
    let read = File::open(path).and_then(|f| {
        use std::os::unix::fs::FileExt;
        f.read_exact_at(&mut version, 0)
    });
    let version = u64::from_ne_bytes(version);
    if read.is_err() || meta.len() < NODE_COUNTER_SIZE as u64 || version != NODE_COUNTER_VERSION {
        return Err(refuse(
            path,
            format!(
                "iceoryx2's node counter is damaged ({} bytes, version field {version:#x}, \
                 expected {NODE_COUNTER_VERSION:#x}): no node of this pipeline can start \
                 until it is removed (rm {})",
                meta.len(),
                path.display()
            ),
        ));
    }
    Ok(())
}

/// Everything a process checks and makes before it joins the pipeline `config` names.
pub(crate) fn prepare(config: &IpcConfig) -> Result<(), IpcError> {
    private_root(Path::new(&config.root))?;
    check_shm(&config.prefix)?;
    own_node_counter(&config.prefix)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> IpcConfig {
        IpcConfig {
            root: format!("/tmp/airglyph-own-{}-{tag}/", std::process::id()),
            prefix: format!("agown{}{tag}_", std::process::id()),
        }
    }

    fn clean(cfg: &IpcConfig) {
        let _ = std::fs::remove_dir_all(&cfg.root);
        for f in shm_files(&cfg.prefix) {
            let _ = std::fs::remove_file(f);
        }
    }

    /// Pins what this module knows of iceoryx2's internals: the node counter iceoryx2
    /// itself makes is the file [`node_counter`] names, with the version and size
    /// [`own_node_counter`] writes. Fails after an upgrade of iceoryx2 that moved it.
    #[test]
    fn the_node_counter_is_where_and_what_iceoryx2_makes() {
        use iceoryx2::prelude::*;
        let cfg = scratch("pin");
        clean(&cfg);
        let iox = cfg.iceoryx2().unwrap();
        let node = NodeBuilder::new()
            .config(&iox)
            .create::<ipc::Service>()
            .unwrap();
        let made: Vec<String> = shm_files(&cfg.prefix)
            .iter()
            .filter_map(|p| Some(p.file_name()?.to_str()?.to_owned()))
            .filter(|n| n.ends_with("global_mgmt"))
            .collect();
        assert_eq!(made, vec![format!("{}{NODE_COUNTER_TAIL}", cfg.prefix)]);
        let bytes = std::fs::read(node_counter(&cfg.prefix)).unwrap();
        assert_eq!(bytes.len(), NODE_COUNTER_SIZE);
        assert_eq!(bytes[..8], NODE_COUNTER_VERSION.to_ne_bytes());
        drop(node);
        clean(&cfg);
    }

    #[test]
    fn the_root_is_made_closed_and_an_open_one_is_refused_by_name() {
        let cfg = scratch("root");
        prepare(&cfg).unwrap();
        let mode = std::fs::metadata(&cfg.root).unwrap().mode() & 0o777;
        assert_eq!(mode, 0o700);
        std::fs::set_permissions(&cfg.root, std::fs::Permissions::from_mode(0o755)).unwrap();
        let err = prepare(&cfg).unwrap_err().to_string();
        assert!(
            err.contains(cfg.root.trim_end_matches('/')) && err.contains("0755"),
            "{err}"
        );
        clean(&cfg);
    }

    #[test]
    fn the_node_counter_is_ours_alone_and_a_damaged_one_is_named() {
        let cfg = scratch("counter");
        prepare(&cfg).unwrap();
        let path = node_counter(&cfg.prefix);
        let meta = std::fs::metadata(&path).unwrap();
        assert_eq!(meta.mode() & 0o777, 0o600);
        assert_eq!(meta.len(), NODE_COUNTER_SIZE as u64);
        prepare(&cfg).unwrap();
        std::fs::write(&path, [0xffu8; 16]).unwrap();
        let err = prepare(&cfg).unwrap_err().to_string();
        assert!(
            err.contains(&path.display().to_string()) && err.contains("damaged"),
            "{err}"
        );
        clean(&cfg);
    }

    #[test]
    fn an_open_file_of_ours_is_closed() {
        let cfg = scratch("open");
        let path = Path::new(SHM_DIR).join(format!("{}leftover", cfg.prefix));
        std::fs::write(&path, b"x").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o666)).unwrap();
        check_shm(&cfg.prefix).unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().mode() & 0o777, 0o600);
        clean(&cfg);
    }
}
