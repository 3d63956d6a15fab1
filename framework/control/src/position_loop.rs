//! Section 4.3's position loop, the same in every joint plugin.

use jointctl_api::{ControlMode, JointCommand, PluginError};

use jointctl_api::MotorSetpoint;

use crate::{LinearTransmission, Pi, PiGains};

/// Default `max_age_s` of a plugin's params: the oldest stale reading still used [s].
/// Assumption: 0.1 s, 4 cycles at the thesis' 40 Hz (sections 2.3, 4.1), so that one or two lost
/// SPI or CAN frames do not fault a joint while a longer loss does.
///
/// ```
/// #[derive(serde::Deserialize)]
/// struct Params {
///     #[serde(default = "jointctl_control::default_max_age_s")]
///     max_age_s: f64,
/// }
/// let p: Params = serde_json::from_str("{}").unwrap();
/// assert_eq!(p.max_age_s, 0.1);
/// ```
pub fn default_max_age_s() -> f64 {
    0.1
}

/// One DOF's joint-position target, section 4.3: in position mode the commanded position plus
/// a PI correction of the measured position error (what the drive's own loop leaves:
/// transmission compliance, friction); in any other mode the position the DOF had when it
/// entered that mode, so that a DOF of a differential holds still while the other one moves.
///
/// A missing position reading is never used as a value: the target is then unknown
/// ([`None`]), and the plugin holds its motors.
///
/// ```
/// use jointctl_api::{ControlMode, JointCommand};
/// use jointctl_control::{PiGains, PositionLoop};
/// let mut pl = PositionLoop::new(PiGains { kp: 0.5, ki: 0.0, output_limit: f64::INFINITY });
/// let go = JointCommand::position(1.0);
/// // Error 1.0 - 0.8 = 0.2 rad, corrected by kp * 0.2 = 0.1 rad.
/// assert_eq!(pl.target_rad(&go, Some(0.8), 0.01), Some(1.1));
/// // Position unknown: no target, the motors hold.
/// assert_eq!(pl.target_rad(&go, None, 0.01), None);
/// // Hold keeps the position the joint had when it entered hold.
/// assert_eq!(pl.target_rad(&JointCommand::HOLD, Some(0.9), 0.01), Some(0.9));
/// assert_eq!(pl.target_rad(&JointCommand::HOLD, Some(0.95), 0.01), Some(0.9));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct PositionLoop {
    pi: Pi,
    mode: ControlMode,
    hold_rad: Option<f64>,
}

impl PositionLoop {
    /// A loop with these PI gains, starting in hold.
    pub fn new(gains: PiGains) -> Self {
        PositionLoop { pi: Pi::new(gains), mode: ControlMode::HOLD, hold_rad: None }
    }

    /// A loop from a plugin's `position_pi` params, the gains checked; an error names the
    /// field (`position_pi.kp`).
    ///
    /// ```
    /// use jointctl_control::{PiGains, PositionLoop};
    /// let e = PositionLoop::from_params(PiGains { kp: -1.0, ki: 0.0, output_limit: 1.0 }).unwrap_err();
    /// assert_eq!(e.field.as_deref(), Some("position_pi.kp"));
    /// ```
    pub fn from_params(gains: PiGains) -> Result<Self, PluginError> {
        gains.validate().map_err(|e| PluginError::at(format!("position_pi.{}", e.field), e.to_string()))?;
        Ok(PositionLoop::new(gains))
    }

    /// Section 4.3 for a joint with one motor behind a linear transmission: in position mode the
    /// motor goes where the corrected target needs it; in every other mode, or with the position
    /// unknown, the drive holds.
    ///
    /// ```
    /// use jointctl_api::{JointCommand, MotorSetpoint};
    /// use jointctl_control::{LinearTransmission, PiGains, PositionLoop};
    /// let mut pl = PositionLoop::new(PiGains { kp: 0.0, ki: 0.0, output_limit: 1.0 });
    /// let t = LinearTransmission::new(2.0);
    /// assert_eq!(pl.motor_setpoint(&JointCommand::position(1.0), Some(0.0), 0.01, &t), MotorSetpoint::move_to(0.5));
    /// assert_eq!(pl.motor_setpoint(&JointCommand::position(1.0), None, 0.01, &t), MotorSetpoint::HOLD);
    /// ```
    pub fn motor_setpoint(&mut self, command: &JointCommand, position_rad: Option<f64>, dt_s: f64, transmission: &LinearTransmission) -> MotorSetpoint {
        match self.target_rad(command, position_rad, dt_s) {
            Some(q) if command.mode == ControlMode::POSITION => MotorSetpoint::move_to(transmission.motor_for(q)),
            _ => MotorSetpoint::HOLD,
        }
    }

    /// Holds at this position from now on (e.g. the pose at activation).
    pub fn hold_at(&mut self, position_rad: f64) {
        self.mode = ControlMode::HOLD;
        self.hold_rad = Some(position_rad);
    }

    /// The joint position to command this cycle [rad], or `None` when it is unknown (hold).
    /// A change of mode resets the PI, so no integral carries over from an earlier move.
    pub fn target_rad(&mut self, command: &JointCommand, position_rad: Option<f64>, dt_s: f64) -> Option<f64> {
        if command.mode != self.mode {
            self.pi.reset();
            self.mode = command.mode;
            self.hold_rad = position_rad;
        }
        match command.mode {
            ControlMode::POSITION => {
                let q = position_rad?;
                let correction = if command.feedback() { self.pi.update(command.position_rad - q, dt_s) } else { 0.0 };
                Some(command.position_rad + correction)
            }
            _ => {
                // Entered this mode with an unknown position: take the first one read since.
                if self.hold_rad.is_none() {
                    self.hold_rad = position_rad;
                }
                self.hold_rad
            }
        }
    }
}
