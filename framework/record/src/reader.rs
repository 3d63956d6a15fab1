//! Reading a recording back: one joint's signals from the `joint_state` channel, as columns, for
//! `jointctl fit`, `identify` and `replay`. A value the runtime did not know (`null`) stays NaN:
//! it is never turned into a number here.

use std::path::{Path, PathBuf};

use jointctl_api::{DriveReading, Reading, ReadingStatus};
use jointctl_ipc::{CommandKind, CommandRequest, MAX_COMMAND_POINTS, TorqueWaveform, encode_name};
use serde_json::Value;

/// One DOF's signals over a recording, one entry per `joint_state` message (SI units; NaN where
/// unknown).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointSeries {
    /// Time since the first joint-state message [s] (from the cycle stamps).
    pub t_s: Vec<f64>,
    /// Cycle counter.
    pub cycle: Vec<u64>,
    /// Joint position [rad].
    pub position_rad: Vec<f64>,
    /// Observed deflection [rad].
    pub deflection_rad: Vec<f64>,
    /// Observed torque [Nm] (the observer's).
    pub observed_torque_nm: Vec<f64>,
    /// The F/T sensor's torque [Nm] (the joint's `torque_sensor`).
    pub sensor_torque_nm: Vec<f64>,
    /// Torque reference in use [Nm].
    pub reference_torque_nm: Vec<f64>,
    /// Pivot setting [mm].
    pub pivot_mm: Vec<f64>,
    /// Stiffness [Nm/rad].
    pub stiffness_nm_per_rad: Vec<f64>,
    /// Control mode.
    pub mode: Vec<String>,
}

impl JointSeries {
    /// Samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
}

/// Why a recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read.
    #[error("cannot read {}", .file.display())]
    File {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: std::io::Error,
    },
    /// Not an MCAP file, or a damaged one.
    #[error("{}: not a readable MCAP file", .file.display())]
    Mcap {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: mcap::McapError,
    },
    /// A message that is not the documented JSON.
    #[error("{}: message {sequence} on `{topic}` is not the documented JSON: {reason}", .file.display())]
    Message {
        /// The file.
        file: PathBuf,
        /// Channel.
        topic: String,
        /// The message's sequence number.
        sequence: u32,
        /// What is wrong.
        reason: String,
    },
    /// The joint is not in the recording.
    #[error("{}: no joint `{joint}` in the recording (joints: {})", .file.display(), .known.join(", "))]
    NoJoint {
        /// The file.
        file: PathBuf,
        /// The joint asked for.
        joint: String,
        /// The joints the recording has.
        known: Vec<String>,
    },
}

fn number(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// The signals of DOF `joint` in the recording `path`.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let q2 = jointctl_record::reader::joint_series(std::path::Path::new("r.mcap"), "q2")?;
/// assert_eq!(q2.t_s.len(), q2.sensor_torque_nm.len());
/// # Ok(()) }
/// ```
pub fn joint_series(path: &Path, joint: &str) -> Result<JointSeries, ReadError> {
    let (mut all, known) = all_joint_series(path)?;
    all.remove(joint).ok_or_else(|| ReadError::NoJoint { file: path.into(), joint: joint.into(), known })
}

/// Every DOF's signals in one pass over the file, and the DOF names in the recording's order.
pub fn all_joint_series(path: &Path) -> Result<(std::collections::HashMap<String, JointSeries>, Vec<String>), ReadError> {
    let mut out: std::collections::HashMap<String, JointSeries> = std::collections::HashMap::new();
    let mut first_stamp = None;
    let mut known: Vec<String> = Vec::new();
    for (sequence, v) in messages(path, "joint_state")? {
        let bad = |reason: &str| ReadError::Message { file: path.into(), topic: "joint_state".into(), sequence, reason: reason.into() };
        let stamp = v["stamp_ns"].as_u64().ok_or_else(|| bad("no `stamp_ns`"))?;
        let joints = v["joints"].as_array().ok_or_else(|| bad("no `joints` array"))?;
        if known.is_empty() {
            known = joints.iter().filter_map(|j| j["name"].as_str().map(str::to_string)).collect();
        }
        // The final sample (the runtime stopping) holds every joint: not part of the experiment.
        if v["final"].as_bool() == Some(true) {
            continue;
        }
        let t0 = *first_stamp.get_or_insert(stamp);
        let cycle = v["cycle"].as_u64().unwrap_or(0);
        for j in joints {
            let Some(name) = j["name"].as_str() else { continue };
            let s = out.entry(name.to_string()).or_default();
            s.t_s.push(stamp.saturating_sub(t0) as f64 * 1e-9);
            s.cycle.push(cycle);
            s.position_rad.push(number(&j["position_rad"]));
            s.deflection_rad.push(number(&j["deflection_rad"]));
            s.observed_torque_nm.push(number(&j["torque_nm"]));
            s.sensor_torque_nm.push(number(&j["sensor_torque_nm"]));
            s.reference_torque_nm.push(number(&j["reference_torque_nm"]));
            s.pivot_mm.push(number(&j["pivot_mm"]));
            s.stiffness_nm_per_rad.push(number(&j["stiffness_nm_per_rad"]));
            s.mode.push(j["mode"].as_str().unwrap_or("unknown").to_string());
        }
    }
    Ok((out, known))
}

/// Whether `path` names an MCAP file (by its extension).
///
/// ```
/// assert!(jointctl_record::reader::is_mcap(std::path::Path::new("r.MCAP")));
/// assert!(!jointctl_record::reader::is_mcap(std::path::Path::new("r.csv")));
/// ```
pub fn is_mcap(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// One recorded `raw` message: every device's reading by name, and the set-points sent.
#[derive(Clone, Debug, PartialEq)]
pub struct RawSample {
    /// Cycle counter.
    pub cycle: u64,
    /// The cycle's stamp [ns].
    pub stamp_ns: u64,
    /// Encoders: name, reading [rad].
    pub encoders: Vec<(String, Reading)>,
    /// Drives: name, reading, set-point sent [rad] (NaN when holding).
    pub drives: Vec<(String, DriveReading, f64)>,
    /// Force/torque sensors: name, reading [Nm].
    pub torque_sensors: Vec<(String, Reading)>,
}

/// A recorded accepted command.
#[derive(Clone, Copy, Debug)]
pub struct RecordedCommand {
    /// When the runtime accepted it [ns] (it was applied at the next cycle).
    pub stamp_ns: u64,
    /// The request, rebuilt from its JSON.
    pub request: CommandRequest,
}

fn reading(v: &Value) -> Reading {
    let status = match v["status"].as_str() {
        Some("valid") => ReadingStatus::VALID,
        Some("stale") => ReadingStatus::STALE,
        Some("invalid") => ReadingStatus::INVALID,
        _ => ReadingStatus::MISSING,
    };
    let value = number(&v["value"]);
    let age_s = v["age_s"].as_f64().unwrap_or(f64::INFINITY);
    match status {
        ReadingStatus::VALID if value.is_finite() => Reading::valid_aged(value, age_s),
        ReadingStatus::STALE if value.is_finite() => Reading::stale(value, age_s),
        ReadingStatus::INVALID => Reading::invalid(),
        _ => Reading::MISSING,
    }
}

fn named(list: &Value) -> Vec<(String, Reading)> {
    list.as_array().map_or_else(Vec::new, |a| a.iter().map(|e| (e["name"].as_str().unwrap_or("").to_string(), reading(e))).collect())
}

/// Every message of `topic`, decoded: (sequence, JSON).
fn messages(path: &Path, topic: &str) -> Result<Vec<(u32, Value)>, ReadError> {
    let bytes = std::fs::read(path).map_err(|source| ReadError::File { file: path.into(), source })?;
    let mut out = Vec::new();
    let stream = mcap::MessageStream::new(&bytes).map_err(|source| ReadError::Mcap { file: path.into(), source })?;
    for message in stream {
        let m = message.map_err(|source| ReadError::Mcap { file: path.into(), source })?;
        if m.channel.topic != topic {
            continue;
        }
        let v: Value = serde_json::from_slice(&m.data)
            .map_err(|e| ReadError::Message { file: path.into(), topic: topic.into(), sequence: m.sequence, reason: e.to_string() })?;
        out.push((m.sequence, v));
    }
    Ok(out)
}

fn raw_sample(v: &Value) -> Result<RawSample, &'static str> {
    let drives = v["drives"]
        .as_array()
        .ok_or("no `drives` array")?
        .iter()
        .map(|d| {
            let r = DriveReading::new(reading(&d["position_rad"]), reading(&d["velocity_rad_s"]), d["enabled"] == true, d["fault"] == true);
            (d["name"].as_str().unwrap_or("").to_string(), r, number(&d["setpoint_rad"]))
        })
        .collect();
    Ok(RawSample {
        cycle: v["cycle"].as_u64().ok_or("no `cycle`")?,
        stamp_ns: v["stamp_ns"].as_u64().ok_or("no `stamp_ns`")?,
        encoders: named(&v["encoders"]),
        drives,
        torque_sensors: named(&v["torque_sensors"]),
    })
}

/// The recording's `raw` messages, in order.
pub fn raw_samples(path: &Path) -> Result<Vec<RawSample>, ReadError> {
    messages(path, "raw")?
        .into_iter()
        .map(|(sequence, v)| raw_sample(&v).map_err(|reason| ReadError::Message { file: path.into(), topic: "raw".into(), sequence, reason: reason.into() }))
        .collect()
}

/// The readings the recorded arm's joints were activated with (the `activation` metadata), if
/// the recording has them.
pub fn activation(path: &Path) -> Result<Option<RawSample>, ReadError> {
    let bytes = std::fs::read(path).map_err(|source| ReadError::File { file: path.into(), source })?;
    let mcap_error = |source| ReadError::Mcap { file: path.into(), source };
    let Some(summary) = mcap::Summary::read(&bytes).map_err(mcap_error)? else { return Ok(None) };
    for index in summary.metadata_indexes.iter().filter(|i| i.name == "activation") {
        let m = mcap::read::metadata(&bytes, index).map_err(mcap_error)?;
        let Some(text) = m.metadata.get("raw") else { continue };
        let bad = |reason: String| ReadError::Message { file: path.into(), topic: "activation".into(), sequence: 0, reason };
        let v: Value = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        return raw_sample(&v).map(Some).map_err(|r| bad(r.into()));
    }
    Ok(None)
}

/// The recording's accepted commands, in order, rebuilt as requests.
pub fn commands(path: &Path) -> Result<Vec<RecordedCommand>, ReadError> {
    messages(path, "commands")?
        .into_iter()
        .map(|(sequence, v)| {
            let bad = |reason: String| ReadError::Message { file: path.into(), topic: "commands".into(), sequence, reason };
            let kind = v["kind"].as_str().and_then(CommandKind::from_name).ok_or_else(|| bad(format!("unknown kind {}", v["kind"])))?;
            let values: Vec<f64> = v["values"].as_array().map_or_else(Vec::new, |a| a.iter().map(number).collect());
            let mut request = CommandRequest::new(kind, v["joint"].as_str().unwrap_or(""), &values);
            request.joint = encode_name(v["joint"].as_str().unwrap_or(""));
            request.streamed = u32::from(v["streamed"] == true);
            request.waveform = v["waveform"].as_str().and_then(TorqueWaveform::from_name).unwrap_or(TorqueWaveform::STEP);
            let points = v["points"].as_array().cloned().unwrap_or_default();
            if points.len() > MAX_COMMAND_POINTS {
                return Err(bad(format!("{} trajectory points, at most {MAX_COMMAND_POINTS}", points.len())));
            }
            for (slot, p) in request.points.iter_mut().zip(&points) {
                *slot = [number(&p[0]), number(&p[1]), number(&p[2])];
            }
            request.point_count = points.len() as u32;
            Ok(RecordedCommand { stamp_ns: v["stamp_ns"].as_u64().ok_or_else(|| bad("no `stamp_ns`".into()))?, request })
        })
        .collect()
}
