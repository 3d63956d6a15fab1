//! The control modes of one joint DOF, shared by every joint type: the runtime runs one
//! [`JointController`] per DOF and hands its joint set-point to the joint's plugin, which maps it
//! onto its motors. Allocation-free in [`JointController::update`].

use jointctl_control::Pi;

use crate::controller_config::{ControllerConfig, DofLimits};
use crate::mode::Mode;
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
    use crate::{Reference, Waveform};

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
