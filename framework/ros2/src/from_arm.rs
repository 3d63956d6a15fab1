//! The arm's shared-memory samples as ROS 2 messages. Every stamp in a header is the wall clock
//! ([`WallClock`]): ROS 2 tools line up topics and play bags by it. The runtime's own
//! CLOCK_MONOTONIC stamp travels beside it in the jointctl messages (`stamp_ns`), so that a
//! reader of the file sees the same times as in the JSON form.

use jointctl_ipc::raw::{CommandRecord, RawDescriptor, RawFrame, RawReading};
use jointctl_ipc::{ArmState, DeviceDiagnostics, Diagnostics, FieldMask, JointDiagnostics, JointSample, decode_name};

use crate::msg::{self, DiagnosticStatus, Header, KeyValue, Time};

/// CLOCK_MONOTONIC stamps on the wall clock: one pair of readings of both clocks taken
/// together (the recording's start) fixes the offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WallClock {
    offset_ns: i128,
}

impl WallClock {
    /// The clock of a pair of readings taken together: UNIX time and CLOCK_MONOTONIC [ns].
    ///
    /// ```
    /// let c = jointctl_ros2::from_arm::WallClock::from_pair(1_700_000_000_000_000_000, 5_000);
    /// assert_eq!(c.unix_ns(6_000), 1_700_000_000_000_001_000);
    /// ```
    pub fn from_pair(unix_ns: u64, monotonic_ns: u64) -> Self {
        WallClock { offset_ns: i128::from(unix_ns) - i128::from(monotonic_ns) }
    }

    /// A monotonic stamp [ns] as UNIX time [ns] (0 before the epoch).
    ///
    /// ```
    /// let c = jointctl_ros2::from_arm::WallClock::from_pair(1_000, 5_000);
    /// assert_eq!((c.unix_ns(5_500), c.unix_ns(0)), (1_500, 0));
    /// ```
    pub fn unix_ns(&self, monotonic_ns: u64) -> u64 {
        u64::try_from((i128::from(monotonic_ns) + self.offset_ns).max(0)).unwrap_or(u64::MAX)
    }

    fn header(&self, monotonic_ns: u64, frame: &str) -> Header {
        Header { stamp: Time::from_unix_ns(self.unix_ns(monotonic_ns)), frame_id: frame.to_string() }
    }
}

pub(crate) fn known(s: &JointSample, bit: u32, value: f64) -> f64 {
    s.get(bit, value).unwrap_or(f64::NAN)
}

/// The joint states as every ROS 2 tool reads them: name, position [rad], velocity [rad/s] and
/// effort = the observed torque [Nm]; NaN where the observer does not know the value.
///
/// ```
/// let mut s = jointctl_ipc::ArmState::EMPTY;
/// s.joints.push(jointctl_ipc::JointSample::EMPTY);
/// s.joints[0].name = jointctl_ipc::encode_name("q2");
/// s.joints[0].position_rad = 0.5;
/// s.joints[0].valid_mask = jointctl_ipc::FieldMask::POSITION;
/// let m = jointctl_ros2::from_arm::joint_state(&s, &jointctl_ros2::from_arm::WallClock::from_pair(0, 0), "sherpa");
/// assert_eq!((m.name[0].as_str(), m.position[0]), ("q2", 0.5));
/// assert!(m.effort[0].is_nan(), "an unobserved torque is not a number");
/// ```
pub fn joint_state(s: &ArmState, clock: &WallClock, arm: &str) -> msg::JointState {
    let joints = s.joints();
    msg::JointState {
        header: clock.header(s.stamp_ns, arm),
        name: joints.iter().map(|j| decode_name(&j.name).to_string()).collect(),
        position: joints.iter().map(|j| known(j, FieldMask::POSITION, j.position_rad)).collect(),
        velocity: joints.iter().map(|j| known(j, FieldMask::VELOCITY, j.velocity_rad_s)).collect(),
        effort: joints.iter().map(|j| known(j, FieldMask::TORQUE, j.torque_nm)).collect(),
    }
}

/// Every DOF's observed state (what the JSON form's `joint_state` holds).
///
/// ```
/// let mut s = jointctl_ipc::ArmState::EMPTY;
/// s.cycle = 7;
/// s.joints.push(jointctl_ipc::JointSample::EMPTY);
/// s.joints[0].sensor_torque_nm = 1.5;
/// let m = jointctl_ros2::from_arm::joint_details(&s, &jointctl_ros2::from_arm::WallClock::from_pair(0, 0), "sherpa");
/// assert_eq!((m.cycle, m.joints[0].sensor_torque_nm), (7, 1.5));
/// assert!(m.joints[0].deflection_rad.is_nan(), "not observed");
/// ```
pub fn joint_details(s: &ArmState, clock: &WallClock, arm: &str) -> msg::JointDetails {
    msg::JointDetails {
        header: clock.header(s.stamp_ns, arm),
        cycle: s.cycle,
        stamp_ns: s.stamp_ns,
        final_sample: s.final_sample != 0,
        joints: s
            .joints()
            .iter()
            .map(|x| msg::JointDetail {
                name: decode_name(&x.name).to_string(),
                position_rad: known(x, FieldMask::POSITION, x.position_rad),
                velocity_rad_s: known(x, FieldMask::VELOCITY, x.velocity_rad_s),
                deflection_rad: known(x, FieldMask::DEFLECTION, x.deflection_rad),
                torque_nm: known(x, FieldMask::TORQUE, x.torque_nm),
                stiffness_nm_per_rad: known(x, FieldMask::STIFFNESS, x.stiffness_nm_per_rad),
                pivot_mm: known(x, FieldMask::PIVOT, x.pivot_mm),
                reference_torque_nm: x.reference_torque_nm,
                sensor_torque_nm: x.sensor_torque_nm,
                gravity_nm: x.gravity_nm,
                mode: x.mode.name().to_string(),
                enabled: x.enabled != 0,
                fault_code: x.fault_code,
            })
            .collect(),
    }
}

fn reading(name: &str, r: &RawReading) -> msg::RawReading {
    msg::RawReading { name: name.to_string(), value: r.value, status: r.status.name().to_string(), age_s: r.age_s }
}

/// A raw frame, its devices named by the descriptor.
///
/// ```
/// use jointctl_ipc::raw::{RawDescriptor, RawFrame, RawReading};
/// let d = RawDescriptor::of(40.0, &[("enc_q2_out", 0)], &[], &[], None);
/// let mut f = RawFrame::EMPTY;
/// f.encoders.push(RawReading::from_reading(&jointctl_api::Reading::valid(0.25)));
/// let m = jointctl_ros2::from_arm::raw_frame(&f, &d, &jointctl_ros2::from_arm::WallClock::from_pair(0, 0), "sherpa");
/// assert_eq!((m.encoders[0].name.as_str(), m.encoders[0].value, m.encoders[0].status.as_str()), ("enc_q2_out", 0.25, "valid"));
/// ```
pub fn raw_frame(f: &RawFrame, d: &RawDescriptor, clock: &WallClock, arm: &str) -> msg::RawFrame {
    msg::RawFrame {
        header: clock.header(f.stamp_ns, arm),
        cycle: f.cycle,
        stamp_ns: f.stamp_ns,
        commands_applied: f.commands_applied,
        encoders: f.encoders().iter().zip(&d.encoders).map(|(r, dev)| reading(decode_name(&dev.name), r)).collect(),
        drives: f
            .drives()
            .iter()
            .zip(&d.drives)
            .map(|(r, dev)| msg::RawDrive {
                name: decode_name(&dev.name).to_string(),
                position_rad: reading("", &r.position_rad),
                velocity_rad_s: reading("", &r.velocity_rad_s),
                torque_nm: reading("", &r.torque_nm),
                enabled: r.enabled != 0,
                fault: r.fault != 0,
                action: r.action.name().to_string(),
                setpoint_rad: r.setpoint_rad,
                velocity_ff_rad_s: r.velocity_ff_rad_s,
            })
            .collect(),
        torque_sensors: f.torque_sensors().iter().zip(&d.torque_sensors).map(|(r, dev)| reading(decode_name(&dev.name), r)).collect(),
    }
}

/// An accepted command.
///
/// ```
/// use jointctl_ipc::{CommandRequest, CommandResponse, TorqueWaveform};
/// let r = jointctl_ipc::raw::CommandRecord {
///     sequence: 1, stamp_ns: 5,
///     request: CommandRequest::torque("q2", TorqueWaveform::SINE, &[5.0, 0.1]),
///     response: CommandResponse::new(true, "q2: torque sine"),
/// };
/// let m = jointctl_ros2::from_arm::command_record(&r, &jointctl_ros2::from_arm::WallClock::from_pair(0, 0), "sherpa");
/// assert_eq!((m.kind.as_str(), m.waveform.as_str(), m.values.len()), ("torque", "sine", 2));
/// ```
pub fn command_record(r: &CommandRecord, clock: &WallClock, arm: &str) -> msg::CommandRecord {
    let q = &r.request;
    // Trailing unset values (NaN) are not part of the command (as in the JSON form).
    let used = q.values.iter().rposition(|v| !v.is_nan()).map_or(0, |i| i + 1);
    msg::CommandRecord {
        header: clock.header(r.stamp_ns, arm),
        sequence: r.sequence,
        stamp_ns: r.stamp_ns,
        kind: q.kind.name().to_string(),
        joint: decode_name(&q.joint).to_string(),
        streamed: q.streamed != 0,
        waveform: q.waveform.name().to_string(),
        values: q.values[..used].to_vec(),
        points: q.points[..(q.point_count as usize).min(q.points.len())].iter().map(|p| msg::CommandPoint { t_s: p[0], position_rad: p[1], velocity_rad_s: p[2] }).collect(),
        message: r.response.text().to_string(),
    }
}

fn values(pairs: &[(&str, u64)]) -> Vec<KeyValue> {
    pairs.iter().map(|(k, v)| KeyValue { key: (*k).to_string(), value: v.to_string() }).collect()
}

/// The loop's counters in `/diagnostics` (shared with [`crate::direct`]).
pub(crate) fn loop_values(d: &Diagnostics) -> [(&'static str, u64); 9] {
    [
        ("cycle", d.cycle),
        ("period_ns", d.period_ns),
        ("overruns", d.overruns),
        ("missed_deadlines", d.missed_deadlines),
        ("hal_errors", d.hal_errors),
        ("publish_drops", d.publish_drops),
        ("last_compute_ns", d.last_compute_ns),
        ("max_compute_ns", d.max_compute_ns),
        ("max_lateness_ns", d.max_jitter_ns),
    ]
}

/// A joint's counters in `/diagnostics`.
pub(crate) fn joint_values(j: &JointDiagnostics) -> [(&'static str, u64); 11] {
    [
        ("fault_code", u64::from(j.fault_code)),
        ("invalid_cycles", j.invalid_cycles),
        ("fault_count", j.fault_count),
        ("setpoint_clamps", j.setpoint_clamps),
        ("torque_clamps", j.torque_clamps),
        ("rate_limited", j.rate_limited),
        ("watchdog_trips", j.watchdog_trips),
        ("missing_inputs", j.missing_inputs),
        ("plugin_max_ns", j.plugin_max_ns),
        ("over_budget_cycles", j.over_budget_cycles),
        ("setpoint_rejections", j.setpoint_rejections),
    ]
}

/// A device's counters in `/diagnostics`.
pub(crate) fn device_values(x: &DeviceDiagnostics) -> [(&'static str, u64); 5] {
    [("missing", x.missing), ("invalid", x.invalid), ("implausible", x.implausible), ("emcy", x.emcy), ("flags", u64::from(x.flags))]
}

/// A joint's level and message: fine (`ok`), held (`held`, WARN) or faulted (ERROR, `fault <code>:
/// <its message>`; `Some(code)`).
pub(crate) fn joint_level(j: &JointDiagnostics) -> (u8, &'static str, Option<u32>) {
    match (j.fault_code, j.held != 0) {
        (0, false) => (DiagnosticStatus::OK, "ok", None),
        (0, true) => (DiagnosticStatus::WARN, "held", None),
        (code, _) => (DiagnosticStatus::ERROR, "", Some(code)),
    }
}

/// The bits of `DeviceDiagnostics::flags` (jointctl_ipc), the HAL's device health: a device
/// with any of them is ERROR, its message their names joined by ", ".
pub(crate) const DEVICE_FLAGS: [(u32, &str); 4] = [(1, "silent"), (2, "fault"), (4, "bus-off"), (8, "error-passive")];

/// The loop's health, each joint's and each device's, as `/diagnostics` shows them (`rqt`'s
/// runtime monitor, the diagnostic aggregator): the loop is OK, a joint with a fault is ERROR
/// and a held one WARN, a device silent, faulted or off the bus (its flags) is ERROR. The
/// counters are totals since the start, as in the JSON form.
///
/// ```
/// let mut d = jointctl_ipc::Diagnostics::EMPTY;
/// d.joints.push(jointctl_ipc::JointDiagnostics::EMPTY);
/// d.joints[0].name = jointctl_ipc::encode_name("q2");
/// d.joints[0].fault_code = 3;
/// let m = jointctl_ros2::from_arm::diagnostic_array(&d, &jointctl_ros2::from_arm::WallClock::from_pair(0, 0), "sherpa");
/// assert_eq!(m.status[1].name, "jointctl/sherpa/joint/q2");
/// assert_eq!(m.status[1].level, jointctl_ros2::msg::DiagnosticStatus::ERROR);
/// ```
pub fn diagnostic_array(d: &Diagnostics, clock: &WallClock, arm: &str) -> msg::DiagnosticArray {
    let mut status = vec![DiagnosticStatus {
        level: DiagnosticStatus::OK,
        name: format!("jointctl/{arm}/loop"),
        message: format!("cycle {}", d.cycle),
        hardware_id: arm.to_string(),
        values: values(&loop_values(d)),
    }];
    for j in &d.joints {
        let (level, message, fault) = joint_level(j);
        status.push(DiagnosticStatus {
            level,
            name: format!("jointctl/{arm}/joint/{}", decode_name(&j.name)),
            message: fault.map_or_else(|| message.to_string(), |code| format!("fault {code}: {}", decode_name(&j.fault_message))),
            hardware_id: arm.to_string(),
            values: values(&joint_values(j)),
        });
    }
    for x in &d.devices {
        let flags: Vec<&str> = DEVICE_FLAGS.iter().filter(|(bit, _)| x.flags & bit != 0).map(|(_, n)| *n).collect();
        status.push(DiagnosticStatus {
            level: if flags.is_empty() { DiagnosticStatus::OK } else { DiagnosticStatus::ERROR },
            name: format!("jointctl/{arm}/device/{}", decode_name(&x.name)),
            message: if flags.is_empty() { "ok".to_string() } else { flags.join(", ") },
            hardware_id: arm.to_string(),
            values: values(&device_values(x)),
        });
    }
    msg::DiagnosticArray { header: clock.header(d.stamp_ns, arm), status }
}
