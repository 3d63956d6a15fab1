//! # jointctl-sim
//!
//! The simulated arm, replacing the thesis' 20-sim bond-graph models (sections 3.2-3.5), as a
//! HAL backend (`hal: {backend: sim}`): [`elmo`] drives (profile + PID + inertia + friction),
//! [`unit`]s (a joint's transmission, elastic element with plant effects, and environment), and
//! the buses: absolute encoders through the AS5048A codec (14-bit quantisation, noise), drive
//! positions through TPDO1 frames (frame loss, appendix A's zero mode), SPI and CAN latency
//! (section 2.3), all through the same conditioner as the robot. Seeded and stepped by the
//! runtime, so a run is repeatable and can go faster than real time.

#![forbid(unsafe_code)]

pub mod elmo;
pub mod free_arm;
pub mod rng;
pub mod unit;

use jointctl_api::{DriveAction, DriveReading, Reading};
use jointctl_config::{ArmConfig, CanLossMode, EncoderSimConfig, LoadedConfig};
use jointctl_kinematics::Chain;
use jointctl_hal::codec::{as5048, canopen};
use jointctl_hal::condition::{Conditioner, Plausibility, Sample};
use jointctl_hal::{ActuatorFrame, DeviceHealth, DeviceIndex, Hal, HalIoError, HalSetupError, SensorFrame};

use crate::elmo::ElmoDrive;
use crate::free_arm::FreeArm;
use crate::rng::SplitMix64;
use crate::unit::{Element, SignalKind, Unit};

/// A value that a simulated encoder reads.
#[derive(Clone, Copy, Debug)]
enum Term {
    Drive(usize),
    Signal { unit: usize, dof: usize, kind: SignalKind },
}

#[derive(Clone, Debug)]
enum EncoderModel {
    Sum { terms: Vec<(Term, f64)>, offset_rad: f64 },
    Fixed(f64),
}

/// Set-points on their way to one drive over the CAN bus: each is applied when its latency has
/// passed. A fixed ring, so that the control cycle never allocates; when it is full the oldest
/// pending set-point is dropped (a newer absolute target supersedes it anyway).
#[derive(Clone, Debug)]
struct InFlight {
    /// (time due [s], target [rad]).
    ring: [(f64, f64); InFlight::CAPACITY],
    head: usize,
    len: usize,
}

impl InFlight {
    /// 30 ms of set-points at 8 kHz.
    const CAPACITY: usize = 256;

    fn new() -> Self {
        InFlight { ring: [(0.0, 0.0); Self::CAPACITY], head: 0, len: 0 }
    }

    fn push(&mut self, due_s: f64, target: f64) {
        if self.len == Self::CAPACITY {
            self.head = (self.head + 1) % Self::CAPACITY;
            self.len -= 1;
        }
        self.ring[(self.head + self.len) % Self::CAPACITY] = (due_s, target);
        self.len += 1;
    }

    /// The newest set-point due by `now_s`, taking it and every older one off the ring.
    fn arrived(&mut self, now_s: f64) -> Option<f64> {
        let mut target = None;
        while self.len > 0 && self.ring[self.head].0 <= now_s + 1e-12 {
            target = Some(self.ring[self.head].1);
            self.head = (self.head + 1) % Self::CAPACITY;
            self.len -= 1;
        }
        target
    }
}

/// Past values of one device, one per physics step, to read them with a bus latency.
#[derive(Clone, Debug)]
struct DelayLine {
    samples: Vec<(f64, f64)>,
    next: usize,
    filled: bool,
}

impl DelayLine {
    const CAPACITY: usize = 512;

    fn new() -> Self {
        DelayLine { samples: vec![(f64::NEG_INFINITY, 0.0); Self::CAPACITY], next: 0, filled: false }
    }

    fn push(&mut self, t: f64, v: f64) {
        self.samples[self.next] = (t, v);
        self.next = (self.next + 1) % Self::CAPACITY;
        self.filled |= self.next == 0;
    }

    /// The newest value no newer than `t` (the oldest kept if all are newer). Walks back from
    /// the newest sample: a latency of L costs L / substep steps.
    fn at(&self, t: f64) -> f64 {
        let n = if self.filled { Self::CAPACITY } else { self.next };
        let mut oldest = 0.0;
        for back in 1..=n {
            let k = (self.next + Self::CAPACITY - back) % Self::CAPACITY;
            let (ts, v) = self.samples[k];
            if ts <= t + 1e-12 {
                return v;
            }
            oldest = v;
        }
        oldest
    }

    /// [`Self::at`], but `None` when nothing was kept at or before `t` and nothing older was
    /// dropped: a reading from before the simulation started, which no sensor gave.
    fn reading_at(&self, t: f64) -> Option<f64> {
        let n = if self.filled { Self::CAPACITY } else { self.next };
        let newest_kept_before = (1..=n).map(|back| self.samples[(self.next + Self::CAPACITY - back) % Self::CAPACITY]).find(|(ts, _)| *ts <= t + 1e-12);
        match newest_kept_before {
            Some((_, v)) => Some(v),
            None if self.filled => Some(self.at(t)),
            None => None,
        }
    }
}

/// The simulated arm.
pub struct SimHal {
    drives: Vec<ElmoDrive>,
    units: Vec<Unit>,
    encoders: Vec<EncoderModel>,
    quantized: Vec<bool>,
    encoder_offset_rad: Vec<f64>,
    encoder_history: Vec<DelayLine>,
    /// Torque-sensor readings per unit and DOF (unit-major, [`MAX_UNIT_DOF`] each), to sample
    /// them at the instant the encoders' readings were taken.
    sensor_history: Vec<DelayLine>,
    drive_history: Vec<DelayLine>,
    encoder_conditioners: Vec<Conditioner>,
    drive_conditioners: Vec<Conditioner>,
    /// Force/torque sensors: (unit, DOF) whose torque sensor each reads, its range [Nm] and its
    /// conditioner.
    torque_sensors: Vec<((usize, usize), f64, Conditioner)>,
    counts_per_rad: Vec<f64>,
    /// Each drive's CANopen node id (its TPDO1's COB-ID), as configured.
    node_ids: Vec<u8>,
    noise_rad: f64,
    loss_rate: f64,
    loss_mode: CanLossMode,
    spi_latency_s: f64,
    can_latency_s: f64,
    /// Age of the drives' readings [s].
    can_feedback_latency_s: f64,
    substep_s: f64,
    rng: SplitMix64,
    time_s: f64,
    positions: Vec<f64>,
    velocities: Vec<f64>,
    loads: Vec<f64>,
    encoder_faults: Vec<Option<EncoderFault>>,
    /// Set-points on the CAN bus, per drive (they arrive `can_latency_s` after the write).
    in_flight: Vec<InFlight>,
    /// The units' `free_arm` DOFs, moved together.
    free_arm: Option<FreeArm>,
}

/// A fault injected into one simulated encoder, as the robot's SPI bus can produce them: the
/// fault-injection suite and fault drills use it. Every one goes through the same conditioner
/// as a real reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EncoderFault {
    /// No answer: the reading goes stale, then missing.
    Silent,
    /// Frames that fail their check (parity, error flag).
    Corrupt,
    /// A jump of this size [rad] on top of the true angle (a slipped magnet, a bit error that
    /// passed parity): implausible for the joint's velocity.
    Offset(f64),
}

fn setup(field: impl Into<String>, message: impl Into<String>) -> HalSetupError {
    HalSetupError::Config { field: field.into(), message: message.into() }
}

impl SimHal {
    /// The simulated arm of a loaded configuration (with its URDF, for a free arm).
    pub fn load(loaded: &LoadedConfig) -> Result<Self, HalSetupError> {
        SimHal::with_chain(&loaded.config, loaded.chain.as_ref())
    }

    /// The simulated arm of a configuration without its URDF (no `free_arm` environment).
    pub fn new(config: &ArmConfig) -> Result<Self, HalSetupError> {
        SimHal::with_chain(config, None)
    }

    /// The simulated arm of a configuration and its kinematic chain (`kinematics.urdf`), which
    /// a `free_arm` environment needs.
    pub fn with_chain(config: &ArmConfig, chain: Option<&Chain>) -> Result<Self, HalSetupError> {
        let devices = DeviceIndex::of(config);
        let sim = &config.hal.sim;
        let drive_cfgs: Vec<_> = config.buses.can.iter().flat_map(|b| b.drives.iter()).collect();
        let drive_index = |name: &str, field: String| devices.drive(name).ok_or_else(|| setup(field, format!("no drive named `{name}`")));
        let mut elmo = vec![sim.elmo; drive_cfgs.len()];
        for (name, g) in &sim.drive_gains {
            let at = format!("hal.sim.drive_gains.{name}");
            let d = drive_index(name, at.clone())?;
            if !(g.kp > 0.0 && g.ki >= 0.0 && g.kd >= 0.0) {
                return Err(setup(at, format!("kp must be > 0, ki and kd >= 0 (got {}, {}, {})", g.kp, g.ki, g.kd)));
            }
            (elmo[d].kp, elmo[d].ki, elmo[d].kd) = (g.kp, g.ki, g.kd);
        }
        // Each drive keeps its target inside its software position limits, as told at start-up.
        let drives: Vec<ElmoDrive> = elmo
            .iter()
            .zip(&drive_cfgs)
            .map(|(e, c)| ElmoDrive::new(*e, 0.0).with_position_limits(c.setpoint_window_rad))
            .collect();

        let mut units = Vec::new();
        let mut unit_joint = Vec::new();
        for (j, joint) in config.joints.iter().enumerate() {
            let Some(s) = &joint.sim else { continue };
            unit_joint.push(j);
            let at = |f: &str| format!("joints[{j}].sim.{f}");
            let dof_names: Vec<String> = joint.dof_names().iter().map(|n| n.to_string()).collect();
            let drive_ids = s
                .drives
                .iter()
                .enumerate()
                .map(|(i, d)| drive_index(d, at(&format!("drives[{i}]"))))
                .collect::<Result<Vec<_>, _>>()?;
            if s.matrix.len() != dof_names.len() || s.matrix.iter().any(|r| r.len() != drive_ids.len() || r.iter().any(|m| !m.is_finite())) {
                return Err(setup(
                    at("matrix"),
                    format!("needs {} row(s) (one per DOF) of {} finite number(s) (one per drive)", dof_names.len(), drive_ids.len()),
                ));
            }
            let n = dof_names.len();
            let element_cfgs: Vec<_> = match (&s.element, s.elements.as_slice()) {
                (Some(e), []) => vec![e.clone()],
                (None, list) if list.len() == n => list.to_vec(),
                _ => return Err(setup(at("element"), format!("give `element` (all DOFs) or `elements` with {n} entries (one per DOF)"))),
            };
            let elements = element_cfgs
                .iter()
                .map(|e| Element::from_config(e, &joint.params.0, if element_cfgs.len() == 1 { n } else { 1 }))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|(f, m)| setup(format!("joints[{j}].{f}"), m))?;
            let environments: Vec<_> = match (&s.environment, s.environments.as_slice()) {
                (Some(e), []) => vec![e.clone(); n],
                (None, list) if list.len() == n => list.to_vec(),
                _ => return Err(setup(at("environment"), format!("give `environment` (all DOFs) or `environments` with {n} entries"))),
            };
            let pivot = match &s.pivot {
                Some(p) => Some((drive_index(&p.drive, at("pivot.drive"))?, p.mm_per_rad, p.offset_mm)),
                None => None,
            };
            unit::check_effects(&s.effects).map_err(|(f, m)| setup(at(&format!("effects.{f}")), m))?;
            if !s.effects_per_dof.is_empty() {
                if s.effects_per_dof.len() != n {
                    return Err(setup(at("effects_per_dof"), format!("give one set per DOF ({n}), got {}", s.effects_per_dof.len())));
                }
                if serde_json::to_value(s.effects).ok() != serde_json::to_value(jointctl_config::EffectsConfig::default()).ok() {
                    return Err(setup(at("effects"), "give `effects` (every DOF) or `effects_per_dof`, not both".to_string()));
                }
                for (i, fx) in s.effects_per_dof.iter().enumerate() {
                    unit::check_effects(fx).map_err(|(f, m)| setup(at(&format!("effects_per_dof[{i}].{f}")), m))?;
                }
            }
            let mut unit = Unit::new(dof_names, drive_ids, s.matrix.clone(), elements, pivot, environments, s.effects);
            for (i, fx) in s.effects_per_dof.iter().enumerate() {
                unit.set_effects(i, *fx);
            }
            units.push(unit);
        }
        let signal = |name: &str, field: String| -> Result<Term, HalSetupError> {
            let (dof, kind) = name.rsplit_once('.').ok_or_else(|| setup(field.clone(), format!("`{name}` is not DOF.SIGNAL")))?;
            let kind = SignalKind::parse(kind).ok_or_else(|| {
                setup(field.clone(), format!("unknown signal `{kind}`: use output, theta, deflection, torque or pivot_mm"))
            })?;
            units
                .iter()
                .enumerate()
                .find_map(|(u, unit)| unit.dof_names.iter().position(|n| n == dof).map(|d| Term::Signal { unit: u, dof: d, kind }))
                .ok_or_else(|| setup(field, format!("no simulated joint has a DOF `{dof}` (give that joint a `sim:` section)")))
        };

        let mut encoders = Vec::new();
        let mut quantized = Vec::new();
        let mut offsets = Vec::new();
        let mut rates = Vec::new();
        for (b, bus) in config.buses.spi.iter().enumerate() {
            for (i, e) in bus.encoders.iter().enumerate() {
                let field = format!("buses.spi[{b}].encoders[{i}].sim");
                let model = match &e.sim {
                    Some(EncoderSimConfig { fixed_rad: Some(q), .. }) => EncoderModel::Fixed(*q),
                    Some(EncoderSimConfig { drive: Some(d), gain, offset_rad, .. }) => {
                        EncoderModel::Sum { terms: vec![(Term::Drive(drive_index(d, format!("{field}.drive"))?), *gain)], offset_rad: *offset_rad }
                    }
                    Some(EncoderSimConfig { signal: Some(sig), gain, offset_rad, .. }) => {
                        EncoderModel::Sum { terms: vec![(signal(sig, format!("{field}.signal"))?, *gain)], offset_rad: *offset_rad }
                    }
                    Some(EncoderSimConfig { sum, offset_rad, .. }) if !sum.is_empty() => {
                        let mut terms = Vec::new();
                        for (t, term) in sum.iter().enumerate() {
                            let what = match (&term.drive, &term.signal) {
                                (Some(d), _) => Term::Drive(drive_index(d, format!("{field}.sum[{t}].drive"))?),
                                (None, Some(s)) => signal(s, format!("{field}.sum[{t}].signal"))?,
                                (None, None) => return Err(setup(format!("{field}.sum[{t}]"), "give `drive` or `signal`")),
                            };
                            terms.push((what, term.gain));
                        }
                        EncoderModel::Sum { terms, offset_rad: *offset_rad }
                    }
                    _ => {
                        return Err(setup(
                            field,
                            format!(
                                "the simulated backend needs to know what encoder `{}` reads: add `sim: {{drive: NAME}}`, `{{signal: DOF.output}}`, `{{sum: [...]}}` or `{{fixed_rad: Q}}`",
                                e.name
                            ),
                        ));
                    }
                };
                quantized.push(sim.quantize_encoders && e.sim.as_ref().is_none_or(|s| s.quantized));
                encoders.push(model);
                offsets.push(e.offset_rad);
                rates.push(e.max_velocity_rad_s);
            }
        }
        let mut torque_sensors = Vec::new();
        for (i, f) in config.buses.force_torque.iter().enumerate() {
            let field = format!("buses.force_torque[{i}].sim");
            let Some(sim_cfg) = &f.sim else {
                return Err(setup(field, format!("the simulated backend needs to know what sensor `{}` measures: add `sim: {{dof: NAME}}`", f.name)));
            };
            let at = units
                .iter()
                .enumerate()
                .find_map(|(u, unit)| unit.dof_names.iter().position(|n| *n == sim_cfg.dof).map(|d| (u, d)))
                .ok_or_else(|| setup(format!("{field}.dof"), format!("no simulated joint has a DOF `{}` (give that joint a `sim:` section)", sim_cfg.dof)))?;
            torque_sensors.push((at, f.range_nm, Conditioner::new(Plausibility::torque_sensor())));
        }
        let g_m_s2 = config.kinematics.as_ref().map_or(jointctl_kinematics::STANDARD_GRAVITY_M_S2, |k| k.gravity_m_s2);
        let free_arm = FreeArm::new(chain, g_m_s2, &units, |u| format!("joints[{}].sim.environment", unit_joint[u])).map_err(|(f, m)| setup(f, m))?;
        let n_drives = drives.len();
        let sensor_history = vec![DelayLine::new(); units.len() * unit::MAX_UNIT_DOF];
        let mut hal = SimHal {
            drives,
            units,
            sensor_history,
            encoder_history: vec![DelayLine::new(); encoders.len()],
            drive_history: vec![DelayLine::new(); n_drives],
            encoder_conditioners: rates.iter().map(|r| Conditioner::new(Plausibility::absolute_encoder(*r))).collect(),
            drive_conditioners: drive_cfgs.iter().map(|d| Conditioner::new(Plausibility::drive_position(d.max_velocity_rad_s))).collect(),
            torque_sensors,
            counts_per_rad: drive_cfgs.iter().map(|d| d.counts_per_rad).collect(),
            node_ids: drive_cfgs.iter().map(|d| d.node_id).collect(),
            encoders,
            quantized,
            encoder_faults: vec![None; offsets.len()],
            in_flight: vec![InFlight::new(); n_drives],
            encoder_offset_rad: offsets,
            noise_rad: sim.encoder_noise_rad,
            loss_rate: sim.can_loss_rate,
            loss_mode: sim.can_loss_mode,
            spi_latency_s: sim.spi_latency_s,
            can_latency_s: sim.can_latency_s,
            can_feedback_latency_s: sim.can_feedback_latency_s.unwrap_or(sim.can_latency_s),
            substep_s: sim.substep_s,
            rng: SplitMix64(sim.seed ^ 0x9e37_79b9_7f4a_7c15),
            time_s: 0.0,
            positions: vec![0.0; n_drives],
            velocities: vec![0.0; n_drives],
            loads: vec![0.0; n_drives],
            free_arm,
        };
        for u in &mut hal.units {
            u.start(&hal.positions);
        }
        hal.record_positions();
        Ok(hal)
    }

    fn truth(&self, model: &EncoderModel) -> f64 {
        match model {
            EncoderModel::Fixed(q) => *q,
            EncoderModel::Sum { terms, offset_rad } => {
                offset_rad
                    + terms
                        .iter()
                        .map(|(t, g)| {
                            g * match *t {
                                Term::Drive(d) => self.drives[d].position,
                                Term::Signal { unit, dof, kind } => self.units[unit].signal(dof, kind),
                            }
                        })
                        .sum::<f64>()
            }
        }
    }

    fn record(&mut self) {
        self.record_positions();
        for (lines, u) in self.sensor_history.chunks_mut(unit::MAX_UNIT_DOF).zip(&self.units) {
            for (h, tau) in lines.iter_mut().zip(&u.sensor_torque[..u.dof_names.len()]) {
                h.push(self.time_s, *tau);
            }
        }
    }

    /// The encoders' and drives' histories; the torque sensors' only once they have read (after
    /// the first physics step: at the start their reading is no reading, see
    /// [`Self::sensor_torque_aged`]).
    fn record_positions(&mut self) {
        for i in 0..self.encoders.len() {
            let v = self.truth(&self.encoders[i]);
            self.encoder_history[i].push(self.time_s, v);
        }
        for (h, d) in self.drive_history.iter_mut().zip(&self.drives) {
            h.push(self.time_s, d.position);
        }
    }

    /// Simulated time [s].
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The simulated joints.
    pub fn units(&self) -> &[Unit] {
        &self.units
    }

    /// The free arm, when some DOF's environment is `free_arm`.
    pub fn free_arm(&self) -> Option<&FreeArm> {
        self.free_arm.as_ref()
    }

    /// The simulated drives, in device order.
    pub fn drives(&self) -> &[ElmoDrive] {
        &self.drives
    }

    /// The true element torque and the torque sensor's reading of DOF `name` [Nm].
    pub fn joint_torque(&self, name: &str) -> Option<(f64, f64)> {
        self.units.iter().find_map(|u| u.dof_names.iter().position(|n| n == name).map(|i| (u.torque[i], u.sensor_torque[i])))
    }

    /// The torque sensor's reading of DOF `name` as it was `age_s` ago [Nm] (within one physics
    /// step; at most about 0.25 s back): a recording pairs it with encoder readings of that age,
    /// so that the channels stay aligned when the SPI bus has latency. `None` for a reading from
    /// before the simulation started (a recording's first samples read 0.0 there, exactly, and
    /// identify took them for lost frames).
    pub fn sensor_torque_aged(&self, name: &str, age_s: f64) -> Option<f64> {
        let (unit, dof) = self.units.iter().enumerate().find_map(|(k, u)| u.dof_names.iter().position(|n| n == name).map(|i| (k, i)))?;
        if age_s <= 0.0 {
            return Some(self.units[unit].sensor_torque[dof]);
        }
        self.sensor_history[unit * unit::MAX_UNIT_DOF + dof].reading_at(self.time_s - age_s)
    }

    /// The configured SPI latency [s]: the age of every encoder reading.
    pub fn spi_latency_s(&self) -> f64 {
        self.spi_latency_s
    }

    /// Advances the physics by `dt` with the drives' current set-points.
    pub fn advance(&mut self, dt: f64) {
        let n = ((dt / self.substep_s).round() as usize).max(1);
        let h = dt / n as f64;
        for _ in 0..n {
            for (d, wire) in self.drives.iter_mut().zip(&mut self.in_flight) {
                if let Some(target) = wire.arrived(self.time_s) {
                    d.set_target(target);
                }
            }
            for (i, d) in self.drives.iter().enumerate() {
                self.positions[i] = d.position;
                self.velocities[i] = d.velocity;
            }
            self.loads.iter_mut().for_each(|l| *l = 0.0);
            for u in &mut self.units {
                u.step(&self.positions, &self.velocities, &mut self.loads, h, &mut self.rng);
            }
            if let Some(arm) = &mut self.free_arm {
                arm.step(&mut self.units, h);
            }
            for (d, load) in self.drives.iter_mut().zip(&self.loads) {
                d.step(*load, h);
            }
            self.time_s += h;
            self.record();
        }
    }
}

impl Hal for SimHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        let now = self.time_s;
        for i in 0..self.encoders.len() {
            let truth = self.encoder_history[i].at(now - self.spi_latency_s);
            let noise = if self.noise_rad > 0.0 { self.noise_rad * self.rng.normal() } else { 0.0 };
            let angle = truth + noise - self.encoder_offset_rad[i];
            frame.encoders[i] = if let Some(fault) = self.encoder_faults[i] {
                let sample = match fault {
                    EncoderFault::Silent => Sample::Missing,
                    EncoderFault::Corrupt => Sample::Invalid,
                    EncoderFault::Offset(jump) => Sample::Value { value: angle + jump, age_s: self.spi_latency_s },
                };
                self.encoder_conditioners[i].update(sample, now)
            } else if self.quantized[i] {
                // The same frames and decoder as the robot's SPI bus: 14-bit words with parity.
                let sample = match as5048::decode(as5048::encode(as5048::rad_to_counts(angle))) {
                    Ok(counts) => Sample::Value { value: as5048::counts_to_rad(counts), age_s: self.spi_latency_s },
                    Err(_) => Sample::Invalid,
                };
                self.encoder_conditioners[i].update(sample, now)
            } else {
                Reading::valid_aged(angle, self.spi_latency_s)
            };
        }
        for (i, d) in frame.drives.iter_mut().enumerate() {
            // The same TPDO1 frames and decoder as the robot's CAN bus, with latency and losses.
            let position = self.drive_history[i].at(now - self.can_feedback_latency_s);
            let counts = (position * self.counts_per_rad[i]).round() as i32;
            let lost = self.loss_rate > 0.0 && self.rng.uniform() < self.loss_rate;
            let frame_out = match (lost, self.loss_mode) {
                (false, _) => Some(canopen::tpdo1(self.node_ids[i], 0x0237, counts)),
                (true, CanLossMode::Zero) => Some(canopen::tpdo1(self.node_ids[i], 0x0237, 0)),
                (true, CanLossMode::Missing) => None,
            };
            let sample = match frame_out.as_ref().and_then(canopen::decode_tpdo1) {
                Some(t) => Sample::Value { value: t.position_counts as f64 / self.counts_per_rad[i], age_s: self.can_feedback_latency_s },
                None => Sample::Missing,
            };
            let reading = self.drive_conditioners[i].update(sample, now);
            *d = DriveReading::new(reading, Reading::valid(self.drives[i].velocity), true, false);
        }
        // Force/torque sensors: the simulated sensor's torque (effects and noise included), read
        // as it is now (a Net F/T box streams at kHz rates: no bus latency modelled), beyond its
        // range invalid.
        for (out, ((unit, dof), range, conditioner)) in frame.torque_sensors.iter_mut().zip(&mut self.torque_sensors) {
            let tau = self.units[*unit].sensor_torque[*dof];
            let sample = if tau.abs() <= *range { Sample::Value { value: tau, age_s: 0.0 } } else { Sample::Invalid };
            *out = conditioner.update(sample, now);
        }
        Ok(())
    }

    fn write(&mut self, frame: &ActuatorFrame, dt_s: f64) -> Result<(), HalIoError> {
        // Set-points cross the CAN bus as readings do: they reach the drive `can_latency_s` later.
        let due = self.time_s + self.can_latency_s;
        for (wire, sp) in self.in_flight.iter_mut().zip(&frame.drives) {
            if sp.action == DriveAction::MOVE && sp.position_rad.is_finite() {
                wire.push(due, sp.position_rad);
            }
        }
        self.advance(dt_s);
        Ok(())
    }

    fn device_health(&self, out: &mut [DeviceHealth]) {
        let all = self.drive_conditioners.iter().chain(&self.encoder_conditioners).chain(self.torque_sensors.iter().map(|t| &t.2));
        for (h, c) in out.iter_mut().zip(all) {
            let l = c.counters();
            *h = DeviceHealth { missing: l.missing, invalid: l.invalid, implausible: l.implausible, emcy: 0, flags: 0 };
        }
    }
}

/// A [`SimHal`] shared with the code that runs an experiment or a test, to read the ground
/// truth (the torque sensor, the true element torque) next to what the arm observes. It locks a
/// mutex in `read` and `write`: for experiments and tests, never for `jointctl run`.
#[derive(Clone)]
pub struct SharedSim(pub std::sync::Arc<std::sync::Mutex<SimHal>>);

impl SharedSim {
    /// Wraps a simulator.
    pub fn new(sim: SimHal) -> Self {
        SharedSim(std::sync::Arc::new(std::sync::Mutex::new(sim)))
    }

    /// Runs `f` on the simulator.
    pub fn with<R>(&self, f: impl FnOnce(&SimHal) -> R) -> R {
        f(&self.0.lock().unwrap_or_else(|p| p.into_inner()))
    }
}

impl Hal for SharedSim {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).read(frame)
    }

    fn write(&mut self, frame: &ActuatorFrame, dt_s: f64) -> Result<(), HalIoError> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).write(frame, dt_s)
    }

    fn device_health(&self, out: &mut [DeviceHealth]) {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).device_health(out)
    }
}

impl SimHal {
    /// Sets a drive's target directly (experiments: hold a VSA's pivot at a setting).
    pub fn set_drive_target(&mut self, drive: usize, position_rad: f64) {
        if let Some(d) = self.drives.get_mut(drive) {
            d.set_target(position_rad);
        }
    }

    /// Injects a fault into encoder `encoder` (device order), or clears it with `None`.
    pub fn inject_encoder_fault(&mut self, encoder: usize, fault: Option<EncoderFault>) {
        if let Some(f) = self.encoder_faults.get_mut(encoder) {
            *f = fault;
        }
    }

    /// Starts the simulated arm from these drive positions [rad] (`None`: where it is), at rest,
    /// with every joint's element relaxed there: a replay starts from a recording's first state.
    pub fn start_at(&mut self, positions: &[Option<f64>]) {
        for (d, p) in self.drives.iter_mut().zip(positions) {
            if let Some(p) = p.filter(|p| p.is_finite()) {
                *d = ElmoDrive::new(d.config(), p).with_position_limits(d.position_limits_rad);
            }
        }
        for (i, d) in self.drives.iter().enumerate() {
            self.positions[i] = d.position;
            self.velocities[i] = 0.0;
        }
        for u in &mut self.units {
            u.start(&self.positions);
        }
        self.record_positions();
    }

    /// Lets the drives move for `seconds` of simulated time without reading (settling).
    pub fn settle_drives(&mut self, seconds: f64) {
        self.advance(seconds);
    }
}
