//! One way to open a file a user names (a config, an include, a URDF, a plugin, a data file, a
//! recording, a credentials file).
//!
//! A path may name anything: a FIFO (reading it blocks until a writer comes, for ever), a
//! device (`/dev/zero` never ends: a reader without a limit eats the machine's memory), a
//! directory, or a file far larger than its kind can be. Every read of a user-named file goes
//! through [`read`] or [`read_to_string`], which refuse what is not a regular file before
//! reading a byte (the open itself does not block: `O_NONBLOCK`), and read at most the size
//! stated for its [`FileKind`].

#![warn(missing_docs)]
use std::io::Read;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

/// What a file is for: each kind has a size limit (see [`FileKind::limit_bytes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// An arm description (YAML).
    Config,
    /// A file a config includes (`params.include`, YAML).
    Include,
    /// A URDF kinematic description (XML).
    Urdf,
    /// A joint plugin (shared library).
    Plugin,
    /// Measured data (CSV).
    Data,
    /// A recording (MCAP).
    Recording,
    /// A file with a password or a key.
    Credentials,
}

impl FileKind {
    /// The largest file of this kind that is read [bytes]. Assumptions, each far above what the
    /// kind holds in practice and far below the memory of the smallest machine this runs on:
    /// a config, include or URDF of 16 MiB (the SHERPA arm's are under 20 KiB); a plugin of
    /// 512 MiB (a debug build with symbols is under 100 MiB); a data file of 4 GiB (a million
    /// rows of all eight columns is about 150 MiB); a recording of 8 GiB (an hour of the
    /// 7-DOF arm at 1 kHz is under 2 GiB); credentials of 64 KiB.
    ///
    /// ```
    /// use jointctl_files::FileKind;
    /// assert_eq!(FileKind::Config.limit_bytes(), 16 << 20);
    /// ```
    pub const fn limit_bytes(self) -> u64 {
        match self {
            FileKind::Config | FileKind::Include | FileKind::Urdf => 16 << 20,
            FileKind::Plugin => 512 << 20,
            FileKind::Data => 4 << 30,
            FileKind::Recording => 8 << 30,
            FileKind::Credentials => 64 << 10,
        }
    }

    /// The kind's name in messages.
    ///
    /// ```
    /// assert_eq!(jointctl_files::FileKind::Urdf.name(), "URDF");
    /// ```
    pub const fn name(self) -> &'static str {
        match self {
            FileKind::Config => "config",
            FileKind::Include => "included file",
            FileKind::Urdf => "URDF",
            FileKind::Plugin => "plugin",
            FileKind::Data => "data file",
            FileKind::Recording => "recording",
            FileKind::Credentials => "credentials file",
        }
    }
}

/// Why a user-named file was not read. Displayed as the file, then [`FileError::reason`].
#[derive(Debug)]
pub enum FileError {
    /// The file could not be opened or read.
    Io {
        /// The file.
        file: PathBuf,
        /// What it was for.
        kind: FileKind,
        /// The system's reason.
        source: std::io::Error,
    },
    /// Not a regular file (a FIFO, a device, a socket, a directory).
    NotRegular {
        /// The file.
        file: PathBuf,
        /// What it was for.
        kind: FileKind,
        /// What it is instead.
        what: &'static str,
    },
    /// Larger than its kind's limit.
    TooLarge {
        /// The file.
        file: PathBuf,
        /// What it was for.
        kind: FileKind,
    },
    /// Not UTF-8 text where text was expected.
    NotText {
        /// The file.
        file: PathBuf,
        /// What it was for.
        kind: FileKind,
    },
}

impl std::fmt::Display for FileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.file().display(), self.reason())
    }
}

impl std::error::Error for FileError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            FileError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl FileError {
    /// The file.
    ///
    /// ```
    /// let e = jointctl_files::read(std::path::Path::new("/dev/zero"), jointctl_files::FileKind::Data).unwrap_err();
    /// assert_eq!(e.file(), std::path::Path::new("/dev/zero"));
    /// ```
    pub fn file(&self) -> &Path {
        match self {
            FileError::Io { file, .. } | FileError::NotRegular { file, .. } | FileError::TooLarge { file, .. } | FileError::NotText { file, .. } => file,
        }
    }

    /// What is wrong, without the file's path (for errors that name the file themselves).
    ///
    /// ```
    /// let e = jointctl_files::read(std::path::Path::new("/dev/zero"), jointctl_files::FileKind::Data).unwrap_err();
    /// assert_eq!(e.reason(), "the data file is a character device, not a regular file");
    /// ```
    pub fn reason(&self) -> String {
        match self {
            FileError::Io { kind, source, .. } => format!("cannot read the {}: {source}", kind.name()),
            FileError::NotRegular { kind, what, .. } => format!("the {} is a {what}, not a regular file", kind.name()),
            FileError::TooLarge { kind, .. } => format!("the {} is larger than {} MiB, the limit for its kind", kind.name(), kind.limit_bytes() >> 20),
            FileError::NotText { kind, .. } => format!("the {} is not UTF-8 text", kind.name()),
        }
    }
}

/// The bytes of the regular file `path`, at most its kind's limit.
///
/// ```
/// use jointctl_files::{FileKind, read};
/// assert!(read(std::path::Path::new("/dev/urandom"), FileKind::Include).unwrap_err().to_string().contains("not a regular file"));
/// assert!(matches!(read(&std::env::temp_dir(), FileKind::Config), Err(jointctl_files::FileError::NotRegular { what: "directory", .. })));
/// ```
pub fn read(path: &Path, kind: FileKind) -> Result<Vec<u8>, FileError> {
    let (file, size) = open(path, kind)?;
    let io = |source| FileError::Io { file: path.into(), kind, source };
    // Read at most one byte past the limit: a file that grew since it was opened is caught too.
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(kind.limit_bytes() + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > kind.limit_bytes() {
        return Err(FileError::TooLarge { file: path.into(), kind });
    }
    Ok(bytes)
}

/// The text of the regular file `path` (UTF-8), at most its kind's limit.
///
/// ```
/// use jointctl_files::{FileKind, read_to_string};
/// let file = std::env::temp_dir().join(format!("jointctl-files-text-{}.yaml", std::process::id()));
/// std::fs::write(&file, "arm: a\n").unwrap();
/// assert_eq!(read_to_string(&file, FileKind::Config).unwrap(), "arm: a\n");
/// # std::fs::remove_file(&file).unwrap();
/// ```
pub fn read_to_string(path: &Path, kind: FileKind) -> Result<String, FileError> {
    String::from_utf8(read(path, kind)?).map_err(|_| FileError::NotText { file: path.into(), kind })
}

/// Opens `path` without blocking (a FIFO with no writer would block an ordinary open for ever)
/// and checks what it is on the open descriptor (no window between a check and the open).
fn open(path: &Path, kind: FileKind) -> Result<(std::fs::File, u64), FileError> {
    let io = |source| FileError::Io { file: path.into(), kind, source };
    let file = std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK).open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    let t = meta.file_type();
    if !t.is_file() {
        use std::os::unix::fs::FileTypeExt;
        let what = if t.is_dir() {
            "directory"
        } else if t.is_fifo() {
            "FIFO"
        } else if t.is_char_device() {
            "character device"
        } else if t.is_block_device() {
            "block device"
        } else if t.is_socket() {
            "socket"
        } else {
            "special file"
        };
        return Err(FileError::NotRegular { file: path.into(), kind, what });
    }
    if meta.len() > kind.limit_bytes() {
        return Err(FileError::TooLarge { file: path.into(), kind });
    }
    Ok((file, meta.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let fifo = std::env::temp_dir().join(format!("jointctl-files-fifo-{}", std::process::id()));
        let _ = std::fs::remove_file(&fifo);
        let c = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
        // SAFETY: `c` is a valid NUL-terminated path that outlives the call.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = read_to_string(&fifo, FileKind::Config).unwrap_err();
        std::fs::remove_file(&fifo).unwrap();
        assert!(matches!(e, FileError::NotRegular { what: "FIFO", .. }), "{e}");
        assert!(e.to_string().contains("config is a FIFO, not a regular file"), "{e}");
    }

    #[test]
    fn a_device_that_never_ends_is_refused_before_a_byte_is_read() {
        for dev in ["/dev/zero", "/dev/urandom"] {
            let e = read(Path::new(dev), FileKind::Plugin).unwrap_err();
            assert!(matches!(e, FileError::NotRegular { what: "character device", .. }), "{e}");
        }
    }

    #[test]
    fn a_file_beyond_its_kinds_limit_is_refused() {
        let file = std::env::temp_dir().join(format!("jointctl-files-big-{}", std::process::id()));
        // A sparse file of 17 MiB: no disk used.
        std::fs::File::create(&file).unwrap().set_len(17 << 20).unwrap();
        let e = read(&file, FileKind::Include).unwrap_err();
        std::fs::remove_file(&file).unwrap();
        assert!(matches!(e, FileError::TooLarge { .. }), "{e}");
        assert!(e.to_string().contains("larger than 16 MiB"), "{e}");
    }
}
