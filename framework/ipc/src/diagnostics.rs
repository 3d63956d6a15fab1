//! The diagnostics sample: the loop's and every joint's and device's health, once per cycle
//! (`<arm>/diagnostics`).

use iceoryx2::prelude::*;

use crate::wire::{ByteRecord, PayloadSizeError, bytes_of, put, take};
use crate::{DEVICE_NAME_LEN, NAME_LEN};

/// Health of one joint DOF.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend, zerocopy::FromBytes, zerocopy::IntoBytes, zerocopy::Immutable, zerocopy::KnownLayout)]
#[repr(C)]
pub struct JointDiagnostics {
    /// NUL-padded joint name.
    pub name: [u8; NAME_LEN],
    /// [`FieldMask`] bits observed this cycle.
    pub valid_mask: u32,
    /// Current fault code (0 = none).
    pub fault_code: u32,
    /// 1 when the runtime held this joint this cycle (fault or unusable state).
    pub held: u32,
    _reserved: u32,
    /// Cycles in which the joint's state was unusable and the joint was held.
    pub invalid_cycles: u64,
    /// Faults raised by the joint's plugin (panics, fault codes).
    pub fault_count: u64,
    /// Joint set-points clamped into the position limits.
    pub setpoint_clamps: u64,
    /// Torque references clamped into the torque limit.
    pub torque_clamps: u64,
    /// Cycles whose set-point change the rate limit cut.
    pub rate_limited: u64,
    /// Streamed commands that timed out (the joint fell back to holding).
    pub watchdog_trips: u64,
    /// Cycles held because the mode needed an unknown value (torque, stiffness, velocity).
    pub missing_inputs: u64,
    /// The joint's plugin: its time budget per cycle [ns].
    pub plugin_budget_ns: u64,
    /// The joint's plugin: most time it took in one cycle (observe + control) [ns].
    pub plugin_max_ns: u64,
    /// Cycles the joint's plugin was over its budget (faulting or not).
    pub over_budget_cycles: u64,
    /// Cycles whose motor set-points the runtime's check refused (not finite, outside the
    /// drive's window, too fast); the first faults the joint.
    pub setpoint_rejections: u64,
    /// NUL-padded reason of the fault that holds the joint (its plugin's message, or the
    /// runtime's), empty when none.
    pub fault_message: [u8; FAULT_MESSAGE_LEN],
}

/// Longest fault reason in [`JointDiagnostics`] [bytes, NUL included].
pub const FAULT_MESSAGE_LEN: usize = 128;

impl JointDiagnostics {
    /// An unnamed entry.
    pub const EMPTY: JointDiagnostics = JointDiagnostics {
        name: [0; NAME_LEN],
        valid_mask: 0,
        fault_code: 0,
        held: 0,
        _reserved: 0,
        invalid_cycles: 0,
        fault_count: 0,
        setpoint_clamps: 0,
        torque_clamps: 0,
        rate_limited: 0,
        watchdog_trips: 0,
        missing_inputs: 0,
        plugin_budget_ns: 0,
        plugin_max_ns: 0,
        over_budget_cycles: 0,
        setpoint_rejections: 0,
        fault_message: [0; FAULT_MESSAGE_LEN],
    };
}

/// Health of one device (drive or encoder): what the HAL did not use, and why.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend, zerocopy::FromBytes, zerocopy::IntoBytes, zerocopy::Immutable, zerocopy::KnownLayout)]
#[repr(C)]
pub struct DeviceDiagnostics {
    /// NUL-padded device name, whole (see [`jointctl_api::MAX_DEVICE_NAME`]).
    pub name: [u8; DEVICE_NAME_LEN],
    /// Cycles in which nothing arrived (lost or late frames).
    pub missing: u64,
    /// Frames that failed their checks (parity, error flag, silent node).
    pub invalid: u64,
    /// Values rejected as implausible (jumps, zeros after non-zero readings).
    pub implausible: u64,
    /// Emergency messages.
    pub emcy: u64,
    /// 1 silent, 2 fault, 4 bus-off, 8 error-passive.
    pub flags: u32,
    _reserved: u32,
}

impl DeviceDiagnostics {
    /// An unnamed entry.
    pub const EMPTY: DeviceDiagnostics =
        DeviceDiagnostics { name: [0; DEVICE_NAME_LEN], missing: 0, invalid: 0, implausible: 0, emcy: 0, flags: 0, _reserved: 0 };
}

/// The loop's health in one cycle: what a diagnostics sample says beside its joints and devices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
pub struct LoopHealth {
    /// Cycle counter.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle [ns].
    pub stamp_ns: u64,
    /// Nominal period [ns].
    pub period_ns: u64,
    /// Cycles whose work ended after the next deadline.
    pub overruns: u64,
    /// Deadlines skipped because a cycle overran.
    pub missed_deadlines: u64,
    /// HAL read/write failures.
    pub hal_errors: u64,
    /// Cycle records the publisher thread could not keep up with (dropped, never blocking the loop).
    pub publish_drops: u64,
    /// Compute time (read to write) of the last cycle [ns].
    pub last_compute_ns: u64,
    /// Longest compute time so far [ns].
    pub max_compute_ns: u64,
    /// Largest wake-up lateness so far [ns].
    pub max_jitter_ns: u64,
    /// Wake-up lateness histogram, buckets bounded by [`crate::JITTER_BUCKET_UPPER_US`].
    pub jitter_histogram: [u64; 16],
}

impl LoopHealth {
    /// Nothing counted yet.
    pub const EMPTY: LoopHealth = LoopHealth {
        cycle: 0,
        stamp_ns: 0,
        period_ns: 0,
        overruns: 0,
        missed_deadlines: 0,
        hal_errors: 0,
        publish_drops: 0,
        last_compute_ns: 0,
        max_compute_ns: 0,
        max_jitter_ns: 0,
        jitter_histogram: [0; 16],
    };
}

/// The user header of a diagnostics sample: the loop's health, and how many entries its payload
/// holds, as bytes ([`crate::wire`]): `joint_count` [`JointDiagnostics`], then `device_count`
/// [`DeviceDiagnostics`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.DiagnosticsHeader.v1")]
pub struct DiagnosticsHeader {
    /// The loop's health.
    pub health: LoopHealth,
    /// Entries of [`JointDiagnostics`] in the payload.
    pub joint_count: u32,
    /// Entries of [`DeviceDiagnostics`] in the payload, after the joints.
    pub device_count: u32,
}

/// Loop health, once per cycle, as a process holds it: the loop's figures (reached through
/// the sample as `d.cycle`, `d.overruns`, ...), every joint's and every device's.
///
/// ```
/// use jointctl_ipc::wire::ByteRecord;
/// let mut d = jointctl_ipc::Diagnostics::EMPTY;
/// d.cycle = 9;
/// d.joints = vec![jointctl_ipc::JointDiagnostics::EMPTY; 20];
/// d.joints[19].fault_count = 3;
/// d.devices = vec![jointctl_ipc::DeviceDiagnostics::EMPTY; 40];
/// let mut bytes = vec![0u8; d.payload_len()];
/// d.write_payload(&mut bytes);
/// let back = jointctl_ipc::Diagnostics::from_parts(&d.header(), &bytes).unwrap();
/// assert_eq!((back.cycle, back.joints.len(), back.joints[19].fault_count, back.devices.len()), (9, 20, 3, 40));
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// The loop's figures.
    pub health: LoopHealth,
    /// Per-joint health, in the order of [`crate::ArmState::joints`].
    pub joints: Vec<JointDiagnostics>,
    /// Per-device health: drives, then encoders, in YAML order.
    pub devices: Vec<DeviceDiagnostics>,
}

impl std::ops::Deref for Diagnostics {
    type Target = LoopHealth;
    fn deref(&self) -> &LoopHealth {
        &self.health
    }
}

impl std::ops::DerefMut for Diagnostics {
    fn deref_mut(&mut self) -> &mut LoopHealth {
        &mut self.health
    }
}

impl Diagnostics {
    /// A sample with no joints and no devices.
    pub const EMPTY: Diagnostics = Diagnostics { health: LoopHealth::EMPTY, joints: Vec::new(), devices: Vec::new() };

    /// A sample from a received header and payload.
    pub fn from_parts(header: &DiagnosticsHeader, payload: &[u8]) -> Result<Self, PayloadSizeError> {
        let mut d = Diagnostics::EMPTY;
        d.copy_from_parts(header, payload)?;
        Ok(d)
    }

    /// This sample overwritten by `other`; allocation-free when it holds as many entries.
    pub fn copy_from(&mut self, other: &Diagnostics) {
        self.health = other.health;
        self.joints.clear();
        self.joints.extend_from_slice(&other.joints);
        self.devices.clear();
        self.devices.extend_from_slice(&other.devices);
    }
}

impl ByteRecord for Diagnostics {
    type Header = DiagnosticsHeader;

    fn header(&self) -> DiagnosticsHeader {
        DiagnosticsHeader { health: self.health, joint_count: self.joints.len() as u32, device_count: self.devices.len() as u32 }
    }

    fn payload_len(&self) -> usize {
        bytes_of::<JointDiagnostics>(self.joints.len()) + bytes_of::<DeviceDiagnostics>(self.devices.len())
    }

    fn write_payload(&self, out: &mut [u8]) {
        let mut at = 0;
        put(out, &mut at, &self.joints);
        put(out, &mut at, &self.devices);
    }

    fn copy_from_parts(&mut self, header: &DiagnosticsHeader, payload: &[u8]) -> Result<(), PayloadSizeError> {
        let (joints, devices) = (header.joint_count as usize, header.device_count as usize);
        let expected = bytes_of::<JointDiagnostics>(joints) + bytes_of::<DeviceDiagnostics>(devices);
        if payload.len() != expected {
            return Err(PayloadSizeError { record: "diagnostics", what: format!("{joints} joints and {devices} devices"), expected, got: payload.len() });
        }
        self.health = header.health;
        let mut at = 0;
        take(payload, &mut at, joints, &mut self.joints);
        take(payload, &mut at, devices, &mut self.devices);
        Ok(())
    }
}

/// A received diagnostics sample.
pub type DiagnosticsSample = iceoryx2::sample::Sample<ipc::Service, [u8], DiagnosticsHeader>;

impl TryFrom<&DiagnosticsSample> for Diagnostics {
    type Error = PayloadSizeError;
    fn try_from(sample: &DiagnosticsSample) -> Result<Self, PayloadSizeError> {
        Diagnostics::from_parts(sample.user_header(), sample.payload())
    }
}
