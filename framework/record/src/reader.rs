//! Reading a recording back: one joint's signals from the `joint_state` channel, as columns, for
//! `jointctl fit`, `identify` and `replay`. A value the runtime did not know (`null`) stays NaN:
//! it is never turned into a number here.

use std::path::{Path, PathBuf};

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
    let bytes = std::fs::read(path).map_err(|source| ReadError::File { file: path.into(), source })?;
    let mut out = JointSeries::default();
    let mut first_stamp = None;
    let mut known: Vec<String> = Vec::new();
    let stream = mcap::MessageStream::new(&bytes).map_err(|source| ReadError::Mcap { file: path.into(), source })?;
    for message in stream {
        let m = message.map_err(|source| ReadError::Mcap { file: path.into(), source })?;
        if m.channel.topic != "joint_state" {
            continue;
        }
        let bad = |reason: &str| ReadError::Message { file: path.into(), topic: m.channel.topic.clone(), sequence: m.sequence, reason: reason.into() };
        let v: Value = serde_json::from_slice(&m.data).map_err(|e| bad(&e.to_string()))?;
        let stamp = v["stamp_ns"].as_u64().ok_or_else(|| bad("no `stamp_ns`"))?;
        let joints = v["joints"].as_array().ok_or_else(|| bad("no `joints` array"))?;
        if known.is_empty() {
            known = joints.iter().filter_map(|j| j["name"].as_str().map(str::to_string)).collect();
        }
        // The final sample (the runtime stopping) holds every joint: not part of the experiment.
        if v["final"].as_bool() == Some(true) {
            continue;
        }
        let Some(j) = joints.iter().find(|j| j["name"] == joint) else { continue };
        let t0 = *first_stamp.get_or_insert(stamp);
        out.t_s.push(stamp.saturating_sub(t0) as f64 * 1e-9);
        out.cycle.push(v["cycle"].as_u64().unwrap_or(0));
        out.position_rad.push(number(&j["position_rad"]));
        out.deflection_rad.push(number(&j["deflection_rad"]));
        out.observed_torque_nm.push(number(&j["torque_nm"]));
        out.sensor_torque_nm.push(number(&j["sensor_torque_nm"]));
        out.reference_torque_nm.push(number(&j["reference_torque_nm"]));
        out.pivot_mm.push(number(&j["pivot_mm"]));
        out.stiffness_nm_per_rad.push(number(&j["stiffness_nm_per_rad"]));
        out.mode.push(j["mode"].as_str().unwrap_or("unknown").to_string());
    }
    if out.is_empty() {
        return Err(ReadError::NoJoint { file: path.into(), joint: joint.into(), known });
    }
    Ok(out)
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
