//! An arm wired from YAML: its plugin instances, their wiring to devices, and one control cycle
//! split in the two halves around publishing (observe, then control).

use jointctl_api::{JointCommand, JointFault, JointState, MAX_DRIVES, MAX_ENCODERS, MotorSetpoint, RawJointView};
use jointctl_modes::{DofLimits, JointController, Mode, Observed};

use crate::commands::ArmCommand;
use jointctl_config::{LimitsConfig, LoadedConfig};
use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, SensorFrame};

use crate::joint::{FfiJoint, LoadedJoint};
use crate::loader::{PluginLoader, PluginSource};
use crate::timing::monotonic_ns;

mod build;

/// A device's name and its bus index in the YAML.
pub type DeviceOnBus<'a> = (&'a str, u32);

/// One plugin instance and its wiring.
pub struct JointSlot {
    /// Instance name from the YAML.
    pub name: String,
    /// Plugin name.
    pub plugin: String,
    /// The plugin crate's version.
    pub plugin_version: String,
    /// The library the plugin was loaded from; `None` when it is linked into the host.
    pub plugin_library: Option<std::path::PathBuf>,
    joint: Box<dyn LoadedJoint>,
    dofs: core::ops::Range<usize>,
    encoder_map: [Option<usize>; MAX_ENCODERS],
    drive_map: [Option<usize>; MAX_DRIVES],
    drive_count: usize,
    raw: RawJointView,
    setpoints: [MotorSetpoint; MAX_DRIVES],
    /// 0, or the fault that holds this joint until restart.
    pub fault: u32,
    /// Faults raised so far.
    pub fault_count: u64,
    /// Cycles in which the state was unusable and the joint was held.
    pub invalid_cycles: u64,
    /// Held this cycle.
    pub held: bool,
    /// A fault was raised this cycle and not yet reported in the log.
    pub fault_unreported: bool,
    /// Time the plugin may take per cycle, observe and control together [ns].
    pub budget_ns: u64,
    /// Time the plugin took this cycle so far [ns].
    pub used_ns: u64,
    /// Most time the plugin took in one cycle [ns].
    pub max_used_ns: u64,
    /// One cycle's plugin time above this faults the joint at once [ns].
    pub stall_limit_ns: u64,
    /// Over-budget cycles that fault the joint when no second of in-budget cycles separates them.
    pub strikes_allowed: u32,
    /// Over-budget cycles since the last second of in-budget cycles.
    pub strikes: u32,
    /// Consecutive in-budget cycles; a second of them forgives the strikes.
    in_budget_cycles: u64,
    /// Cycles in one second.
    forgive_after: u64,
    /// Cycles over budget so far (faulting or not).
    pub over_budget_cycles: u64,
    /// Cycles whose motor set-points the runtime's check refused (see [`crate::guard`]).
    pub setpoint_rejections: u64,
    /// The runtime's own reason for the fault that holds the joint (a refused set-point), empty
    /// when the plugin's message is the reason.
    runtime_reason: crate::guard::Reason,
    /// Whether an over-budget plugin is faulted (real time) or only measured (simulated time:
    /// see [`Arm::run_in_simulated_time`]).
    budget_enforced: bool,
}

impl JointSlot {
    /// The DOF indices (into [`Arm::states`]) this instance serves.
    pub fn dofs(&self) -> core::ops::Range<usize> {
        self.dofs.clone()
    }

    /// The plugin's last error or panic text.
    pub fn last_message(&self) -> &str {
        self.joint.last_message()
    }

    /// Why the joint is faulted: the runtime's reason when it raised the fault (a refused
    /// set-point), else the plugin's last message.
    pub fn fault_reason(&self) -> &str {
        match self.runtime_reason.as_str() {
            "" => self.joint.last_message(),
            own => own,
        }
    }

    fn gather(&mut self, sensor: &SensorFrame, stamp_s: f64, dt_s: f64) {
        self.raw.stamp_s = stamp_s;
        self.raw.dt_s = dt_s;
        for (slot, map) in self.raw.encoders.iter_mut().zip(self.encoder_map) {
            *slot = map.map_or(jointctl_api::Reading::MISSING, |i| sensor.encoders[i]);
        }
        for (slot, map) in self.raw.drives.iter_mut().zip(self.drive_map) {
            *slot = map.map_or_else(Default::default, |i| sensor.drives[i]);
        }
    }

    /// Starts a cycle's budget; a second of in-budget cycles forgives earlier strikes.
    fn start_cycle(&mut self) {
        if self.used_ns <= self.budget_ns {
            self.in_budget_cycles += 1;
            if self.in_budget_cycles >= self.forgive_after {
                self.strikes = 0;
            }
        } else {
            self.in_budget_cycles = 0;
        }
        self.used_ns = 0;
    }

    /// Charges a plugin call that started at `start_ns` to this cycle's budget. The joint is
    /// faulted (its plugin never called again) when the cycle's plugin time passes the stall
    /// limit (it alone missed a deadline), or when it is over budget for the `strikes_allowed`-th
    /// time without a second in budget between; a lone shorter excess is counted, not faulted,
    /// because the platform stalls threads too (see `timing.joint_stall_floor_us`). True when the
    /// results may be used.
    fn charge(&mut self, start_ns: u64) -> bool {
        let was_within = self.used_ns <= self.budget_ns;
        self.used_ns += monotonic_ns().saturating_sub(start_ns);
        self.max_used_ns = self.max_used_ns.max(self.used_ns);
        if self.used_ns <= self.budget_ns {
            return true;
        }
        if !self.budget_enforced {
            if was_within {
                self.over_budget_cycles += 1;
            }
            return true;
        }
        if was_within {
            self.over_budget_cycles += 1;
            self.strikes += 1;
        }
        if self.used_ns > self.stall_limit_ns || self.strikes >= self.strikes_allowed {
            self.raise(JointFault::OVER_BUDGET);
            return false;
        }
        true
    }

    /// The first of this cycle's set-points the guard refuses: its drive and why.
    fn first_refused(&self, guard: &crate::guard::SetpointGuard, sensor: &SensorFrame) -> Option<(usize, crate::guard::Violation)> {
        self.setpoints[..self.drive_count].iter().zip(self.drive_map).find_map(|(sp, map)| {
            let drive = map?;
            let now = sensor.drives[drive].position_rad.usable(f64::INFINITY);
            guard.check(drive, sp, now).err().map(|v| (drive, v))
        })
    }

    fn raise(&mut self, fault: JointFault) {
        if self.fault == 0 {
            self.fault_unreported = true;
        }
        self.fault = fault.code();
        self.fault_count += 1;
    }
}

/// Why a running arm could not start.
#[derive(Debug, thiserror::Error)]
pub enum ActivateError {
    /// The HAL could not be read for the first readings.
    #[error("cannot read the hardware before the first cycle: {0}")]
    Hal(#[from] jointctl_hal::HalIoError),
    /// A plugin refused to activate.
    #[error("joint `{joint}` (plugin `{plugin}`) cannot activate: {message}")]
    Plugin {
        /// Joint instance.
        joint: String,
        /// Plugin name.
        plugin: String,
        /// Its reason.
        message: String,
    },
}

/// The arm: plugin instances, devices, and the state and command of every DOF.
pub struct Arm {
    /// Arm name.
    pub name: String,
    /// Loop rate [Hz].
    pub rate_hz: f64,
    /// Loop period [s].
    pub dt_s: f64,
    /// Plugin instances in YAML order.
    pub slots: Vec<JointSlot>,
    /// DOF names, in YAML order.
    pub dof_names: Vec<String>,
    /// DOF limits.
    pub limits: Vec<Option<LimitsConfig>>,
    /// What each DOF can do, as its plugin declares: `(observes torque, stiffness settable)`.
    pub capabilities: Vec<(bool, bool)>,
    /// Observed state of each DOF this cycle.
    pub states: Vec<JointState>,
    /// The command each DOF's plugin got this cycle (derived from its controller).
    pub commands: Vec<JointCommand>,
    /// Each DOF's controller (its mode, limits and safety counters).
    pub controllers: Vec<JointController>,
    /// The torque reference each DOF used this cycle [Nm] (NaN outside torque/impedance modes).
    pub torque_references: Vec<f64>,
    /// The torque that holds the arm against gravity at this cycle's observed pose, per DOF
    /// [Nm] (NaN: no URDF, a DOF the URDF does not name, or a position of the chain unknown).
    pub gravity_torques: Vec<f64>,
    /// Requested stiffness per DOF [Nm/rad], NaN when none.
    pub stiffness_requests: Vec<f64>,
    /// Disabled DOFs hold and ignore modes until enabled.
    pub enabled: Vec<bool>,
    /// A stop command arrived.
    pub stop_requested: bool,
    /// Runtime time of the current cycle [s].
    pub now_s: f64,
    /// HAL read or write failures.
    pub hal_errors: u64,
    /// CLOCK_MONOTONIC time the current cycle's HAL read returned [ns]: the readings in hand.
    /// One clock read per cycle (a vDSO call), for the publisher's hop log.
    pub readings_ns: u64,
    sensor: SensorFrame,
    actuator: ActuatorFrame,
    hal: Box<dyn Hal>,
    devices: DeviceIndex,
    /// Each DOF's force/torque sensor (index in the frame), if it has one.
    torque_sensor_of: Vec<Option<usize>>,
    /// Bus index of each encoder and each drive, in [`DeviceIndex`] order.
    device_buses: (Vec<u32>, Vec<u32>),
    /// The arm description's file, absolute when it could be resolved.
    config_path: Option<std::path::PathBuf>,
    /// The gravity model of the arm's URDF, with its working memory.
    gravity: Option<ArmGravity>,
    /// The last check of every motor set-point before the HAL.
    guard: crate::guard::SetpointGuard,
    /// `safety.stop_sequence` and its step timeout [s].
    stop_sequence: Vec<jointctl_config::StopStep>,
    stop_step_timeout_s: f64,
    /// [`Arm::shutdown`] ran: the drives are stopped and the plugins deactivated.
    shut_down: bool,
}

/// An arm dropped without [`Arm::shutdown`] (on any drop: a panic of the runtime unwinding
/// through it, an early return) still holds its drives, runs the stop sequence and deactivates
/// its plugins. While a panic unwinds, a second panic in the HAL is caught here: it would abort.
impl Drop for Arm {
    fn drop(&mut self) {
        if std::thread::panicking() {
            let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.shutdown()));
        } else {
            self.shutdown();
        }
    }
}

/// The arm's gravity model and the buffers that keep its cycle allocation-free.
struct ArmGravity {
    model: jointctl_kinematics::Gravity,
    /// The arm DOF of each of the chain's joints.
    dof_of: Vec<usize>,
    q_rad: Vec<f64>,
    tau_nm: Vec<f64>,
}

impl ArmGravity {
    fn new(loaded: &LoadedConfig, dof_names: &[String]) -> Option<ArmGravity> {
        let (chain, k) = (loaded.chain.clone()?, loaded.config.kinematics.as_ref()?);
        // Config loading checked that every joint of the chain is a DOF.
        let dof_of: Vec<usize> = chain.dof_names().iter().map(|d| dof_names.iter().position(|n| n == d)).collect::<Option<_>>()?;
        let n = dof_of.len();
        let model = jointctl_kinematics::Gravity::downward(chain, k.gravity_m_s2);
        Some(ArmGravity { model, dof_of, q_rad: vec![0.0; n], tau_nm: vec![0.0; n] })
    }

    /// This cycle's holding torques into `out` (per arm DOF); all unknown when one position of
    /// the chain is: a missing reading is never taken as a pose.
    fn update(&mut self, states: &[JointState], out: &mut [f64]) {
        out.fill(f64::NAN);
        for (q, &d) in self.q_rad.iter_mut().zip(&self.dof_of) {
            match states[d].position() {
                Some(p) if p.is_finite() => *q = p,
                _ => return,
            }
        }
        if self.model.torques(&self.q_rad, &mut self.tau_nm).is_ok() {
            for (t, &d) in self.tau_nm.iter().zip(&self.dof_of) {
                out[d] = *t;
            }
        }
    }
}

impl Arm {
    /// Runs this arm in simulated time (an experiment, a replay): the plugins' wall-clock budgets
    /// are still measured ([`JointSlot::max_used_ns`], [`JointSlot::over_budget_cycles`]) but no
    /// longer fault a joint. A simulated cycle has no deadline, and faulting on wall-clock time
    /// made the same experiment's result depend on how busy the machine was.
    pub fn run_in_simulated_time(&mut self) {
        self.slots.iter_mut().for_each(|s| s.budget_enforced = false);
    }

    /// Activates every joint with the hardware's first readings. Readings may not all be there at
    /// once (a real CAN bus answers only after the first SYNC; a frame may be lost), so it reads,
    /// holds every drive and tries again, for up to `timeout_s`; joints already activated are not
    /// activated twice. The error names the joints that never could.
    pub fn activate(&mut self) -> Result<(), ActivateError> {
        self.activate_within(1.0)
    }

    /// [`Arm::activate`] with an explicit timeout [s].
    pub fn activate_within(&mut self, timeout_s: f64) -> Result<(), ActivateError> {
        // Activated again after a shutdown: the next shutdown stops the drives again.
        self.shut_down = false;
        let attempts = ((timeout_s * self.rate_hz).ceil() as usize).max(1);
        let mut done = vec![false; self.slots.len()];
        let mut last_error = None;
        for attempt in 0..attempts {
            self.hal.read(&mut self.sensor)?;
            for (slot, done) in self.slots.iter_mut().zip(done.iter_mut()).filter(|(_, d)| !**d) {
                slot.gather(&self.sensor, 0.0, self.dt_s);
                let raw = slot.raw;
                match slot.joint.activate(&raw) {
                    Ok(()) => *done = true,
                    Err(e) => {
                        last_error = Some(ActivateError::Plugin { joint: slot.name.clone(), plugin: slot.plugin.clone(), message: e.to_string() })
                    }
                }
            }
            if done.iter().all(|d| *d) {
                return Ok(());
            }
            if attempt + 1 < attempts {
                self.actuator.drives.fill(MotorSetpoint::HOLD);
                self.hal.write(&self.actuator, self.dt_s)?;
                std::thread::sleep(std::time::Duration::from_secs_f64(self.dt_s.min(0.05)));
            }
        }
        Err(last_error.unwrap_or(ActivateError::Hal(jointctl_hal::HalIoError::BusFailed { bus: 0 })))
    }

    /// First half of a cycle: read the hardware and observe every joint. A joint whose plugin
    /// faults is held from now on; its state is unknown.
    pub fn observe(&mut self, stamp_s: f64) {
        self.now_s = stamp_s;
        if self.hal.read(&mut self.sensor).is_err() {
            // The HAL marks what it could not read as stale or missing; the count is published.
            self.hal_errors += 1;
        }
        self.readings_ns = monotonic_ns();
        for slot in &mut self.slots {
            slot.gather(&self.sensor, stamp_s, self.dt_s);
            let out = &mut self.states[slot.dofs.clone()];
            slot.start_cycle();
            if slot.fault != 0 {
                out.fill(JointState::UNKNOWN);
                continue;
            }
            let start = monotonic_ns();
            let result = slot.joint.observe(&slot.raw, out);
            // A state that came too late is not used: the joint is held from this cycle on.
            let in_time = slot.charge(start);
            if let Err(f) = result {
                out.fill(JointState::UNKNOWN);
                slot.raise(f);
            } else if !in_time {
                out.fill(JointState::UNKNOWN);
            }
        }
    }

    /// Switches DOF `dof` to a mode now. A disabled DOF stays in hold.
    pub fn set_mode(&mut self, dof: usize, mode: Mode) {
        self.apply(ArmCommand::Mode { dof, mode, streamed: false });
    }

    /// Applies a validated command at the current cycle's time: a reference's start delay and a
    /// trajectory's time 0 count from now; an impedance target of NaN means "where it is".
    pub fn apply(&mut self, command: ArmCommand) {
        let now = self.now_s;
        match command {
            ArmCommand::Mode { dof, mut mode, streamed } => {
                if !self.enabled[dof] {
                    return;
                }
                match &mut mode {
                    Mode::Torque { reference } => reference.start_s += now,
                    Mode::Trajectory { start_s, .. } => *start_s = now,
                    Mode::Impedance { target_rad, .. } if target_rad.is_nan() => match self.states[dof].position() {
                        Some(q) => *target_rad = q,
                        None => mode = Mode::Hold,
                    },
                    _ => {}
                }
                self.controllers[dof].set_mode(mode, now, streamed);
            }
            ArmCommand::Stiffness { dof, stiffness_nm_per_rad } => self.stiffness_requests[dof] = stiffness_nm_per_rad,
            ArmCommand::Enable { dof, enabled } => {
                self.enabled[dof] = enabled;
                self.controllers[dof].set_mode(Mode::Hold, now, false);
            }
            ArmCommand::HoldAll => {
                for c in &mut self.controllers {
                    c.set_mode(Mode::Hold, now, false);
                }
            }
            ArmCommand::Stop => self.stop_requested = true,
        }
    }

    /// Second half of a cycle: run every DOF's controller, control every joint whose state is
    /// usable, hold the others, and write the set-points.
    pub fn control(&mut self) {
        if let Some(g) = &mut self.gravity {
            g.update(&self.states, &mut self.gravity_torques);
        }
        for d in 0..self.states.len() {
            let s = &self.states[d];
            let observed = Observed {
                position_rad: s.position(),
                velocity_rad_s: s.velocity(),
                torque_nm: s.torque(),
                stiffness_nm_per_rad: s.stiffness(),
                gravity_nm: Some(self.gravity_torques[d]).filter(|g| g.is_finite()),
            };
            let out = self.controllers[d].update(&observed, self.now_s, self.dt_s);
            self.torque_references[d] = out.torque_reference_nm;
            let command = if out.hold || !self.enabled[d] {
                JointCommand::HOLD
            } else {
                JointCommand::setpoint(out.setpoint_rad, out.velocity_rad_s, out.position_feedback)
            };
            self.commands[d] = command.with_stiffness(self.stiffness_requests[d]);
        }
        for slot in &mut self.slots {
            let dofs = slot.dofs.clone();
            let usable = self.states[dofs.clone()].iter().all(|s| s.position().is_some());
            let n = slot.drive_count;
            slot.held = true;
            if slot.fault != 0 {
                slot.setpoints[..n].fill(MotorSetpoint::HOLD);
            } else if !usable {
                // A missing or implausible reading is never driven on: hold, count, publish.
                slot.invalid_cycles += 1;
                slot.setpoints[..n].fill(MotorSetpoint::HOLD);
            } else {
                let start = monotonic_ns();
                let result = slot.joint.control(&self.states[dofs.clone()], &self.commands[dofs], &slot.raw, &mut slot.setpoints[..n]);
                // Set-points computed too late are not written: the joint is held instead.
                let in_time = slot.charge(start);
                match result {
                    Ok(()) if in_time => match slot.first_refused(&self.guard, &self.sensor) {
                        None => slot.held = false,
                        Some((drive, violation)) => {
                            // A refused set-point holds the whole joint: its drives move together.
                            slot.setpoints[..n].fill(MotorSetpoint::HOLD);
                            slot.setpoint_rejections += 1;
                            slot.runtime_reason.set_violation(&slot.plugin, self.guard.drive_name(drive), &violation);
                            slot.raise(JointFault::SETPOINT_REJECTED);
                        }
                    },
                    Ok(()) => slot.setpoints[..n].fill(MotorSetpoint::HOLD),
                    Err(f) => {
                        slot.setpoints[..n].fill(MotorSetpoint::HOLD);
                        slot.raise(f);
                    }
                }
            }
            for (sp, map) in slot.setpoints[..slot.drive_count].iter().zip(slot.drive_map) {
                if let Some(i) = map {
                    self.actuator.drives[i] = *sp;
                    self.guard.written(i, sp);
                }
            }
        }
        if self.hal.write(&self.actuator, self.dt_s).is_err() {
            self.hal_errors += 1;
        }
    }

    /// Both halves of a cycle, for runs without publishing (tests, benchmarks, experiments).
    pub fn step(&mut self, stamp_s: f64) {
        self.observe(stamp_s);
        self.control();
    }

    /// Holds every drive and tells every plugin the loop stopped.
    pub fn shutdown(&mut self) {
        if self.shut_down {
            return;
        }
        self.shut_down = true;
        for sp in &mut self.actuator.drives {
            *sp = MotorSetpoint::HOLD;
        }
        let _ = self.hal.write(&self.actuator, self.dt_s);
        // The configured stop sequence, the same on every path that ends the runtime.
        for report in self.hal.stop(&self.stop_sequence, self.stop_step_timeout_s) {
            if report.pending.is_empty() {
                tracing::info!(step = ?report.step, "stop sequence: every drive reached it");
            } else {
                tracing::error!(step = ?report.step, "stop sequence: {} did not report it within {} s", report.pending.join(", "), self.stop_step_timeout_s);
            }
        }
        for slot in &mut self.slots {
            slot.joint.deactivate();
        }
    }

    /// What commands may ask of each DOF: its name, plugin, limits and capabilities.
    pub fn dof_specs(&self) -> Vec<crate::commands::DofSpec> {
        let mut specs = Vec::with_capacity(self.dof_names.len());
        for slot in &self.slots {
            for i in slot.dofs() {
                let (torque, stiffness) = self.capabilities[i];
                specs.push(crate::commands::DofSpec { name: self.dof_names[i].clone(), plugin: slot.plugin.clone(), limits: self.limits[i], torque, stiffness });
            }
        }
        specs
    }

    /// The HAL's health of each device (drives, then encoders). Allocation-free.
    pub fn device_health(&self, out: &mut [jointctl_hal::DeviceHealth]) {
        self.hal.device_health(out);
    }

    /// Device names: drives, then encoders, then force/torque sensors (the order of
    /// [`Arm::device_health`]).
    pub fn device_names(&self) -> impl Iterator<Item = &str> {
        self.devices.drives.iter().chain(&self.devices.encoders).chain(&self.devices.torque_sensors).map(String::as_str)
    }

    /// The torque DOF `dof`'s force/torque sensor measured this cycle [Nm]: `None` when it has
    /// no sensor or the reading is not usable (missing, invalid, or stale beyond two periods).
    /// Allocation-free.
    pub fn sensor_torque(&self, dof: usize) -> Option<f64> {
        let i = (*self.torque_sensor_of.get(dof)?)?;
        self.sensor.torque_sensors.get(i)?.usable(2.0 * self.dt_s)
    }

    /// The set-points written in the last cycle, in device order.
    pub fn last_setpoints(&self) -> &[MotorSetpoint] {
        &self.actuator.drives
    }

    /// This cycle's readings as the HAL gave them, before any observer (in [`DeviceIndex`] order).
    pub fn last_readings(&self) -> &SensorFrame {
        &self.sensor
    }

    /// Encoders and drives with their bus index (`buses.spi[i]`, `buses.can[i]`), in the
    /// frames' order.
    pub fn raw_devices(&self) -> (Vec<DeviceOnBus<'_>>, Vec<DeviceOnBus<'_>>) {
        let encoders = self.devices.encoders.iter().map(String::as_str).zip(self.device_buses.0.iter().copied()).collect();
        let drives = self.devices.drives.iter().map(String::as_str).zip(self.device_buses.1.iter().copied()).collect();
        (encoders, drives)
    }

    /// Force/torque sensor names, in the frames' order.
    pub fn torque_sensor_names(&self) -> Vec<&str> {
        self.devices.torque_sensors.iter().map(String::as_str).collect()
    }

    /// The arm description's file (absolute), when known.
    pub fn config_path(&self) -> Option<&std::path::Path> {
        self.config_path.as_deref()
    }
}
