//! [`SimHal`], the simulated arm: its state, what its encoders read, the physics step, and what
//! experiments and tests read and set on it. Built in [`build`], a HAL backend in [`io`].

use jointctl_config::CanLossMode;
use jointctl_hal::condition::Conditioner;

use crate::elmo::ElmoDrive;
use crate::free_arm::FreeArm;
use crate::latency::{DelayLine, InFlight};
use crate::rng::SplitMix64;
use crate::unit::{self, SignalKind, Unit};

mod build;
mod io;

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
    /// The torque each drive's current loop applied, read with its position (one TPDO1).
    drive_torque_history: Vec<DelayLine>,
    /// Each drive's last torque reading [Nm] and the time its frame came [s].
    drive_torque_last: Vec<Option<(f64, f64)>>,
    encoder_conditioners: Vec<Conditioner>,
    drive_conditioners: Vec<Conditioner>,
    /// Force/torque sensors: (unit, DOF) whose torque sensor each reads, its range [Nm] and its
    /// conditioner.
    torque_sensors: Vec<((usize, usize), f64, Conditioner)>,
    counts_per_rad: Vec<f64>,
    /// Each drive's CANopen node id (its TPDO1's COB-ID), as configured.
    node_ids: Vec<u8>,
    /// Each drive's `rated_torque_nm`: the unit of the torque its TPDO1 carries (none: no torque).
    rated_torque_nm: Vec<Option<f64>>,
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

impl SimHal {
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
        for ((h, ht), d) in self.drive_history.iter_mut().zip(&mut self.drive_torque_history).zip(&self.drives) {
            h.push(self.time_s, d.position);
            ht.push(self.time_s, d.torque);
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
