//! Reading a recording back, in either form (the JSON channels or the ROS 2 profile): the raw
//! frames, commands and activation a replay needs, and one joint's signals as columns for
//! `jointctl fit` and `identify`. A value the runtime did not know (`null`, NaN) stays NaN: it is
//! never turned into a number here.
//!
//! `file` walks the file's messages up to a cut a crash left, `decode` reads each message of
//! either form, `measured` makes a joint's measured data.

use std::path::{Path, PathBuf};

use jointctl_api::{DriveReading, Reading};
use jointctl_ipc::CommandRequest;

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
    /// The file is not one to read (a FIFO, a device, a directory, beyond the size limit).
    #[error(transparent)]
    UserFile(#[from] jointctl_files::FileError),
    /// The file could not be read.
    #[error("cannot read {}: {source}", .file.display())]
    File {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: std::io::Error,
    },
    /// Not an MCAP file, or a damaged one.
    #[error("{}: not a readable MCAP file: {source}", .file.display())]
    Mcap {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: mcap::McapError,
    },
    /// A file named as a recording that does not begin as MCAP does: not a recording at all (a
    /// CSV given a `.mcap` name), not one cut short.
    #[error("{}: not an MCAP file: it does not begin with MCAP's magic bytes but with {begins}", .file.display())]
    NotMcap {
        /// The file.
        file: PathBuf,
        /// What it begins with instead.
        begins: String,
    },
    /// A recording cut short before its first chunk of messages was complete (the chunks before it hold the schemas and channels): no message is left to read.
    #[error("{}: the recording was cut short after {bytes} bytes, before its first complete chunk of messages, so no message can be read: {source}", .file.display())]
    CutBeforeData {
        /// The file.
        file: PathBuf,
        /// Its length [bytes].
        bytes: u64,
        /// Where reading stopped.
        source: mcap::McapError,
    },
    /// A message that is not the documented JSON (or, in the ROS 2 profile, CDR of its type).
    #[error("{}: message {sequence} on `{topic}` cannot be read: {reason}", .file.display())]
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

mod before_torque;
mod decode;
mod file;
mod measured;

pub use measured::{Measured, measured};

use decode::{JointStates, RawJson, parse_command, parse_raw};
use file::{for_each_message, is_cut, read_recording, records_before_cut};

/// A whole recording, read in one pass: what a replay needs.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// The `raw` messages, in order.
    pub raw: Vec<RawSample>,
    /// Each DOF's joint states.
    pub joints: std::collections::HashMap<String, JointSeries>,
    /// The DOF names, in the recording's order.
    pub joint_names: Vec<String>,
    /// The accepted commands, in order.
    pub commands: Vec<RecordedCommand>,
    /// The readings the joints were activated with, if recorded.
    pub activation: Option<RawSample>,
}

/// Reads a whole recording (raw frames, joint states, commands, activation).
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let r = jointctl_record::reader::read(std::path::Path::new("r.mcap"))?;
/// println!("{} cycles, {} commands", r.raw.len(), r.commands.len());
/// # Ok(()) }
/// ```
pub fn read(path: &Path) -> Result<Recording, ReadError> {
    let (mut raw, mut states, mut commands) = (Vec::new(), JointStates::default(), Vec::new());
    for_each_message(path, &["raw", "joint_state", "commands"], |topic, encoding, sequence, data| {
        match topic {
            "raw" => raw.push(parse_raw(path, encoding, sequence, data)?),
            "joint_state" => states.add(path, encoding, sequence, data)?,
            _ => commands.push(parse_command(path, encoding, sequence, data)?),
        }
        Ok(())
    })?;
    Ok(Recording { raw, joints: states.series, joint_names: states.names, commands, activation: activation(path)? })
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
    let mut states = JointStates::default();
    for_each_message(path, &["joint_state"], |_, encoding, sequence, data| states.add(path, encoding, sequence, data))?;
    Ok((states.series, states.names))
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
    /// Accepted commands applied up to this cycle (`None` in recordings that do not say).
    pub commands_applied: Option<u64>,
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
    /// Its number among the accepted commands, from 1.
    pub sequence: u64,
    /// When the runtime accepted it [ns] (it was applied at the next cycle).
    pub stamp_ns: u64,
    /// The request, rebuilt from its message.
    pub request: CommandRequest,
}



/// The recording's `raw` messages, in order.
pub fn raw_samples(path: &Path) -> Result<Vec<RawSample>, ReadError> {
    let mut out = Vec::new();
    for_each_message(path, &["raw"], |_, encoding, sequence, data| {
        out.push(parse_raw(path, encoding, sequence, data)?);
        Ok(())
    })?;
    Ok(out)
}

/// The readings the recorded arm's joints were activated with (the `activation` metadata), if
/// the recording has them.
pub fn activation(path: &Path) -> Result<Option<RawSample>, ReadError> {
    let bytes = read_recording(path)?;
    let mcap_error = |source| ReadError::Mcap { file: path.into(), source };
    let metadata: Vec<mcap::records::Metadata> = if is_cut(&bytes) {
        records_before_cut(&bytes).into_iter().filter_map(|r| if let mcap::records::Record::Metadata(m) = r { Some(m) } else { None }).collect()
    } else {
        let Some(summary) = mcap::Summary::read(&bytes).map_err(mcap_error)? else { return Ok(None) };
        summary.metadata_indexes.iter().filter(|i| i.name == "activation").map(|index| mcap::read::metadata(&bytes, index).map_err(mcap_error)).collect::<Result<_, _>>()?
    };
    for m in metadata.iter().filter(|m| m.name == "activation") {
        let Some(text) = m.metadata.get("raw") else { continue };
        let bad = |reason: String| ReadError::Message { file: path.into(), topic: "activation".into(), sequence: 0, reason };
        let v: RawJson = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        return Ok(Some(v.sample()));
    }
    Ok(None)
}

/// The arm description attached to the recording (the first attachment, the file `jointctl
/// run` was given): its name and text.
pub fn config_attachment(path: &Path) -> Result<Option<(String, String)>, ReadError> {
    let bytes = read_recording(path)?;
    let mcap_error = |source| ReadError::Mcap { file: path.into(), source };
    if is_cut(&bytes) {
        return Ok(records_before_cut(&bytes).into_iter().find_map(|r| match r {
            mcap::records::Record::Attachment { header, data, .. } => Some((header.name, String::from_utf8_lossy(&data).into_owned())),
            _ => None,
        }));
    }
    let Some(summary) = mcap::Summary::read(&bytes).map_err(mcap_error)? else { return Ok(None) };
    let Some(index) = summary.attachment_indexes.first() else { return Ok(None) };
    let a = mcap::read::attachment(&bytes, index).map_err(mcap_error)?;
    Ok(Some((a.name, String::from_utf8_lossy(&a.data).into_owned())))
}

/// The recording's accepted commands, in order, rebuilt as requests.
pub fn commands(path: &Path) -> Result<Vec<RecordedCommand>, ReadError> {
    let mut out = Vec::new();
    for_each_message(path, &["commands"], |_, encoding, sequence, data| {
        out.push(parse_command(path, encoding, sequence, data)?);
        Ok(())
    })?;
    Ok(out)
}
