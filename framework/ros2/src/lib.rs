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
#[error("not a CDR-encoded {type_name}: {source}")]
pub struct DecodeError {
    /// The type it was read as.
    pub type_name: &'static str,
    /// The CDR reader's reason.
    pub source: cdr::Error,
}

/// A message as CDR, little-endian, with its encapsulation header.
///
/// ```
/// let t = jointctl_ros2::msg::Time { sec: 1, nanosec: 2 };
/// assert_eq!(jointctl_ros2::encode(&t), [0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]);
/// ```
pub fn encode<M: serde::Serialize>(m: &M) -> Vec<u8> {
    // Only a type serde cannot write as CDR fails (an Option, a map): none of this crate's.
    cdr::serialize::<_, _, cdr::CdrLe>(m, cdr::Infinite).unwrap_or_default()
}

/// A CDR message (either byte order, as its header says) as `M`.
///
/// ```
/// use jointctl_ros2::msg::{JointState, Message};
/// let m = JointState { name: vec!["q1".into()], position: vec![0.5], ..Default::default() };
/// assert_eq!(jointctl_ros2::decode::<JointState>(&jointctl_ros2::encode(&m)).unwrap(), m);
/// assert!(jointctl_ros2::decode::<JointState>(&[0, 1, 0, 0, 9]).is_err());
/// ```
pub fn decode<M: Message>(bytes: &[u8]) -> Result<M, DecodeError> {
    cdr::deserialize(bytes).map_err(|source| DecodeError { type_name: M::NAME, source })
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
        let b = encode(&r);
        assert_eq!(&b[..4], &[0, 1, 0, 0], "CDR_LE encapsulation");
        assert_eq!(&b[4..8], &3u32.to_le_bytes(), "length with the NUL");
        assert_eq!(&b[8..11], b"ab\0");
        assert_eq!(b[11], 0, "padding to 8");
        assert_eq!(&b[12..20], &1.0f64.to_le_bytes());
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
