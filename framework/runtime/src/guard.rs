//! The last check between the plugins and the HAL: every motor set-point a plugin writes is
//! finite, inside its drive's window and no faster than its drive's set-point rate before the
//! HAL sees it (issue 37, finding 1: the DOF's limits bound the joint-level command, but the
//! motor set-points a plugin derives from it, through its transmission or two motors of a VSA,
//! went to the drives as computed, and a plugin bug drove a motor wherever it said).
//!
//! The check is the runtime's, not each plugin's, so a plugin cannot skip it. It allocates
//! nothing and takes a few comparisons per drive; a violation is described in a fixed buffer
//! ([`Reason`]) that the log and the diagnostics read outside the cycle.

use core::fmt::Write as _;

use jointctl_api::{DriveAction, MotorSetpoint};
use jointctl_config::ArmConfig;

/// What a set-point broke.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Violation {
    /// The position or velocity feed-forward is NaN or infinite.
    NotFinite {
        /// The set-point's position [rad].
        position_rad: f64,
        /// Its velocity feed-forward [rad/s].
        velocity_ff_rad_s: f64,
    },
    /// The position is outside the drive's `setpoint_window_rad`.
    OutsideWindow {
        /// The set-point's position [rad].
        position_rad: f64,
        /// The window `[low, high]` [rad].
        window_rad: [f64; 2],
    },
    /// The position moved from the last target faster than `max_setpoint_rate_rad_s`.
    TooFast {
        /// The set-point's position [rad].
        position_rad: f64,
        /// Where the drive's target was [rad].
        from_rad: f64,
        /// The most it may move in a cycle [rad].
        max_step_rad: f64,
    },
}

/// One drive's limits and its last target.
struct DriveLimits {
    name: String,
    window_rad: Option<[f64; 2]>,
    max_step_rad: Option<f64>,
    /// The drive's target: the last set-point written with [`DriveAction::MOVE`], or its
    /// position before the first (the HAL's first target is where the drive is).
    target_rad: Option<f64>,
}

/// The set-point check of every drive of an arm, in the HAL's drive order.
///
/// ```
/// use jointctl_api::MotorSetpoint;
/// use jointctl_runtime::guard::{SetpointGuard, Violation};
/// let yaml = "arm: a\nhal: {backend: sim}\nbuses:\n  can:\n    - interface: can0\n      drives: [{name: m, node_id: 1, setpoint_window_rad: [-1.0, 1.0]}]\njoints: [{name: q, plugin: rigid, drives: {motor: m}}]\n";
/// let config = jointctl_config::parse_str(yaml, "a.yaml").unwrap().config;
/// let mut guard = SetpointGuard::new(&config);
/// assert_eq!(guard.check(0, &MotorSetpoint::move_to(0.5), Some(0.0)), Ok(()));
/// assert!(matches!(guard.check(0, &MotorSetpoint::move_to(1.5), Some(0.0)), Err(Violation::OutsideWindow { .. })));
/// assert!(matches!(guard.check(0, &MotorSetpoint::move_to(f64::NAN), Some(0.0)), Err(Violation::NotFinite { .. })));
/// ```
pub struct SetpointGuard {
    enabled: bool,
    drives: Vec<DriveLimits>,
}

impl SetpointGuard {
    /// The limits of every drive in the config; off when `safety.check_setpoints` is false.
    pub fn new(config: &ArmConfig) -> Self {
        let dt_s = 1.0 / config.rate_hz;
        let drives = config
            .buses
            .can
            .iter()
            .flat_map(|b| b.drives.iter())
            .map(|d| DriveLimits {
                name: d.name.clone(),
                window_rad: d.setpoint_window_rad,
                max_step_rad: d.max_setpoint_rate_rad_s.map(|r| r * dt_s),
                target_rad: None,
            })
            .collect();
        SetpointGuard { enabled: config.safety.check_setpoints, drives }
    }

    /// Checks drive `drive`'s set-point; `position_now_rad` is the drive's position this cycle,
    /// the rate's reference before any target was written. A hold always passes (the drive
    /// keeps its target).
    pub fn check(&self, drive: usize, sp: &MotorSetpoint, position_now_rad: Option<f64>) -> Result<(), Violation> {
        let Some(d) = self.drives.get(drive).filter(|_| self.enabled) else { return Ok(()) };
        if sp.action != DriveAction::MOVE {
            return Ok(());
        }
        let position_rad = sp.position_rad;
        if !position_rad.is_finite() || !sp.velocity_ff_rad_s.is_finite() {
            return Err(Violation::NotFinite { position_rad, velocity_ff_rad_s: sp.velocity_ff_rad_s });
        }
        if let Some(window_rad @ [lo, hi]) = d.window_rad
            && !(lo..=hi).contains(&position_rad)
        {
            return Err(Violation::OutsideWindow { position_rad, window_rad });
        }
        if let (Some(max_step_rad), Some(from_rad)) = (d.max_step_rad, d.target_rad.or(position_now_rad))
            && (position_rad - from_rad).abs() > max_step_rad
        {
            return Err(Violation::TooFast { position_rad, from_rad, max_step_rad });
        }
        Ok(())
    }

    /// Notes what was written to drive `drive` (a move's position becomes its target).
    pub fn written(&mut self, drive: usize, sp: &MotorSetpoint) {
        if let Some(d) = self.drives.get_mut(drive)
            && sp.action == DriveAction::MOVE
            && sp.position_rad.is_finite()
        {
            d.target_rad = Some(sp.position_rad);
        }
    }

    /// The drive's name, for the fault's reason.
    pub fn drive_name(&self, drive: usize) -> &str {
        self.drives.get(drive).map_or("?", |d| d.name.as_str())
    }
}

/// Longest reason kept [bytes]: what the diagnostics carry (`jointctl_ipc::FAULT_MESSAGE_LEN`
/// less its NUL).
pub const REASON_LEN: usize = 127;

/// A fault's reason written by the runtime in the cycle: a fixed buffer, no allocation; longer
/// text is cut at a character boundary.
#[derive(Clone)]
pub struct Reason {
    bytes: [u8; REASON_LEN],
    len: usize,
}

impl Default for Reason {
    fn default() -> Self {
        Reason { bytes: [0; REASON_LEN], len: 0 }
    }
}

impl Reason {
    /// The text ("" when none).
    pub fn as_str(&self) -> &str {
        // Only whole characters are ever copied in (see `write_str`).
        core::str::from_utf8(&self.bytes[..self.len]).unwrap_or("")
    }

    /// Replaces the text with a set-point violation's description.
    pub fn set_violation(&mut self, plugin: &str, drive: &str, v: &Violation) {
        self.len = 0;
        let _ = match *v {
            Violation::NotFinite { position_rad, velocity_ff_rad_s } => write!(
                self,
                "plugin `{plugin}` wrote a set-point that is not a number to drive `{drive}`: position {position_rad} rad, velocity {velocity_ff_rad_s} rad/s"
            ),
            Violation::OutsideWindow { position_rad, window_rad: [lo, hi] } => write!(
                self,
                "plugin `{plugin}` wrote {} rad to drive `{drive}`, outside its setpoint_window_rad [{lo}, {hi}]",
                Short(position_rad)
            ),
            Violation::TooFast { position_rad, from_rad, max_step_rad } => write!(
                self,
                "plugin `{plugin}` moved drive `{drive}` from {} to {} rad in one cycle, more than {} rad (max_setpoint_rate_rad_s)",
                Short(from_rad),
                Short(position_rad),
                Short(max_step_rad)
            ),
        };
    }
}

impl core::fmt::Write for Reason {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for c in s.chars() {
            let n = c.len_utf8();
            if self.len + n > REASON_LEN {
                return Err(core::fmt::Error);
            }
            c.encode_utf8(&mut self.bytes[self.len..self.len + n]);
            self.len += n;
        }
        Ok(())
    }
}

/// A number printed in at most 4 significant digits, without allocating (a 1e308 rad set-point
/// would otherwise fill the reason with digits).
struct Short(f64);

impl core::fmt::Display for Short {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let x = self.0;
        if x != 0.0 && (x.abs() >= 1e5 || x.abs() < 1e-3) { write!(f, "{x:.3e}") } else { write!(f, "{}", (x * 1e4).round() / 1e4) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard(extra: &str, check: bool) -> SetpointGuard {
        let yaml = format!(
            "arm: a\nrate_hz: 100\nhal: {{backend: sim}}\nsafety: {{check_setpoints: {check}}}\nbuses:\n  can:\n    - interface: can0\n      drives: [{{name: m, node_id: 1{extra}}}]\njoints: [{{name: q, plugin: rigid, drives: {{motor: m}}}}]\n"
        );
        SetpointGuard::new(&jointctl_config::parse_str(&yaml, "a.yaml").unwrap().config)
    }

    #[test]
    fn the_rate_is_measured_from_the_drives_position_then_from_its_last_target() {
        // 20 rad/s at 100 Hz: 0.2 rad a cycle.
        let mut g = guard(", max_setpoint_rate_rad_s: 20", true);
        assert!(g.check(0, &MotorSetpoint::move_to(1.15), Some(1.0)).is_ok());
        assert!(matches!(g.check(0, &MotorSetpoint::move_to(1.25), Some(1.0)), Err(Violation::TooFast { .. })));
        g.written(0, &MotorSetpoint::move_to(1.15));
        // A hold keeps the target: the next move is measured from 1.15, not from the position.
        g.written(0, &MotorSetpoint::HOLD);
        assert!(g.check(0, &MotorSetpoint::move_to(1.3), Some(0.0)).is_ok());
        assert!(g.check(0, &MotorSetpoint::HOLD, Some(0.0)).is_ok());
    }

    #[test]
    fn with_the_check_off_anything_passes() {
        let g = guard(", setpoint_window_rad: [-1, 1]", false);
        assert!(g.check(0, &MotorSetpoint::move_to(5.0), None).is_ok());
        assert!(g.check(0, &MotorSetpoint::move_to(f64::NAN), None).is_ok());
    }

    #[test]
    fn the_reason_names_plugin_drive_and_values_and_fits_its_buffer() {
        let mut r = Reason::default();
        r.set_violation("elastic", "elmo_q4", &Violation::OutsideWindow { position_rad: 1e308, window_rad: [-1.0, 1.0] });
        assert_eq!(r.as_str(), "plugin `elastic` wrote 1.000e308 rad to drive `elmo_q4`, outside its setpoint_window_rad [-1, 1]");
        r.set_violation(&"p".repeat(200), "m", &Violation::NotFinite { position_rad: f64::NAN, velocity_ff_rad_s: 0.0 });
        assert_eq!(r.as_str().len(), REASON_LEN);
    }
}
