//! What the runtime asks of one joint DOF each cycle.

/// The control mode of one joint DOF.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ControlMode(pub u32);

impl ControlMode {
    /// Keep the drives where they are; the safe state.
    pub const HOLD: Self = Self(0);
    /// Go to `position_rad` (joint side), with the plugin's position feedback (thesis section 4.3).
    pub const POSITION: Self = Self(1);

    /// A short lower-case name for logs and the command line.
    pub const fn name(self) -> &'static str {
        match self.0 {
            0 => "hold",
            1 => "position",
            _ => "unknown",
        }
    }
}

/// The command for one joint DOF, already validated by the runtime (finite, within limits).
///
/// ```
/// use jointctl_api::{ControlMode, JointCommand};
/// let c = JointCommand::position(0.3);
/// assert_eq!(c.mode, ControlMode::POSITION);
/// assert_eq!(JointCommand::HOLD.mode, ControlMode::HOLD);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointCommand {
    /// The mode this command selects.
    pub mode: ControlMode,
    _reserved: u32,
    /// Joint position set-point [rad].
    pub position_rad: f64,
    /// Joint velocity feed-forward [rad/s].
    pub velocity_rad_s: f64,
}

impl JointCommand {
    /// Hold: keep the drives where they are.
    pub const HOLD: JointCommand =
        JointCommand { mode: ControlMode::HOLD, _reserved: 0, position_rad: 0.0, velocity_rad_s: 0.0 };

    /// Go to a joint position [rad].
    pub const fn position(position_rad: f64) -> Self {
        JointCommand { mode: ControlMode::POSITION, position_rad, ..JointCommand::HOLD }
    }
}

impl Default for JointCommand {
    fn default() -> Self {
        JointCommand::HOLD
    }
}
