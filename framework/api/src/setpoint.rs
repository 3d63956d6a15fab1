//! What a joint plugin asks of its drives each cycle.

/// What a drive should do with a [`MotorSetpoint`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct DriveAction(pub u8);

impl DriveAction {
    /// Keep the drive's current target: the safe state, used for held and faulted joints.
    pub const HOLD: Self = Self(0);
    /// Move to `position_rad` (ELMO profile position mode, thesis section 3.2).
    pub const MOVE: Self = Self(1);
}

/// A motor (gearbox output) position set-point for one drive.
///
/// ```
/// use jointctl_api::{DriveAction, MotorSetpoint};
/// assert_eq!(MotorSetpoint::move_to(1.0).action, DriveAction::MOVE);
/// assert_eq!(MotorSetpoint::HOLD.action, DriveAction::HOLD);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorSetpoint {
    /// Target motor position [rad].
    pub position_rad: f64,
    /// Velocity feed-forward [rad/s].
    pub velocity_ff_rad_s: f64,
    /// What the drive should do.
    pub action: DriveAction,
    _reserved: [u8; 7],
}

impl MotorSetpoint {
    /// Keep the current target.
    pub const HOLD: MotorSetpoint =
        MotorSetpoint { position_rad: 0.0, velocity_ff_rad_s: 0.0, action: DriveAction::HOLD, _reserved: [0; 7] };

    /// Move to `position_rad`.
    pub const fn move_to(position_rad: f64) -> Self {
        MotorSetpoint { position_rad, action: DriveAction::MOVE, ..MotorSetpoint::HOLD }
    }
}

impl Default for MotorSetpoint {
    fn default() -> Self {
        MotorSetpoint::HOLD
    }
}
