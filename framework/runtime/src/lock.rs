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
    /// A runtime of the same arm name runs on this machine in another domain or root.
    #[error("arm `{arm}` is already running on this machine{} in another domain or ipc.root: one runtime per arm name, whatever the domain (two would drive the same drives); stop it first (lock {})", .holder.map(|p| format!(" (process {p})")).unwrap_or_default(), .path.display())]
    RunningElsewhere {
        /// Arm name.
        arm: String,
        /// The lock file.
        path: PathBuf,
        /// The holder's process id, when it could be read.
        holder: Option<u32>,
    },
    /// Another runtime drives the CAN interface (whatever its arm, domain or root).
    #[error("CAN interface `{interface}` is driven by another runtime{}: two hosts on one bus would both command its drives; stop it first (lock {})", .holder.map(|p| format!(" (process {p})")).unwrap_or_default(), .path.display())]
    BusInUse {
        /// The interface.
        interface: String,
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

/// Whether [`take`] got a lock.
enum Taken {
    /// This process holds it now.
    Yes,
    /// Another process holds it (its id, when the file says).
    By(Option<u32>),
}

/// Takes the exclusive lock of an open lock file without waiting and writes this process's id
/// into it (for the message another runtime prints), or reads the holder's.
fn take(file: &mut std::fs::File) -> std::io::Result<Taken> {
    // SAFETY: flock on a file descriptor the caller owns.
    if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
        let e = std::io::Error::last_os_error();
        if e.raw_os_error() != Some(libc::EWOULDBLOCK) {
            return Err(e);
        }
        let mut text = String::new();
        return Ok(Taken::By(file.read_to_string(&mut text).ok().and_then(|_| text.trim().parse().ok())));
    }
    let _ = file.set_len(0).and_then(|()| file.rewind()).and_then(|()| write!(file, "{}", std::process::id()));
    Ok(Taken::Yes)
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
/// # std::fs::remove_dir_all(&dir).unwrap();
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
        match take(&mut file).map_err(io)? {
            Taken::Yes => Ok(ArmLock { _file: file, path }),
            Taken::By(holder) => Err(LockError::AlreadyRunning { arm: arm.into(), path, holder }),
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// The folder of the machine's arm and bus locks, the same for every domain and root: `/run/lock/jointctl`
/// (the system's folder for device locks), or `jointctl-locks` in the temporary folder where
/// there is none.
pub fn machine_lock_dir() -> PathBuf {
    let run_lock = Path::new("/run/lock");
    if run_lock.is_dir() { run_lock.join("jointctl") } else { std::env::temp_dir().join("jointctl-locks") }
}

/// Opens (creating) `<dir>/<name>` for a machine-wide lock. `dir` is made sticky and open to
/// every user (as `/run/lock` is): another user's runtime must find, not be refused, the lock.
fn open_machine_lock(dir: &Path, name: &str, label: &str) -> Result<(std::fs::File, PathBuf), LockError> {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join(name);
    let io = |source| LockError::Io { arm: label.into(), path: path.clone(), source };
    if !dir.is_dir() {
        std::fs::DirBuilder::new().recursive(true).mode(0o755).create(dir).map_err(io)?;
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o1777)).map_err(io)?;
    }
    let file = match std::fs::OpenOptions::new().read(true).write(true).create(true).truncate(false).mode(0o644).open(&path) {
        Ok(f) => f,
        // Another user's lock file: readable, and a read-only descriptor locks as well.
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => std::fs::File::open(&path).map_err(io)?,
        Err(e) => return Err(io(e)),
    };
    Ok((file, path))
}

/// A machine-wide lock, held until dropped: a CAN interface's ([`MachineLock::bus`]) or an arm
/// name's ([`MachineLock::arm`]). The arm's [`ArmLock`] is per domain and root: a copy of a
/// SocketCAN config in another domain went on to open `can0` beside the running arm, and the
/// same arm ran twice in two domains (issue 40, finding 16).
///
/// ```
/// let dir = std::env::temp_dir().join(format!("bus-doc-{}", std::process::id()));
/// let lock = jointctl_runtime::lock::MachineLock::bus(&dir, "vcan9").unwrap();
/// assert!(jointctl_runtime::lock::MachineLock::bus(&dir, "vcan9").is_err());
/// let arm = jointctl_runtime::lock::MachineLock::arm(&dir, "doc-arm").unwrap();
/// assert!(jointctl_runtime::lock::MachineLock::arm(&dir, "doc-arm").is_err());
/// drop((lock, arm));
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Debug)]
pub struct MachineLock {
    _file: std::fs::File,
}

impl MachineLock {
    /// Takes `<dir>/can-<interface>.lock` without waiting.
    pub fn bus(dir: &Path, interface: &str) -> Result<Self, LockError> {
        Self::take(dir, &format!("can-{interface}.lock"), &format!("CAN interface {interface}"), |path, holder| LockError::BusInUse { interface: interface.into(), path, holder })
    }

    /// Takes `<dir>/arm-<arm>.lock` without waiting (arm names are letters, digits, `_` and `-`).
    pub fn arm(dir: &Path, arm: &str) -> Result<Self, LockError> {
        Self::take(dir, &format!("arm-{arm}.lock"), arm, |path, holder| LockError::RunningElsewhere { arm: arm.into(), path, holder })
    }

    /// Takes `<dir>/<name>`; `held` is the error when another process holds it.
    fn take(dir: &Path, name: &str, label: &str, held: impl FnOnce(PathBuf, Option<u32>) -> LockError) -> Result<Self, LockError> {
        let (mut file, path) = open_machine_lock(dir, name, label)?;
        match take(&mut file).map_err(|source| LockError::Io { arm: label.into(), path: path.clone(), source })? {
            Taken::Yes => Ok(MachineLock { _file: file }),
            Taken::By(holder) => Err(held(path, holder)),
        }
    }
}

/// The process holding arm `arm`'s lock in `dir`, if a runtime holds it: the lock is tried, not
/// trusted from the file alone (a pid left by a crashed runtime may belong to another process
/// by now).
///
/// ```
/// let dir = std::env::temp_dir().join(format!("holder-doc-{}", std::process::id()));
/// assert_eq!(jointctl_runtime::lock::holder(&dir, "doc-arm"), None);
/// let lock = jointctl_runtime::lock::ArmLock::acquire(&dir, "doc-arm").unwrap();
/// // flock locks belong to the open file: a second open sees it held, even in this process.
/// assert_eq!(jointctl_runtime::lock::holder(&dir, "doc-arm"), Some(std::process::id()));
/// drop(lock);
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn holder(dir: &Path, arm: &str) -> Option<u32> {
    let mut file = std::fs::File::open(dir.join(format!("{arm}.lock"))).ok()?;
    // SAFETY: flock on a file descriptor this function owns.
    if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_SH | libc::LOCK_NB) } == 0 {
        // Nobody holds it (dropping the file releases the shared lock just taken).
        return None;
    }
    let mut text = String::new();
    file.read_to_string(&mut text).ok()?;
    text.trim().parse().ok()
}

/// Asks the runtime holding arm `arm`'s lock to stop with SIGTERM (it holds the joints,
/// publishes a final sample and releases shared memory, as for every terminating signal).
/// The path `jointctl cmd stop` takes when the command service has no free client slot, so
/// that idle clients can never lock out a stop. Returns the runtime's process id.
pub fn signal_stop(dir: &Path, arm: &str) -> Result<u32, std::io::Error> {
    let pid = holder(dir, arm).ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, format!("no runtime holds the lock of arm `{arm}`")))?;
    // SAFETY: kill has no memory-safety preconditions.
    if unsafe { libc::kill(pid as libc::pid_t, libc::SIGTERM) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(pid)
}
