//! The arm's samples written straight to their ROS 2 messages' CDR, into a buffer that is kept:
//! the recording profile's path at the loop's rate. [`crate::from_arm`] builds each message
//! (every name, status and counter a `String`) and [`crate::encode`] writes it; at 700 DOFs
//! that was some 40 000 strings per cycle, and the ROS 2 recorder fell behind a 1 kHz arm
//! (docs/benchmarks.md). These write the same bytes (the tests compare them field for field
//! through the message types) without allocating once the buffers have grown.

use jointctl_ipc::raw::{RawDescriptor, RawFrame, RawReading};
use jointctl_ipc::{ArmState, DeviceDiagnostics, Diagnostics, FieldMask, JointDiagnostics, JointSample, decode_name};

use crate::cdr_out::CdrOut;
use crate::from_arm::{DEVICE_FLAGS, WallClock, device_values, joint_level, joint_values, known, loop_values};
use crate::msg::{DiagnosticStatus, Time};

/// Writes the arm's samples as CDR; keeps its scratch text between messages.
///
/// ```
/// let mut s = jointctl_ipc::ArmState::EMPTY;
/// s.joints.push(jointctl_ipc::JointSample::EMPTY);
/// s.joints[0].name = jointctl_ipc::encode_name("q2");
/// let clock = jointctl_ros2::from_arm::WallClock::from_pair(0, 0);
/// let mut out = Vec::new();
/// jointctl_ros2::direct::DirectEncoder::default().joint_state(&s, &clock, "sherpa", &mut out);
/// let m: jointctl_ros2::msg::JointState = jointctl_ros2::decode(&out).unwrap();
/// assert_eq!(m.name, ["q2"]);
/// ```
#[derive(Debug, Default)]
pub struct DirectEncoder {
    number: String,
    text: String,
    /// The statuses written of each joint and device ([`DirectEncoder::diagnostic_changes`]).
    last_joints: Vec<JointDiagnostics>,
    last_devices: Vec<DeviceDiagnostics>,
    /// The arm's time of the last array with every status.
    every_status_at_ns: Option<u64>,
    /// Which joints and devices the array being written holds.
    send_joint: Vec<bool>,
    send_device: Vec<bool>,
}

/// One value of a joint's sample.
type FieldOf = fn(&JointSample) -> f64;

fn header(w: &mut CdrOut<'_>, clock: &WallClock, monotonic_ns: u64, frame: &str) {
    let t = Time::from_unix_ns(clock.unix_ns(monotonic_ns));
    w.i32(t.sec);
    w.u32(t.nanosec);
    w.str(frame);
}

fn reading(w: &mut CdrOut<'_>, name: &str, r: &RawReading) {
    w.str(name);
    w.f64(r.value);
    w.str(r.status.name());
    w.f64(r.age_s);
}

impl DirectEncoder {
    /// `sensor_msgs/msg/JointState` of `s` (as [`crate::from_arm::joint_state`]) into `out`.
    pub fn joint_state(&mut self, s: &ArmState, clock: &WallClock, arm: &str, out: &mut Vec<u8>) {
        let joints = s.joints();
        let mut w = CdrOut::begin(out);
        header(&mut w, clock, s.stamp_ns, arm);
        w.len(joints.len());
        for j in joints {
            w.str(decode_name(&j.name));
        }
        let fields: [(u32, FieldOf); 3] = [(FieldMask::POSITION, |j| j.position_rad), (FieldMask::VELOCITY, |j| j.velocity_rad_s), (FieldMask::TORQUE, |j| j.torque_nm)];
        for (bit, value) in fields {
            w.len(joints.len());
            for j in joints {
                w.f64(known(j, bit, value(j)));
            }
        }
    }

    /// `jointctl_msgs/msg/JointDetails` of `s` (as [`crate::from_arm::joint_details`]).
    pub fn joint_details(&mut self, s: &ArmState, clock: &WallClock, arm: &str, out: &mut Vec<u8>) {
        let mut w = CdrOut::begin(out);
        header(&mut w, clock, s.stamp_ns, arm);
        w.u64(s.cycle);
        w.u64(s.stamp_ns);
        w.bool(s.final_sample != 0);
        w.len(s.joints().len());
        for x in s.joints() {
            w.str(decode_name(&x.name));
            w.f64(known(x, FieldMask::POSITION, x.position_rad));
            w.f64(known(x, FieldMask::VELOCITY, x.velocity_rad_s));
            w.f64(known(x, FieldMask::DEFLECTION, x.deflection_rad));
            w.f64(known(x, FieldMask::TORQUE, x.torque_nm));
            w.f64(known(x, FieldMask::STIFFNESS, x.stiffness_nm_per_rad));
            w.f64(known(x, FieldMask::PIVOT, x.pivot_mm));
            w.f64(x.reference_torque_nm);
            w.f64(x.sensor_torque_nm);
            w.f64(x.gravity_nm);
            w.str(x.mode.name());
            w.bool(x.enabled != 0);
            w.u32(x.fault_code);
        }
    }

    /// `jointctl_msgs/msg/RawFrame` of `f`, its devices named by `d` (as
    /// [`crate::from_arm::raw_frame`]).
    pub fn raw_frame(&mut self, f: &RawFrame, d: &RawDescriptor, clock: &WallClock, arm: &str, out: &mut Vec<u8>) {
        let mut w = CdrOut::begin(out);
        header(&mut w, clock, f.stamp_ns, arm);
        w.u64(f.cycle);
        w.u64(f.stamp_ns);
        w.u64(f.commands_applied);
        w.len(f.encoders().len().min(d.encoders.len()));
        for (r, dev) in f.encoders().iter().zip(&d.encoders) {
            reading(&mut w, decode_name(&dev.name), r);
        }
        w.len(f.drives().len().min(d.drives.len()));
        for (r, dev) in f.drives().iter().zip(&d.drives) {
            w.str(decode_name(&dev.name));
            reading(&mut w, "", &r.position_rad);
            reading(&mut w, "", &r.velocity_rad_s);
            reading(&mut w, "", &r.torque_nm);
            w.bool(r.enabled != 0);
            w.bool(r.fault != 0);
            w.str(r.action.name());
            w.f64(r.setpoint_rad);
            w.f64(r.velocity_ff_rad_s);
        }
        w.len(f.torque_sensors().len().min(d.torque_sensors.len()));
        for (r, dev) in f.torque_sensors().iter().zip(&d.torque_sensors) {
            reading(&mut w, decode_name(&dev.name), r);
        }
    }

    /// `diagnostic_msgs/msg/DiagnosticArray` of `d` (as [`crate::from_arm::diagnostic_array`]):
    /// every status.
    pub fn diagnostic_array(&mut self, d: &Diagnostics, clock: &WallClock, arm: &str, out: &mut Vec<u8>) {
        self.send_joint.clear();
        self.send_joint.resize(d.joints.len(), true);
        self.send_device.clear();
        self.send_device.resize(d.devices.len(), true);
        self.write_diagnostics(d, clock, arm, out);
    }

    /// `diagnostic_msgs/msg/DiagnosticArray` of `d` with the statuses that changed: the loop's
    /// status each time, a joint's or a device's when what its status shows (name, level,
    /// message, counters) differs from what this encoder last wrote of it, and every status
    /// once per [`EVERY_STATUS_PERIOD_NS`] of the arm's time (and whenever the arm's parts
    /// change). ROS 2's diagnostic aggregator and `rqt_runtime_monitor` key statuses by name,
    /// and the counters are totals since the start: carrying each status forward gives every
    /// cycle's full array (the tests check it). A reader that indexes statuses by their place
    /// in the array (`status[3]`) sees other statuses there, and one that starts in the middle
    /// of a file has every status within a second. At 700 DOFs a full array is 0.7 MB; at
    /// 1 kHz that is more than one core writes.
    ///
    /// ```
    /// let mut d = jointctl_ipc::Diagnostics::EMPTY;
    /// d.joints.push(jointctl_ipc::JointDiagnostics::EMPTY);
    /// let clock = jointctl_ros2::from_arm::WallClock::from_pair(0, 0);
    /// let (mut enc, mut out) = (jointctl_ros2::direct::DirectEncoder::default(), Vec::new());
    /// let statuses = |out: &Vec<u8>| jointctl_ros2::decode::<jointctl_ros2::msg::DiagnosticArray>(out).unwrap().status.len();
    /// enc.diagnostic_changes(&d, &clock, "arm", &mut out);
    /// assert_eq!(statuses(&out), 2, "the first: every status");
    /// d.stamp_ns = 1_000_000;
    /// enc.diagnostic_changes(&d, &clock, "arm", &mut out);
    /// assert_eq!(statuses(&out), 1, "nothing changed: the loop's");
    /// d.joints[0].valid_mask ^= 1;
    /// enc.diagnostic_changes(&d, &clock, "arm", &mut out);
    /// assert_eq!(statuses(&out), 1, "what the status does not show is no change");
    /// d.joints[0].fault_count = 1;
    /// enc.diagnostic_changes(&d, &clock, "arm", &mut out);
    /// assert_eq!(statuses(&out), 2, "the joint's changed");
    /// ```
    pub fn diagnostic_changes(&mut self, d: &Diagnostics, clock: &WallClock, arm: &str, out: &mut Vec<u8>) {
        let reshaped = self.last_joints.len() != d.joints.len() || self.last_devices.len() != d.devices.len();
        let full = reshaped || self.every_status_at_ns.is_none_or(|t| d.stamp_ns.saturating_sub(t) >= EVERY_STATUS_PERIOD_NS);
        if full {
            self.every_status_at_ns = Some(d.stamp_ns);
            self.last_joints.clone_from(&d.joints);
            self.last_devices.clone_from(&d.devices);
            return self.diagnostic_array(d, clock, arm, out);
        }
        self.send_joint.clear();
        for (now, last) in d.joints.iter().zip(&mut self.last_joints) {
            self.send_joint.push(joint_status_differs(now, last));
            *last = *now;
        }
        self.send_device.clear();
        for (now, last) in d.devices.iter().zip(&mut self.last_devices) {
            self.send_device.push(device_status_differs(now, last));
            *last = *now;
        }
        self.write_diagnostics(d, clock, arm, out);
    }

    /// The loop's status and those of the joints and devices marked in `send_joint`,
    /// `send_device`.
    fn write_diagnostics(&mut self, d: &Diagnostics, clock: &WallClock, arm: &str, out: &mut Vec<u8>) {
        use std::fmt::Write as _;
        let mut w = CdrOut::begin(out);
        let (number, text) = (&mut self.number, &mut self.text);
        header(&mut w, clock, d.stamp_ns, arm);
        let sent = |marks: &[bool]| marks.iter().filter(|m| **m).count();
        w.len(1 + sent(&self.send_joint) + sent(&self.send_device));
        w.u8(DiagnosticStatus::OK);
        w.str_of(&["jointctl/", arm, "/loop"]);
        text.clear();
        let _ = write!(text, "cycle {}", d.cycle);
        w.str(text);
        w.str(arm);
        values(&mut w, &loop_values(d), number);
        for (j, _) in d.joints.iter().zip(&self.send_joint).filter(|(_, send)| **send) {
            let (level, message, fault) = joint_level(j);
            w.u8(level);
            w.str_of(&["jointctl/", arm, "/joint/", decode_name(&j.name)]);
            match fault {
                None => w.str(message),
                Some(code) => {
                    text.clear();
                    let _ = write!(text, "fault {code}: {}", decode_name(&j.fault_message));
                    w.str(text);
                }
            }
            w.str(arm);
            values(&mut w, &joint_values(j), number);
        }
        for (x, _) in d.devices.iter().zip(&self.send_device).filter(|(_, send)| **send) {
            text.clear();
            for (_, name) in DEVICE_FLAGS.iter().filter(|(bit, _)| x.flags & bit != 0) {
                if !text.is_empty() {
                    text.push_str(", ");
                }
                text.push_str(name);
            }
            w.u8(if text.is_empty() { DiagnosticStatus::OK } else { DiagnosticStatus::ERROR });
            w.str_of(&["jointctl/", arm, "/device/", decode_name(&x.name)]);
            w.str(if text.is_empty() { "ok" } else { text });
            w.str(arm);
            values(&mut w, &device_values(x), number);
        }
    }
}

/// How often [`DirectEncoder::diagnostic_changes`] writes every status [ns of the arm's time]:
/// 1 s, the period of ROS 2's `diagnostic_updater` (assumption: what a ROS 2 user's tools expect
/// of a status that does not change).
pub const EVERY_STATUS_PERIOD_NS: u64 = 1_000_000_000;

/// Whether a joint's status shows something else: its name, level, message or counters (not
/// what the status does not show, such as `valid_mask`, set again every cycle).
fn joint_status_differs(now: &JointDiagnostics, last: &JointDiagnostics) -> bool {
    let shown = |j: &JointDiagnostics| {
        let (level, _, fault) = joint_level(j);
        (j.name, level, fault.map(|_| j.fault_message), joint_values(j))
    };
    shown(now) != shown(last)
}

/// Whether a device's status shows something else: its name, flags or counters.
fn device_status_differs(now: &DeviceDiagnostics, last: &DeviceDiagnostics) -> bool {
    now.name != last.name || device_values(now) != device_values(last)
}

fn values(w: &mut CdrOut<'_>, pairs: &[(&str, u64)], number: &mut String) {
    w.len(pairs.len());
    for (key, value) in pairs {
        w.str(key);
        w.str_u64(*value, number);
    }
}

#[cfg(test)]
mod tests {
    use jointctl_ipc::raw::{RawAction, RawDrive, RawStatus};
    use jointctl_ipc::{JointMode, encode_name};
    use proptest::prelude::*;

    use super::*;
    use crate::{encode, from_arm};

    /// Values as a sample may hold them: ordinary, NaN, infinite, huge.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![-1e3..1e3f64, Just(f64::NAN), Just(f64::INFINITY), Just(-0.0), Just(1e300)]
    }

    /// Names of every length a name field holds, and empty.
    fn name() -> impl Strategy<Value = String> {
        "[a-z0-9_]{0,40}"
    }

    fn state() -> impl Strategy<Value = ArmState> {
        let joint = (name(), prop::array::uniform9(value()), 0u32..64, 0u32..12, any::<bool>(), 0u32..5);
        (prop::collection::vec(joint, 0..12), any::<u64>(), any::<u64>(), any::<bool>()).prop_map(|(joints, cycle, stamp, last)| {
            let mut s = ArmState::EMPTY;
            s.cycle = cycle;
            s.stamp_ns = stamp;
            s.final_sample = u32::from(last);
            for (n, v, mask, mode, enabled, fault) in joints {
                let mut j = JointSample::EMPTY;
                j.name = encode_name(&n);
                [j.position_rad, j.velocity_rad_s, j.deflection_rad, j.torque_nm, j.stiffness_nm_per_rad, j.pivot_mm, j.reference_torque_nm, j.sensor_torque_nm, j.gravity_nm] = v;
                j.valid_mask = mask;
                j.mode = JointMode(mode);
                j.enabled = u32::from(enabled);
                j.fault_code = fault;
                s.joints.push(j);
            }
            s
        })
    }

    fn reading() -> impl Strategy<Value = RawReading> {
        (value(), value(), 0u32..6).prop_map(|(v, age, status)| {
            let mut r = RawReading::MISSING;
            r.value = v;
            r.age_s = age;
            r.status = RawStatus(status);
            r
        })
    }

    fn frame() -> impl Strategy<Value = (RawFrame, RawDescriptor)> {
        let drive = (prop::array::uniform3(reading()), any::<bool>(), any::<bool>(), 0u32..6, value(), value());
        (
            prop::collection::vec((name(), reading()), 0..6),
            prop::collection::vec((name(), drive), 0..6),
            prop::collection::vec((name(), reading()), 0..3),
            0usize..3,
            any::<(u64, u64, u64)>(),
        )
            .prop_map(|(encoders, drives, sensors, described_fewer, (cycle, stamp, applied))| {
                let mut f = RawFrame::EMPTY;
                (f.cycle, f.stamp_ns, f.commands_applied) = (cycle, stamp, applied);
                f.encoders = encoders.iter().map(|(_, r)| *r).collect();
                f.torque_sensors = sensors.iter().map(|(_, r)| *r).collect();
                for (_, ([p, v, t], enabled, fault, action, setpoint, ff)) in &drives {
                    let mut d = RawDrive::EMPTY;
                    (d.position_rad, d.velocity_rad_s, d.torque_nm) = (*p, *v, *t);
                    (d.enabled, d.fault, d.action) = (u32::from(*enabled), u32::from(*fault), RawAction(*action));
                    (d.setpoint_rad, d.velocity_ff_rad_s) = (*setpoint, *ff);
                    f.drives.push(d);
                }
                // A descriptor that names fewer devices than the frame has: both writers stop
                // at the shorter list.
                let enc: Vec<(&str, u32)> = encoders.iter().skip(described_fewer).map(|(n, _)| (n.as_str(), 0)).collect();
                let drv: Vec<(&str, u32)> = drives.iter().map(|(n, _)| (n.as_str(), 1)).collect();
                let ft: Vec<&str> = sensors.iter().map(|(n, _)| n.as_str()).collect();
                (f, RawDescriptor::of(1000.0, &enc, &drv, &ft, None))
            })
    }

    fn diagnostics() -> impl Strategy<Value = Diagnostics> {
        let joint = (name(), name(), prop_oneof![Just(0u32), 1u32..500], any::<bool>(), prop::array::uniform10(any::<u64>()));
        let device = (name(), prop::array::uniform4(any::<u64>()), 0u32..32);
        (prop::collection::vec(joint, 0..8), prop::collection::vec(device, 0..8), prop::array::uniform9(any::<u64>()), any::<u64>()).prop_map(
            |(joints, devices, counters, stamp)| {
                let mut d = Diagnostics::EMPTY;
                d.stamp_ns = stamp;
                [d.cycle, d.period_ns, d.overruns, d.missed_deadlines, d.hal_errors, d.publish_drops, d.last_compute_ns, d.max_compute_ns, d.max_jitter_ns] =
                    counters;
                for (n, message, fault, held, c) in joints {
                    let mut j = JointDiagnostics::EMPTY;
                    (j.name, j.fault_message, j.fault_code, j.held) = (encode_name(&n), encode_name(&message), fault, u32::from(held));
                    [j.invalid_cycles, j.fault_count, j.setpoint_clamps, j.torque_clamps, j.rate_limited, j.watchdog_trips, j.missing_inputs, j.plugin_max_ns, j.over_budget_cycles, j.setpoint_rejections] = c;
                    d.joints.push(j);
                }
                for (n, [missing, invalid, implausible, emcy], flags) in devices {
                    let mut x = DeviceDiagnostics::EMPTY;
                    (x.name, x.missing, x.invalid, x.implausible, x.emcy, x.flags) = (encode_name(&n), missing, invalid, implausible, emcy, flags);
                    d.devices.push(x);
                }
                d
            },
        )
    }

    proptest! {
        /// Every sample written directly is byte for byte the CDR of the message built by
        /// `from_arm` (the reference, whose field order the `.msg` definitions and the interop
        /// tests check), and a buffer reused from a longer message holds nothing of it.
        #[test]
        fn direct_bytes_are_the_messages_cdr(s in state(), (f, desc) in frame(), d in diagnostics(), unix in any::<u64>(), mono in any::<u64>(), arm in "[a-z]{1,12}") {
            let clock = WallClock::from_pair(unix, mono);
            let mut enc = DirectEncoder::default();
            let mut out = vec![0xAA; 4096];
            enc.joint_state(&s, &clock, &arm, &mut out);
            prop_assert_eq!(&out, &encode(&from_arm::joint_state(&s, &clock, &arm)).unwrap());
            enc.joint_details(&s, &clock, &arm, &mut out);
            prop_assert_eq!(&out, &encode(&from_arm::joint_details(&s, &clock, &arm)).unwrap());
            enc.raw_frame(&f, &desc, &clock, &arm, &mut out);
            prop_assert_eq!(&out, &encode(&from_arm::raw_frame(&f, &desc, &clock, &arm)).unwrap());
            enc.diagnostic_array(&d, &clock, &arm, &mut out);
            prop_assert_eq!(&out, &encode(&from_arm::diagnostic_array(&d, &clock, &arm)).unwrap());
            // Through a serde CDR serializer (RustDDS's is this crate's `cdr_encoding`), as the
            // live bridge sends it: the same bytes after the header.
            let passed = cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&crate::Encoded::<crate::msg::DiagnosticArray>::from_cdr(&out).unwrap()).unwrap();
            prop_assert_eq!(&passed[..], &out[4..]);
        }
    }

    proptest! {
        /// A reader that carries each status forward by its name (as ROS 2's diagnostic tools
        /// do) has, after every message of `diagnostic_changes`, the full array of that cycle;
        /// and no message leaves out a status for a second of the arm's time or more.
        #[test]
        fn changed_statuses_carried_forward_are_every_cycles_full_array(
            joints in 0usize..5, devices in 0usize..5,
            steps in prop::collection::vec((0u64..400_000_000, prop::collection::vec((0usize..10, 0usize..4), 0..3)), 1..40),
        ) {
            let clock = WallClock::from_pair(0, 0);
            let mut d = Diagnostics::EMPTY;
            d.joints = (0..joints).map(|i| { let mut j = JointDiagnostics::EMPTY; j.name = encode_name(&format!("j{i}")); j }).collect();
            d.devices = (0..devices).map(|i| { let mut x = DeviceDiagnostics::EMPTY; x.name = encode_name(&format!("d{i}")); x }).collect();
            let (mut enc, mut out) = (DirectEncoder::default(), Vec::new());
            let mut carried: std::collections::BTreeMap<String, crate::msg::DiagnosticStatus> = Default::default();
            let mut written_at: std::collections::BTreeMap<String, u64> = Default::default();
            for (dt, changes) in steps {
                d.stamp_ns += dt;
                d.cycle += 1;
                d.last_compute_ns = dt % 7;
                for (who, what) in changes {
                    if who < joints {
                        let j = &mut d.joints[who];
                        match what { 0 => j.fault_code = 3, 1 => j.held ^= 1, 2 => j.invalid_cycles += 1, _ => j.fault_code = 0 }
                    } else if who - joints < devices {
                        let x = &mut d.devices[who - joints];
                        match what { 0 => x.flags ^= 2, 1 => x.missing += 1, _ => x.emcy += 1 }
                    }
                }
                enc.diagnostic_changes(&d, &clock, "arm", &mut out);
                for st in crate::decode::<crate::msg::DiagnosticArray>(&out).unwrap().status {
                    written_at.insert(st.name.clone(), d.stamp_ns);
                    carried.insert(st.name.clone(), st);
                }
                let full = from_arm::diagnostic_array(&d, &clock, "arm").status;
                for st in &full {
                    prop_assert_eq!(carried.get(&st.name), Some(st), "cycle {}", d.cycle);
                    prop_assert!(d.stamp_ns - written_at[&st.name] < EVERY_STATUS_PERIOD_NS, "{} not written for a second", st.name);
                }
            }
        }
    }
}
