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

use crate::wire::{ByteRecord, PayloadSizeError, bytes_of, put, take};
use crate::{CommandRequest, DEVICE_NAME_LEN, NAME_LEN, encode_name};

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
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend, zerocopy::FromBytes, zerocopy::IntoBytes, zerocopy::Immutable, zerocopy::KnownLayout)]
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
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend, zerocopy::FromBytes, zerocopy::IntoBytes, zerocopy::Immutable, zerocopy::KnownLayout)]
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

/// The user header of a raw-readings sample: the cycle's fields and how many of each device
/// the payload holds, as bytes ([`crate::wire`]): `encoder_count` [`RawReading`]s, then
/// `drive_count` [`RawDrive`]s, then `torque_sensor_count` [`RawReading`]s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.RawFrameHeader.v1")]
pub struct RawFrameHeader {
    /// Cycle counter, the same as the cycle's [`crate::ArmState::cycle`].
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// Accepted commands the loop has applied so far, this cycle's included.
    pub commands_applied: u64,
    /// Encoders in the payload.
    pub encoder_count: u32,
    /// Drives in the payload.
    pub drive_count: u32,
    /// Force/torque sensors in the payload.
    pub torque_sensor_count: u32,
    _reserved: u32,
}

impl RawFrameHeader {
    fn payload_len(&self) -> usize {
        bytes_of::<RawReading>(self.encoder_count as usize) + bytes_of::<RawDrive>(self.drive_count as usize) + bytes_of::<RawReading>(self.torque_sensor_count as usize)
    }
}

/// Every device of the arm in one cycle, in the order of [`RawDescriptor`].
///
/// ```
/// use jointctl_ipc::raw::{RawDrive, RawFrame, RawReading};
/// use jointctl_ipc::wire::ByteRecord;
/// let mut f = RawFrame { cycle: 4, ..RawFrame::EMPTY };
/// f.encoders = vec![RawReading::MISSING; 33];
/// f.drives = vec![RawDrive::EMPTY; 17];
/// f.drives[16].enabled = 1;
/// let mut bytes = vec![0u8; f.payload_len()];
/// f.write_payload(&mut bytes);
/// let back = RawFrame::from_parts(&f.header(), &bytes).unwrap();
/// assert_eq!((back.cycle, back.encoders().len(), back.drives()[16].enabled), (4, 33, 1));
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawFrame {
    /// Cycle counter, the same as the cycle's [`crate::ArmState::cycle`].
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// Accepted commands the loop has applied so far, this cycle's included: the
    /// [`CommandRecord::sequence`] up to which a replay applies them here.
    pub commands_applied: u64,
    /// Encoders [rad].
    pub encoders: Vec<RawReading>,
    /// Drives.
    pub drives: Vec<RawDrive>,
    /// Force/torque sensors: the torque about each one's joint axis [Nm].
    pub torque_sensors: Vec<RawReading>,
}

impl RawFrame {
    /// A frame of no devices.
    pub const EMPTY: RawFrame = RawFrame { cycle: 0, stamp_ns: 0, commands_applied: 0, encoders: Vec::new(), drives: Vec::new(), torque_sensors: Vec::new() };

    /// A frame of missing readings and holding drives, for these many devices.
    pub fn with_devices(encoders: usize, drives: usize, torque_sensors: usize) -> Self {
        RawFrame { encoders: vec![RawReading::MISSING; encoders], drives: vec![RawDrive::EMPTY; drives], torque_sensors: vec![RawReading::MISSING; torque_sensors], ..RawFrame::EMPTY }
    }

    /// The force/torque sensors.
    pub fn torque_sensors(&self) -> &[RawReading] {
        &self.torque_sensors
    }

    /// The encoders.
    pub fn encoders(&self) -> &[RawReading] {
        &self.encoders
    }

    /// The drives.
    pub fn drives(&self) -> &[RawDrive] {
        &self.drives
    }

    /// A frame from a received header and payload.
    pub fn from_parts(header: &RawFrameHeader, payload: &[u8]) -> Result<Self, PayloadSizeError> {
        let mut f = RawFrame::EMPTY;
        f.copy_from_parts(header, payload)?;
        Ok(f)
    }

    /// This frame overwritten by `other`; allocation-free when it holds as many devices.
    pub fn copy_from(&mut self, other: &RawFrame) {
        (self.cycle, self.stamp_ns, self.commands_applied) = (other.cycle, other.stamp_ns, other.commands_applied);
        self.encoders.clear();
        self.encoders.extend_from_slice(&other.encoders);
        self.drives.clear();
        self.drives.extend_from_slice(&other.drives);
        self.torque_sensors.clear();
        self.torque_sensors.extend_from_slice(&other.torque_sensors);
    }
}

impl ByteRecord for RawFrame {
    type Header = RawFrameHeader;

    fn header(&self) -> RawFrameHeader {
        RawFrameHeader {
            cycle: self.cycle,
            stamp_ns: self.stamp_ns,
            commands_applied: self.commands_applied,
            encoder_count: self.encoders.len() as u32,
            drive_count: self.drives.len() as u32,
            torque_sensor_count: self.torque_sensors.len() as u32,
            _reserved: 0,
        }
    }

    fn payload_len(&self) -> usize {
        self.header().payload_len()
    }

    fn write_payload(&self, out: &mut [u8]) {
        let mut at = 0;
        put(out, &mut at, &self.encoders);
        put(out, &mut at, &self.drives);
        put(out, &mut at, &self.torque_sensors);
    }

    fn copy_from_parts(&mut self, header: &RawFrameHeader, payload: &[u8]) -> Result<(), PayloadSizeError> {
        let expected = header.payload_len();
        if payload.len() != expected {
            let what = format!("{} encoders, {} drives and {} force/torque sensors", header.encoder_count, header.drive_count, header.torque_sensor_count);
            return Err(PayloadSizeError { record: "raw-readings", what, expected, got: payload.len() });
        }
        (self.cycle, self.stamp_ns, self.commands_applied) = (header.cycle, header.stamp_ns, header.commands_applied);
        let mut at = 0;
        take(payload, &mut at, header.encoder_count as usize, &mut self.encoders);
        take(payload, &mut at, header.drive_count as usize, &mut self.drives);
        take(payload, &mut at, header.torque_sensor_count as usize, &mut self.torque_sensors);
        Ok(())
    }
}

/// A received raw-readings sample.
pub type RawFrameSample = iceoryx2::sample::Sample<ipc::Service, [u8], RawFrameHeader>;

impl TryFrom<&RawFrameSample> for RawFrame {
    type Error = PayloadSizeError;
    fn try_from(sample: &RawFrameSample) -> Result<Self, PayloadSizeError> {
        RawFrame::from_parts(sample.user_header(), sample.payload())
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
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend, zerocopy::FromBytes, zerocopy::IntoBytes, zerocopy::Immutable, zerocopy::KnownLayout)]
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

/// The user header of the raw-reading descriptor: the rate, the config path, how many
/// devices of each kind the payload describes, and the activation frame's header. The payload,
/// as bytes ([`crate::wire`]): the encoders', drives' and force/torque sensors'
/// [`DeviceDescriptor`]s, then the activation frame's payload.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.RawDescriptorHeader.v1")]
pub struct RawDescriptorHeader {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
    /// Encoders described.
    pub encoder_count: u32,
    /// Drives described.
    pub drive_count: u32,
    /// Force/torque sensors described.
    pub torque_sensor_count: u32,
    _reserved: u32,
    /// The activation frame's header.
    pub activation: RawFrameHeader,
    /// NUL-padded absolute path of the arm's YAML, empty when unknown.
    pub config_path: [u8; PATH_LEN],
}

impl Default for RawDescriptorHeader {
    fn default() -> Self {
        RawDescriptorHeader { rate_hz: 0.0, encoder_count: 0, drive_count: 0, torque_sensor_count: 0, _reserved: 0, activation: RawFrameHeader::default(), config_path: [0; PATH_LEN] }
    }
}

/// What the raw frames of an arm carry, published once when the runtime starts.
#[derive(Clone, Debug, PartialEq)]
pub struct RawDescriptor {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
    /// Encoders, in the order of [`RawFrame::encoders`].
    pub encoders: Vec<DeviceDescriptor>,
    /// Drives, in the order of [`RawFrame::drives`].
    pub drives: Vec<DeviceDescriptor>,
    /// Force/torque sensors, in the order of [`RawFrame::torque_sensors`].
    pub torque_sensors: Vec<DeviceDescriptor>,
    /// The readings the joints were activated with (observers take their zeros there, section
    /// 3.4.1): a replay of a recording that starts later activates with them.
    pub activation: RawFrame,
    /// NUL-padded absolute path of the arm's YAML, empty when unknown (a recorder attaches it).
    pub config_path: [u8; PATH_LEN],
}

impl Default for RawDescriptor {
    fn default() -> Self {
        RawDescriptor::EMPTY
    }
}

impl RawDescriptor {
    /// A descriptor of no devices.
    pub const EMPTY: RawDescriptor = RawDescriptor { rate_hz: 0.0, encoders: Vec::new(), drives: Vec::new(), torque_sensors: Vec::new(), activation: RawFrame::EMPTY, config_path: [0; PATH_LEN] };

    /// The descriptor of `encoders`, `drives` (name, bus index each) and `torque_sensors`, at
    /// `rate_hz`; its activation frame holds as many devices, missing and holding.
    ///
    /// ```
    /// let d = jointctl_ipc::raw::RawDescriptor::of(40.0, &[("enc_a", 0)], &[("elmo_a", 0), ("elmo_b", 0)], &["ft_q2"], None);
    /// assert_eq!((d.encoders.len(), d.drives.len(), d.torque_sensors.len()), (1, 2, 1));
    /// assert_eq!(jointctl_ipc::decode_name(&d.drives[1].name), "elmo_b");
    /// assert_eq!(jointctl_ipc::decode_name(&d.torque_sensors[0].unit), "Nm");
    /// assert_eq!(d.activation.drives().len(), 2);
    /// ```
    pub fn of(rate_hz: f64, encoders: &[(&str, u32)], drives: &[(&str, u32)], torque_sensors: &[&str], config_path: Option<&std::path::Path>) -> Self {
        let mut d = RawDescriptor {
            rate_hz,
            encoders: encoders.iter().map(|(name, bus)| DeviceDescriptor::new(name, DeviceKind::ABSOLUTE_ENCODER, *bus, "rad")).collect(),
            drives: drives.iter().map(|(name, bus)| DeviceDescriptor::new(name, DeviceKind::DRIVE, *bus, "rad")).collect(),
            torque_sensors: torque_sensors.iter().map(|name| DeviceDescriptor::new(name, DeviceKind::FORCE_TORQUE, 0, "Nm")).collect(),
            activation: RawFrame::with_devices(encoders.len(), drives.len(), torque_sensors.len()),
            config_path: [0; PATH_LEN],
        };
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

    /// A descriptor from a received header and payload.
    pub fn from_parts(header: &RawDescriptorHeader, payload: &[u8]) -> Result<Self, PayloadSizeError> {
        let mut d = RawDescriptor::EMPTY;
        d.copy_from_parts(header, payload)?;
        Ok(d)
    }
}

impl ByteRecord for RawDescriptor {
    type Header = RawDescriptorHeader;

    fn header(&self) -> RawDescriptorHeader {
        RawDescriptorHeader {
            rate_hz: self.rate_hz,
            encoder_count: self.encoders.len() as u32,
            drive_count: self.drives.len() as u32,
            torque_sensor_count: self.torque_sensors.len() as u32,
            _reserved: 0,
            activation: self.activation.header(),
            config_path: self.config_path,
        }
    }

    fn payload_len(&self) -> usize {
        bytes_of::<DeviceDescriptor>(self.encoders.len() + self.drives.len() + self.torque_sensors.len()) + self.activation.payload_len()
    }

    fn write_payload(&self, out: &mut [u8]) {
        let mut at = 0;
        put(out, &mut at, &self.encoders);
        put(out, &mut at, &self.drives);
        put(out, &mut at, &self.torque_sensors);
        self.activation.write_payload(&mut out[at..]);
    }

    fn copy_from_parts(&mut self, header: &RawDescriptorHeader, payload: &[u8]) -> Result<(), PayloadSizeError> {
        let (e, d, t) = (header.encoder_count as usize, header.drive_count as usize, header.torque_sensor_count as usize);
        let devices = bytes_of::<DeviceDescriptor>(e + d + t);
        let expected = devices + header.activation.payload_len();
        if payload.len() != expected {
            let what = format!("{e} encoders, {d} drives and {t} force/torque sensors with an activation frame of {} bytes", header.activation.payload_len());
            return Err(PayloadSizeError { record: "raw-descriptor", what, expected, got: payload.len() });
        }
        self.activation.copy_from_parts(&header.activation, &payload[devices..])?;
        (self.rate_hz, self.config_path) = (header.rate_hz, header.config_path);
        let mut at = 0;
        take(payload, &mut at, e, &mut self.encoders);
        take(payload, &mut at, d, &mut self.drives);
        take(payload, &mut at, t, &mut self.torque_sensors);
        Ok(())
    }
}

/// A received raw-descriptor sample.
pub type RawDescriptorSample = iceoryx2::sample::Sample<ipc::Service, [u8], RawDescriptorHeader>;

impl TryFrom<&RawDescriptorSample> for RawDescriptor {
    type Error = PayloadSizeError;
    fn try_from(sample: &RawDescriptorSample) -> Result<Self, PayloadSizeError> {
        RawDescriptor::from_parts(sample.user_header(), sample.payload())
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
