//! Each message of a recording, in either form (the JSON of the default profile, the CDR of the
//! ROS 2 profile), into what the readers return: a value the runtime did not know stays NaN.

use std::path::Path;

use jointctl_api::{DriveReading, Reading};
use jointctl_ipc::{CommandKind, CommandRequest, MAX_COMMAND_POINTS, TorqueWaveform, encode_name};
use serde_json::Value;

use super::file::Encoding;
use super::{JointSeries, RawSample, ReadError, RecordedCommand, before_torque};

fn number(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

// The per-cycle messages, typed: reading tens of thousands of them through `serde_json::Value`
// maps made a replay four times slower than real time.

#[derive(serde::Deserialize)]
struct ReadingJson<'a> {
    #[serde(default, borrow)]
    name: &'a str,
    value: Option<f64>,
    #[serde(borrow)]
    status: &'a str,
    age_s: Option<f64>,
}

#[derive(serde::Deserialize)]
struct DriveJson<'a> {
    #[serde(borrow)]
    name: &'a str,
    #[serde(borrow)]
    position_rad: ReadingJson<'a>,
    #[serde(borrow)]
    velocity_rad_s: ReadingJson<'a>,
    /// Absent in recordings made before drives reported their torque.
    #[serde(borrow, default)]
    torque_nm: Option<ReadingJson<'a>>,
    enabled: bool,
    fault: bool,
    setpoint_rad: Option<f64>,
}

#[derive(serde::Deserialize)]
pub(super) struct RawJson<'a> {
    cycle: u64,
    stamp_ns: u64,
    #[serde(default)]
    commands_applied: Option<u64>,
    #[serde(borrow)]
    encoders: Vec<ReadingJson<'a>>,
    #[serde(borrow)]
    drives: Vec<DriveJson<'a>>,
    #[serde(default, borrow)]
    torque_sensors: Vec<ReadingJson<'a>>,
}

#[derive(serde::Deserialize)]
struct JointJson<'a> {
    #[serde(borrow)]
    name: &'a str,
    position_rad: Option<f64>,
    deflection_rad: Option<f64>,
    torque_nm: Option<f64>,
    #[serde(default)]
    sensor_torque_nm: Option<f64>,
    reference_torque_nm: Option<f64>,
    pivot_mm: Option<f64>,
    stiffness_nm_per_rad: Option<f64>,
    #[serde(borrow)]
    mode: &'a str,
}

#[derive(serde::Deserialize)]
struct StateJson<'a> {
    cycle: u64,
    stamp_ns: u64,
    #[serde(default, rename = "final")]
    final_sample: bool,
    #[serde(borrow)]
    joints: Vec<JointJson<'a>>,
}

impl ReadingJson<'_> {
    fn reading(&self) -> Reading {
        let value = self.value.unwrap_or(f64::NAN);
        let age_s = self.age_s.unwrap_or(f64::INFINITY);
        match self.status {
            "valid" if value.is_finite() => Reading::valid_aged(value, age_s),
            "stale" if value.is_finite() => Reading::stale(value, age_s),
            "invalid" => Reading::invalid(),
            _ => Reading::MISSING,
        }
    }
}

impl RawJson<'_> {
    pub(super) fn sample(&self) -> RawSample {
        RawSample {
            cycle: self.cycle,
            stamp_ns: self.stamp_ns,
            commands_applied: self.commands_applied,
            encoders: self.encoders.iter().map(|e| (e.name.to_string(), e.reading())).collect(),
            drives: self
                .drives
                .iter()
                .map(|d| {
                    let reading = DriveReading::new(d.position_rad.reading(), d.velocity_rad_s.reading(), d.enabled, d.fault);
                    (d.name.to_string(), reading.with_torque(d.torque_nm.as_ref().map_or(Reading::MISSING, ReadingJson::reading)), d.setpoint_rad.unwrap_or(f64::NAN))
                })
                .collect(),
            torque_sensors: self.torque_sensors.iter().map(|e| (e.name.to_string(), e.reading())).collect(),
        }
    }
}

/// A number the JSON form would write as a number (it writes every other as `null`): the two
/// forms read the same.
fn finite(x: f64) -> Option<f64> {
    Some(x).filter(|x| x.is_finite())
}

/// A ROS 2 profile message as its type, or the error that names file, topic and message.
pub(super) fn decode_cdr<M: jointctl_ros2::msg::Message>(path: &Path, topic: &str, sequence: u32, data: &[u8]) -> Result<M, ReadError> {
    jointctl_ros2::decode(data).map_err(|e| ReadError::Message { file: path.into(), topic: topic.into(), sequence, reason: e.to_string() })
}

/// The joint states, DOF by DOF, as they are read.
#[derive(Default)]
pub(super) struct JointStates {
    pub(super) series: std::collections::HashMap<String, JointSeries>,
    first_stamp: Option<u64>,
    pub(super) names: Vec<String>,
}

impl JointStates {
    pub(super) fn add(&mut self, path: &Path, encoding: Encoding, sequence: u32, data: &[u8]) -> Result<(), ReadError> {
        match encoding {
            Encoding::Json => {
                let v: StateJson = serde_json::from_slice(data).map_err(|e| ReadError::Message { file: path.into(), topic: "joint_state".into(), sequence, reason: e.to_string() })?;
                self.add_state(&v);
            }
            Encoding::Cdr | Encoding::CdrRawBeforeTorque => {
                let m: jointctl_ros2::msg::JointDetails = decode_cdr(path, jointctl_ros2::JOINT_DETAILS, sequence, data)?;
                let joints = m
                    .joints
                    .iter()
                    .map(|j| JointJson {
                        name: &j.name,
                        position_rad: finite(j.position_rad),
                        deflection_rad: finite(j.deflection_rad),
                        torque_nm: finite(j.torque_nm),
                        sensor_torque_nm: finite(j.sensor_torque_nm),
                        reference_torque_nm: finite(j.reference_torque_nm),
                        pivot_mm: finite(j.pivot_mm),
                        stiffness_nm_per_rad: finite(j.stiffness_nm_per_rad),
                        mode: &j.mode,
                    })
                    .collect();
                self.add_state(&StateJson { cycle: m.cycle, stamp_ns: m.stamp_ns, final_sample: m.final_sample, joints });
            }
        }
        Ok(())
    }

    fn add_state(&mut self, v: &StateJson<'_>) {
        if self.names.is_empty() {
            self.names = v.joints.iter().map(|j| j.name.to_string()).collect();
        }
        // The final sample (the runtime stopping) holds every joint: not part of the experiment.
        if v.final_sample {
            return;
        }
        let t0 = *self.first_stamp.get_or_insert(v.stamp_ns);
        for j in &v.joints {
            let s = match self.series.get_mut(j.name) {
                Some(s) => s,
                None => self.series.entry(j.name.to_string()).or_default(),
            };
            let nan = |x: Option<f64>| x.unwrap_or(f64::NAN);
            s.t_s.push(v.stamp_ns.saturating_sub(t0) as f64 * 1e-9);
            s.cycle.push(v.cycle);
            s.position_rad.push(nan(j.position_rad));
            s.deflection_rad.push(nan(j.deflection_rad));
            s.observed_torque_nm.push(nan(j.torque_nm));
            s.sensor_torque_nm.push(nan(j.sensor_torque_nm));
            s.reference_torque_nm.push(nan(j.reference_torque_nm));
            s.pivot_mm.push(nan(j.pivot_mm));
            s.stiffness_nm_per_rad.push(nan(j.stiffness_nm_per_rad));
            s.mode.push(j.mode.to_string());
        }
    }
}

/// A CDR raw reading as the HAL's reading (its NaN and infinite numbers: none).
fn reading_of(x: &jointctl_ros2::msg::RawReading) -> Reading {
    ReadingJson { name: &x.name, value: finite(x.value), status: &x.status, age_s: finite(x.age_s) }.reading()
}

pub(super) fn parse_raw(path: &Path, encoding: Encoding, sequence: u32, data: &[u8]) -> Result<RawSample, ReadError> {
    if encoding == Encoding::Cdr || encoding == Encoding::CdrRawBeforeTorque {
        let m: jointctl_ros2::msg::RawFrame = if encoding == Encoding::Cdr {
            decode_cdr(path, jointctl_ros2::RAW, sequence, data)?
        } else {
            before_torque::decode(data).map_err(|e| ReadError::Message { file: path.into(), topic: jointctl_ros2::RAW.into(), sequence, reason: e.to_string() })?
        };
        let r = reading_of;
        return Ok(RawSample {
            cycle: m.cycle,
            stamp_ns: m.stamp_ns,
            commands_applied: Some(m.commands_applied),
            encoders: m.encoders.iter().map(|e| (e.name.clone(), r(e))).collect(),
            drives: m.drives.iter().map(|d| (d.name.clone(), DriveReading::new(r(&d.position_rad), r(&d.velocity_rad_s), d.enabled, d.fault).with_torque(r(&d.torque_nm)), finite(d.setpoint_rad).unwrap_or(f64::NAN))).collect(),
            torque_sensors: m.torque_sensors.iter().map(|e| (e.name.clone(), r(e))).collect(),
        });
    }
    let v: RawJson = serde_json::from_slice(data).map_err(|e| ReadError::Message { file: path.into(), topic: "raw".into(), sequence, reason: e.to_string() })?;
    Ok(v.sample())
}

pub(super) fn parse_command(path: &Path, encoding: Encoding, sequence: u32, data: &[u8]) -> Result<RecordedCommand, ReadError> {
    let bad = |reason: String| ReadError::Message { file: path.into(), topic: "commands".into(), sequence, reason };
    let m = match encoding {
        Encoding::Cdr | Encoding::CdrRawBeforeTorque => decode_cdr::<jointctl_ros2::msg::CommandRecord>(path, jointctl_ros2::COMMANDS, sequence, data)?,
        Encoding::Json => {
            // The JSON form read into the ROS 2 message's fields: one way to build the request.
            let v: Value = serde_json::from_slice(data).map_err(|e| bad(e.to_string()))?;
            let points = v["points"].as_array().cloned().unwrap_or_default();
            jointctl_ros2::msg::CommandRecord {
                sequence: v["sequence"].as_u64().ok_or_else(|| bad("no `sequence`".into()))?,
                stamp_ns: v["stamp_ns"].as_u64().ok_or_else(|| bad("no `stamp_ns`".into()))?,
                kind: v["kind"].as_str().unwrap_or_default().to_string(),
                joint: v["joint"].as_str().unwrap_or("").to_string(),
                streamed: v["streamed"] == true,
                waveform: v["waveform"].as_str().unwrap_or_default().to_string(),
                values: v["values"].as_array().map_or_else(Vec::new, |a| a.iter().map(number).collect()),
                points: points.iter().map(|p| jointctl_ros2::msg::CommandPoint { t_s: number(&p[0]), position_rad: number(&p[1]), velocity_rad_s: number(&p[2]) }).collect(),
                ..Default::default()
            }
        }
    };
    let kind = CommandKind::from_name(&m.kind).ok_or_else(|| bad(format!("unknown kind `{}`", m.kind)))?;
    if m.points.len() > MAX_COMMAND_POINTS {
        return Err(bad(format!("{} trajectory points, at most {MAX_COMMAND_POINTS}", m.points.len())));
    }
    let mut request = CommandRequest::new(kind, &m.joint, &m.values);
    request.joint = encode_name(&m.joint);
    request.streamed = u32::from(m.streamed);
    request.waveform = TorqueWaveform::from_name(&m.waveform).unwrap_or(TorqueWaveform::STEP);
    for (slot, p) in request.points.iter_mut().zip(&m.points) {
        *slot = [p.t_s, p.position_rad, p.velocity_rad_s];
    }
    request.point_count = m.points.len() as u32;
    Ok(RecordedCommand { sequence: m.sequence, stamp_ns: m.stamp_ns, request })
}

#[cfg(test)]
mod tests {
    use jointctl_api::ReadingStatus;

    use super::*;

    fn drive_of(json: &str) -> DriveReading {
        parse_raw(Path::new("t.mcap"), Encoding::Json, 1, json.as_bytes()).unwrap().drives[0].1
    }

    /// A JSON raw frame with the drive's torque reading reads it; one written before drives
    /// reported their torque reads it as missing, the rest as recorded.
    #[test]
    fn a_drives_torque_reading_is_read_and_its_absence_is_missing() {
        let drive = |torque: &str| {
            format!(
                r#"{{"cycle": 3, "stamp_ns": 75000000, "encoders": [], "torque_sensors": [], "drives": [{{"name": "m",
                "position_rad": {{"value": 0.5, "status": "valid", "age_s": 0.02}}, "velocity_rad_s": {{"value": null, "status": "missing", "age_s": null}},
                {torque} "enabled": true, "fault": false, "setpoint_rad": 0.6}}]}}"#
            )
        };
        let now = drive_of(&drive(r#""torque_nm": {"value": -12.5, "status": "stale", "age_s": 0.05},"#));
        assert_eq!((now.torque_nm.status, now.torque_nm.value, now.torque_nm.age_s), (ReadingStatus::STALE, -12.5, 0.05));
        let before = drive_of(&drive(""));
        assert_eq!(before.torque_nm.status, ReadingStatus::MISSING);
        assert_eq!(before.position_rad.usable(1.0), Some(0.5));
    }
}
