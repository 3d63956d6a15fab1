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
pub struct FfiJoint {
    descriptor: &'static PluginDescriptor,
    handle: Handle,
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
        let handle = unsafe { (d.vtable.create)(params_json.as_ptr(), params_json.len(), &mut *err) };
        if handle.is_null() {
            let message = if err.message().is_empty() { "the plugin refused its parameters" } else { err.message() };
            return Err(PluginError { message: message.to_string(), field: err.field().map(str::to_string) });
        }
        Ok(FfiJoint { descriptor: d, handle, err })
    }

    fn lifecycle_result(&self, status: u32, what: &str) -> Result<(), PluginError> {
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
        let status = unsafe { (self.descriptor.vtable.configure)(self.handle, ctx, &mut *self.err) };
        self.lifecycle_result(status, "configure")
    }

}

impl Observer for FfiJoint {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        // SAFETY: handle is live; `out` is valid for `out.len()` writes.
        fault_of(unsafe {
            (self.descriptor.vtable.observe)(self.handle, raw, out.as_mut_ptr(), out.len() as u32, &mut *self.err)
        })
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
        // SAFETY: handle is live; slices valid for their lengths.
        fault_of(unsafe {
            (self.descriptor.vtable.control)(
                self.handle,
                state.as_ptr(),
                command.as_ptr(),
                state.len() as u32,
                raw,
                out.as_mut_ptr(),
                out.len() as u32,
                &mut *self.err,
            )
        })
    }
}

impl LoadedJoint for FfiJoint {
    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        self.err.clear();
        // SAFETY: handle is live; pointers valid for the call.
        let status = unsafe { (self.descriptor.vtable.activate)(self.handle, raw, &mut *self.err) };
        self.lifecycle_result(status, "activate")
    }

    fn deactivate(&mut self) {
        // SAFETY: handle is live.
        unsafe { (self.descriptor.vtable.deactivate)(self.handle) };
    }

    fn last_message(&self) -> &str {
        self.err.message()
    }
}

impl Drop for FfiJoint {
    fn drop(&mut self) {
        // SAFETY: handle came from this plugin's create and is not used afterwards.
        unsafe { (self.descriptor.vtable.destroy)(self.handle) };
    }
}
