//! The host side of one plugin instance: an adapter that turns the C entry points back into the
//! [`Observer`] and [`Controller`] traits.

use jointctl_api::abi::{ErrorBuf, Handle, PluginDescriptor, STATUS_FAILED, STATUS_OK, STATUS_PANICKED};
use jointctl_api::{
    Controller, JointCommand, JointContext, JointFault, JointState, MotorSetpoint, Observer, PluginError,
    RawJointView,
};

use crate::loader::PluginSource;

/// What the runtime needs of a joint besides observing and controlling it.
pub trait LoadedJoint: Observer + Controller + Send {
    /// Hands over the first readings before the first cycle.
    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError>;
    /// Called once when the loop stops.
    fn deactivate(&mut self);
    /// The text of the last error or panic the plugin reported.
    fn last_message(&self) -> &str;
}

/// A plugin instance behind the C ABI. Created and freed by the plugin itself.
///
/// An instance that panicked is never entered again (as dora-rs treats a panicked operator):
/// its state may be broken half-way through an update, so `observe` and `control` answer
/// [`JointFault::PANICKED`] without calling it, `deactivate` is skipped and the instance is
/// leaked rather than destroyed (its `Drop` would run on that broken state).
pub struct FfiJoint {
    descriptor: &'static PluginDescriptor,
    handle: Handle,
    panicked: bool,
    // Boxed so that its address is stable and the cycle never copies 1.3 kB around.
    err: Box<ErrorBuf>,
}

// SAFETY: `JointPlugin: Send`, so the instance behind `handle` may move between threads.
unsafe impl Send for FfiJoint {}

fn fault_of(code: u32) -> Result<(), JointFault> {
    match code {
        STATUS_OK => Ok(()),
        STATUS_PANICKED => Err(JointFault::PANICKED),
        c if c >= JointFault::FIRST_PLUGIN_CODE => Err(JointFault::new(c)),
        _ => Err(JointFault::BAD_STATUS),
    }
}

impl FfiJoint {
    /// Creates an instance from its parameters (JSON text).
    pub fn create(source: PluginSource, params_json: &str) -> Result<Self, PluginError> {
        let mut err = Box::new(ErrorBuf::new());
        let d = source.descriptor;
        // SAFETY: the descriptor passed the ABI check; params is valid for its length.
        let handle = unsafe { (d.vtable().create)(params_json.as_ptr(), params_json.len(), &mut *err) };
        if handle.is_null() {
            let message = if err.message().is_empty() { "the plugin refused its parameters" } else { err.message() };
            return Err(PluginError { message: message.to_string(), field: err.field().map(str::to_string) });
        }
        Ok(FfiJoint { descriptor: d, handle, panicked: false, err })
    }

    /// Whether the plugin panicked in any call so far; it is not entered again.
    pub fn panicked(&self) -> bool {
        self.panicked
    }

    /// Turns a cycle call's status into a result, remembering a panic.
    fn cycle_result(&mut self, status: u32) -> Result<(), JointFault> {
        self.panicked |= status == STATUS_PANICKED;
        fault_of(status)
    }

    fn lifecycle_result(&mut self, status: u32, what: &str) -> Result<(), PluginError> {
        self.panicked |= status == STATUS_PANICKED;
        match status {
            STATUS_OK => Ok(()),
            STATUS_PANICKED => Err(PluginError::new(format!("the plugin panicked in {what}: {}", self.err.message()))),
            STATUS_FAILED => Err(PluginError { message: self.err.message().to_string(), field: self.err.field().map(str::to_string) }),
            other => Err(PluginError::new(format!("the plugin returned unknown status {other} from {what}"))),
        }
    }

    /// Checks wiring and rate.
    pub fn configure(&mut self, ctx: &JointContext) -> Result<(), PluginError> {
        self.err.clear();
        // SAFETY: handle is live; pointers valid for the call.
        let status = unsafe { (self.descriptor.vtable().configure)(self.handle, ctx, &mut *self.err) };
        self.lifecycle_result(status, "configure")
    }
}

impl Observer for FfiJoint {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        if self.panicked {
            return Err(JointFault::PANICKED);
        }
        // SAFETY: handle is live; `out` is valid for `out.len()` writes.
        let status = unsafe {
            (self.descriptor.vtable().observe)(self.handle, raw, out.as_mut_ptr(), out.len() as u32, &mut *self.err)
        };
        self.cycle_result(status)
    }
}

impl Controller for FfiJoint {
    fn control(
        &mut self,
        state: &[JointState],
        command: &[JointCommand],
        raw: &RawJointView,
        out: &mut [MotorSetpoint],
    ) -> Result<(), JointFault> {
        debug_assert_eq!(state.len(), command.len());
        if self.panicked {
            return Err(JointFault::PANICKED);
        }
        // SAFETY: handle is live; slices valid for their lengths.
        let status = unsafe {
            (self.descriptor.vtable().control)(
                self.handle,
                state.as_ptr(),
                command.as_ptr(),
                state.len() as u32,
                raw,
                out.as_mut_ptr(),
                out.len() as u32,
                &mut *self.err,
            )
        };
        self.cycle_result(status)
    }
}

impl LoadedJoint for FfiJoint {
    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        if self.panicked {
            return Err(PluginError::new("the plugin panicked before and is not entered again"));
        }
        self.err.clear();
        // SAFETY: handle is live; pointers valid for the call.
        let status = unsafe { (self.descriptor.vtable().activate)(self.handle, raw, &mut *self.err) };
        self.lifecycle_result(status, "activate")
    }

    fn deactivate(&mut self) {
        if self.panicked {
            return;
        }
        // SAFETY: handle is live.
        let status = unsafe { (self.descriptor.vtable().deactivate)(self.handle) };
        self.panicked |= status == STATUS_PANICKED;
    }

    fn last_message(&self) -> &str {
        self.err.message()
    }
}

impl Drop for FfiJoint {
    fn drop(&mut self) {
        if self.panicked {
            // Leaked on purpose: see the type's docs.
            return;
        }
        // SAFETY: handle came from this plugin's create and is not used afterwards.
        unsafe { (self.descriptor.vtable().destroy)(self.handle) };
    }
}
