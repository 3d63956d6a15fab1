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

/// The command for one joint DOF, already validated by the runtime (finite, within limits): a
/// joint position set-point and how to reach it. The runtime's controller turns every mode
/// (position, trajectory, manual, torque, impedance) into such a set-point each cycle.
///
/// ```
/// use jointctl_api::{ControlMode, JointCommand};
/// let c = JointCommand::position(0.3);
/// assert_eq!(c.mode, ControlMode::POSITION);
/// assert!(c.feedback() && c.stiffness().is_none());
/// assert_eq!(JointCommand::HOLD.mode, ControlMode::HOLD);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointCommand {
    /// HOLD, or POSITION to go to `position_rad`.
    pub mode: ControlMode,
    /// 1: apply the joint's position feedback PI (section 4.3); 0: pass the set-point through
    /// (torque and impedance modes, where the feedback would fight the torque loop).
    pub position_feedback: u8,
    _reserved: [u8; 3],
    /// Joint position set-point [rad].
    pub position_rad: f64,
    /// Joint velocity feed-forward [rad/s].
    pub velocity_rad_s: f64,
    /// Requested joint stiffness [Nm/rad] for a variable stiffness joint; NaN: keep the pivot.
    pub stiffness_nm_per_rad: f64,
}

impl JointCommand {
    /// Hold: keep the drives where they are.
    pub const HOLD: JointCommand = JointCommand {
        mode: ControlMode::HOLD,
        position_feedback: 0,
        _reserved: [0; 3],
        position_rad: 0.0,
        velocity_rad_s: 0.0,
        stiffness_nm_per_rad: f64::NAN,
    };

    /// Go to a joint position [rad] with position feedback.
    pub const fn position(position_rad: f64) -> Self {
        JointCommand { mode: ControlMode::POSITION, position_feedback: 1, position_rad, ..JointCommand::HOLD }
    }

    /// A set-point with or without position feedback.
    pub const fn setpoint(position_rad: f64, velocity_rad_s: f64, feedback: bool) -> Self {
        JointCommand { mode: ControlMode::POSITION, position_feedback: feedback as u8, position_rad, velocity_rad_s, ..JointCommand::HOLD }
    }

    /// The same command with a stiffness request [Nm/rad].
    pub const fn with_stiffness(self, stiffness_nm_per_rad: f64) -> Self {
        JointCommand { stiffness_nm_per_rad, ..self }
    }

    /// Whether the position feedback PI should act.
    pub const fn feedback(&self) -> bool {
        self.position_feedback != 0
    }

    /// The requested stiffness, if any.
    pub fn stiffness(&self) -> Option<f64> {
        (self.stiffness_nm_per_rad.is_finite() && self.stiffness_nm_per_rad > 0.0).then_some(self.stiffness_nm_per_rad)
    }
}

impl Default for JointCommand {
    fn default() -> Self {
        JointCommand::HOLD
    }
}
