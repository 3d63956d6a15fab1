//! The arm's samples as ROS 2 messages: what the ROS 2 recording profile writes (`jointctl record
//! --profile ros2`) and reads back. The topics and types:
//!
//! | topic | type | from |
//! |---|---|---|
//! | `/joint_states` | `sensor_msgs/msg/JointState` | the joint state (effort = observed torque) |
//! | `/jointctl/joint_details` | `jointctl_msgs/msg/JointDetails` | the joint state, every field |
//! | `/diagnostics` | `diagnostic_msgs/msg/DiagnosticArray` | the diagnostics |
//! | `/jointctl/raw` | `jointctl_msgs/msg/RawFrame` | the raw readings and set-points |
//! | `/jointctl/commands` | `jointctl_msgs/msg/CommandRecord` | the accepted commands |
//!
//! Messages are CDR (little-endian, XCDR1, with its 4-byte encapsulation header), the form of
//! ROS 2 messages on DDS and in `ros2 bag` MCAP files.

#![deny(missing_docs)]

mod cdr_out;
pub mod direct;
pub mod from_arm;
pub mod msg;

use msg::Message;

/// The ROS 2 topics of a recording, by the channel of the arm they come from (`joint_state`
/// feeds two), with their type's name and MCAP schema text.
///
/// ```
/// let topics = jointctl_ros2::topics();
/// assert_eq!(topics[0].topic, "/joint_states");
/// assert_eq!(topics.iter().filter(|t| t.source == "joint_state").count(), 2);
/// ```
pub fn topics() -> Vec<Topic> {
    fn of<M: Message>(topic: &'static str, source: &'static str) -> Topic {
        Topic { topic, source, type_name: M::NAME, schema: M::schema() }
    }
    vec![
        of::<msg::JointState>(JOINT_STATES, "joint_state"),
        of::<msg::JointDetails>(JOINT_DETAILS, "joint_state"),
        of::<msg::DiagnosticArray>(DIAGNOSTICS, "diagnostics"),
        of::<msg::RawFrame>(RAW, "raw"),
        of::<msg::CommandRecord>(COMMANDS, "commands"),
    ]
}

/// `sensor_msgs/msg/JointState`.
pub const JOINT_STATES: &str = "/joint_states";
/// `jointctl_msgs/msg/JointDetails`.
pub const JOINT_DETAILS: &str = "/jointctl/joint_details";
/// `diagnostic_msgs/msg/DiagnosticArray`.
pub const DIAGNOSTICS: &str = "/diagnostics";
/// `jointctl_msgs/msg/RawFrame`.
pub const RAW: &str = "/jointctl/raw";
/// `jointctl_msgs/msg/CommandRecord`.
pub const COMMANDS: &str = "/jointctl/commands";
/// `trajectory_msgs/msg/JointTrajectory`, to the arm (the live bridge, when its YAML allows).
pub const JOINT_TRAJECTORY: &str = "/jointctl/joint_trajectory";
/// `jointctl_msgs/msg/CommandRequest`, to the arm (the live bridge, when its YAML allows).
pub const COMMAND: &str = "/jointctl/command";
/// `jointctl_msgs/msg/CommandResponse`: the answer to each command from ROS 2.
pub const COMMAND_RESPONSES: &str = "/jointctl/command_responses";

/// One ROS 2 topic of a recording.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topic {
    /// The topic (`/joint_states`).
    pub topic: &'static str,
    /// The arm's channel it is made from (`joint_state`, `raw`, `diagnostics`, `commands`).
    pub source: &'static str,
    /// The message type (`sensor_msgs/msg/JointState`).
    pub type_name: &'static str,
    /// Its `ros2msg` schema.
    pub schema: String,
}

/// A message that is not the CDR of its type.
#[derive(Debug, thiserror::Error)]
#[error("not a CDR-encoded {type_name}: {reason}")]
pub struct DecodeError {
    /// The type it was read as.
    pub type_name: &'static str,
    /// What is wrong.
    pub reason: String,
}

/// A message that could not be written as CDR (only a type CDR cannot carry fails: a map, an
/// optional field; none of this crate's).
#[derive(Debug, thiserror::Error)]
#[error("cannot write a {type_name} as CDR: {source}")]
pub struct EncodeError {
    /// The type.
    pub type_name: &'static str,
    /// The encoder's reason.
    pub source: cdr_encoding::Error,
}

/// The encapsulation header of little-endian plain CDR (XCDR1): the representation id
/// `CDR_LE` and two bytes of options.
const CDR_LE: [u8; 4] = [0, 1, 0, 0];
/// The same for big-endian (`CDR_BE`).
const CDR_BE: [u8; 4] = [0, 0, 0, 0];

/// A message as CDR, little-endian, with its encapsulation header.
///
/// ```
/// let p = jointctl_ros2::msg::CommandPoint { t_s: 1.0, position_rad: 0.0, velocity_rad_s: 0.0 };
/// let b = jointctl_ros2::encode(&p).unwrap();
/// assert_eq!((&b[..4], &b[4..12]), (&[0, 1, 0, 0][..], &1.0f64.to_le_bytes()[..]));
/// ```
pub fn encode<M: msg::Message>(m: &M) -> Result<Vec<u8>, EncodeError> {
    let body = cdr_encoding::to_vec::<M, byteorder::LittleEndian>(m).map_err(|source| EncodeError { type_name: M::NAME, source })?;
    let mut out = Vec::with_capacity(4 + body.len());
    out.extend_from_slice(&CDR_LE);
    out.extend_from_slice(&body);
    Ok(out)
}

/// A CDR message (either byte order, as its header says) as `M`. Every length in it is checked
/// against the bytes left before anything is allocated for it.
///
/// ```
/// use jointctl_ros2::msg::{JointState, Message};
/// let m = JointState { name: vec!["q1".into()], position: vec![0.5], ..Default::default() };
/// assert_eq!(jointctl_ros2::decode::<JointState>(&jointctl_ros2::encode(&m).unwrap()).unwrap(), m);
/// assert!(jointctl_ros2::decode::<JointState>(&[0, 1, 0, 0, 9]).is_err());
/// ```
pub fn decode<M: msg::Message>(bytes: &[u8]) -> Result<M, DecodeError> {
    let bad = |reason: String| DecodeError { type_name: M::NAME, reason };
    let (header, body) = bytes.split_at_checked(4).ok_or_else(|| bad(format!("{} bytes, shorter than the 4-byte encapsulation header", bytes.len())))?;
    let decoded = match header[..2] {
        [a, b] if [a, b] == CDR_LE[..2] => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        [a, b] if [a, b] == CDR_BE[..2] => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        _ => return Err(bad(format!("encapsulation {:02x}{:02x} is not plain CDR (00 00 or 00 01)", header[0], header[1]))),
    };
    decoded.map(|(m, _)| m).map_err(|e| bad(e.to_string()))
}

/// A message of type `M` already in CDR ([`direct::DirectEncoder`] wrote it), for a DDS writer
/// that serializes through serde (RustDDS's, under the live ROS 2 bridge): its serializer writes
/// these bytes as they are (a tuple of octets: no length, no alignment) after its own
/// encapsulation header. CDR aligns from the start of the data after that header, as
/// `DirectEncoder` did, so the bytes on the wire are the message's.
///
/// ```
/// use jointctl_ros2::{Encoded, msg::JointState};
/// let m = JointState { name: vec!["q1".into()], position: vec![0.5], ..Default::default() };
/// let cdr = jointctl_ros2::encode(&m).unwrap();
/// let e = Encoded::<JointState>::from_cdr(&cdr).unwrap();
/// assert_eq!(e.body(), &cdr[4..]);
/// assert!(Encoded::<JointState>::from_cdr(&[0, 0, 0, 0, 1]).is_err(), "big-endian: not what DirectEncoder writes");
/// ```
pub struct Encoded<M> {
    body: Vec<u8>,
    _type: std::marker::PhantomData<fn() -> M>,
}

impl<M: msg::Message> Encoded<M> {
    /// The message of `cdr`: a whole little-endian CDR message with its encapsulation header.
    pub fn from_cdr(cdr: &[u8]) -> Result<Self, DecodeError> {
        match cdr.split_at_checked(4) {
            Some((header, body)) if header[..2] == CDR_LE[..2] => Ok(Encoded { body: body.to_vec(), _type: std::marker::PhantomData }),
            _ => Err(DecodeError { type_name: M::NAME, reason: "not a little-endian CDR message with its encapsulation header".into() }),
        }
    }

    /// The CDR after the encapsulation header.
    pub fn body(&self) -> &[u8] {
        &self.body
    }
}

impl<M> serde::Serialize for Encoded<M> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple as _;
        let mut octets = serializer.serialize_tuple(self.body.len())?;
        for b in &self.body {
            octets.serialize_element(b)?;
        }
        octets.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CDR aligns each value to its size from the start of the data after the 4-byte header:
    /// a string "ab" (a length of 4 bytes, then 3 with its NUL) ends at offset 7, so the f64
    /// after it starts at 8 (one byte of padding).
    #[test]
    fn cdr_layout_is_xcdr1_little_endian() {
        let r = msg::RawReading { name: "ab".into(), value: 1.0, status: "v".into(), age_s: 0.0 };
        let b = encode(&r).unwrap();
        assert_eq!(&b[..4], &[0, 1, 0, 0], "CDR_LE encapsulation");
        assert_eq!(&b[4..8], &3u32.to_le_bytes(), "length with the NUL");
        assert_eq!(&b[8..11], b"ab\0");
        assert_eq!(b[11], 0, "padding to 8");
        assert_eq!(&b[12..20], &1.0f64.to_le_bytes());
    }

    /// Finding (review): the `cdr` crate allocated a string's stated length before checking that
    /// the bytes were there: a length of 4 GiB in a damaged file took 29 s and 4.2 GB, or aborted
    /// the process under a memory limit. Read now, they are an error at once.
    #[test]
    fn a_length_beyond_the_message_is_an_error_not_an_allocation() {
        let started = std::time::Instant::now();
        // A JointState's header: its stamp (8 bytes), then frame_id's length.
        let e = decode::<msg::JointState>(&[0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xf0, 0xff, 0xff, 0xff]).unwrap_err();
        assert!(started.elapsed() < std::time::Duration::from_secs(1), "{e}");
        assert!(decode::<msg::JointState>(&[0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0x7f]).is_err());
        assert!(decode::<msg::JointDetail>(&[0, 9, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]).unwrap_err().to_string().contains("encapsulation 0009"));
    }

    /// CDR has no field names: a struct's fields must be in its definition's order. Each
    /// jointctl message written with distinct values is read back field by field from the bytes
    /// at the offsets its definition gives.
    #[test]
    fn the_rust_fields_are_in_the_definitions_order() {
        let detail = msg::JointDetail {
            name: "q".into(), position_rad: 1.0, velocity_rad_s: 2.0, deflection_rad: 3.0, torque_nm: 4.0, stiffness_nm_per_rad: 5.0, pivot_mm: 6.0,
            reference_torque_nm: 7.0, sensor_torque_nm: 8.0, gravity_nm: 9.0, mode: "m".into(), enabled: true, fault_code: 10,
        };
        let b = encode(&detail).unwrap();
        // After the header and the name (4-byte length, "q\0", padding to 8): nine float64 in
        // the definition's order.
        let floats: Vec<f64> = (0..9).map(|i| f64::from_le_bytes(b[12 + 8 * i..20 + 8 * i].try_into().unwrap())).collect();
        assert_eq!(floats, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        let names: Vec<&str> = msg::JointDetail::DEFINITION.lines().filter_map(|l| l.split_whitespace().nth(1)).collect();
        assert_eq!(&names[1..10], ["position_rad", "velocity_rad_s", "deflection_rad", "torque_nm", "stiffness_nm_per_rad", "pivot_mm", "reference_torque_nm", "sensor_torque_nm", "gravity_nm"]);
    }

    #[test]
    fn every_schema_names_each_type_it_uses() {
        let mut all = topics();
        all.push(Topic { topic: JOINT_TRAJECTORY, source: "", type_name: msg::JointTrajectory::NAME, schema: msg::JointTrajectory::schema() });
        all.push(Topic { topic: COMMAND, source: "", type_name: msg::CommandRequest::NAME, schema: msg::CommandRequest::schema() });
        all.push(Topic { topic: COMMAND_RESPONSES, source: "", type_name: msg::CommandResponse::NAME, schema: msg::CommandResponse::schema() });
        for t in all {
            let used: Vec<&str> = t.schema.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
            for line in t.schema.lines().filter(|l| !l.starts_with('#') && !l.starts_with("MSG: ") && !l.starts_with('=')) {
                let ty = line.split_whitespace().next().unwrap_or("").trim_end_matches("[]");
                if ty.contains('/') {
                    assert!(used.contains(&ty), "{}: {ty} is used but not defined", t.topic);
                }
            }
        }
    }
}
