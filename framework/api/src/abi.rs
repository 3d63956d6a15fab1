//! The plugin ABI: what crosses the shared-library boundary.
//!
//! Only `#[repr(C)]` data and `extern "C"` functions cross it. A plugin library exports one
//! function, `jointctl_plugin_<name>`, returning a `'static` [`PluginDescriptor`]. The host checks
//! the [`DescriptorHeader`] (magic, ABI version, layout hash) before it reads anything else.
//! The shims below are generated per plugin type by
//! [`export_joint_plugin!`](crate::export_joint_plugin); they catch panics so that a panic never
//! unwinds across the boundary, and each side frees only what it allocated (the plugin's
//! instance is freed by the plugin's `destroy`; error text is written into a host-owned buffer).

use core::ffi::{CStr, c_char, c_void};
use core::mem::{align_of, offset_of, size_of};
use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::{
    DriveReading, JointCommand, JointContext, JointFault, JointPlugin, JointState, MotorSetpoint, PluginError,
    RawJointView, Reading,
};

/// First 8 bytes of every descriptor: "JNTCTL" + format 1.
pub const ABI_MAGIC: u64 = u64::from_le_bytes(*b"JNTCTL\x00\x01");
/// Bumped on any incompatible change of the shared types or entry points.
pub const ABI_MAJOR: u32 = 1;
/// Bumped on compatible additions; a host accepts plugins with a minor version up to its own.
pub const ABI_MINOR: u32 = 1;
/// Version of the `jointctl-api` crate the library was built against.
pub const API_VERSION: &str = env!("CARGO_PKG_VERSION");
const API_VERSION_C: &CStr = c_string(concat!(env!("CARGO_PKG_VERSION"), "\0"));

/// A `'static` C string from a literal that ends in exactly one NUL; anything else is refused
/// when the constant is evaluated (at compile time in [`export_joint_plugin!`]).
///
/// ```
/// assert_eq!(jointctl_api::abi::c_string("motor\0").to_str(), Ok("motor"));
/// ```
pub const fn c_string(text: &'static str) -> &'static CStr {
    match CStr::from_bytes_with_nul(text.as_bytes()) {
        Ok(c) => c,
        Err(_) => panic!("a descriptor string must end with one NUL and contain no other"),
    }
}

/// Return code of an entry point: success.
pub const STATUS_OK: u32 = 0;
/// Return code of an entry point: the plugin panicked; the panic was caught at the boundary.
pub const STATUS_PANICKED: u32 = 1;
/// Return code of an entry point: the plugin returned an error (see the [`ErrorBuf`]).
pub const STATUS_FAILED: u32 = 2;
// The faults a host raises for these codes carry the same numbers (the plugin module, below the
// ABI, does not import it).
const _: () = assert!(crate::JointFault::PANICKED.code() == STATUS_PANICKED && crate::JointFault::BAD_STATUS.code() == STATUS_FAILED);

/// An opaque plugin instance, owned by the plugin.
pub type Handle = *mut c_void;

/// The part of a descriptor that never changes shape, read before anything else.
///
/// Its fields are private: a header is only made by [`PluginDescriptor::new`] (this host's
/// versions and hash) or changed through [`PluginDescriptor::with_versions`], so safe code can
/// never point `api_version` at memory that is not a NUL-terminated string.
#[repr(C)]
#[derive(Debug)]
pub struct DescriptorHeader {
    magic: u64,
    abi_major: u32,
    abi_minor: u32,
    layout_hash: u64,
    api_version: *const c_char,
}

impl DescriptorHeader {
    /// Must equal [`ABI_MAGIC`].
    pub const fn magic(&self) -> u64 {
        self.magic
    }

    /// [`ABI_MAJOR`] of the library.
    pub const fn abi_major(&self) -> u32 {
        self.abi_major
    }

    /// [`ABI_MINOR`] of the library.
    pub const fn abi_minor(&self) -> u32 {
        self.abi_minor
    }

    /// [`LAYOUT_HASH`] of the library: the shared types, entry-point signatures and constants.
    pub const fn layout_hash(&self) -> u64 {
        self.layout_hash
    }

    /// The `jointctl-api` version the library was built with.
    ///
    /// ```
    /// # use jointctl_api::*;
    /// # struct P;
    /// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
    /// export_joint_plugin!(name: p, plugin: P, dof: 1, encoders: "output", drives: "motor");
    /// assert_eq!(plugin_descriptor().header().api_version(), env!("CARGO_PKG_VERSION"));
    /// ```
    pub fn api_version(&self) -> &str {
        // SAFETY: `api_version` is only ever set from `API_VERSION_C`, a `'static` C string
        // (the fields are private and every constructor sets it so).
        unsafe { c_text(self.api_version) }
    }
}

/// Reads a C string the safe constructors made.
///
/// # Safety
/// `ptr` is null or points at a NUL-terminated string that outlives `'a`.
unsafe fn c_text<'a>(ptr: *const c_char) -> &'a str {
    if ptr.is_null() {
        return "";
    }
    // SAFETY: guaranteed by the caller.
    unsafe { CStr::from_ptr(ptr) }.to_str().unwrap_or("<not UTF-8>")
}

/// Declares [`PluginVTable`] and, from the same tokens, the text of its signatures (field
/// names, parameter names and types) that [`LAYOUT_HASH`] covers: the declaration and what the
/// hash sees cannot drift apart, and swapping two `u32` parameters changes the hash.
macro_rules! plugin_vtable {
    ($($(#[$doc:meta])* $field:ident : $fty:ty,)*) => {
        /// Entry points of one plugin type. All take and return only `#[repr(C)]` data.
        #[repr(C)]
        #[derive(Debug)]
        pub struct PluginVTable {
            $($(#[$doc])* pub $field: $fty,)*
        }

        /// The vtable's fields with their full signatures, as hashed into [`LAYOUT_HASH`].
        ///
        /// ```
        /// assert!(jointctl_api::abi::VTABLE_SIGNATURES.contains("observe"));
        /// ```
        pub const VTABLE_SIGNATURES: &str = concat!($(stringify!($field), ": ", stringify!($fty), ";\n",)*);
    };
}

plugin_vtable! {
    /// Creates an instance from JSON parameters (`params`, `len` bytes of UTF-8); null on error.
    create: unsafe extern "C" fn(params: *const u8, len: usize, err: *mut ErrorBuf) -> Handle,
    /// Checks the wiring and rate.
    configure: unsafe extern "C" fn(h: Handle, ctx: *const JointContext, err: *mut ErrorBuf) -> u32,
    /// First readings, before the first cycle.
    activate: unsafe extern "C" fn(h: Handle, raw: *const RawJointView, err: *mut ErrorBuf) -> u32,
    /// One observation: `out` has `dof` entries. Returns a status or a fault code (>= 16).
    observe: unsafe extern "C" fn(h: Handle, raw: *const RawJointView, out: *mut JointState, dof: u32, err: *mut ErrorBuf) -> u32,
    /// One control step: `state`/`command` have `dof` entries, `out` has `drives` entries.
    control: unsafe extern "C" fn(
        h: Handle,
        state: *const JointState,
        command: *const JointCommand,
        dof: u32,
        raw: *const RawJointView,
        out: *mut MotorSetpoint,
        drives: u32,
        err: *mut ErrorBuf,
    ) -> u32,
    /// The loop stopped.
    deactivate: unsafe extern "C" fn(h: Handle) -> u32,
    /// Frees the instance (the plugin allocated it, so the plugin frees it).
    destroy: unsafe extern "C" fn(h: Handle),
}

/// What a plugin library exports.
///
/// Every field is private: a descriptor is made only by [`PluginDescriptor::new`], whose strings
/// are `&'static CStr`, so safe code cannot make one whose strings lack their NUL or point at
/// freed memory. A descriptor read from a library is trusted only after
/// `jointctl_runtime::loader::check_descriptor` compared its header with this host's.
///
/// The safe API cannot take a string without its NUL, nor set a field:
///
/// ```compile_fail
/// # use jointctl_api::*;
/// # struct P;
/// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
/// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
/// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
/// static D: abi::PluginDescriptor = abi::PluginDescriptor::new::<P>("fixed", c"1", 1, c"output", c"motor", true);
/// ```
///
/// ```compile_fail
/// # use jointctl_api::*;
/// # struct P;
/// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
/// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
/// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
/// let mut d = abi::PluginDescriptor::new::<P>(c"fixed", c"1", 1, c"output", c"motor", true);
/// d.name = b"fixed".as_ptr().cast();
/// ```
///
/// while the same descriptor with C strings is fine:
///
/// ```
/// # use jointctl_api::*;
/// # struct P;
/// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
/// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
/// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
/// static D: abi::PluginDescriptor = abi::PluginDescriptor::new::<P>(c"fixed", c"1", 1, c"output", c"motor", true);
/// assert_eq!(D.name(), "fixed");
/// ```
#[repr(C)]
#[derive(Debug)]
pub struct PluginDescriptor {
    header: DescriptorHeader,
    name: *const c_char,
    version: *const c_char,
    built_with_unwind: u8,
    torque_dofs: u8,
    stiffness_dofs: u8,
    _reserved: u8,
    dof: u32,
    encoder_roles: *const c_char,
    drive_roles: *const c_char,
    vtable: PluginVTable,
}

// SAFETY: the pointers in a descriptor point at `'static` immutable strings (see `new`).
unsafe impl Sync for PluginDescriptor {}

impl PluginDescriptor {
    /// The descriptor of plugin type `P`. Used by [`export_joint_plugin!`](crate::export_joint_plugin).
    /// Roles are comma-separated; a trailing `?` marks a role optional.
    pub const fn new<P: JointPlugin>(
        name: &'static CStr,
        version: &'static CStr,
        dof: u32,
        encoder_roles: &'static CStr,
        drive_roles: &'static CStr,
        built_with_unwind: bool,
    ) -> Self {
        PluginDescriptor {
            header: DescriptorHeader {
                magic: ABI_MAGIC,
                abi_major: ABI_MAJOR,
                abi_minor: ABI_MINOR,
                layout_hash: LAYOUT_HASH,
                api_version: API_VERSION_C.as_ptr(),
            },
            name: name.as_ptr(),
            version: version.as_ptr(),
            built_with_unwind: built_with_unwind as u8,
            torque_dofs: 0,
            stiffness_dofs: 0,
            _reserved: 0,
            dof,
            encoder_roles: encoder_roles.as_ptr(),
            drive_roles: drive_roles.as_ptr(),
            vtable: PluginVTable {
                create: shim_create::<P>,
                configure: shim_configure::<P>,
                activate: shim_activate::<P>,
                observe: shim_observe::<P>,
                control: shim_control::<P>,
                deactivate: shim_deactivate::<P>,
                destroy: shim_destroy::<P>,
            },
        }
    }

    /// The same descriptor claiming other ABI versions and layout hash: how a library built
    /// against another `jointctl-api` looks to this host (the loader's refusal tests use it).
    /// Only numbers change, so it is safe.
    ///
    /// ```
    /// # use jointctl_api::*;
    /// # struct P;
    /// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
    /// let d = abi::PluginDescriptor::new::<P>(c"p", c"1", 1, c"output", c"motor", true)
    ///     .with_versions(abi::ABI_MAJOR + 1, 0, abi::LAYOUT_HASH);
    /// assert_eq!(d.header().abi_major(), abi::ABI_MAJOR + 1);
    /// ```
    pub const fn with_versions(mut self, abi_major: u32, abi_minor: u32, layout_hash: u64) -> Self {
        self.header.abi_major = abi_major;
        self.header.abi_minor = abi_minor;
        self.header.layout_hash = layout_hash;
        self
    }

    /// Checked first: magic, versions, layout hash.
    pub const fn header(&self) -> &DescriptorHeader {
        &self.header
    }

    /// The plugin name (the name YAML uses).
    pub fn name(&self) -> &str {
        // SAFETY: set only from a `&'static CStr` in `new` (fields are private).
        unsafe { c_text(self.name) }
    }

    /// The plugin crate's version.
    pub fn version(&self) -> &str {
        // SAFETY: as in `name`.
        unsafe { c_text(self.version) }
    }

    /// Comma-separated encoder roles; a trailing `?` marks a role optional.
    pub fn encoder_roles(&self) -> &str {
        // SAFETY: as in `name`.
        unsafe { c_text(self.encoder_roles) }
    }

    /// Comma-separated drive roles; a trailing `?` marks a role optional.
    pub fn drive_roles(&self) -> &str {
        // SAFETY: as in `name`.
        unsafe { c_text(self.drive_roles) }
    }

    /// Degrees of freedom one instance handles.
    pub const fn dof(&self) -> u32 {
        self.dof
    }

    /// Built with `panic = "unwind"`, so that its panics can be caught at the boundary.
    pub const fn built_with_unwind(&self) -> bool {
        self.built_with_unwind != 0
    }

    /// The same descriptor declaring what its DOFs can do, one bit per DOF (bit 0: the first
    /// DOF): which observe their torque (so torque and impedance control can run on them) and
    /// which have a stiffness that commands can set (variable stiffness joints). The host
    /// refuses commands a DOF cannot carry out.
    ///
    /// ```
    /// # use jointctl_api::*;
    /// # struct P;
    /// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
    /// export_joint_plugin!(name: p, plugin: P, dof: 2, encoders: "a", drives: "m", torque_dofs: 0b01, stiffness_dofs: 0b01);
    /// let d = plugin_descriptor();
    /// assert!(d.observes_torque(0) && d.sets_stiffness(0));
    /// assert!(!d.observes_torque(1) && !d.sets_stiffness(1));
    /// ```
    pub const fn with_capabilities(mut self, torque_dofs: u8, stiffness_dofs: u8) -> Self {
        self.torque_dofs = torque_dofs;
        self.stiffness_dofs = stiffness_dofs;
        self
    }

    /// Whether DOF `dof` observes its torque.
    pub const fn observes_torque(&self, dof: usize) -> bool {
        dof < 8 && self.torque_dofs & (1 << dof) != 0
    }

    /// Whether DOF `dof`'s stiffness can be set by a command.
    pub const fn sets_stiffness(&self, dof: usize) -> bool {
        dof < 8 && self.stiffness_dofs & (1 << dof) != 0
    }

    /// Entry points. Calling them is `unsafe`: see [`PluginVTable`].
    pub const fn vtable(&self) -> &PluginVTable {
        &self.vtable
    }
}

/// A host-owned buffer a plugin writes an error or panic message into.
///
/// ```
/// use jointctl_api::abi::ErrorBuf;
/// let mut e = ErrorBuf::new();
/// e.write("must be > 0", Some("k"));
/// assert_eq!((e.message(), e.field()), ("must be > 0", Some("k")));
/// ```
#[repr(C)]
#[derive(Clone)]
pub struct ErrorBuf {
    message_len: u32,
    field_len: u32,
    message: [u8; 1024],
    field: [u8; 256],
}

impl Default for ErrorBuf {
    fn default() -> Self {
        Self::new()
    }
}

impl ErrorBuf {
    /// An empty buffer.
    pub const fn new() -> Self {
        ErrorBuf { message_len: 0, field_len: 0, message: [0; 1024], field: [0; 256] }
    }

    /// Stores a message and optional field path, truncated at a character boundary.
    pub fn write(&mut self, message: &str, field: Option<&str>) {
        self.message_len = copy_utf8_prefix(&mut self.message, message) as u32;
        self.field_len = copy_utf8_prefix(&mut self.field, field.unwrap_or("")) as u32;
    }

    /// The stored message. The length was written by the plugin's copy of this code, so it is
    /// clamped to the buffer and cut at the last whole UTF-8 character, never trusted.
    pub fn message(&self) -> &str {
        utf8_prefix(&self.message, self.message_len)
    }

    /// The stored field path, if any.
    pub fn field(&self) -> Option<&str> {
        let f = utf8_prefix(&self.field, self.field_len);
        (!f.is_empty()).then_some(f)
    }

    /// Clears the buffer.
    pub fn clear(&mut self) {
        self.message_len = 0;
        self.field_len = 0;
    }
}

/// The valid UTF-8 start of `buf[..len]`, with `len` clamped to the buffer and the text ending
/// at the first NUL (a forged length must not expose the buffer's unused bytes).
fn utf8_prefix(buf: &[u8], len: u32) -> &str {
    let bytes = &buf[..(len as usize).min(buf.len())];
    let bytes = &bytes[..bytes.iter().position(|b| *b == 0).unwrap_or(bytes.len())];
    match core::str::from_utf8(bytes) {
        Ok(s) => s,
        // The prefix up to the first invalid byte is valid UTF-8 by definition.
        Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
    }
}

/// Copies the longest prefix of `src` that fits `dst` and ends at a character boundary, so the
/// bytes copied are always valid UTF-8; returns how many were copied. Every fixed-size text
/// field that crosses a process or plugin boundary is written with it.
///
/// ```
/// let mut buf = [0u8; 3];
/// assert_eq!(jointctl_api::abi::copy_utf8_prefix(&mut buf, "aü!"), 3);
/// assert_eq!(&buf, "aü".as_bytes());
/// assert_eq!(jointctl_api::abi::copy_utf8_prefix(&mut buf[..2], "aü"), 1, "ü does not fit whole");
/// ```
pub fn copy_utf8_prefix(dst: &mut [u8], src: &str) -> usize {
    let mut n = src.len().min(dst.len());
    while !src.is_char_boundary(n) {
        n -= 1;
    }
    dst[..n].copy_from_slice(&src.as_bytes()[..n]);
    n
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> &str {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s
    } else {
        "panic with a non-string payload"
    }
}

/// # Safety
/// `err` is null or valid for writes.
unsafe fn report(err: *mut ErrorBuf, message: &str, field: Option<&str>) {
    // SAFETY: guaranteed by the caller.
    if let Some(err) = unsafe { err.as_mut() } {
        err.write(message, field);
    }
}

fn plugin_error_status(err: *mut ErrorBuf, e: &PluginError) -> u32 {
    // SAFETY: every shim receives `err` from the host as null or a valid buffer.
    unsafe { report(err, &e.message, e.field.as_deref()) };
    STATUS_FAILED
}

std::thread_local! {
    /// Set while this thread is inside a plugin entry point.
    static IN_PLUGIN_CALL: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
}

/// Installs, once per copy of std (a plugin library has its own), a panic hook that stays
/// silent for panics inside plugin entry points and defers to the previous hook for every
/// other panic. A plugin's panic is caught at the boundary and its message goes to the host
/// through the [`ErrorBuf`]; the default hook would print it, with a backtrace when
/// `RUST_BACKTRACE` is set, on the control thread and stall the loop for that long.
fn install_quiet_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !IN_PLUGIN_CALL.with(core::cell::Cell::get) {
                previous(info);
            }
        }));
    });
}

/// Runs a plugin's code with its panics caught and not printed. Allocation-free.
fn guarded<R>(f: impl FnOnce() -> R) -> std::thread::Result<R> {
    let outer = IN_PLUGIN_CALL.with(|c| c.replace(true));
    let result = catch_unwind(AssertUnwindSafe(f));
    IN_PLUGIN_CALL.with(|c| c.set(outer));
    result
}

fn panic_status(err: *mut ErrorBuf, payload: &(dyn std::any::Any + Send)) -> u32 {
    // SAFETY: as above.
    unsafe { report(err, panic_text(payload), None) };
    STATUS_PANICKED
}

/// # Safety
/// `params` valid for `len` bytes; `err` null or valid.
unsafe extern "C" fn shim_create<P: JointPlugin>(params: *const u8, len: usize, err: *mut ErrorBuf) -> Handle {
    install_quiet_panic_hook();
    let result = guarded(|| {
        // SAFETY: the host passes a valid UTF-8 buffer of `len` bytes.
        let bytes = if params.is_null() { &[][..] } else { unsafe { core::slice::from_raw_parts(params, len) } };
        let text = core::str::from_utf8(bytes).map_err(|_| PluginError::new("parameters are not UTF-8"))?;
        P::create(text)
    });
    match result {
        Ok(Ok(plugin)) => Box::into_raw(Box::new(plugin)).cast(),
        Ok(Err(e)) => {
            plugin_error_status(err, &e);
            core::ptr::null_mut()
        }
        Err(payload) => {
            panic_status(err, &*payload);
            core::ptr::null_mut()
        }
    }
}

/// # Safety
/// `h` was returned by `shim_create::<P>`, `ctx` valid, `err` null or valid.
unsafe extern "C" fn shim_configure<P: JointPlugin>(h: Handle, ctx: *const JointContext, err: *mut ErrorBuf) -> u32 {
    // SAFETY: guaranteed by the host (see the vtable contract).
    let (plugin, ctx) = unsafe { (&mut *h.cast::<P>(), &*ctx) };
    match guarded(|| plugin.configure(ctx)) {
        Ok(Ok(())) => STATUS_OK,
        Ok(Err(e)) => plugin_error_status(err, &e),
        Err(payload) => panic_status(err, &*payload),
    }
}

/// # Safety
/// As [`shim_configure`].
unsafe extern "C" fn shim_activate<P: JointPlugin>(h: Handle, raw: *const RawJointView, err: *mut ErrorBuf) -> u32 {
    // SAFETY: guaranteed by the host.
    let (plugin, raw) = unsafe { (&mut *h.cast::<P>(), &*raw) };
    match guarded(|| plugin.activate(raw)) {
        Ok(Ok(())) => STATUS_OK,
        Ok(Err(e)) => plugin_error_status(err, &e),
        Err(payload) => panic_status(err, &*payload),
    }
}

/// # Safety
/// As [`shim_configure`]; `out` valid for `dof` writes.
unsafe extern "C" fn shim_observe<P: JointPlugin>(
    h: Handle,
    raw: *const RawJointView,
    out: *mut JointState,
    dof: u32,
    err: *mut ErrorBuf,
) -> u32 {
    // SAFETY: guaranteed by the host.
    let (plugin, raw, out) = unsafe { (&mut *h.cast::<P>(), &*raw, core::slice::from_raw_parts_mut(out, dof as usize)) };
    match guarded(|| plugin.observe(raw, out)) {
        Ok(Ok(())) => STATUS_OK,
        Ok(Err(fault)) => fault.code(),
        Err(payload) => panic_status(err, &*payload),
    }
}

/// # Safety
/// As [`shim_configure`]; `state`/`command` valid for `dof` reads, `out` for `drives` writes.
#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn shim_control<P: JointPlugin>(
    h: Handle,
    state: *const JointState,
    command: *const JointCommand,
    dof: u32,
    raw: *const RawJointView,
    out: *mut MotorSetpoint,
    drives: u32,
    err: *mut ErrorBuf,
) -> u32 {
    // SAFETY: guaranteed by the host.
    let (plugin, state, command, raw, out) = unsafe {
        (
            &mut *h.cast::<P>(),
            core::slice::from_raw_parts(state, dof as usize),
            core::slice::from_raw_parts(command, dof as usize),
            &*raw,
            core::slice::from_raw_parts_mut(out, drives as usize),
        )
    };
    match guarded(|| plugin.control(state, command, raw, out)) {
        Ok(Ok(())) => STATUS_OK,
        Ok(Err(fault)) => fault.code(),
        Err(payload) => panic_status(err, &*payload),
    }
}

/// # Safety
/// `h` was returned by `shim_create::<P>`.
unsafe extern "C" fn shim_deactivate<P: JointPlugin>(h: Handle) -> u32 {
    // SAFETY: guaranteed by the host.
    let plugin = unsafe { &mut *h.cast::<P>() };
    match guarded(|| plugin.deactivate()) {
        Ok(()) => STATUS_OK,
        Err(_) => STATUS_PANICKED,
    }
}

/// # Safety
/// `h` was returned by `shim_create::<P>` and is not used afterwards.
unsafe extern "C" fn shim_destroy<P: JointPlugin>(h: Handle) {
    if h.is_null() {
        return;
    }
    // SAFETY: `h` came from `Box::into_raw` in `shim_create::<P>`.
    let boxed = unsafe { Box::from_raw(h.cast::<P>()) };
    // A panicking Drop must not unwind into the host; the instance is gone either way.
    let _ = guarded(move || drop(boxed));
}

const fn mix_bytes(mut hash: u64, bytes: &[u8]) -> u64 {
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u64;
        hash = hash.wrapping_mul(0x0100_0000_01b3);
        i += 1;
    }
    hash
}

/// [`mix_bytes`] over a token text without its whitespace, which the compiler's pretty-printer
/// (`stringify!`) may lay out differently from one version to the next.
const fn mix_tokens(mut hash: u64, text: &str) -> u64 {
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if !bytes[i].is_ascii_whitespace() {
            hash ^= bytes[i] as u64;
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
        i += 1;
    }
    hash
}

const fn mix_usize(hash: u64, value: usize) -> u64 {
    mix_bytes(hash, &(value as u64).to_le_bytes())
}

/// Hashes each listed type's name, size and alignment and each field's name, offset and
/// declared type (as written). A compile-time check beside each field makes the declared type
/// the real one, so the hash cannot drift from the code: change a field's type and this list
/// must change too, and with it the hash.
macro_rules! hash_layouts {
    ($hash:ident; $($ty:ident { $($field:ident : $fty:ty),* $(,)? })*) => {
        $(
            $hash = mix_bytes($hash, stringify!($ty).as_bytes());
            $hash = mix_usize($hash, size_of::<$ty>());
            $hash = mix_usize($hash, align_of::<$ty>());
            $(
                $hash = mix_bytes($hash, stringify!($field).as_bytes());
                $hash = mix_tokens($hash, stringify!($fty));
                $hash = mix_usize($hash, offset_of!($ty, $field));
            )*
            const _: () = {
                #[allow(dead_code)]
                fn declared_types_are_the_real_ones(v: &$ty) {
                    $( let _: &$fty = &v.$field; )*
                }
            };
        )*
    };
}

/// Mixes named constants (name and value) into the hash: status codes, limits and the values
/// of the `#[repr(transparent)]` enums both sides must agree on.
macro_rules! hash_constants {
    ($hash:ident; $($name:expr),* $(,)?) => {
        $(
            $hash = mix_bytes($hash, stringify!($name).as_bytes());
            $hash = mix_bytes($hash, &($name as u64).to_le_bytes());
        )*
    };
}

/// FNV-1a over everything both sides of the boundary must agree on: the size, alignment, field
/// names, offsets and field types of every shared type, the signatures of the entry points
/// (the vtable's field types), and the constants (status codes, limits, mode, action, status
/// and mask values). Two builds agree on it only if they agree on all of these.
pub const LAYOUT_HASH: u64 = {
    use crate::{ControlMode, DriveAction, FieldMask, ReadingStatus};
    let mut hash = 0xcbf2_9ce4_8422_2325_u64;
    hash_layouts!(hash;
        Reading { value: f64, age_s: f64, status: ReadingStatus }
        DriveReading { position_rad: Reading, velocity_rad_s: Reading, enabled: u8, fault: u8 }
        RawJointView { stamp_s: f64, dt_s: f64, encoders: [Reading; crate::MAX_ENCODERS], drives: [DriveReading; crate::MAX_DRIVES] }
        JointState { position_rad: f64, velocity_rad_s: f64, deflection_rad: f64, torque_nm: f64, stiffness_nm_per_rad: f64, pivot_mm: f64, valid: FieldMask }
        JointCommand { mode: ControlMode, position_feedback: u8, position_rad: f64, velocity_rad_s: f64, stiffness_nm_per_rad: f64 }
        MotorSetpoint { position_rad: f64, velocity_ff_rad_s: f64, action: DriveAction }
        JointContext { dof: u32, encoder_count: u32, drive_count: u32, rate_hz: f64 }
        ErrorBuf { message_len: u32, field_len: u32, message: [u8; 1024], field: [u8; 256] }
        DescriptorHeader { magic: u64, abi_major: u32, abi_minor: u32, layout_hash: u64, api_version: *const c_char }
        PluginDescriptor {
            header: DescriptorHeader, name: *const c_char, version: *const c_char, built_with_unwind: u8,
            torque_dofs: u8, stiffness_dofs: u8, dof: u32, encoder_roles: *const c_char, drive_roles: *const c_char, vtable: PluginVTable,
        }
    );
    // The entry points: their names, parameter names and types, in order, and the table's size.
    hash = mix_tokens(hash, VTABLE_SIGNATURES);
    hash = mix_usize(hash, size_of::<PluginVTable>());
    hash_constants!(hash;
        crate::MAX_ENCODERS, crate::MAX_DRIVES, crate::MAX_DOF,
        STATUS_OK, STATUS_PANICKED, STATUS_FAILED, JointFault::FIRST_PLUGIN_CODE,
        ControlMode::HOLD.0, ControlMode::POSITION.0,
        DriveAction::HOLD.0, DriveAction::MOVE.0,
        ReadingStatus::MISSING.0, ReadingStatus::VALID.0, ReadingStatus::STALE.0, ReadingStatus::INVALID.0,
        FieldMask::POSITION, FieldMask::VELOCITY, FieldMask::DEFLECTION, FieldMask::TORQUE,
        FieldMask::STIFFNESS, FieldMask::PIVOT, FieldMask::CLAMPED,
    );
    hash
};

/// Exports a [`JointPlugin`] type from a library crate (`crate-type = ["cdylib", "rlib"]`).
///
/// Generates the `extern "C"` entry `jointctl_plugin_<name>` that the host loads with
/// `libloading`, and `plugin_descriptor()` for linking the same plugin statically. Encoder and
/// drive roles are comma-separated; a trailing `?` marks a role optional.
///
/// ```
/// use jointctl_api::*;
/// struct Fixed;
/// impl Observer for Fixed {
///     fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
///         if let Some(q) = raw.encoder(0).usable(0.1) { out[0].set_position(q); }
///         Ok(())
///     }
/// }
/// impl Controller for Fixed {
///     fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView,
///                out: &mut [MotorSetpoint]) -> Result<(), JointFault> {
///         out[0] = MotorSetpoint::HOLD;
///         Ok(())
///     }
/// }
/// impl JointPlugin for Fixed {
///     fn create(_: &str) -> Result<Self, PluginError> { Ok(Fixed) }
/// }
/// export_joint_plugin!(name: fixed, plugin: Fixed, dof: 1, encoders: "output", drives: "motor");
/// assert_eq!(plugin_descriptor().name(), "fixed");
/// ```
#[macro_export]
macro_rules! export_joint_plugin {
    (
        name: $name:ident, plugin: $ty:ty, dof: $dof:literal, encoders: $enc:literal, drives: $drv:literal
        $(, torque_dofs: $torque:expr)? $(, stiffness_dofs: $stiffness:expr)? $(,)?
    ) => {
        #[doc(hidden)]
        pub static __JOINTCTL_DESCRIPTOR: $crate::abi::PluginDescriptor = $crate::abi::PluginDescriptor::new::<$ty>(
            $crate::abi::c_string(concat!(stringify!($name), "\0")),
            $crate::abi::c_string(concat!(env!("CARGO_PKG_VERSION"), "\0")),
            $dof,
            $crate::abi::c_string(concat!($enc, "\0")),
            $crate::abi::c_string(concat!($drv, "\0")),
            cfg!(panic = "unwind"),
        )
        .with_capabilities(0 $(| $torque)?, 0 $(| $stiffness)?);

        /// This plugin's descriptor, for linking it statically into a host.
        pub fn plugin_descriptor() -> &'static $crate::abi::PluginDescriptor {
            &__JOINTCTL_DESCRIPTOR
        }

        #[doc(hidden)]
        #[unsafe(export_name = concat!("jointctl_plugin_", stringify!($name)))]
        pub extern "C" fn __jointctl_plugin_entry() -> *const $crate::abi::PluginDescriptor {
            &__JOINTCTL_DESCRIPTOR
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue finding: `ErrorBuf::message` sliced by a length the plugin wrote. A length beyond the
    /// buffer, or one that cuts a character, gives the valid text, never a panic.
    #[test]
    fn an_error_buffer_with_a_forged_length_reads_safely() {
        let mut e = ErrorBuf::new();
        e.write("grüße", Some("k"));
        e.message_len = 5000;
        e.field_len = u32::MAX;
        assert_eq!(e.message(), "grüße");
        assert_eq!(e.field(), Some("k"));
        e.write("grüße", None);
        e.message_len = 3; // inside the two bytes of `ü`
        assert_eq!(e.message(), "gr");
    }

    /// Issue finding: swapping two `u32` parameters of an entry point passed the ABI check.
    /// The signatures' text (parameter names included) is part of the hash, taken from the same
    /// tokens that declare the vtable; a changed constant changes the hash too.
    #[test]
    fn the_layout_hash_covers_signatures_with_parameter_names_and_constants() {
        let compact: String = VTABLE_SIGNATURES.split_whitespace().collect();
        let order = "dof:u32,raw:*constRawJointView,out:*mutMotorSetpoint,drives:u32";
        assert!(compact.contains(order), "{compact}");
        let swapped = compact.replacen(order, "drives:u32,raw:*constRawJointView,out:*mutMotorSetpoint,dof:u32", 1);
        let h = |text: &str| mix_tokens(0xcbf2_9ce4_8422_2325, text);
        assert_eq!(h(VTABLE_SIGNATURES), h(&compact), "whitespace does not count");
        assert_ne!(h(&compact), h(&swapped));
        let (mut a, mut b) = (0xcbf2_9ce4_8422_2325_u64, 0xcbf2_9ce4_8422_2325_u64);
        hash_constants!(a; STATUS_FAILED);
        b = mix_bytes(b, b"STATUS_FAILED");
        b = mix_bytes(b, &(STATUS_FAILED as u64 + 1).to_le_bytes());
        assert_ne!(a, b, "a constant's value is hashed");
    }
}
