//! The ROS 2 profile's raw frames as recorded before drives reported their torque: the same
//! message without `torque_nm` in `jointctl_msgs/RawDrive` (CDR is positional, so the current
//! definition cannot read them). Read so that those recordings stay usable; their drives' torque
//! is missing.

use jointctl_ros2::DecodeError;
use jointctl_ros2::msg::{self, Header, Message, RawReading};
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize)]
struct RawDrive {
    name: String,
    position_rad: RawReading,
    velocity_rad_s: RawReading,
    enabled: bool,
    fault: bool,
    action: String,
    setpoint_rad: f64,
    velocity_ff_rad_s: f64,
}

#[derive(Serialize, Deserialize)]
struct RawFrame {
    header: Header,
    cycle: u64,
    stamp_ns: u64,
    commands_applied: u64,
    encoders: Vec<RawReading>,
    drives: Vec<RawDrive>,
    torque_sensors: Vec<RawReading>,
}

impl Message for RawFrame {
    const NAME: &'static str = "jointctl_msgs/msg/RawFrame";
    const DEFINITION: &'static str = "";
    const USES: &'static [(&'static str, &'static str)] = &[];
}

/// Whether a `ros2msg` schema of the raw frame defines the drives' torque reading (a recording
/// whose schema does not is read with [`decode`]).
pub(super) fn raw_schema_has_torque(schema: &str) -> bool {
    schema.split("MSG: ").any(|part| part.starts_with("jointctl_msgs/RawDrive") && part.lines().any(|l| l.trim() == "jointctl_msgs/RawReading torque_nm"))
}

/// One message of such a recording, as the current message with the drives' torque missing.
pub(super) fn decode(data: &[u8]) -> Result<msg::RawFrame, DecodeError> {
    let old: RawFrame = jointctl_ros2::decode(data)?;
    let missing = || RawReading { name: String::new(), value: f64::NAN, status: "missing".into(), age_s: f64::INFINITY };
    Ok(msg::RawFrame {
        header: old.header,
        cycle: old.cycle,
        stamp_ns: old.stamp_ns,
        commands_applied: old.commands_applied,
        encoders: old.encoders,
        drives: old
            .drives
            .into_iter()
            .map(|d| msg::RawDrive {
                name: d.name,
                position_rad: d.position_rad,
                velocity_rad_s: d.velocity_rad_s,
                torque_nm: missing(),
                enabled: d.enabled,
                fault: d.fault,
                action: d.action,
                setpoint_rad: d.setpoint_rad,
                velocity_ff_rad_s: d.velocity_ff_rad_s,
            })
            .collect(),
        torque_sensors: old.torque_sensors,
    })
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use jointctl_api::ReadingStatus;
    use jointctl_ros2::msg::{Message, Time};

    use super::*;

    fn reading(value: f64) -> RawReading {
        RawReading { name: String::new(), value, status: "valid".into(), age_s: 0.01 }
    }

    /// A ROS 2 profile recording written with the raw frame's definition of before drives
    /// reported their torque (`torque_nm` not in `RawDrive`) reads with its drives' torque
    /// missing, everything else as recorded. With the current definition alone (CDR is
    /// positional) it did not read at all.
    #[test]
    fn a_recording_from_before_drive_torque_still_reads() {
        let path = std::env::temp_dir().join(format!("jointctl-before-torque-{}.mcap", std::process::id()));
        let schema = jointctl_ros2::msg::RawFrame::schema().replace("jointctl_msgs/RawReading torque_nm\n", "");
        assert!(!raw_schema_has_torque(&schema) && raw_schema_has_torque(&jointctl_ros2::msg::RawFrame::schema()));
        let frame = RawFrame {
            header: Header { stamp: Time { sec: 1, nanosec: 0 }, frame_id: "arm".into() },
            cycle: 7,
            stamp_ns: 175_000_000,
            commands_applied: 2,
            encoders: vec![RawReading { name: "enc".into(), ..reading(0.25) }],
            drives: vec![RawDrive {
                name: "m".into(),
                position_rad: reading(1.5),
                velocity_rad_s: reading(-0.5),
                enabled: true,
                fault: false,
                action: "move".into(),
                setpoint_rad: 1.6,
                velocity_ff_rad_s: 0.0,
            }],
            torque_sensors: vec![],
        };
        {
            let mut w = mcap::WriteOptions::new().profile("ros2").create(std::io::BufWriter::new(std::fs::File::create(&path).unwrap())).unwrap();
            let schema_id = w.add_schema(jointctl_ros2::msg::RawFrame::NAME, "ros2msg", schema.as_bytes()).unwrap();
            let channel = w.add_channel(schema_id, jointctl_ros2::RAW, "cdr", &BTreeMap::new()).unwrap();
            let data = jointctl_ros2::encode(&frame).unwrap();
            let header = mcap::records::MessageHeader { channel_id: channel, sequence: 1, log_time: 1, publish_time: 1 };
            w.write_to_known_channel(&header, &data).unwrap();
            w.finish().unwrap();
        }
        let samples = crate::reader::raw_samples(&path);
        let _ = std::fs::remove_file(&path);
        let samples = samples.expect("an old recording reads");
        let (name, drive, setpoint) = &samples[0].drives[0];
        assert_eq!((name.as_str(), samples[0].cycle, *setpoint), ("m", 7, 1.6));
        assert_eq!(drive.position_rad.usable(1.0), Some(1.5));
        assert_eq!(drive.torque_nm.status, ReadingStatus::MISSING);
        assert_eq!(samples[0].encoders[0].1.usable(1.0), Some(0.25));
    }
}
