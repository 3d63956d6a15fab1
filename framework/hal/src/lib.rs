//! # jointctl-hal
//!
//! The hardware interface knows devices, not joints or controllers (compare ros2_control's
//! hardware interfaces): it fills a [`SensorFrame`] with one reading per configured device and
//! sends an [`ActuatorFrame`] of motor set-points. Which joint uses which device is the
//! runtime's business.
//!
//! This crate holds what every backend shares and nothing that needs hardware: the [`Hal`]
//! trait and its frames, the robot's frame codecs ([`codec`]), the plausibility conditioner
//! ([`condition`]), the bus budget ([`budget`]) and the [`NullHal`]. Backends live in their own
//! crates: the simulated arm (`jointctl-sim`), the default, which runs anywhere, and the real
//! buses (`jointctl-hal-socketcan`: SocketCAN + spidev); `jointctl-backends` picks the one a
//! config asks for.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod budget;
pub mod codec;
pub mod condition;

use jointctl_api::{DriveReading, MotorSetpoint, Reading};
use jointctl_config::ArmConfig;

/// Device names in the order the frames use: encoders by SPI bus then position, drives by CAN
/// bus then position, as written in the YAML.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DeviceIndex {
    /// Encoder names; `SensorFrame::encoders[i]` is `encoders[i]`.
    pub encoders: Vec<String>,
    /// Drive names; `SensorFrame::drives[i]` and `ActuatorFrame::drives[i]` are `drives[i]`.
    pub drives: Vec<String>,
    /// Force/torque sensor names; `SensorFrame::torque_sensors[i]` is `torque_sensors[i]`.
    pub torque_sensors: Vec<String>,
}

impl DeviceIndex {
    /// The devices of an arm description.
    ///
    /// ```
    /// let cfg = jointctl_config::parse_str(
    ///     "arm: a\nhal: {backend: sim}\nbuses: {can: [{interface: can0, drives: [{name: m, node_id: 1}]}]}\njoints: [{name: q, plugin: rigid}]\n",
    ///     "a.yaml").unwrap().config;
    /// let idx = jointctl_hal::DeviceIndex::of(&cfg);
    /// assert_eq!(idx.drive("m"), Some(0));
    /// ```
    pub fn of(config: &ArmConfig) -> Self {
        DeviceIndex {
            encoders: config.buses.spi.iter().flat_map(|b| b.encoders.iter().map(|e| e.name.clone())).collect(),
            drives: config.buses.can.iter().flat_map(|b| b.drives.iter().map(|d| d.name.clone())).collect(),
            torque_sensors: config.buses.force_torque.iter().map(|f| f.name.clone()).collect(),
        }
    }

    /// Index of a force/torque sensor by name.
    pub fn torque_sensor(&self, name: &str) -> Option<usize> {
        self.torque_sensors.iter().position(|n| n == name)
    }

    /// Index of an encoder by name.
    pub fn encoder(&self, name: &str) -> Option<usize> {
        self.encoders.iter().position(|n| n == name)
    }

    /// Index of a drive by name.
    pub fn drive(&self, name: &str) -> Option<usize> {
        self.drives.iter().position(|n| n == name)
    }
}

/// One cycle's readings of every device. Allocated once; the HAL overwrites it in place.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorFrame {
    /// Encoders in [`DeviceIndex`] order.
    pub encoders: Vec<Reading>,
    /// Drives in [`DeviceIndex`] order.
    pub drives: Vec<DriveReading>,
    /// Torques about the configured joint axes [Nm], in [`DeviceIndex`] order.
    pub torque_sensors: Vec<Reading>,
}

impl SensorFrame {
    /// A frame for `devices`, every reading missing.
    pub fn new(devices: &DeviceIndex) -> Self {
        SensorFrame {
            encoders: vec![Reading::MISSING; devices.encoders.len()],
            drives: vec![DriveReading::default(); devices.drives.len()],
            torque_sensors: vec![Reading::MISSING; devices.torque_sensors.len()],
        }
    }
}

/// One cycle's set-points for every drive.
#[derive(Clone, Debug, PartialEq)]
pub struct ActuatorFrame {
    /// Drives in [`DeviceIndex`] order.
    pub drives: Vec<MotorSetpoint>,
}

impl ActuatorFrame {
    /// A frame for `devices`, every drive holding.
    pub fn new(devices: &DeviceIndex) -> Self {
        ActuatorFrame { drives: vec![MotorSetpoint::HOLD; devices.drives.len()] }
    }
}

/// A failure of one HAL call. Carries no heap data: it is raised inside the control cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HalIoError {
    /// A bus could not be read or written this cycle; every device on it reads stale.
    #[error("bus {bus} failed this cycle")]
    BusFailed {
        /// Index of the bus in the YAML (CAN buses first, then SPI).
        bus: u16,
    },
}

/// A HAL with no hardware behind it: every reading missing, writes go nowhere. For validating
/// an arm description (`jointctl check`) without its buses.
#[derive(Clone, Copy, Debug, Default)]
pub struct NullHal;

impl Hal for NullHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        frame.encoders.fill(Reading::MISSING);
        frame.drives.fill(DriveReading::default());
        frame.torque_sensors.fill(Reading::MISSING);
        Ok(())
    }

    fn write(&mut self, _: &ActuatorFrame, _: f64) -> Result<(), HalIoError> {
        Ok(())
    }
}

/// A failure to set a backend up.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HalSetupError {
    /// The configuration asks for something the backend cannot do.
    #[error("{field}: {message}")]
    Config {
        /// Field path in the arm YAML.
        field: String,
        /// What is wrong.
        message: String,
    },
}

/// The hardware interface. `read` and `write` run inside the control cycle: they must not
/// allocate, and their only I/O is the buses.
pub trait Hal: Send {
    /// Fills `frame` with this cycle's readings. A device that did not answer reads stale or
    /// missing, never zero.
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError>;

    /// Sends this cycle's set-points; a simulated backend advances its time by `dt_s` here.
    fn write(&mut self, frame: &ActuatorFrame, dt_s: f64) -> Result<(), HalIoError>;

    /// Asks faulted drives to reset at the next write (CiA 402 fault reset). Default: nothing.
    fn reset_faults(&mut self) {}

    /// Fills the health of each device, drives first, then encoders, then force/torque
    /// sensors, in [`DeviceIndex`] order.
    /// Called every cycle: must not allocate. Default: nothing to report.
    fn device_health(&self, _out: &mut [DeviceHealth]) {}

    /// Takes every drive through `sequence` (`safety.stop_sequence`) when the runtime stops,
    /// after the last hold was written: blocking, outside the loop, each step waiting up to
    /// `step_timeout_s` for every drive to report it. Returns what each step reached. Default:
    /// nothing (a backend without drive states, such as the simulated one, where the last hold
    /// is the stop).
    fn stop(&mut self, _sequence: &[jointctl_config::StopStep], _step_timeout_s: f64) -> Vec<StopStepReport> {
        Vec::new()
    }
}

/// What one step of the stop sequence reached.
#[derive(Clone, Debug, PartialEq)]
pub struct StopStepReport {
    /// The step.
    pub step: jointctl_config::StopStep,
    /// The drives that did not report the step's state within the timeout (empty: all did).
    pub pending: Vec<String>,
}

/// Health of one device, published in diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceHealth {
    /// Cycles in which nothing arrived from it.
    pub missing: u64,
    /// Frames that failed their checks.
    pub invalid: u64,
    /// Values rejected as implausible.
    pub implausible: u64,
    /// Emergency messages (drives).
    pub emcy: u64,
    /// Bit flags: [`DeviceHealth::SILENT`], [`DeviceHealth::FAULT`], [`DeviceHealth::BUS_OFF`],
    /// [`DeviceHealth::ERROR_PASSIVE`].
    pub flags: u32,
}

impl DeviceHealth {
    /// No heartbeat within the timeout.
    pub const SILENT: u32 = 1;
    /// The drive reports a fault.
    pub const FAULT: u32 = 2;
    /// Its bus is off.
    pub const BUS_OFF: u32 = 4;
    /// Its bus controller is error-passive.
    pub const ERROR_PASSIVE: u32 = 8;
}
