//! The traits a joint type implements. A plugin author writes ordinary Rust against these and
//! exports the type with [`export_joint_plugin!`](crate::export_joint_plugin).

use crate::{JointCommand, JointState, MotorSetpoint, RawJointView};

/// Everything the runtime tells a plugin instance once, before it runs.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointContext {
    /// Degrees of freedom this instance observes and controls.
    pub dof: u32,
    /// Encoder roles wired in the YAML (the optional ones may be missing).
    pub encoder_count: u32,
    /// Drive roles wired in the YAML.
    pub drive_count: u32,
    _reserved: u32,
    /// Loop rate [Hz].
    pub rate_hz: f64,
}

impl JointContext {
    /// A context from its parts.
    ///
    /// ```
    /// let ctx = jointctl_api::JointContext::new(1, 1, 1, 40.0);
    /// assert_eq!(ctx.rate_hz, 40.0);
    /// ```
    pub const fn new(dof: u32, encoder_count: u32, drive_count: u32, rate_hz: f64) -> Self {
        JointContext { dof, encoder_count, drive_count, _reserved: 0, rate_hz }
    }
}

/// A fault a plugin reports from `observe` or `control`: the joint is held and the code
/// published. Codes 0 and 1 are reserved by the ABI (ok, panicked).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointFault(u32);

impl JointFault {
    /// First code available to plugins.
    pub const FIRST_PLUGIN_CODE: u32 = 16;
    /// The plugin panicked; the panic was caught at the library boundary (the ABI's
    /// `STATUS_PANICKED`, which `abi` checks at compile time).
    pub const PANICKED: JointFault = JointFault(1);
    /// The plugin returned an unknown status (the ABI's `STATUS_FAILED`, checked likewise).
    pub const BAD_STATUS: JointFault = JointFault(2);
    /// Raised by the host, never by a plugin: the plugin's calls in one cycle took longer than
    /// the joint's time budget, so it is not called again.
    pub const OVER_BUDGET: JointFault = JointFault(3);
    /// Raised by the host, never by a plugin: a motor set-point the plugin wrote was not
    /// finite, outside its drive's window or faster than its drive's set-point rate, so the
    /// joint is held (the runtime's set-point check, `safety.check_setpoints`).
    pub const SETPOINT_REJECTED: JointFault = JointFault(4);

    /// A plugin-defined fault code; codes below [`JointFault::FIRST_PLUGIN_CODE`] are moved above it.
    ///
    /// ```
    /// use jointctl_api::JointFault;
    /// assert_eq!(JointFault::new(3).code(), 19);
    /// ```
    pub const fn new(code: u32) -> Self {
        if code < Self::FIRST_PLUGIN_CODE { JointFault(code + Self::FIRST_PLUGIN_CODE) } else { JointFault(code) }
    }

    /// The numeric code, as published in diagnostics.
    pub const fn code(self) -> u32 {
        self.0
    }
}

/// An error while creating, configuring or activating a plugin instance.
///
/// `field` is a path inside the joint's `params` (e.g. `characteristic.order`), so that the
/// runtime can point at the YAML file, line and column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PluginError {
    /// What is wrong.
    pub message: String,
    /// Where inside the joint's `params`, if known.
    pub field: Option<String>,
}

impl PluginError {
    /// An error not tied to a parameter.
    ///
    /// ```
    /// let e = jointctl_api::PluginError::new("encoder not calibrated");
    /// assert!(e.field.is_none());
    /// ```
    pub fn new(message: impl Into<String>) -> Self {
        PluginError { message: message.into(), field: None }
    }

    /// An error about one parameter.
    ///
    /// ```
    /// let e = jointctl_api::PluginError::at("stiffness_nm_per_rad", "must be > 0");
    /// assert_eq!(e.field.as_deref(), Some("stiffness_nm_per_rad"));
    /// ```
    pub fn at(field: impl Into<String>, message: impl Into<String>) -> Self {
        PluginError { message: message.into(), field: Some(field.into()) }
    }
}

impl core::fmt::Display for PluginError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match &self.field {
            Some(field) => write!(f, "{field}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for PluginError {}

/// Raw sensor readings → joint state, every cycle. Must not allocate, block or do I/O.
pub trait Observer {
    /// Fills `out` (one entry per DOF). A reading that is not usable leaves the fields that
    /// depend on it unknown; it is never read as a value.
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault>;
}

/// Joint state + command → motor set-points, every cycle. Must not allocate, block or do I/O.
pub trait Controller {
    /// Fills `out` (one entry per drive role). Called only when the runtime found the joint's
    /// state usable; otherwise the runtime holds the drives itself.
    fn control(
        &mut self,
        state: &[JointState],
        command: &[JointCommand],
        raw: &RawJointView,
        out: &mut [MotorSetpoint],
    ) -> Result<(), JointFault>;
}

/// A joint type: its lifecycle around [`Observer`] and [`Controller`].
///
/// create (from YAML parameters) → configure → activate → observe/control every cycle →
/// deactivate → drop. Allocation is allowed everywhere except in `observe` and `control`.
pub trait JointPlugin: Observer + Controller + Send + 'static {
    /// Builds an instance from the joint's `params` (the YAML subtree, handed over as JSON).
    fn create(params_json: &str) -> Result<Self, PluginError>
    where
        Self: Sized;

    /// Checks the wiring and rate; called once before activation.
    fn configure(&mut self, _ctx: &JointContext) -> Result<(), PluginError> {
        Ok(())
    }

    /// Called with the first readings before the first cycle (e.g. to capture the initial
    /// angle that section 3.4.1 subtracts from the deflection).
    fn activate(&mut self, _raw: &RawJointView) -> Result<(), PluginError> {
        Ok(())
    }

    /// Called once when the loop stops.
    fn deactivate(&mut self) {}
}
