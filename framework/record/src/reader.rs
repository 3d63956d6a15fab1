//! Reading a recording back: one joint's signals from the `joint_state` channel, as columns, for
//! `jointctl fit`, `identify` and `replay`. A value the runtime did not know (`null`) stays NaN:
//! it is never turned into a number here.

use std::path::{Path, PathBuf};

use jointctl_api::{DriveReading, Reading};
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
    /// A recording cut short before its first chunk was complete: no message is left to read.
    #[error("{}: the recording was cut short after {bytes} bytes, before its first complete chunk: no message can be read ({source})", .file.display())]
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
    enabled: bool,
    fault: bool,
    setpoint_rad: Option<f64>,
}

#[derive(serde::Deserialize)]
struct RawJson<'a> {
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
    fn sample(&self) -> RawSample {
        RawSample {
            cycle: self.cycle,
            stamp_ns: self.stamp_ns,
            commands_applied: self.commands_applied,
            encoders: self.encoders.iter().map(|e| (e.name.to_string(), e.reading())).collect(),
            drives: self
                .drives
                .iter()
                .map(|d| (d.name.to_string(), DriveReading::new(d.position_rad.reading(), d.velocity_rad_s.reading(), d.enabled, d.fault), d.setpoint_rad.unwrap_or(f64::NAN)))
                .collect(),
            torque_sensors: self.torque_sensors.iter().map(|e| (e.name.to_string(), e.reading())).collect(),
        }
    }
}

/// How a message is written: the JSON form, or the ROS 2 profile's CDR.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Json,
    Cdr,
}

/// The arm's channel a file's channel holds: itself in the JSON form; in the ROS 2 profile the
/// jointctl topic made from it (`/joint_states` is a subset of `/jointctl/joint_details`, and
/// not read).
fn source_of(topic: &str, message_encoding: &str) -> Option<(&'static str, Encoding)> {
    if message_encoding == "cdr" {
        return match topic {
            jointctl_ros2::JOINT_DETAILS => Some(("joint_state", Encoding::Cdr)),
            jointctl_ros2::RAW => Some(("raw", Encoding::Cdr)),
            jointctl_ros2::COMMANDS => Some(("commands", Encoding::Cdr)),
            jointctl_ros2::DIAGNOSTICS => Some(("diagnostics", Encoding::Cdr)),
            _ => None,
        };
    }
    crate::messages::CHANNELS.iter().find(|(t, _)| *t == topic).map(|(t, _)| (*t, Encoding::Json))
}

/// Calls `each(channel, encoding, sequence, data)` for every message of one of the arm's
/// channels `topics`, in file order (the file is read and decompressed once), whichever form
/// the file has.
fn for_each_message(path: &Path, topics: &[&str], mut each: impl FnMut(&str, Encoding, u32, &[u8]) -> Result<(), ReadError>) -> Result<(), ReadError> {
    let bytes = jointctl_files::read(path, jointctl_files::FileKind::Recording)?;
    let mcap_error = |source| ReadError::Mcap { file: path.into(), source };
    // A file without its end (the recorder killed, the machine off, the disk full) is read up to
    // its last complete chunk.
    let stream = mcap::MessageStream::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into()).map_err(mcap_error)?;
    let mut read = 0u64;
    for message in stream {
        match message {
            Ok(m) => {
                read += 1;
                if let Some((source, encoding)) = source_of(&m.channel.topic, &m.channel.message_encoding)
                    && topics.contains(&source)
                {
                    each(source, encoding, m.sequence, &m.data)?;
                }
            }
            Err(source) if is_cut(&bytes) && read > 0 => {
                warn_cut(path, read, &source);
                break;
            }
            Err(source) if is_cut(&bytes) => return Err(ReadError::CutBeforeData { file: path.into(), bytes: bytes.len() as u64, source }),
            Err(source) => return Err(mcap_error(source)),
        }
    }
    Ok(())
}

/// A number the JSON form would write as a number (it writes every other as `null`): the two
/// forms read the same.
fn finite(x: f64) -> Option<f64> {
    Some(x).filter(|x| x.is_finite())
}

/// A ROS 2 profile message as its type, or the error that names file, topic and message.
fn decode_cdr<M: jointctl_ros2::msg::Message>(path: &Path, topic: &str, sequence: u32, data: &[u8]) -> Result<M, ReadError> {
    jointctl_ros2::decode(data).map_err(|e| ReadError::Message { file: path.into(), topic: topic.into(), sequence, reason: e.to_string() })
}

/// A file that does not end with MCAP's closing magic was cut short while it was written.
fn is_cut(bytes: &[u8]) -> bool {
    bytes.len() < 2 * mcap::MAGIC.len() || !bytes.ends_with(mcap::MAGIC)
}

/// Says once per file that a recording was cut short and what is read of it.
fn warn_cut(path: &Path, messages: u64, source: &mcap::McapError) {
    static WARNED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
    let mut warned = WARNED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if !warned.iter().any(|p| p == path) {
        warned.push(path.to_path_buf());
        tracing::warn!(
            "{}: the recording was cut short (its writer was killed, the machine stopped or the disk filled: {source}); \
             reading the {messages} messages of its complete chunks, the rest is lost",
            path.display()
        );
    }
}

/// The top-level records of a file that was cut short, up to the cut (its summary, at the end, is
/// not there to index them).
fn records_before_cut(bytes: &[u8]) -> Vec<mcap::records::Record<'_>> {
    match mcap::read::LinearReader::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into()) {
        Ok(reader) => reader.map_while(Result::ok).collect(),
        Err(_) => Vec::new(),
    }
}

/// The joint states, DOF by DOF, as they are read.
#[derive(Default)]
struct JointStates {
    series: std::collections::HashMap<String, JointSeries>,
    first_stamp: Option<u64>,
    names: Vec<String>,
}

impl JointStates {
    fn add(&mut self, path: &Path, encoding: Encoding, sequence: u32, data: &[u8]) -> Result<(), ReadError> {
        match encoding {
            Encoding::Json => {
                let v: StateJson = serde_json::from_slice(data).map_err(|e| ReadError::Message { file: path.into(), topic: "joint_state".into(), sequence, reason: e.to_string() })?;
                self.add_state(&v);
            }
            Encoding::Cdr => {
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

fn parse_raw(path: &Path, encoding: Encoding, sequence: u32, data: &[u8]) -> Result<RawSample, ReadError> {
    if encoding == Encoding::Cdr {
        let m: jointctl_ros2::msg::RawFrame = decode_cdr(path, jointctl_ros2::RAW, sequence, data)?;
        let r = |x: &jointctl_ros2::msg::RawReading| ReadingJson { name: &x.name, value: finite(x.value), status: &x.status, age_s: finite(x.age_s) }.reading();
        return Ok(RawSample {
            cycle: m.cycle,
            stamp_ns: m.stamp_ns,
            commands_applied: Some(m.commands_applied),
            encoders: m.encoders.iter().map(|e| (e.name.clone(), r(e))).collect(),
            drives: m.drives.iter().map(|d| (d.name.clone(), DriveReading::new(r(&d.position_rad), r(&d.velocity_rad_s), d.enabled, d.fault), finite(d.setpoint_rad).unwrap_or(f64::NAN))).collect(),
            torque_sensors: m.torque_sensors.iter().map(|e| (e.name.clone(), r(e))).collect(),
        });
    }
    let v: RawJson = serde_json::from_slice(data).map_err(|e| ReadError::Message { file: path.into(), topic: "raw".into(), sequence, reason: e.to_string() })?;
    Ok(v.sample())
}

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
    let bytes = jointctl_files::read(path, jointctl_files::FileKind::Recording)?;
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

/// One joint's measured data from a recording, as `fit` and `identify` take it: its observed
/// deflection against its F/T sensor's torque, only where both are known.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Measured {
    /// Time [s] from the cycle stamps.
    pub t_s: Vec<f64>,
    /// Observed deflection [rad].
    pub deflection_rad: Vec<f64>,
    /// The F/T sensor's torque [Nm].
    pub torque_nm: Vec<f64>,
    /// Pivot setting [mm] to 0.1 mm (a VSA), else empty.
    pub pivot_mm: Vec<f64>,
    /// Torque reference [Nm] (NaN outside torque modes), empty when never set.
    pub reference_torque_nm: Vec<f64>,
    /// The position of a 1-DOF joint's `motor` drive [rad] (its wiring from the attached arm
    /// description), empty when it has none.
    pub motor_position_rad: Vec<f64>,
    /// For a 2-DOF joint (the wrist, asked by its joint name): the direction of each sample's
    /// deflection [deg] (0 = the second DOF only, 90 = the first), the nearest of section
    /// 3.5.2's four (0, 45, 90, 135); deflection and torque are then along it. Else empty.
    pub angle_deg: Vec<f64>,
    /// Samples of the joint left out: deflection or F/T torque unknown.
    pub left_out: usize,
    /// Samples of the joint in the recording.
    pub samples: usize,
    /// Samples with a usable F/T torque (0: the joint has no `torque_sensor`).
    pub ft_samples: usize,
}

/// `joint`'s measured data in the recording `path`.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let m = jointctl_record::reader::measured(std::path::Path::new("r.mcap"), "q2")?;
/// assert_eq!(m.t_s.len(), m.torque_nm.len());
/// # Ok(()) }
/// ```
pub fn measured(path: &Path, joint: &str) -> Result<Measured, ReadError> {
    if let Some((first, second)) = two_dofs(path, joint)? {
        return measured_along_directions(path, &first, &second);
    }
    let s = joint_series(path, joint)?;
    let keep: Vec<usize> = (0..s.len()).filter(|&i| s.deflection_rad[i].is_finite() && s.sensor_torque_nm[i].is_finite()).collect();
    let pick = |col: &[f64]| keep.iter().map(|&i| col[i]).collect::<Vec<f64>>();
    let mut m = Measured { t_s: pick(&s.t_s), deflection_rad: pick(&s.deflection_rad), torque_nm: pick(&s.sensor_torque_nm), left_out: s.len() - keep.len(), samples: s.len(), ft_samples: s.sensor_torque_nm.iter().filter(|t| t.is_finite()).count(), ..Measured::default() };
    // The observer's pivot carries its encoder's quantisation: settings are told apart to 0.1 mm.
    if s.pivot_mm.iter().any(|p| p.is_finite()) {
        m.pivot_mm = keep.iter().map(|&i| (s.pivot_mm[i] * 10.0).round() / 10.0).collect();
    }
    if s.reference_torque_nm.iter().any(|r| r.is_finite()) {
        m.reference_torque_nm = pick(&s.reference_torque_nm);
    }
    if let Some(drive) = motor_drive(path, joint)? {
        let by_cycle: std::collections::HashMap<u64, f64> = raw_samples(path)?
            .iter()
            .map(|f| (f.cycle, f.drives.iter().find(|(n, ..)| *n == drive).and_then(|(_, r, _)| r.position_rad.usable(f64::INFINITY)).unwrap_or(f64::NAN)))
            .collect();
        m.motor_position_rad = keep.iter().map(|&i| by_cycle.get(&s.cycle[i]).copied().unwrap_or(f64::NAN)).collect();
    }
    Ok(m)
}

/// A 2-DOF joint's data the way section 3.5.2 characterised the wrist: along the direction of
/// the deflection, the nearest of four (0, 45, 90, 135 deg), both DOFs' deflections and F/T
/// torques projected on it.
fn measured_along_directions(path: &Path, first: &str, second: &str) -> Result<Measured, ReadError> {
    let (mut all, known) = all_joint_series(path)?;
    let no = |j: &str| ReadError::NoJoint { file: path.into(), joint: j.into(), known: known.clone() };
    let a = all.remove(first).ok_or_else(|| no(first))?;
    let b = all.remove(second).ok_or_else(|| no(second))?;
    let mut m = Measured { samples: a.len().min(b.len()), ..Measured::default() };
    for i in 0..m.samples {
        let (d1, d2, t1, t2) = (a.deflection_rad[i], b.deflection_rad[i], a.sensor_torque_nm[i], b.sensor_torque_nm[i]);
        if t1.is_finite() && t2.is_finite() {
            m.ft_samples += 1;
        }
        if !(d1.is_finite() && d2.is_finite() && t1.is_finite() && t2.is_finite()) {
            m.left_out += 1;
            continue;
        }
        // Folded into [0, 180): a direction and its opposite are one line (the projection's sign
        // tells them apart).
        let direction = d1.atan2(d2).to_degrees().rem_euclid(180.0);
        let angle = ((direction / 45.0).round() * 45.0).rem_euclid(180.0);
        let (sa, ca) = (angle.to_radians().sin(), angle.to_radians().cos());
        m.t_s.push(a.t_s[i]);
        m.deflection_rad.push(d1 * sa + d2 * ca);
        m.torque_nm.push(t1 * sa + t2 * ca);
        m.angle_deg.push(angle);
        if a.pivot_mm[i].is_finite() {
            m.pivot_mm.push((a.pivot_mm[i] * 10.0).round() / 10.0);
        }
    }
    if m.pivot_mm.len() != m.t_s.len() {
        m.pivot_mm.clear();
    }
    Ok(m)
}

/// The two DOFs of 2-DOF joint `joint` in the attached arm description, if it is one.
fn two_dofs(path: &Path, joint: &str) -> Result<Option<(String, String)>, ReadError> {
    let Some((_, text)) = config_attachment(path)? else { return Ok(None) };
    let Ok(yaml) = serde_yaml::from_str::<serde_yaml::Value>(&text) else { return Ok(None) };
    let dofs = yaml["joints"].as_sequence().and_then(|joints| joints.iter().find(|j| j["name"].as_str() == Some(joint))).and_then(|j| j["dofs"].as_sequence());
    Ok(match dofs.map(|d| d.iter().filter_map(|x| x["name"].as_str()).collect::<Vec<_>>()).as_deref() {
        Some([first, second]) => Some((first.to_string(), second.to_string())),
        _ => None,
    })
}

/// The `motor` drive of 1-DOF joint `joint` in the attached arm description, if any.
fn motor_drive(path: &Path, joint: &str) -> Result<Option<String>, ReadError> {
    let Some((_, text)) = config_attachment(path)? else { return Ok(None) };
    let Ok(yaml) = serde_yaml::from_str::<serde_yaml::Value>(&text) else { return Ok(None) };
    let entry = yaml["joints"].as_sequence().and_then(|joints| joints.iter().find(|j| j["name"].as_str() == Some(joint) && j["dofs"].is_null()));
    Ok(entry.and_then(|j| j["drives"]["motor"].as_str()).map(str::to_string))
}

/// The arm description attached to the recording (the first attachment, the file `jointctl
/// run` was given): its name and text.
pub fn config_attachment(path: &Path) -> Result<Option<(String, String)>, ReadError> {
    let bytes = jointctl_files::read(path, jointctl_files::FileKind::Recording)?;
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

fn parse_command(path: &Path, encoding: Encoding, sequence: u32, data: &[u8]) -> Result<RecordedCommand, ReadError> {
    let bad = |reason: String| ReadError::Message { file: path.into(), topic: "commands".into(), sequence, reason };
    let m = match encoding {
        Encoding::Cdr => decode_cdr::<jointctl_ros2::msg::CommandRecord>(path, jointctl_ros2::COMMANDS, sequence, data)?,
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
