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

static DESCRIPTOR: PluginDescriptor = PluginDescriptor::new::<Nothing>(c"wrong_layout", c"0.0.0", 1, c"output", c"motor", true)
    .with_versions(abi::ABI_MAJOR, abi::ABI_MINOR, abi::LAYOUT_HASH ^ 0x5a5a);

/// The entry point the host looks up.
#[unsafe(no_mangle)]
pub extern "C" fn jointctl_plugin_wrong_layout() -> *const PluginDescriptor {
    &DESCRIPTOR
}
