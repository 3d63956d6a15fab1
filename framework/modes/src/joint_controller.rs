//! The control modes of one joint DOF, shared by every joint type: the runtime runs one
//! [`JointController`] per DOF and hands its joint set-point to the joint's plugin, which maps it
//! onto its motors. Allocation-free in [`JointController::update`].

use serde::Deserialize;

use jointctl_control::{InvalidNumber, Pi, PiGains};

use crate::{Reference, Trajectory};

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

/// What a DOF is asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant, reason = "a trajectory lives inline so that switching modes never allocates in the loop")]
pub enum Mode {
    /// Keep the drives where they are.
    Hold,
    /// Go to a joint position with the position feedback PI (section 4.3).
    Position {
        /// [rad]
        target_rad: f64,
    },
    /// Direct joint set-points (the thesis' dynamic-reconfigure GUI), through the feedback PI
    /// unless `controller.manual_position_feedback` is false (section 4.3).
    Manual {
        /// [rad]
        target_rad: f64,
    },
    /// Follow a time-stamped trajectory started at `start_s`.
    Trajectory {
        /// The points.
        trajectory: Trajectory,
        /// Runtime time at which the trajectory's time 0 is [s].
        start_s: f64,
    },
    /// Figure 4.6: regulate the deflection so that the observed torque follows `reference` [Nm].
    Torque {
        /// The torque reference.
        reference: Reference,
    },
    /// Section 1.2: `tau_ref = K (q_d - q) - D dq/dt`, realised through the torque mode.
    Impedance {
        /// K_d [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// D_d [Nms/rad].
        damping_nms_per_rad: f64,
        /// q_d [rad].
        target_rad: f64,
    },
}

impl Mode {
    /// A short name.
    pub fn name(&self) -> &'static str {
        match self {
            Mode::Hold => "hold",
            Mode::Position { .. } => "position",
            Mode::Manual { .. } => "manual",
            Mode::Trajectory { .. } => "trajectory",
            Mode::Torque { .. } => "torque",
            Mode::Impedance { .. } => "impedance",
        }
    }
}

/// Safety events of one DOF, counted since start and published in diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ControllerEvents {
    /// Joint set-points clamped into the position limits.
    pub setpoint_clamps: u64,
    /// Torque references clamped into the torque limit.
    pub torque_clamps: u64,
    /// Cycles whose set-point change was limited by the rate limit.
    pub rate_limited: u64,
    /// Streamed commands that timed out and fell back to holding.
    pub watchdog_trips: u64,
    /// Cycles held because a value the mode needs (torque, stiffness, velocity) was unknown.
    pub missing_inputs: u64,
}

/// One cycle's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    /// Hold the drives (no set-point).
    pub hold: bool,
    /// Joint position set-point [rad].
    pub setpoint_rad: f64,
    /// Joint velocity feed-forward [rad/s].
    pub velocity_rad_s: f64,
    /// Whether the plugin's position feedback PI should act (off in torque and impedance modes,
    /// where it would fight the torque loop, section 4.3).
    pub position_feedback: bool,
    /// The torque reference used this cycle [Nm], NaN outside torque/impedance modes: the
    /// torque beyond gravity when `gravity_feedforward` is on (the joint regulates this plus
    /// [`Observed::gravity_nm`]).
    pub torque_reference_nm: f64,
    /// The set-point was clamped this cycle (limits or rate).
    pub clamped: bool,
}

impl Output {
    const HOLD: Output = Output {
        hold: true,
        setpoint_rad: f64::NAN,
        velocity_rad_s: 0.0,
        position_feedback: false,
        torque_reference_nm: f64::NAN,
        clamped: false,
    };
}

/// The observed quantities the controller needs (from the joint's state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observed {
    /// Joint position [rad], if observed.
    pub position_rad: Option<f64>,
    /// Joint velocity [rad/s], if observed.
    pub velocity_rad_s: Option<f64>,
    /// Joint torque [Nm], if observed.
    pub torque_nm: Option<f64>,
    /// Joint stiffness [Nm/rad], if observed.
    pub stiffness_nm_per_rad: Option<f64>,
    /// The torque that holds the arm against gravity at the observed pose [Nm], if known (an
    /// arm with a URDF and every position of the chain observed). Used only with
    /// `gravity_feedforward`; unknown then, the DOF holds.
    pub gravity_nm: Option<f64>,
}

/// The controller of one DOF.
#[derive(Clone, Debug)]
pub struct JointController {
    config: ControllerConfig,
    limits: DofLimits,
    mode: Mode,
    pi: Pi,
    last_setpoint: Option<f64>,
    stream_deadline_s: Option<f64>,
    /// Safety events so far.
    pub events: ControllerEvents,
}

impl JointController {
    /// A controller in [`Mode::Hold`], or in its configured startup mode.
    pub fn new(config: ControllerConfig, limits: DofLimits) -> Self {
        let pi = Pi::new(config.torque_pi);
        let mode = config.startup.map_or(Mode::Hold, |s| s.mode());
        JointController { config, limits, mode, pi, last_setpoint: None, stream_deadline_s: None, events: ControllerEvents::default() }
    }

    /// The current mode.
    pub fn mode(&self) -> &Mode {
        &self.mode
    }

    /// The limits.
    pub fn limits(&self) -> DofLimits {
        self.limits
    }

    /// Switches mode at runtime time `now_s`. A `streamed` command must be renewed within the
    /// watchdog time or the DOF falls back to holding.
    pub fn set_mode(&mut self, mode: Mode, now_s: f64, streamed: bool) {
        if core::mem::discriminant(&mode) != core::mem::discriminant(&self.mode) {
            self.pi.reset();
        }
        self.mode = mode;
        self.stream_deadline_s = streamed.then_some(now_s + self.config.watchdog_s);
    }

    /// One control step at runtime time `now_s`.
    pub fn update(&mut self, observed: &Observed, now_s: f64, dt_s: f64) -> Output {
        if let Some(deadline) = self.stream_deadline_s
            && now_s > deadline
        {
            self.events.watchdog_trips += 1;
            self.stream_deadline_s = None;
            self.mode = Mode::Hold;
        }
        let Some(q) = observed.position_rad else {
            self.last_setpoint = None;
            return Output::HOLD;
        };
        let (mut target, mut velocity, feedback, tau_ref) = match self.mode {
            Mode::Hold => {
                self.last_setpoint = None;
                return Output::HOLD;
            }
            Mode::Position { target_rad } => (target_rad, 0.0, true, f64::NAN),
            Mode::Manual { target_rad } => (target_rad, 0.0, self.config.manual_position_feedback, f64::NAN),
            Mode::Trajectory { trajectory, start_s } => {
                let (p, v) = trajectory.sample(now_s - start_s);
                (p, v, true, f64::NAN)
            }
            Mode::Torque { reference } => match self.torque_law(reference.value(now_s), observed, q, dt_s) {
                Some((sp, t)) => (sp, 0.0, false, t),
                None => return self.missing(),
            },
            Mode::Impedance { stiffness_nm_per_rad, damping_nms_per_rad, target_rad } => {
                let Some(dq) = observed.velocity_rad_s else { return self.missing() };
                // Section 1.2's law.
                let tau = stiffness_nm_per_rad * (target_rad - q) - damping_nms_per_rad * dq;
                match self.torque_law(tau, observed, q, dt_s) {
                    Some((sp, t)) => (sp, 0.0, false, t),
                    None => return self.missing(),
                }
            }
        };
        let mut clamped = false;
        let [lo, hi] = self.limits.position_rad;
        if target < lo || target > hi {
            target = target.clamp(lo, hi);
            self.events.setpoint_clamps += 1;
            clamped = true;
        }
        let rate = self.config.max_setpoint_rate_rad_s.min(self.limits.velocity_rad_s);
        let step = rate * dt_s;
        let from = self.last_setpoint.unwrap_or(q);
        if (target - from).abs() > step {
            target = from + step.copysign(target - from);
            self.events.rate_limited += 1;
            clamped = true;
        }
        if velocity.abs() > self.limits.velocity_rad_s {
            velocity = self.limits.velocity_rad_s.copysign(velocity);
            self.events.rate_limited += 1;
            clamped = true;
        }
        self.last_setpoint = Some(target);
        Output { hold: false, setpoint_rad: target, velocity_rad_s: velocity, position_feedback: feedback, torque_reference_nm: tau_ref, clamped }
    }

    fn missing(&mut self) -> Output {
        self.events.missing_inputs += 1;
        self.last_setpoint = None;
        Output::HOLD
    }

    /// Figure 4.6: torque error → deflection error (÷ stiffness) → PI (gains scheduled over the
    /// stiffness, section 6.2) → + feed-forward deflection + current joint position.
    ///
    /// With `gravity_feedforward`, the joint regulates `reference + gravity` (the reference is
    /// the torque beyond gravity); the torque limit bounds what the joint applies in all.
    fn torque_law(&mut self, reference_nm: f64, observed: &Observed, q: f64, dt_s: f64) -> Option<(f64, f64)> {
        let tau = observed.torque_nm?;
        let k = observed.stiffness_nm_per_rad.filter(|k| *k > 0.0)?;
        let gravity = if self.config.gravity_feedforward { observed.gravity_nm.filter(|g| g.is_finite())? } else { 0.0 };
        let mut regulated = reference_nm + gravity;
        if regulated.abs() > self.limits.torque_nm {
            regulated = self.limits.torque_nm.copysign(regulated);
            self.events.torque_clamps += 1;
        }
        self.pi.set_gains(self.config.gains_at(k));
        let deflection_error = (regulated - tau) / k;
        let correction = self.pi.update(deflection_error, dt_s);
        let feed_forward = regulated / k;
        Some((q + feed_forward + correction, regulated - gravity))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Waveform;

    /// The closed-form plant: output clamped (q = 0), the motor follows the set-point with a
    /// first-order response (time constant `tau_m`), torque = K_true * deflection, observed with
    /// the model stiffness `k_model` (a model error the integrator must remove).
    struct Plant {
        motor: f64,
        k_true: f64,
        tau_m: f64,
    }

    impl Plant {
        fn observe(&self, k_model: f64) -> Observed {
            Observed { position_rad: Some(0.0), velocity_rad_s: Some(0.0), torque_nm: Some(self.k_true * self.motor), stiffness_nm_per_rad: Some(k_model), gravity_nm: None }
        }
        fn step(&mut self, out: &Output, dt: f64) {
            if !out.hold {
                self.motor += (out.setpoint_rad - self.motor) * (1.0 - (-dt / self.tau_m).exp());
            }
        }
    }

    fn controller(limit_nm: f64) -> JointController {
        let cfg = ControllerConfig { max_setpoint_rate_rad_s: 100.0, ..ControllerConfig::default() };
        JointController::new(cfg, DofLimits { position_rad: [-1.0, 1.0], torque_nm: limit_nm, velocity_rad_s: f64::INFINITY })
    }

    fn step_reference(nm: f64) -> Mode {
        Mode::Torque { reference: Reference { waveform: Waveform::Step, amplitude: nm, frequency_hz: 0.0, offset: 0.0, start_s: 0.0 } }
    }

    #[test]
    fn a_torque_step_settles_with_zero_steady_state_error() {
        // The model stiffness is 20 % off: feed-forward alone would leave a 20 % error.
        let (dt, mut plant) = (1.0 / 40.0, Plant { motor: 0.0, k_true: 120.0, tau_m: 0.05 });
        let mut c = controller(100.0);
        c.set_mode(step_reference(20.0), 0.0, false);
        let mut t = 0.0;
        for _ in 0..(20.0 / dt) as usize {
            let out = c.update(&plant.observe(100.0), t, dt);
            assert!(!out.position_feedback, "the position PI is off in torque mode");
            plant.step(&out, dt);
            t += dt;
        }
        let torque = plant.k_true * plant.motor;
        assert!((torque - 20.0).abs() < 1e-3, "steady-state torque {torque}");
    }

    #[test]
    fn anti_windup_recovers_after_saturation() {
        // The PI correction is limited to 0.2 rad; a plant far softer than the model cannot reach
        // the reference, so the PI saturates. When the reference returns to a reachable value,
        // the torque must settle quickly instead of unwinding a huge integral.
        let dt = 1.0 / 40.0;
        let mut plant = Plant { motor: 0.0, k_true: 20.0, tau_m: 0.05 };
        let mut c = controller(100.0);
        c.set_mode(step_reference(30.0), 0.0, false);
        let mut t = 0.0;
        for _ in 0..(10.0 / dt) as usize {
            let out = c.update(&plant.observe(100.0), t, dt);
            plant.step(&out, dt);
            t += dt;
        }
        // Saturated: feed-forward 0.3 rad + correction limit 0.2 rad -> at most 10 Nm.
        assert!((plant.k_true * plant.motor - 10.0).abs() < 0.1, "saturated torque {}", plant.k_true * plant.motor);
        c.set_mode(step_reference(5.0), t, false);
        let mut settled_at = None;
        for i in 0..(10.0 / dt) as usize {
            let out = c.update(&plant.observe(100.0), t, dt);
            plant.step(&out, dt);
            t += dt;
            if settled_at.is_none() && (plant.k_true * plant.motor - 5.0).abs() < 0.1 {
                settled_at = Some(i as f64 * dt);
            }
        }
        let settled = settled_at.expect("recovers");
        assert!(settled < 2.0, "took {settled} s to recover");
        assert!((plant.k_true * plant.motor - 5.0).abs() < 1e-2);
    }

    #[test]
    fn limits_clamp_and_count() {
        let mut c = controller(10.0);
        c.set_mode(Mode::Position { target_rad: 3.0 }, 0.0, false);
        let obs = Observed { position_rad: Some(0.99), velocity_rad_s: None, torque_nm: None, stiffness_nm_per_rad: None, gravity_nm: None };
        let out = c.update(&obs, 0.0, 0.01);
        assert_eq!(out.setpoint_rad, 1.0);
        assert!(out.clamped);
        assert_eq!(c.events.setpoint_clamps, 1);
        // A torque reference beyond the limit is clamped to it and counted.
        c.set_mode(step_reference(50.0), 0.0, false);
        let obs = Observed { position_rad: Some(0.0), velocity_rad_s: None, torque_nm: Some(0.0), stiffness_nm_per_rad: Some(100.0), gravity_nm: None };
        let out = c.update(&obs, 0.0, 0.01);
        assert_eq!(out.torque_reference_nm, 10.0);
        assert_eq!(c.events.torque_clamps, 1);
    }

    #[test]
    fn torque_mode_without_an_observed_torque_holds() {
        let mut c = controller(10.0);
        c.set_mode(step_reference(5.0), 0.0, false);
        let obs = Observed { position_rad: Some(0.0), velocity_rad_s: None, torque_nm: None, stiffness_nm_per_rad: Some(100.0), gravity_nm: None };
        assert!(c.update(&obs, 0.0, 0.01).hold);
        assert_eq!(c.events.missing_inputs, 1);
    }

    /// Issue finding (the thesis' arm): manual set-points skipped the feedback PI, which the
    /// thesis has on by default in manual manipulation (section 4.3).
    #[test]
    fn manual_mode_uses_the_feedback_pi_unless_the_yaml_turns_it_off() {
        let observed = Observed { position_rad: Some(0.0), velocity_rad_s: Some(0.0), torque_nm: None, stiffness_nm_per_rad: None, gravity_nm: None };
        let mut c = JointController::new(ControllerConfig::default(), DofLimits::NONE);
        c.set_mode(Mode::Manual { target_rad: 0.01 }, 0.0, false);
        assert!(c.update(&observed, 0.0, 0.025).position_feedback);
        let cfg: ControllerConfig = serde_json::from_str(r#"{"manual_position_feedback": false}"#).unwrap();
        let mut c = JointController::new(cfg, DofLimits::NONE);
        c.set_mode(Mode::Manual { target_rad: 0.01 }, 0.0, false);
        assert!(!c.update(&observed, 0.0, 0.025).position_feedback);
    }

    #[test]
    fn the_rate_limit_ramps_a_position_step() {
        let mut c = JointController::new(ControllerConfig { max_setpoint_rate_rad_s: 1.0, ..Default::default() }, DofLimits::NONE);
        c.set_mode(Mode::Position { target_rad: 1.0 }, 0.0, false);
        let obs = Observed { position_rad: Some(0.0), velocity_rad_s: None, torque_nm: None, stiffness_nm_per_rad: None, gravity_nm: None };
        let a = c.update(&obs, 0.0, 0.1);
        let b = c.update(&obs, 0.1, 0.1);
        assert!((a.setpoint_rad - 0.1).abs() < 1e-12 && (b.setpoint_rad - 0.2).abs() < 1e-12);
        assert_eq!(c.events.rate_limited, 2);
    }

    #[test]
    fn a_stream_that_stops_falls_back_to_hold() {
        let mut c = controller(10.0);
        c.set_mode(step_reference(1.0), 0.0, true);
        let obs = Observed { position_rad: Some(0.0), velocity_rad_s: Some(0.0), torque_nm: Some(0.0), stiffness_nm_per_rad: Some(100.0), gravity_nm: None };
        assert!(!c.update(&obs, 0.4, 0.01).hold);
        c.set_mode(step_reference(1.0), 0.4, true); // renewed
        assert!(!c.update(&obs, 0.8, 0.01).hold);
        assert!(c.update(&obs, 0.95, 0.01).hold, "0.55 s since the last renewal");
        assert_eq!(c.events.watchdog_trips, 1);
        assert_eq!(c.mode().name(), "hold");
    }

    #[test]
    fn a_startup_reference_from_yaml_runs_from_the_start() {
        let cfg: ControllerConfig =
            serde_json::from_str(r#"{"startup": {"torque": {"waveform": "cosine", "amplitude": 2.0, "frequency_hz": 0.2}}}"#).unwrap();
        cfg.validate().unwrap();
        let c = JointController::new(cfg, DofLimits::NONE);
        match c.mode() {
            Mode::Torque { reference } => assert_eq!(reference.value(0.0), 2.0),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn impedance_behaves_like_a_spring_damper() {
        // Output clamped at q = 0.1, target 0: the torque reference is -K * 0.1.
        let mut c = controller(100.0);
        c.set_mode(Mode::Impedance { stiffness_nm_per_rad: 50.0, damping_nms_per_rad: 2.0, target_rad: 0.0 }, 0.0, false);
        let obs = Observed { position_rad: Some(0.1), velocity_rad_s: Some(0.5), torque_nm: Some(0.0), stiffness_nm_per_rad: Some(100.0), gravity_nm: None };
        let out = c.update(&obs, 0.0, 0.01);
        assert!((out.torque_reference_nm - (-5.0 - 1.0)).abs() < 1e-12);
        // Unknown velocity: no damping term can be formed, so hold.
        let obs = Observed { velocity_rad_s: None, ..obs };
        assert!(c.update(&obs, 0.01, 0.01).hold);
    }

    fn with_gravity(on: bool) -> JointController {
        let cfg = ControllerConfig { max_setpoint_rate_rad_s: 100.0, gravity_feedforward: on, ..ControllerConfig::default() };
        JointController::new(cfg, DofLimits { position_rad: [-1.0, 1.0], torque_nm: 30.0, velocity_rad_s: f64::INFINITY })
    }

    #[test]
    fn gravity_feedforward_regulates_the_reference_beyond_gravity() {
        // Impedance at its target, at rest: the law asks for 0 Nm; the joint must still hold
        // the 12 Nm gravity asks of it. It regulates exactly as a torque mode asked for 12 Nm
        // without gravity would (same deflection set-point), and the published reference stays
        // the torque beyond gravity.
        let obs = Observed { position_rad: Some(0.2), velocity_rad_s: Some(0.0), torque_nm: Some(0.0), stiffness_nm_per_rad: Some(100.0), gravity_nm: Some(12.0) };
        let mode = Mode::Impedance { stiffness_nm_per_rad: 50.0, damping_nms_per_rad: 2.0, target_rad: 0.2 };
        let mut on = with_gravity(true);
        on.set_mode(mode, 0.0, false);
        let out = on.update(&obs, 0.0, 0.01);
        assert_eq!(out.torque_reference_nm, 0.0);
        let mut plain = with_gravity(false);
        plain.set_mode(step_reference(12.0), 0.0, false);
        let same = plain.update(&Observed { gravity_nm: None, ..obs }, 0.0, 0.01);
        assert_eq!(same.torque_reference_nm, 12.0);
        assert!((out.setpoint_rad - same.setpoint_rad).abs() < 1e-15, "{} vs {}", out.setpoint_rad, same.setpoint_rad);
        assert!(out.setpoint_rad > 0.2 + 12.0 / 100.0, "at least the feed-forward deflection: {}", out.setpoint_rad);
        // Off: gravity is not the controller's business; the same state sets no deflection.
        let mut off = with_gravity(false);
        off.set_mode(mode, 0.0, false);
        assert!((off.update(&obs, 0.0, 0.01).setpoint_rad - 0.2).abs() < 1e-12);
    }

    #[test]
    fn an_unknown_gravity_torque_holds_a_compensated_joint_and_counts() {
        // A missing position elsewhere in the chain makes the gravity torque unknown: never 0.
        let obs = Observed { position_rad: Some(0.0), velocity_rad_s: Some(0.0), torque_nm: Some(0.0), stiffness_nm_per_rad: Some(100.0), gravity_nm: None };
        let mut c = with_gravity(true);
        c.set_mode(step_reference(5.0), 0.0, false);
        assert!(c.update(&obs, 0.0, 0.01).hold);
        assert_eq!(c.events.missing_inputs, 1);
        let nan = Observed { gravity_nm: Some(f64::NAN), ..obs };
        assert!(c.update(&nan, 0.01, 0.01).hold);
        assert_eq!(c.events.missing_inputs, 2);
    }

    #[test]
    fn the_torque_limit_bounds_reference_and_gravity_together() {
        // Limit 30 Nm: 20 beyond 25 of gravity is clamped to 30 in all, 5 beyond gravity.
        let obs = Observed { position_rad: Some(0.0), velocity_rad_s: Some(0.0), torque_nm: Some(0.0), stiffness_nm_per_rad: Some(100.0), gravity_nm: Some(25.0) };
        let mut c = with_gravity(true);
        c.set_mode(step_reference(20.0), 0.0, false);
        let out = c.update(&obs, 0.0, 0.01);
        assert!((out.torque_reference_nm - 5.0).abs() < 1e-12, "{}", out.torque_reference_nm);
        assert_eq!(c.events.torque_clamps, 1);
    }
}
