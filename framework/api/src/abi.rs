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
    DriveReading, JointCommand, JointContext, JointPlugin, JointState, MotorSetpoint, PluginError, RawJointView,
    Reading,
};

/// First 8 bytes of every descriptor: "JNTCTL" + format 1.
pub const ABI_MAGIC: u64 = u64::from_le_bytes(*b"JNTCTL\x00\x01");
/// Bumped on any incompatible change of the shared types or entry points.
pub const ABI_MAJOR: u32 = 1;
/// Bumped on compatible additions; a host accepts plugins with a minor version up to its own.
pub const ABI_MINOR: u32 = 0;
/// Version of the `jointctl-api` crate the library was built against.
pub const API_VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "\0");

/// Return code of an entry point: success.
pub const STATUS_OK: u32 = 0;
/// Return code of an entry point: the plugin panicked; the panic was caught at the boundary.
pub const STATUS_PANICKED: u32 = 1;
/// Return code of an entry point: the plugin returned an error (see the [`ErrorBuf`]).
pub const STATUS_FAILED: u32 = 2;

/// An opaque plugin instance, owned by the plugin.
pub type Handle = *mut c_void;

/// The part of a descriptor that never changes shape, read before anything else.
#[repr(C)]
#[derive(Debug)]
pub struct DescriptorHeader {
    /// Must equal [`ABI_MAGIC`].
    pub magic: u64,
    /// [`ABI_MAJOR`] of the library.
    pub abi_major: u32,
    /// [`ABI_MINOR`] of the library.
    pub abi_minor: u32,
    /// [`LAYOUT_HASH`] of the library: sizes, alignments, field names and offsets of every shared type.
    pub layout_hash: u64,
    /// NUL-terminated `jointctl-api` version the library was built with.
    pub api_version: *const c_char,
}

/// Entry points of one plugin type. All take and return only `#[repr(C)]` data.
#[repr(C)]
#[derive(Debug)]
pub struct PluginVTable {
    /// Creates an instance from JSON parameters (`params`, `len` bytes of UTF-8); null on error.
    pub create: unsafe extern "C" fn(params: *const u8, len: usize, err: *mut ErrorBuf) -> Handle,
    /// Checks the wiring and rate.
    pub configure: unsafe extern "C" fn(Handle, ctx: *const JointContext, err: *mut ErrorBuf) -> u32,
    /// First readings, before the first cycle.
    pub activate: unsafe extern "C" fn(Handle, raw: *const RawJointView, err: *mut ErrorBuf) -> u32,
    /// One observation: `out` has `dof` entries. Returns a status or a fault code (>= 16).
    pub observe: unsafe extern "C" fn(Handle, raw: *const RawJointView, out: *mut JointState, dof: u32, err: *mut ErrorBuf) -> u32,
    /// One control step: `state`/`command` have `dof` entries, `out` has `drives` entries.
    pub control: unsafe extern "C" fn(
        Handle,
        state: *const JointState,
        command: *const JointCommand,
        dof: u32,
        raw: *const RawJointView,
        out: *mut MotorSetpoint,
        drives: u32,
        err: *mut ErrorBuf,
    ) -> u32,
    /// The loop stopped.
    pub deactivate: unsafe extern "C" fn(Handle) -> u32,
    /// Frees the instance (the plugin allocated it, so the plugin frees it).
    pub destroy: unsafe extern "C" fn(Handle),
}

/// What a plugin library exports.
#[repr(C)]
#[derive(Debug)]
pub struct PluginDescriptor {
    /// Checked first.
    pub header: DescriptorHeader,
    /// NUL-terminated plugin name (the name YAML uses).
    pub name: *const c_char,
    /// NUL-terminated plugin crate version.
    pub version: *const c_char,
    /// 1 when built with `panic = "unwind"`, so that panics can be caught at the boundary.
    pub built_with_unwind: u8,
    _reserved: [u8; 3],
    /// Degrees of freedom one instance handles.
    pub dof: u32,
    /// NUL-terminated, comma-separated encoder roles; a trailing `?` marks a role optional.
    pub encoder_roles: *const c_char,
    /// NUL-terminated, comma-separated drive roles.
    pub drive_roles: *const c_char,
    /// Entry points.
    pub vtable: PluginVTable,
}

// SAFETY: the pointers in a descriptor point at `'static` immutable strings.
unsafe impl Sync for PluginDescriptor {}

impl PluginDescriptor {
    /// The descriptor of plugin type `P`. All strings must end with `\0`.
    /// Used by [`export_joint_plugin!`](crate::export_joint_plugin).
    pub const fn new<P: JointPlugin>(
        name: &'static str,
        version: &'static str,
        dof: u32,
        encoder_roles: &'static str,
        drive_roles: &'static str,
        built_with_unwind: bool,
    ) -> Self {
        PluginDescriptor {
            header: DescriptorHeader {
                magic: ABI_MAGIC,
                abi_major: ABI_MAJOR,
                abi_minor: ABI_MINOR,
                layout_hash: LAYOUT_HASH,
                api_version: API_VERSION.as_ptr().cast(),
            },
            name: name.as_ptr().cast(),
            version: version.as_ptr().cast(),
            built_with_unwind: built_with_unwind as u8,
            _reserved: [0; 3],
            dof,
            encoder_roles: encoder_roles.as_ptr().cast(),
            drive_roles: drive_roles.as_ptr().cast(),
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

    /// Reads one of the descriptor's strings.
    ///
    /// # Safety
    /// `ptr` must be null or point at a NUL-terminated string that lives as long as `self`.
    pub unsafe fn text(&self, ptr: *const c_char) -> &str {
        if ptr.is_null() {
            return "";
        }
        // SAFETY: guaranteed by the caller.
        unsafe { CStr::from_ptr(ptr) }.to_str().unwrap_or("<not UTF-8>")
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
        self.message_len = copy_truncated(&mut self.message, message);
        self.field_len = copy_truncated(&mut self.field, field.unwrap_or(""));
    }

    /// The stored message.
    pub fn message(&self) -> &str {
        core::str::from_utf8(&self.message[..self.message_len as usize]).unwrap_or("<not UTF-8>")
    }

    /// The stored field path, if any.
    pub fn field(&self) -> Option<&str> {
        let f = core::str::from_utf8(&self.field[..self.field_len as usize]).unwrap_or("");
        (!f.is_empty()).then_some(f)
    }

    /// Clears the buffer.
    pub fn clear(&mut self) {
        self.message_len = 0;
        self.field_len = 0;
    }
}

fn copy_truncated(dst: &mut [u8], src: &str) -> u32 {
    let mut n = src.len().min(dst.len());
    while !src.is_char_boundary(n) {
        n -= 1;
    }
    dst[..n].copy_from_slice(&src.as_bytes()[..n]);
    n as u32
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

fn panic_status(err: *mut ErrorBuf, payload: &(dyn std::any::Any + Send)) -> u32 {
    // SAFETY: as above.
    unsafe { report(err, panic_text(payload), None) };
    STATUS_PANICKED
}

/// # Safety
/// `params` valid for `len` bytes; `err` null or valid.
unsafe extern "C" fn shim_create<P: JointPlugin>(params: *const u8, len: usize, err: *mut ErrorBuf) -> Handle {
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: the host passes a valid UTF-8 buffer of `len` bytes.
        let bytes = if params.is_null() { &[][..] } else { unsafe { core::slice::from_raw_parts(params, len) } };
        let text = core::str::from_utf8(bytes).map_err(|_| PluginError::new("parameters are not UTF-8"))?;
        P::create(text)
    }));
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
    match catch_unwind(AssertUnwindSafe(|| plugin.configure(ctx))) {
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
    match catch_unwind(AssertUnwindSafe(|| plugin.activate(raw))) {
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
    match catch_unwind(AssertUnwindSafe(|| plugin.observe(raw, out))) {
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
    match catch_unwind(AssertUnwindSafe(|| plugin.control(state, command, raw, out))) {
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
    match catch_unwind(AssertUnwindSafe(|| plugin.deactivate())) {
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
    let _ = catch_unwind(AssertUnwindSafe(move || drop(boxed)));
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

const fn mix_usize(hash: u64, value: usize) -> u64 {
    mix_bytes(hash, &(value as u64).to_le_bytes())
}

macro_rules! hash_layouts {
    ($hash:ident; $($ty:ident { $($field:ident),* $(,)? })*) => {
        $(
            $hash = mix_bytes($hash, stringify!($ty).as_bytes());
            $hash = mix_usize($hash, size_of::<$ty>());
            $hash = mix_usize($hash, align_of::<$ty>());
            $(
                $hash = mix_bytes($hash, stringify!($field).as_bytes());
                $hash = mix_usize($hash, offset_of!($ty, $field));
            )*
        )*
    };
}

/// FNV-1a over the size, alignment, field names and field offsets of every type that crosses
/// the boundary. Two builds agree on it only if they agree on the layout.
pub const LAYOUT_HASH: u64 = {
    let mut hash = 0xcbf2_9ce4_8422_2325_u64;
    hash_layouts!(hash;
        Reading { value, age_s, status }
        DriveReading { position_rad, velocity_rad_s, enabled, fault }
        RawJointView { stamp_s, dt_s, encoders, drives }
        JointState { position_rad, velocity_rad_s, deflection_rad, torque_nm, stiffness_nm_per_rad, pivot_mm, valid }
        JointCommand { mode, position_feedback, position_rad, velocity_rad_s, stiffness_nm_per_rad }
        MotorSetpoint { position_rad, velocity_ff_rad_s, action }
        JointContext { dof, encoder_count, drive_count, rate_hz }
        ErrorBuf { message_len, field_len, message, field }
        PluginVTable { create, configure, activate, observe, control, deactivate, destroy }
        DescriptorHeader { magic, abi_major, abi_minor, layout_hash, api_version }
        PluginDescriptor { header, name, version, built_with_unwind, dof, encoder_roles, drive_roles, vtable }
    );
    hash = mix_usize(hash, crate::MAX_ENCODERS);
    hash = mix_usize(hash, crate::MAX_DRIVES);
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
/// assert_eq!(unsafe { plugin_descriptor().text(plugin_descriptor().name) }, "fixed");
/// ```
#[macro_export]
macro_rules! export_joint_plugin {
    (name: $name:ident, plugin: $ty:ty, dof: $dof:literal, encoders: $enc:literal, drives: $drv:literal $(,)?) => {
        #[doc(hidden)]
        pub static __JOINTCTL_DESCRIPTOR: $crate::abi::PluginDescriptor = $crate::abi::PluginDescriptor::new::<$ty>(
            concat!(stringify!($name), "\0"),
            concat!(env!("CARGO_PKG_VERSION"), "\0"),
            $dof,
            concat!($enc, "\0"),
            concat!($drv, "\0"),
            cfg!(panic = "unwind"),
        );

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
