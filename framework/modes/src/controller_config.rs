//! A DOF's controller settings from the YAML (`controller:`): the torque PI and its gain schedule
//! over the stiffness, the set-point rate limit, the watchdog, the start-up mode, and the DOF's
//! limits; checked once, before the loop.

use serde::Deserialize;

use jointctl_control::{InvalidNumber, PiGains};

use crate::Reference;
use crate::mode::Mode;

/// One point of the torque PI's gain schedule over the joint stiffness (section 6.2).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GainPoint {
    /// Joint stiffness at which these gains apply [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// Proportional gain on the deflection error [rad/rad].
    pub kp: f64,
    /// Integral gain on the deflection error [1/s].
    pub ki: f64,
}

/// A DOF's controller settings (YAML `controller:` of a joint or DOF). The thesis tuned its PI
/// experimentally without printing the gains (section 4.3): every default is an assumption.
#[derive(Clone, Debug, PartialEq, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ControllerConfig {
    /// Figure 4.6: the PI on the deflection error; `output_limit` bounds its correction [rad].
    #[serde(default = "default_torque_pi")]
    #[schemars(with = "crate::PiGainsSchema")]
    pub torque_pi: PiGains,
    /// Section 6.2: gains at several stiffness settings, interpolated linearly in stiffness and
    /// held constant beyond the ends. Empty: `torque_pi` at every stiffness.
    #[serde(default)]
    pub torque_pi_schedule: Vec<GainPoint>,
    /// Largest joint set-point rate [rad/s]. Assumption: 2 rad/s.
    #[serde(default = "default_rate")]
    pub max_setpoint_rate_rad_s: f64,
    /// A streamed torque or impedance command that is not renewed within this time falls back
    /// to holding [s]. Assumption: 0.5 s.
    #[serde(default = "default_watchdog")]
    pub watchdog_s: f64,
    /// The mode the DOF starts in (default: hold): `{position_rad: 0.3}`, or e.g. `{torque:
    /// {waveform: sine, amplitude: 5, frequency_hz: 0.1}}` to run a chapter-5 experiment from
    /// YAML alone.
    #[serde(default)]
    pub startup: Option<StartupMode>,
    /// Manual set-points go through the joint's position feedback PI, as in the thesis, where
    /// "in case of ... manual manipulation the feedback PI loop is by default activated"
    /// (section 4.3). `false`: the set-point goes to the drive as it is.
    #[serde(default = "default_true")]
    pub manual_position_feedback: bool,
    /// Appendix C / future work: in torque and impedance modes, add the torque that holds the
    /// arm against gravity (from the arm's URDF, `kinematics`, at the observed joint positions)
    /// to the torque the joint regulates, so that a torque reference is the torque beyond
    /// gravity. Default off (the thesis' clamped experiments have no gravity load).
    #[serde(default)]
    pub gravity_feedforward: bool,
}

fn default_true() -> bool {
    true
}

/// A DOF's mode at start, from YAML: exactly one of `position_rad` or `torque`. Times are from
/// the loop's start [s].
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StartupMode {
    /// Go to a position [rad] with the feedback PI.
    #[serde(default)]
    pub position_rad: Option<f64>,
    /// Follow a torque reference.
    #[serde(default)]
    pub torque: Option<Reference>,
}

impl StartupMode {
    /// The mode it selects.
    pub fn mode(&self) -> Mode {
        match (self.position_rad, self.torque) {
            (Some(target_rad), None) => Mode::Position { target_rad },
            (None, Some(reference)) => Mode::Torque { reference },
            _ => Mode::Hold,
        }
    }
}

fn default_torque_pi() -> PiGains {
    PiGains { kp: 0.3, ki: 4.0, output_limit: 0.2 }
}
fn default_rate() -> f64 {
    2.0
}
fn default_watchdog() -> f64 {
    0.5
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig {
            torque_pi: default_torque_pi(),
            torque_pi_schedule: Vec::new(),
            max_setpoint_rate_rad_s: default_rate(),
            watchdog_s: default_watchdog(),
            startup: None,
            manual_position_feedback: true,
            gravity_feedforward: false,
        }
    }
}

impl ControllerConfig {
    /// Checks every number; the error names the field.
    pub fn validate(&self) -> Result<(), ControllerConfigError> {
        use ControllerConfigError as E;
        self.torque_pi.validate().map_err(|source| E::Number { at: "torque_pi.".into(), source })?;
        for (i, g) in self.torque_pi_schedule.iter().enumerate() {
            let at = || format!("torque_pi_schedule[{i}].");
            let k = g.stiffness_nm_per_rad;
            InvalidNumber::check("stiffness_nm_per_rad", k, "finite and > 0", k.is_finite() && k > 0.0).map_err(|source| E::Number { at: at(), source })?;
            InvalidNumber::check("kp", g.kp, "finite and >= 0", g.kp.is_finite() && g.kp >= 0.0).map_err(|source| E::Number { at: at(), source })?;
            InvalidNumber::check("ki", g.ki, "finite and >= 0", g.ki.is_finite() && g.ki >= 0.0).map_err(|source| E::Number { at: at(), source })?;
            if i > 0 && k <= self.torque_pi_schedule[i - 1].stiffness_nm_per_rad {
                return Err(E::ScheduleNotIncreasing { index: i });
            }
        }
        let rate = self.max_setpoint_rate_rad_s;
        InvalidNumber::check("max_setpoint_rate_rad_s", rate, "finite and > 0", rate.is_finite() && rate > 0.0)
            .map_err(|source| E::Number { at: String::new(), source })?;
        let w = self.watchdog_s;
        InvalidNumber::check("watchdog_s", w, "finite and > 0", w.is_finite() && w > 0.0).map_err(|source| E::Number { at: String::new(), source })?;
        match self.startup {
            Some(StartupMode { position_rad: Some(q), torque: None }) => InvalidNumber::check("position_rad", q, "finite", q.is_finite())
                .map(|_| ())
                .map_err(|source| E::Number { at: "startup.".into(), source }),
            Some(StartupMode { position_rad: None, torque: Some(r) }) => r.validate().map_err(|source| E::Number { at: "startup.torque.".into(), source }),
            None => Ok(()),
            Some(_) => Err(E::StartupAmbiguous),
        }
    }

    /// The torque PI gains at a stiffness (section 6.2's gain scheduling).
    ///
    /// ```
    /// use jointctl_modes::{ControllerConfig, GainPoint};
    /// let mut c = ControllerConfig::default();
    /// c.torque_pi_schedule = vec![
    ///     GainPoint { stiffness_nm_per_rad: 10.0, kp: 1.0, ki: 10.0 },
    ///     GainPoint { stiffness_nm_per_rad: 30.0, kp: 0.2, ki: 2.0 },
    /// ];
    /// let g = c.gains_at(20.0);
    /// assert!((g.kp - 0.6).abs() < 1e-12 && (g.ki - 6.0).abs() < 1e-12);
    /// assert_eq!(c.gains_at(100.0).kp, 0.2);
    /// ```
    pub fn gains_at(&self, stiffness_nm_per_rad: f64) -> PiGains {
        let s = &self.torque_pi_schedule;
        let (kp, ki) = match s.len() {
            0 => return self.torque_pi,
            _ if stiffness_nm_per_rad <= s[0].stiffness_nm_per_rad => (s[0].kp, s[0].ki),
            n if stiffness_nm_per_rad >= s[n - 1].stiffness_nm_per_rad => (s[n - 1].kp, s[n - 1].ki),
            _ => {
                let i = s.partition_point(|g| g.stiffness_nm_per_rad <= stiffness_nm_per_rad) - 1;
                let (a, b) = (s[i], s[i + 1]);
                let w = (stiffness_nm_per_rad - a.stiffness_nm_per_rad) / (b.stiffness_nm_per_rad - a.stiffness_nm_per_rad);
                (a.kp + w * (b.kp - a.kp), a.ki + w * (b.ki - a.ki))
            }
        };
        PiGains { kp, ki, output_limit: self.torque_pi.output_limit }
    }
}

/// Limits of one DOF (from the YAML `limits`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DofLimits {
    /// `[lower, upper]` joint position [rad].
    pub position_rad: [f64; 2],
    /// Largest |torque reference| [Nm].
    pub torque_nm: f64,
    /// Largest joint velocity a set-point may ask for [rad/s]: the set-point never moves
    /// faster (with `max_setpoint_rate_rad_s`, the lower of the two counts) and a trajectory's
    /// velocity feed-forward is clamped to it.
    pub velocity_rad_s: f64,
}

impl DofLimits {
    /// No limits.
    pub const NONE: DofLimits =
        DofLimits { position_rad: [f64::NEG_INFINITY, f64::INFINITY], torque_nm: f64::INFINITY, velocity_rad_s: f64::INFINITY };
}

/// What is wrong with a [`ControllerConfig`]; [`field`](Self::field) is the YAML path below
/// `controller`.
///
/// ```
/// use jointctl_modes::ControllerConfig;
/// let mut c = ControllerConfig::default();
/// c.watchdog_s = 0.0;
/// let e = c.validate().unwrap_err();
/// assert_eq!(e.field(), "watchdog_s");
/// assert_eq!(e.to_string(), "watchdog_s must be finite and > 0, got 0");
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ControllerConfigError {
    /// A number out of its range; `at` is the path of the table holding it (`""`,
    /// `"torque_pi."`, `"torque_pi_schedule[2]."`, `"startup."`).
    #[error("{source}")]
    Number {
        /// Path prefix of the table holding the number.
        at: String,
        /// The number and its rule.
        source: InvalidNumber,
    },
    /// A gain-schedule point's stiffness is not above its predecessor's.
    #[error("must increase from point to point")]
    ScheduleNotIncreasing {
        /// The point's index.
        index: usize,
    },
    /// `startup` gives both or neither of `position_rad` and `torque`.
    #[error("give exactly one of `position_rad` or `torque`")]
    StartupAmbiguous,
}

impl ControllerConfigError {
    /// The field's path below the joint's `controller` table.
    pub fn field(&self) -> String {
        match self {
            ControllerConfigError::Number { at, source } => format!("{at}{}", source.field),
            ControllerConfigError::ScheduleNotIncreasing { index } => format!("torque_pi_schedule[{index}].stiffness_nm_per_rad"),
            ControllerConfigError::StartupAmbiguous => "startup".into(),
        }
    }
}
