//! Who may touch an arm's shared memory. iceoryx2 0.10 makes every file of a domain readable
//! by its owner only, except one: the domain's management segment in `/dev/shm`, which it
//! creates world-writable (mode 0666). Any local user could overwrite it and lock every
//! process out of the domain (`UnableToGenerateUniqueNodeId`). So, around iceoryx2:
//! - the root folder (`ipc.root`) is created owner-only (or 0750 for `ipc.group`) and refused
//!   when another user owns it or others may write it;
//! - the management segment is made owner-only as soon as it exists, and refused when another
//!   user created it (squatting);
//! - permission failures name the file, its owner and mode, instead of "InternalError".
//!
//! A small window remains between iceoryx2 creating the segment and this module closing it;
//! it is open only while the first process of a domain starts.

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Where iceoryx2 keeps POSIX shared memory on Linux.
const SHM_DIR: &str = "/dev/shm";

/// Why a domain's shared memory is not safe or not accessible.
#[derive(Debug, thiserror::Error)]
pub enum AccessError {
    /// A file or folder of the domain belongs to another user.
    #[error("{} belongs to uid {owner} (mode {mode:04o}), not to this process' uid {me}: {advice}", .path.display())]
    ForeignOwner {
        /// The file or folder.
        path: PathBuf,
        /// Its owner.
        owner: u32,
        /// Its permission bits.
        mode: u32,
        /// This process' effective uid.
        me: u32,
        /// What to do.
        advice: &'static str,
    },
    /// The root folder lets other users create or replace files in it.
    #[error("{} is writable by other users (mode {mode:04o}): they could replace the arm's shared memory or make its folders first; chmod o-w it or name a folder of your own (ipc.root)", .path.display())]
    OpenToOthers {
        /// The folder.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
    /// `ipc.group` names no group of this machine.
    #[error("group `{0}` (ipc.group) does not exist on this machine (see /etc/group)")]
    UnknownGroup(String),
    /// A file operation failed.
    #[error("{what} {}", .path.display())]
    Io {
        /// What was done.
        what: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
}

/// This process' effective uid: the owner of `/proc/self` (no libc needed).
pub fn effective_uid() -> u32 {
    std::fs::metadata("/proc/self").map(|m| m.uid()).unwrap_or(u32::MAX)
}

/// A group's id from its name or number, looked up in `/etc/group`.
fn group_id(group: &str) -> Result<u32, AccessError> {
    if let Ok(gid) = group.parse() {
        return Ok(gid);
    }
    let text = std::fs::read_to_string("/etc/group").unwrap_or_default();
    text.lines()
        .filter_map(|l| {
            let mut f = l.split(':');
            Some((f.next()?, f.nth(1)?))
        })
        .find(|(name, _)| *name == group)
        .and_then(|(_, gid)| gid.parse().ok())
        .ok_or_else(|| AccessError::UnknownGroup(group.to_string()))
}

/// Creates the root folder if missing (mode 0700, or 0750 with `group` as its group) and
/// checks one that exists: it must belong to this user (or root) and not be writable by others.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("root-doc-{}", std::process::id()));
/// // A process id comes back: a folder left by an earlier run is not this run's.
/// let _ = std::fs::remove_dir_all(&dir);
/// jointctl_ipc::access::secure_root(&dir, None).unwrap();
/// use std::os::unix::fs::PermissionsExt;
/// assert_eq!(std::fs::metadata(&dir).unwrap().permissions().mode() & 0o777, 0o700);
/// std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
/// assert!(jointctl_ipc::access::secure_root(&dir, None).is_err());
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn secure_root(root: &Path, group: Option<&str>) -> Result<(), AccessError> {
    let io = |what, source| AccessError::Io { what, path: root.to_path_buf(), source };
    let gid = group.map(group_id).transpose()?;
    if !root.exists() {
        use std::os::unix::fs::DirBuilderExt;
        let mode = if gid.is_some() { 0o750 } else { 0o700 };
        std::fs::DirBuilder::new().recursive(true).mode(mode).create(root).map_err(|e| io("cannot create", e))?;
        // The umask may have removed bits; set exactly.
        std::fs::set_permissions(root, std::fs::Permissions::from_mode(mode)).map_err(|e| io("cannot set the mode of", e))?;
        if let Some(gid) = gid {
            std::os::unix::fs::chown(root, None, Some(gid)).map_err(|e| io("cannot give the group to", e))?;
        }
    }
    let meta = std::fs::metadata(root).map_err(|e| io("cannot read", e))?;
    let me = effective_uid();
    if meta.uid() != me && meta.uid() != 0 {
        return Err(AccessError::ForeignOwner {
            path: root.to_path_buf(),
            owner: meta.uid(),
            mode: meta.mode() & 0o7777,
            me,
            advice: "run as that user, or name a root of your own (ipc.root)",
        });
    }
    // Sticky or not: in a sticky folder (`ipc.root: /tmp`) another user could not replace the
    // arm's files, but could make its `services/`, `nodes/` and `jointctl/` folders first, open
    // to all, and empty them later, cutting every client off a running arm (issue 40, finding 15).
    if meta.mode() & 0o002 != 0 {
        return Err(AccessError::OpenToOthers { path: root.to_path_buf(), mode: meta.mode() & 0o7777 });
    }
    Ok(())
}

/// The management segment of the domain with file prefix `prefix`, if it exists:
/// `<prefix><40 hex digits>_node.<version>.global_mgmt` in `/dev/shm`.
pub fn management_segment(prefix: &str) -> Option<PathBuf> {
    let entries = std::fs::read_dir(SHM_DIR).ok()?;
    entries.filter_map(Result::ok).map(|e| e.path()).find(|p| {
        let Some(name) = p.file_name().and_then(|n| n.to_str()) else { return false };
        let Some(rest) = name.strip_prefix(prefix) else { return false };
        rest.len() > 40
            && rest.as_bytes()[..40].iter().all(u8::is_ascii_hexdigit)
            && rest[40..].starts_with("_node.")
            && rest.ends_with(".global_mgmt")
    })
}

/// Checks the domain's management segment before a node is created: if it exists, it must
/// belong to this user (or root); another user's segment was planted (or the domain is theirs).
pub fn check_management_segment(prefix: &str) -> Result<(), AccessError> {
    let Some(path) = management_segment(prefix) else { return Ok(()) };
    let meta = std::fs::metadata(&path).map_err(|source| AccessError::Io { what: "cannot read", path: path.clone(), source })?;
    let me = effective_uid();
    if meta.uid() != me && meta.uid() != 0 {
        return Err(AccessError::ForeignOwner {
            path,
            owner: meta.uid(),
            mode: meta.mode() & 0o7777,
            me,
            advice: "another user created this domain's management segment; have it removed (by that user or root), or use another ipc.domain",
        });
    }
    Ok(())
}

/// Makes the domain's management segment owner-only once iceoryx2 created it, if it is ours.
pub fn close_management_segment(prefix: &str) -> Result<(), AccessError> {
    let Some(path) = management_segment(prefix) else { return Ok(()) };
    let meta = std::fs::metadata(&path).map_err(|source| AccessError::Io { what: "cannot read", path: path.clone(), source })?;
    if meta.uid() == effective_uid() && meta.mode() & 0o077 != 0 {
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600))
            .map_err(|source| AccessError::Io { what: "cannot make owner-only", path, source })?;
    }
    Ok(())
}
