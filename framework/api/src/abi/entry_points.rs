//! The entry points: the [`PluginVTable`] a descriptor carries, with the text of its signatures
//! that the layout hash covers, and the generic `extern "C"` shims that fill it for a plugin type,
//! catching panics at the boundary and reporting errors into the host's [`ErrorBuf`].

use std::panic::{AssertUnwindSafe, catch_unwind};

use super::error_buf::ErrorBuf;
use super::{Handle, STATUS_FAILED, STATUS_OK, STATUS_PANICKED};
use crate::{JointCommand, JointContext, JointPlugin, JointState, MotorSetpoint, PluginError, RawJointView};

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

        /// The vtable's fields with their full signatures, as hashed into [`LAYOUT_HASH`](super::LAYOUT_HASH).
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
pub(super) unsafe extern "C" fn shim_create<P: JointPlugin>(params: *const u8, len: usize, err: *mut ErrorBuf) -> Handle {
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
pub(super) unsafe extern "C" fn shim_configure<P: JointPlugin>(h: Handle, ctx: *const JointContext, err: *mut ErrorBuf) -> u32 {
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
pub(super) unsafe extern "C" fn shim_activate<P: JointPlugin>(h: Handle, raw: *const RawJointView, err: *mut ErrorBuf) -> u32 {
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
pub(super) unsafe extern "C" fn shim_observe<P: JointPlugin>(
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
pub(super) unsafe extern "C" fn shim_control<P: JointPlugin>(
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
pub(super) unsafe extern "C" fn shim_deactivate<P: JointPlugin>(h: Handle) -> u32 {
    // SAFETY: guaranteed by the host.
    let plugin = unsafe { &mut *h.cast::<P>() };
    match guarded(|| plugin.deactivate()) {
        Ok(()) => STATUS_OK,
        Err(_) => STATUS_PANICKED,
    }
}

/// # Safety
/// `h` was returned by `shim_create::<P>` and is not used afterwards.
pub(super) unsafe extern "C" fn shim_destroy<P: JointPlugin>(h: Handle) {
    if h.is_null() {
        return;
    }
    // SAFETY: `h` came from `Box::into_raw` in `shim_create::<P>`.
    let boxed = unsafe { Box::from_raw(h.cast::<P>()) };
    // A panicking Drop must not unwind into the host; the instance is gone either way.
    let _ = guarded(move || drop(boxed));
}
