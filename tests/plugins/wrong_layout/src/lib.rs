//! Test fixture: a plugin library whose descriptor does not match this host (wrong_layout).
//! The host must refuse it with a message naming the file, both versions and the fix.

use jointctl_api::abi::PluginDescriptor;
use jointctl_api::*;

/// A joint that does nothing.
pub struct Nothing;

impl Observer for Nothing {
    fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> {
        Ok(())
    }
}

impl Controller for Nothing {
    fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> {
        Ok(())
    }
}

impl JointPlugin for Nothing {
    fn create(_: &str) -> Result<Self, PluginError> {
        Ok(Nothing)
    }
}

static DESCRIPTOR: PluginDescriptor = {
    let mut d = PluginDescriptor::new::<Nothing>("wrong_layout\0", "0.0.0\0", 1, "output\0", "motor\0", true);
    d.header.layout_hash ^= 0x5a5a;
    d
};

/// The entry point the host looks up.
#[unsafe(no_mangle)]
pub extern "C" fn jointctl_plugin_wrong_layout() -> *const PluginDescriptor {
    &DESCRIPTOR
}
