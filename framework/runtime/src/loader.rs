//! Finding, loading and checking plugin libraries.
//!
//! Libraries are never unloaded while the process runs (unloading code that may still be
//! referenced is how other plugin hosts crashed): a loaded [`libloading::Library`] is leaked on
//! purpose, once per file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use jointctl_api::abi::{ABI_MAGIC, ABI_MAJOR, ABI_MINOR, LAYOUT_HASH, PluginDescriptor};
use jointctl_api::{MAX_DOF, MAX_DRIVES, MAX_ENCODERS};

/// Where a plugin's code comes from.
#[derive(Clone, Debug)]
pub struct PluginSource {
    /// The descriptor (from a loaded library or linked statically).
    pub descriptor: &'static PluginDescriptor,
    /// The library it was loaded from; `None` when it is linked into the host.
    pub library: Option<PathBuf>,
}

/// Why a plugin could not be loaded.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LoadPluginError {
    /// No library for the plugin name in the search path.
    #[error("plugin `{name}` not found; looked for {candidates} in: {dirs}. Build it (cargo build -p jointctl-plugin-{name}) or give `plugin: {{name: {name}, path: ...}}`")]
    NotFound {
        /// Plugin name.
        name: String,
        /// File names tried.
        candidates: String,
        /// Folders searched.
        dirs: String,
    },
    /// dlopen failed.
    #[error("cannot load {file}: {reason}")]
    Open {
        /// Library file.
        file: PathBuf,
        /// What the dynamic loader said.
        reason: String,
    },
    /// The library has no entry point for this plugin name.
    #[error("{file} exports no jointctl plugin named `{name}` (symbol `{symbol}` missing): is it a jointctl plugin, built with export_joint_plugin!(name: {name}, ...)?")]
    NoEntry {
        /// Library file.
        file: PathBuf,
        /// Plugin name.
        name: String,
        /// Symbol looked up.
        symbol: String,
    },
    /// The library is not a jointctl plugin (wrong magic).
    #[error("{file} is not a jointctl plugin library (bad descriptor magic {magic:#018x})")]
    BadMagic {
        /// Library file.
        file: PathBuf,
        /// What was found.
        magic: u64,
    },
    /// ABI versions differ.
    #[error("{file} was built for jointctl plugin ABI {found_major}.{found_minor} (jointctl-api {api}), this host speaks ABI {host_major}.{host_minor}: rebuild the plugin against jointctl-api {host_major}.x (cargo build in the plugin's crate)")]
    AbiVersion {
        /// Library file.
        file: PathBuf,
        /// Library's ABI major.
        found_major: u32,
        /// Library's ABI minor.
        found_minor: u32,
        /// Host ABI major.
        host_major: u32,
        /// Host ABI minor.
        host_minor: u32,
        /// jointctl-api version of the library.
        api: String,
    },
    /// ABI versions agree but the shared types differ.
    #[error("{file} has ABI {major}.{minor} but a different layout of the shared types (layout hash {found:#018x}, host {host:#018x}): it was built against a modified jointctl-api; rebuild it against this host's jointctl-api")]
    Layout {
        /// Library file.
        file: PathBuf,
        /// ABI major.
        major: u32,
        /// ABI minor.
        minor: u32,
        /// Library's hash.
        found: u64,
        /// Host's hash.
        host: u64,
    },
    /// The descriptor declares roles or DOFs this host cannot wire.
    #[error("{file}: plugin `{name}` declares {problem}: rebuild it with at most {max_encoders} encoder and {max_drives} drive roles, each named once, and 1 to {max_dof} DOFs")]
    Roles {
        /// Library file.
        file: PathBuf,
        /// Plugin name.
        name: String,
        /// What is wrong with its declaration.
        problem: String,
        /// [`jointctl_api::MAX_ENCODERS`].
        max_encoders: usize,
        /// [`jointctl_api::MAX_DRIVES`].
        max_drives: usize,
        /// [`jointctl_api::MAX_DOF`].
        max_dof: usize,
    },
    /// The file is not a complete shared library for this machine: mapping it could kill the
    /// host (a truncated library raises SIGBUS when the loader touches a missing page).
    #[error("{file} is not a loadable plugin library: {reason}; rebuild it or copy it again")]
    Malformed {
        /// Library file.
        file: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The library was built with `panic = "abort"`: a panic in it would end the host instead
    /// of faulting one joint.
    #[error("{file}: plugin `{name}` was built with panic = \"abort\", so one panic in it would kill the whole runtime; build it with panic = \"unwind\" (the default)")]
    PanicAbort {
        /// Library file.
        file: PathBuf,
        /// Plugin name.
        name: String,
    },
    /// The descriptor's name differs from the name asked for.
    #[error("{file} exports plugin `{found}` under the entry for `{name}`")]
    NameMismatch {
        /// Library file.
        file: PathBuf,
        /// Name asked for.
        name: String,
        /// Name in the descriptor.
        found: String,
    },
}

/// Checks a descriptor against this host. Reads only the header until it is known good.
///
/// # Safety
/// `descriptor` must point at a readable descriptor header.
pub unsafe fn check_descriptor(
    descriptor: *const PluginDescriptor,
    file: &Path,
    name: &str,
) -> Result<&'static PluginDescriptor, LoadPluginError> {
    // SAFETY: the caller guarantees the header is readable; nothing past it is read before the
    // magic, version and layout hash are checked.
    let header = unsafe { (*descriptor).header() };
    if header.magic() != ABI_MAGIC {
        return Err(LoadPluginError::BadMagic { file: file.into(), magic: header.magic() });
    }
    if header.abi_major() != ABI_MAJOR || header.abi_minor() > ABI_MINOR {
        // The header layout is stable across ABI versions, so its version string can be read.
        let api = header.api_version().to_string();
        return Err(LoadPluginError::AbiVersion {
            file: file.into(),
            found_major: header.abi_major(),
            found_minor: header.abi_minor(),
            host_major: ABI_MAJOR,
            host_minor: ABI_MINOR,
            api,
        });
    }
    if header.layout_hash() != LAYOUT_HASH {
        return Err(LoadPluginError::Layout {
            file: file.into(),
            major: header.abi_major(),
            minor: header.abi_minor(),
            found: header.layout_hash(),
            host: LAYOUT_HASH,
        });
    }
    // SAFETY: the layout matches this host's, so the whole descriptor can be read.
    let d: &'static PluginDescriptor = unsafe { &*descriptor };
    let found = d.name();
    if found != name {
        return Err(LoadPluginError::NameMismatch { file: file.into(), name: name.into(), found: found.into() });
    }
    if !d.built_with_unwind() {
        return Err(LoadPluginError::PanicAbort { file: file.into(), name: name.into() });
    }
    if let Some(problem) = declaration_problem(d) {
        return Err(LoadPluginError::Roles {
            file: file.into(),
            name: name.into(),
            problem,
            max_encoders: MAX_ENCODERS,
            max_drives: MAX_DRIVES,
            max_dof: MAX_DOF,
        });
    }
    Ok(d)
}

/// What is wrong with a descriptor's DOF count and role lists, if anything: the host wires at
/// most [`MAX_ENCODERS`] encoders and [`MAX_DRIVES`] drives per instance (optional roles
/// included, since the YAML may wire them), each role named once.
fn declaration_problem(d: &PluginDescriptor) -> Option<String> {
    if d.dof() == 0 || d.dof() as usize > MAX_DOF {
        return Some(format!("{} DOFs", d.dof()));
    }
    for (kind, text, max) in [("encoder", d.encoder_roles(), MAX_ENCODERS), ("drive", d.drive_roles(), MAX_DRIVES)] {
        let names: Vec<&str> = text.split(',').filter(|r| !r.is_empty()).map(|r| r.strip_suffix('?').unwrap_or(r)).collect();
        if names.len() > max {
            return Some(format!("{} {kind} roles ({text})", names.len()));
        }
        if let Some(bad) = names.iter().find(|n| n.is_empty() || !n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')) {
            return Some(format!("the {kind} role `{bad}` (names are letters, digits and `_`)"));
        }
        if let Some((_, dup)) = names.iter().enumerate().find(|(i, n)| names[..*i].contains(n)) {
            return Some(format!("the {kind} role `{dup}` twice"));
        }
    }
    None
}

/// Finds and loads plugins; remembers statically linked ones.
#[derive(Default)]
pub struct PluginLoader {
    search_dirs: Vec<PathBuf>,
    statics: HashMap<String, &'static PluginDescriptor>,
}

static LOADED: Mutex<Vec<(PathBuf, &'static libloading::Library)>> = Mutex::new(Vec::new());

impl PluginLoader {
    /// A loader searching, in order: `extra_dirs`, `$JOINTCTL_PLUGIN_PATH` (colon-separated),
    /// the executable's folder and its parent (so that `target/debug/deps/test` finds
    /// `target/debug/*.so`).
    pub fn new(extra_dirs: impl IntoIterator<Item = PathBuf>) -> Self {
        let mut dirs: Vec<PathBuf> = extra_dirs.into_iter().collect();
        if let Some(path) = std::env::var_os("JOINTCTL_PLUGIN_PATH") {
            dirs.extend(std::env::split_paths(&path));
        }
        if let Ok(exe) = std::env::current_exe()
            && let Some(dir) = exe.parent()
        {
            dirs.push(dir.to_path_buf());
            if let Some(parent) = dir.parent() {
                dirs.push(parent.to_path_buf());
            }
        }
        PluginLoader { search_dirs: dirs, statics: HashMap::new() }
    }

    /// Registers a statically linked plugin; a YAML `plugin: NAME` without a path then uses it
    /// instead of searching for a library.
    pub fn register_static(&mut self, descriptor: &'static PluginDescriptor) -> Result<(), LoadPluginError> {
        let name = descriptor.name().to_string();
        // SAFETY: a reference is a readable pointer.
        let d = unsafe { check_descriptor(descriptor, Path::new("<statically linked>"), &name)? };
        self.statics.insert(name, d);
        Ok(())
    }

    /// The folders searched for libraries.
    pub fn search_dirs(&self) -> &[PathBuf] {
        &self.search_dirs
    }

    /// The plugin `name`, from `path` when given, else a static registration, else the search path.
    pub fn load(&self, name: &str, path: Option<&Path>) -> Result<PluginSource, LoadPluginError> {
        if path.is_none()
            && let Some(d) = self.statics.get(name)
        {
            return Ok(PluginSource { descriptor: d, library: None });
        }
        let file = match path {
            Some(p) => p.to_path_buf(),
            None => self.find(name)?,
        };
        let library = load_library(&file)?;
        let symbol = format!("jointctl_plugin_{name}");
        // SAFETY: the symbol, if present, is the entry generated by export_joint_plugin!, an
        // `extern "C" fn() -> *const PluginDescriptor`.
        let entry = unsafe { library.get::<unsafe extern "C" fn() -> *const PluginDescriptor>(symbol.as_bytes()) }
            .map_err(|_| LoadPluginError::NoEntry { file: file.clone(), name: name.into(), symbol: symbol.clone() })?;
        // SAFETY: calling the entry has no preconditions; it returns a 'static descriptor.
        let descriptor = unsafe { entry() };
        // SAFETY: the library stays loaded forever, so its descriptor is 'static.
        let d = unsafe { check_descriptor(descriptor, &file, name)? };
        Ok(PluginSource { descriptor: d, library: Some(file) })
    }

    fn find(&self, name: &str) -> Result<PathBuf, LoadPluginError> {
        let candidates = [format!("libjointctl_plugin_{name}.so"), format!("lib{name}.so")];
        for dir in &self.search_dirs {
            for c in &candidates {
                let p = dir.join(c);
                if p.is_file() {
                    return Ok(p);
                }
            }
        }
        Err(LoadPluginError::NotFound {
            name: name.into(),
            candidates: candidates.join(" or "),
            dirs: self.search_dirs.iter().map(|d| d.display().to_string()).collect::<Vec<_>>().join(", "),
        })
    }
}

/// The ELF machine this host runs on.
const HOST_MACHINE: u16 = if cfg!(target_arch = "x86_64") {
    object::elf::EM_X86_64
} else if cfg!(target_arch = "aarch64") {
    object::elf::EM_AARCH64
} else if cfg!(target_arch = "arm") {
    object::elf::EM_ARM
} else {
    object::elf::EM_NONE
};

/// Checks, from the file's bytes and before the dynamic loader maps it, that a library is a
/// complete 64-bit ELF shared object for this machine: every segment and section the loader
/// could touch lies inside the file. A truncated library otherwise kills the host with SIGBUS.
/// The runtime loads the bytes it checked (see [`private_copy`]), so a file replaced after the
/// check is not what runs.
pub fn check_library_file(file: &Path) -> Result<(), LoadPluginError> {
    let data = jointctl_files::read(file, jointctl_files::FileKind::Plugin).map_err(|e| LoadPluginError::Open { file: file.into(), reason: e.to_string() })?;
    check_library_bytes(file, &data)
}

/// [`check_library_file`] on bytes already read from `file`.
fn check_library_bytes(file: &Path, data: &[u8]) -> Result<(), LoadPluginError> {
    use object::read::elf::{ElfFile64, FileHeader, ProgramHeader, SectionHeader};
    let bad = |reason: String| LoadPluginError::Malformed { file: file.into(), reason };
    let elf = ElfFile64::<object::Endianness>::parse(data).map_err(|e| bad(format!("not a complete 64-bit ELF file ({e})")))?;
    let (header, endian) = (elf.elf_header(), elf.endian());
    if header.e_type(endian) != object::elf::ET_DYN {
        return Err(bad("not a shared library (ELF type is not ET_DYN)".into()));
    }
    if cfg!(target_os = "linux") && HOST_MACHINE != object::elf::EM_NONE && header.e_machine(endian) != HOST_MACHINE {
        return Err(bad(format!("built for ELF machine {}, this host is {HOST_MACHINE}", header.e_machine(endian))));
    }
    let len = data.len() as u64;
    for (i, ph) in elf.elf_program_headers().iter().enumerate() {
        let (offset, size) = (ph.p_offset(endian), ph.p_filesz(endian));
        if offset.checked_add(size).is_none_or(|end| end > len) {
            return Err(bad(format!("truncated: segment {i} needs bytes {offset}..{} of a {len}-byte file", offset.saturating_add(size))));
        }
    }
    for (i, sh) in elf.elf_section_table().iter().enumerate() {
        if sh.sh_type(endian) == object::elf::SHT_NOBITS {
            continue;
        }
        let (offset, size) = (sh.sh_offset(endian), sh.sh_size(endian));
        if offset.checked_add(size).is_none_or(|end| end > len) {
            return Err(bad(format!("truncated: section {i} needs bytes {offset}..{} of a {len}-byte file", offset.saturating_add(size))));
        }
    }
    Ok(())
}

/// The checked bytes of a library in an anonymous in-memory file, the one the dynamic loader
/// maps. Mapping the plugin's own file tied the running code to it: overwriting it in place
/// while the runtime ran (`cp new.so plugin.so` truncates and rewrites the same file) changed the
/// mapped pages under the running code, and the host died with SIGSEGV (issue 40, finding 5).
/// A library that loads others relative to itself (`$ORIGIN`) would not find them from here;
/// jointctl plugins link only the C library.
fn private_copy(data: &[u8]) -> std::io::Result<std::fs::File> {
    use std::io::Write as _;
    use std::os::fd::FromRawFd as _;
    // SAFETY: a valid NUL-terminated name; the new descriptor is owned by the File below.
    let fd = unsafe { libc::memfd_create(c"jointctl-plugin".as_ptr(), libc::MFD_CLOEXEC) };
    if fd < 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: `fd` was just created and is owned by nothing else.
    let mut file = unsafe { std::fs::File::from_raw_fd(fd) };
    file.write_all(data)?;
    Ok(file)
}

/// Why a library's bytes were refused, or could not be loaded, before the host loaded them (in
/// a probe process, or in the host from its private copy).
#[derive(Debug, thiserror::Error)]
pub enum ProbeError {
    /// The bytes fail the structure check.
    #[error(transparent)]
    Malformed(Box<LoadPluginError>),
    /// The private copy the library is loaded from could not be made.
    #[error("cannot make the private copy it is loaded from: {0}")]
    PrivateCopy(#[source] std::io::Error),
    /// The dynamic loader refused the library.
    #[error(transparent)]
    Load(libloading::Error),
    /// Loading did not return in a probe process.
    #[error("loading it did not finish in {seconds} s in a probe process")]
    TimedOut {
        /// How long the probe was given [s].
        seconds: u64,
    },
    /// Loading killed a probe process.
    #[error("loading it killed a probe process with {signal} before this process loaded it (the dynamic loader trusts its relocations and dynamic section, and they are corrupt); rebuild it or copy it again")]
    Killed {
        /// The signal's name (SIGSEGV, ...).
        signal: String,
    },
}

/// Loads a library's bytes through a [`private_copy`], which stays open as the library stays
/// loaded: a descriptor closed here is the next copy's, and the dynamic loader, which knows a
/// loaded library by its path, handed the next plugin the first one's library.
fn load_private_copy(data: &[u8]) -> Result<libloading::Library, ProbeError> {
    let copy = private_copy(data).map_err(ProbeError::PrivateCopy)?;
    // SAFETY: loading a library runs its initialisers; jointctl plugins have none beyond Rust's
    // (and a probe process loads a library precisely to die in the host's place).
    let lib = unsafe { libloading::Library::new(format!("/proc/self/fd/{}", std::os::fd::AsRawFd::as_raw_fd(&copy))) }.map_err(ProbeError::Load)?;
    std::mem::forget(copy);
    Ok(lib)
}

/// Loads a library's bytes somewhere the host survives, before the host loads them: the
/// structure check cannot see everything the dynamic loader trusts (relocations that point out
/// of the library crashed `check` and `run` inside it, exit 139, issue 40, finding 4). `Err`
/// says why the library is refused.
pub type Probe = fn(&[u8]) -> Result<(), ProbeError>;

static PROBE: std::sync::OnceLock<Probe> = std::sync::OnceLock::new();

/// Sets the probe every library passes before this process loads it (once; the `jointctl`
/// binary loads each library first in a short-lived child of itself). Without one, a library is
/// loaded after the structure check alone.
///
/// ```
/// fn accept(_: &[u8]) -> Result<(), jointctl_runtime::loader::ProbeError> { Ok(()) }
/// jointctl_runtime::loader::set_probe(accept);
/// ```
pub fn set_probe(probe: Probe) {
    let _ = PROBE.set(probe);
}

/// What a probe process does with a library's bytes: loads them from a private copy, as the
/// host would. It returns if the load returns; the caller's process dies where the host would.
pub fn probe_load(data: &[u8]) -> Result<(), ProbeError> {
    check_library_bytes(Path::new("<probe>"), data).map_err(|e| ProbeError::Malformed(Box::new(e)))?;
    std::mem::forget(load_private_copy(data)?);
    Ok(())
}

fn load_library(file: &Path) -> Result<&'static libloading::Library, LoadPluginError> {
    let canonical = file.canonicalize().map_err(|e| LoadPluginError::Open { file: file.into(), reason: e.to_string() })?;
    let mut loaded = LOADED.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((_, lib)) = loaded.iter().find(|(p, _)| *p == canonical) {
        return Ok(lib);
    }
    let data = jointctl_files::read(&canonical, jointctl_files::FileKind::Plugin).map_err(|e| LoadPluginError::Open { file: file.into(), reason: e.to_string() })?;
    check_library_bytes(&canonical, &data)?;
    if let Some(probe) = PROBE.get() {
        probe(&data).map_err(|e| LoadPluginError::Malformed { file: file.into(), reason: e.to_string() })?;
    }
    let lib = load_private_copy(&data).map_err(|e| LoadPluginError::Open { file: file.into(), reason: e.to_string() })?;
    // Never unloaded: see the module docs.
    let lib: &'static libloading::Library = Box::leak(Box::new(lib));
    loaded.push((canonical, lib));
    Ok(lib)
}
