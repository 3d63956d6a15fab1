//! What the loop read and wrote, device by device: the raw side of a cycle, for recording and
//! replay (the joint state is what the observers made of it).
//!
//! - `<arm>/raw`: one [`RawFrame`] per cycle, every encoder's and drive's reading with its status
//!   and age, and every set-point written;
//! - `<arm>/raw_descriptor`: one [`RawDescriptor`], published when the runtime starts and kept
//!   for late subscribers: the devices' names, kinds and units, so that a client can say what it
//!   reads without the arm's YAML;
//! - `<arm>/commands`: one [`CommandRecord`] per command the runtime accepted.

use iceoryx2::prelude::*;

use crate::{CommandRequest, DEVICE_NAME_LEN, NAME_LEN, encode_name};

/// Most encoders in a [`RawFrame`] (the config validates against the same constant).
pub const MAX_RAW_ENCODERS: usize = jointctl_api::MAX_ARM_ENCODERS;
/// Most drives in a [`RawFrame`].
pub const MAX_RAW_DRIVES: usize = jointctl_api::MAX_ARM_DRIVES;
/// Most force/torque sensor axes in a [`RawFrame`].
pub const MAX_RAW_TORQUE_SENSORS: usize = jointctl_api::MAX_ARM_TORQUE_SENSORS;
/// Bytes of the config path in a [`RawDescriptor`] (NUL-padded).
pub const PATH_LEN: usize = 512;

named_codes! {
    /// A reading's status, as the HAL gave it ([`jointctl_api::ReadingStatus`]).
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::raw::RawStatus::STALE.name(), "stale");
    /// ```
    RawStatus {
        /// Never received; the value is not a value.
        MISSING = 0, "missing";
        /// Received this cycle and checked.
        VALID = 1, "valid";
        /// The last good value, `age_s` old.
        STALE = 2, "stale";
        /// Received but failed a check; the value is not a value.
        INVALID = 3, "invalid";
    }
}

named_codes! {
    /// What a drive was told ([`jointctl_api::DriveAction`]).
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::raw::RawAction::MOVE.name(), "move");
    /// ```
    RawAction {
        /// Keep the current target.
        HOLD = 0, "hold";
        /// Move to the set-point.
        MOVE = 1, "move";
    }
}

/// One reading: value [the device's unit], its age [s] and status.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct RawReading {
    /// The value; NaN when the status says there is none.
    pub value: f64,
    /// Age [s]: 0 when it arrived this cycle, infinite when it never did.
    pub age_s: f64,
    /// Status.
    pub status: RawStatus,
    _reserved: u32,
}

impl RawReading {
    /// A missing reading.
    pub const MISSING: RawReading = RawReading { value: f64::NAN, age_s: f64::INFINITY, status: RawStatus::MISSING, _reserved: 0 };

    /// The reading the HAL gave. A missing or invalid one is published with a NaN value, so that
    /// nobody reading the file takes it for a number.
    ///
    /// ```
    /// use jointctl_ipc::raw::{RawReading, RawStatus};
    /// let r = RawReading::from_reading(&jointctl_api::Reading::stale(0.3, 0.02));
    /// assert_eq!((r.value, r.age_s, r.status), (0.3, 0.02, RawStatus::STALE));
    /// assert!(RawReading::from_reading(&jointctl_api::Reading::invalid()).value.is_nan());
    /// ```
    pub fn from_reading(r: &jointctl_api::Reading) -> Self {
        let status = RawStatus(u32::from(r.status.0));
        let value = if matches!(status, RawStatus::VALID | RawStatus::STALE) { r.value } else { f64::NAN };
        RawReading { value, age_s: r.age_s, status, _reserved: 0 }
    }
}

/// One drive in a cycle: what it reported and what it was sent.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct RawDrive {
    /// Motor (gearbox output) position [rad].
    pub position_rad: RawReading,
    /// Motor velocity [rad/s].
    pub velocity_rad_s: RawReading,
    /// The motor's torque at the gearbox output [Nm], from the drive's current reading.
    pub torque_nm: RawReading,
    /// 1 when the drive reported it follows set-points.
    pub enabled: u32,
    /// 1 when the drive reported a fault.
    pub fault: u32,
    /// Set-point sent this cycle [rad] (meaningful with [`RawAction::MOVE`]).
    pub setpoint_rad: f64,
    /// Velocity feed-forward sent [rad/s].
    pub velocity_ff_rad_s: f64,
    /// What the drive was told.
    pub action: RawAction,
    _reserved: u32,
}

impl RawDrive {
    /// Nothing reported, holding.
    pub const EMPTY: RawDrive = RawDrive {
        position_rad: RawReading::MISSING,
        velocity_rad_s: RawReading::MISSING,
        torque_nm: RawReading::MISSING,
        enabled: 0,
        fault: 0,
        setpoint_rad: f64::NAN,
        velocity_ff_rad_s: 0.0,
        action: RawAction::HOLD,
        _reserved: 0,
    };

    /// A drive's reading and the set-point it was sent.
    ///
    /// ```
    /// use jointctl_api::{DriveReading, MotorSetpoint, Reading};
    /// let d = jointctl_ipc::raw::RawDrive::new(&DriveReading::new(Reading::valid(1.0), Reading::MISSING, true, false), &MotorSetpoint::move_to(1.2));
    /// assert_eq!((d.position_rad.value, d.setpoint_rad, d.enabled), (1.0, 1.2, 1));
    /// ```
    pub fn new(reading: &jointctl_api::DriveReading, setpoint: &jointctl_api::MotorSetpoint) -> Self {
        let moving = setpoint.action == jointctl_api::DriveAction::MOVE;
        RawDrive {
            position_rad: RawReading::from_reading(&reading.position_rad),
            velocity_rad_s: RawReading::from_reading(&reading.velocity_rad_s),
            torque_nm: RawReading::from_reading(&reading.torque_nm),
            enabled: u32::from(reading.enabled),
            fault: u32::from(reading.fault),
            setpoint_rad: if moving { setpoint.position_rad } else { f64::NAN },
            velocity_ff_rad_s: setpoint.velocity_ff_rad_s,
            action: RawAction(u32::from(setpoint.action.0)),
            _reserved: 0,
        }
    }
}

/// Every device of the arm in one cycle, in the order of [`RawDescriptor`].
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.RawFrame.v2")]
pub struct RawFrame {
    /// Cycle counter, the same as the cycle's [`crate::ArmState::cycle`].
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// Accepted commands the loop has applied so far, this cycle's included: the
    /// [`CommandRecord::sequence`] up to which a replay applies them here.
    pub commands_applied: u64,
    /// Valid entries in `encoders`.
    pub encoder_count: u32,
    /// Valid entries in `drives`.
    pub drive_count: u32,
    /// Encoders [rad].
    pub encoders: [RawReading; MAX_RAW_ENCODERS],
    /// Drives.
    pub drives: [RawDrive; MAX_RAW_DRIVES],
    /// Valid entries in `torque_sensors`.
    pub torque_sensor_count: u32,
    _reserved: u32,
    /// Force/torque sensors: the torque about each one's joint axis [Nm].
    pub torque_sensors: [RawReading; MAX_RAW_TORQUE_SENSORS],
}

impl RawFrame {
    /// An empty frame.
    pub const EMPTY: RawFrame = RawFrame {
        cycle: 0,
        stamp_ns: 0,
        commands_applied: 0,
        encoder_count: 0,
        drive_count: 0,
        encoders: [RawReading::MISSING; MAX_RAW_ENCODERS],
        drives: [RawDrive::EMPTY; MAX_RAW_DRIVES],
        torque_sensor_count: 0,
        _reserved: 0,
        torque_sensors: [RawReading::MISSING; MAX_RAW_TORQUE_SENSORS],
    };

    /// The valid force/torque sensors.
    pub fn torque_sensors(&self) -> &[RawReading] {
        &self.torque_sensors[..(self.torque_sensor_count as usize).min(MAX_RAW_TORQUE_SENSORS)]
    }

    /// The valid encoders.
    pub fn encoders(&self) -> &[RawReading] {
        &self.encoders[..(self.encoder_count as usize).min(MAX_RAW_ENCODERS)]
    }

    /// The valid drives.
    pub fn drives(&self) -> &[RawDrive] {
        &self.drives[..(self.drive_count as usize).min(MAX_RAW_DRIVES)]
    }
}

named_codes! {
    /// What kind of device an entry of [`RawDescriptor`] is.
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::raw::DeviceKind::ABSOLUTE_ENCODER.name(), "absolute_encoder");
    /// ```
    DeviceKind {
        /// A 14-bit absolute encoder on SPI (section 2.2); value [rad].
        ABSOLUTE_ENCODER = 1, "absolute_encoder";
        /// An ELMO drive on CAN (CANopen CiA 402); position [rad], velocity [rad/s].
        DRIVE = 2, "drive";
        /// A force/torque sensor axis (an ATI Net F/T box, chapter 5); torque [Nm].
        FORCE_TORQUE = 3, "force_torque";
    }
}

/// One device: its name, kind and the unit of its value.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct DeviceDescriptor {
    /// NUL-padded device name, as in the arm's YAML.
    pub name: [u8; DEVICE_NAME_LEN],
    /// Kind.
    pub kind: DeviceKind,
    /// Bus index in the YAML (`buses.spi[i]` for encoders, `buses.can[i]` for drives).
    pub bus: u32,
    /// NUL-padded SI unit of the value (`rad`; a drive's velocity is in `rad/s`).
    pub unit: [u8; NAME_LEN],
}

impl DeviceDescriptor {
    /// An unnamed entry.
    pub const EMPTY: DeviceDescriptor = DeviceDescriptor { name: [0; DEVICE_NAME_LEN], kind: DeviceKind(0), bus: 0, unit: [0; NAME_LEN] };

    /// A named device.
    ///
    /// ```
    /// use jointctl_ipc::raw::{DeviceDescriptor, DeviceKind};
    /// let d = DeviceDescriptor::new("enc_q2_out", DeviceKind::ABSOLUTE_ENCODER, 0, "rad");
    /// assert_eq!(jointctl_ipc::decode_name(&d.unit), "rad");
    /// ```
    pub fn new(name: &str, kind: DeviceKind, bus: u32, unit: &str) -> Self {
        DeviceDescriptor { name: encode_name(name), kind, bus, unit: encode_name(unit) }
    }
}

/// What the raw frames of an arm carry, published once when the runtime starts.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.RawDescriptor.v1")]
pub struct RawDescriptor {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
    /// Valid entries in `encoders`.
    pub encoder_count: u32,
    /// Valid entries in `drives`.
    pub drive_count: u32,
    /// Encoders, in the order of [`RawFrame::encoders`].
    pub encoders: [DeviceDescriptor; MAX_RAW_ENCODERS],
    /// Drives, in the order of [`RawFrame::drives`].
    pub drives: [DeviceDescriptor; MAX_RAW_DRIVES],
    /// Valid entries in `torque_sensors`.
    pub torque_sensor_count: u32,
    _reserved: u32,
    /// Force/torque sensors, in the order of [`RawFrame::torque_sensors`].
    pub torque_sensors: [DeviceDescriptor; MAX_RAW_TORQUE_SENSORS],
    /// The readings the joints were activated with (observers take their zeros there, section
    /// 3.4.1): a replay of a recording that starts later activates with them.
    pub activation: RawFrame,
    /// NUL-padded absolute path of the arm's YAML, empty when unknown (a recorder attaches it).
    pub config_path: [u8; PATH_LEN],
}

impl RawDescriptor {
    /// An empty descriptor.
    pub const EMPTY: RawDescriptor = RawDescriptor {
        rate_hz: 0.0,
        encoder_count: 0,
        drive_count: 0,
        encoders: [DeviceDescriptor::EMPTY; MAX_RAW_ENCODERS],
        drives: [DeviceDescriptor::EMPTY; MAX_RAW_DRIVES],
        torque_sensor_count: 0,
        _reserved: 0,
        torque_sensors: [DeviceDescriptor::EMPTY; MAX_RAW_TORQUE_SENSORS],
        activation: RawFrame::EMPTY,
        config_path: [0; PATH_LEN],
    };

    /// The descriptor of `encoders`, `drives` (name, bus index each) and `torque_sensors`, at
    /// `rate_hz`; names past the frames' capacity are left out (the config refuses such arms).
    ///
    /// ```
    /// let d = jointctl_ipc::raw::RawDescriptor::of(40.0, &[("enc_a", 0)], &[("elmo_a", 0), ("elmo_b", 0)], &["ft_q2"], None);
    /// assert_eq!((d.encoder_count, d.drive_count, d.torque_sensor_count), (1, 2, 1));
    /// assert_eq!(jointctl_ipc::decode_name(&d.drives[1].name), "elmo_b");
    /// assert_eq!(jointctl_ipc::decode_name(&d.torque_sensors[0].unit), "Nm");
    /// ```
    pub fn of(rate_hz: f64, encoders: &[(&str, u32)], drives: &[(&str, u32)], torque_sensors: &[&str], config_path: Option<&std::path::Path>) -> Self {
        let mut d = RawDescriptor { rate_hz, ..RawDescriptor::EMPTY };
        for (slot, (name, bus)) in d.encoders.iter_mut().zip(encoders) {
            *slot = DeviceDescriptor::new(name, DeviceKind::ABSOLUTE_ENCODER, *bus, "rad");
        }
        for (slot, (name, bus)) in d.drives.iter_mut().zip(drives) {
            *slot = DeviceDescriptor::new(name, DeviceKind::DRIVE, *bus, "rad");
        }
        for (slot, name) in d.torque_sensors.iter_mut().zip(torque_sensors) {
            *slot = DeviceDescriptor::new(name, DeviceKind::FORCE_TORQUE, 0, "Nm");
        }
        d.torque_sensor_count = torque_sensors.len().min(MAX_RAW_TORQUE_SENSORS) as u32;
        d.encoder_count = encoders.len().min(MAX_RAW_ENCODERS) as u32;
        d.drive_count = drives.len().min(MAX_RAW_DRIVES) as u32;
        // The activation frame holds the same devices.
        (d.activation.encoder_count, d.activation.drive_count, d.activation.torque_sensor_count) = (d.encoder_count, d.drive_count, d.torque_sensor_count);
        if let Some(p) = config_path {
            d.config_path = encode_name(&p.to_string_lossy());
        }
        d
    }

    /// The config path, if one was given.
    pub fn config_path(&self) -> Option<std::path::PathBuf> {
        let text = crate::decode_name(&self.config_path);
        (!text.is_empty()).then(|| std::path::PathBuf::from(text))
    }
}

/// A command the runtime accepted, as it was asked, with when and what it said.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.CommandRecord.v1")]
pub struct CommandRecord {
    /// Accepted commands so far, from 1: a gap means a record was lost.
    pub sequence: u64,
    /// CLOCK_MONOTONIC time of the answer [ns] (the loop applies it at its next cycle).
    pub stamp_ns: u64,
    /// The request.
    pub request: CommandRequest,
    /// The runtime's answer.
    pub response: crate::CommandResponse,
}
