//! One runtime per arm, decided before any hardware is touched: a second `jointctl run` of the
//! same arm must not open the buses or wake the drives (an NMT broadcast) of the one running.

use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// Why the arm's lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds it.
    #[error("arm `{arm}` is already running{}: stop it first (lock {})", .holder.map(|p| format!(" (process {p})")).unwrap_or_default(), .path.display())]
    AlreadyRunning {
        /// Arm name.
        arm: String,
        /// The lock file.
        path: PathBuf,
        /// The holder's process id, when it could be read.
        holder: Option<u32>,
    },
    /// The lock file or its folder could not be created or locked.
    #[error("cannot take the lock {} of arm `{arm}`", .path.display())]
    Io {
        /// Arm name.
        arm: String,
        /// The lock file.
        path: PathBuf,
        /// The OS error (permission denied names a folder of another user or group).
        source: std::io::Error,
    },
}

/// The arm's single-runtime lock, held until dropped. The kernel releases it when the process
/// ends in any way (SIGKILL included), so a crashed runtime never blocks a restart.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("lock-doc-{}", std::process::id()));
/// let lock = jointctl_runtime::lock::ArmLock::acquire(&dir, "doc-arm").unwrap();
/// assert!(jointctl_runtime::lock::ArmLock::acquire(&dir, "doc-arm").is_err());
/// drop(lock);
/// assert!(jointctl_runtime::lock::ArmLock::acquire(&dir, "doc-arm").is_ok());
/// ```
#[derive(Debug)]
pub struct ArmLock {
    _file: std::fs::File,
    path: PathBuf,
}

impl ArmLock {
    /// Takes `<dir>/<arm>.lock` (creating `dir` owner-only if missing) without waiting.
    pub fn acquire(dir: &Path, arm: &str) -> Result<Self, LockError> {
        let path = dir.join(format!("{arm}.lock"));
        let io = |source| LockError::Io { arm: arm.into(), path: path.clone(), source };
        std::fs::DirBuilder::new().recursive(true).mode(0o750).create(dir).map_err(io)?;
        let mut file =
            std::fs::OpenOptions::new().read(true).write(true).create(true).truncate(false).mode(0o600).open(&path).map_err(io)?;
        // SAFETY: flock on a file descriptor this function owns.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
                let mut text = String::new();
                let holder = file.read_to_string(&mut text).ok().and_then(|_| text.trim().parse().ok());
                return Err(LockError::AlreadyRunning { arm: arm.into(), path, holder });
            }
            return Err(io(e));
        }
        // The holder's pid, for the message a second runtime prints.
        let _ = file.set_len(0).and_then(|()| file.rewind()).and_then(|()| write!(file, "{}", std::process::id()));
        Ok(ArmLock { _file: file, path })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}
