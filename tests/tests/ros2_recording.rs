//! `jointctl record --profile ros2` (issue 33, item 3): ROS 2 topics and types as CDR with
//! `ros2msg` schemas, read by two outside ROS 2 readers that are not jointctl's (PyPI rosbags'
//! AnyReader with the Jazzy type store, and mcap-ros2-support's decoder) and by every jointctl
//! reader, which must find in it what they find in the JSON form of the same cycles.

use std::process::{Command, Stdio};

use jointctl_record::reader;
use jointctl_tests::{arm_name, interop_python, jointctl, scratch, sherpa_with, stop};

/// Both outside readers: every message decoded, counts per topic, and q4's `/joint_states`
/// position and effort in file order.
const OUTSIDE_READERS: &str = r#"
import json, math, sys
from pathlib import Path
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

counts, types, q4 = {}, {}, []
with AnyReader([Path(sys.argv[1])], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as r:
    for c, t, raw in r.messages():
        m = r.deserialize(raw, c.msgtype)
        counts[c.topic] = counts.get(c.topic, 0) + 1
        types[c.topic] = c.msgtype
        if c.topic == "/joint_states":
            i = list(m.name).index("q4")
            q4.append([m.position[i], m.effort[i], m.header.stamp.sec, m.header.stamp.nanosec, t])
            names = list(m.name)
decoded, profile = {}, None
with open(sys.argv[1], "rb") as f:
    rd = make_reader(f, decoder_factories=[DecoderFactory()])
    profile = rd.get_header().profile
    for schema, channel, message, ros_msg in rd.iter_decoded_messages():
        decoded[channel.topic] = decoded.get(channel.topic, 0) + 1
clean = lambda x: None if isinstance(x, float) and math.isnan(x) else x
print(json.dumps({"counts": counts, "types": types, "decoded": decoded, "profile": profile, "names": names,
                  "q4": [[clean(v) for v in row] for row in q4]}))
"#;

#[test]
fn a_ros2_recording_is_read_by_rosbags_mcap_ros2_and_every_jointctl_reader() {
    let test = "record-ros2";
    let arm = arm_name(test);
    let config = sherpa_with(test, &arm, &[]);
    let mut run = Command::new(jointctl()).arg("run").arg(&config).args(["--duration", "30"]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the runtime is up: {}", String::from_utf8_lossy(&up.stderr));
    let dir = scratch(&format!("{test}-out"));
    let (ros2, json) = (dir.join("r2.mcap"), dir.join("r.mcap"));
    // The same arm in both forms at once: the cycles both hold must read the same.
    let record = |profile: &str, out: &std::path::Path| {
        Command::new(jointctl()).args(["record", "--arm", &arm, "--duration", "3", "--json", "--profile", profile, "--out"]).arg(out).stdout(Stdio::piped()).spawn().unwrap()
    };
    let (rec_ros2, rec_json) = (record("ros2", &ros2), record("json", &json));
    std::thread::sleep(std::time::Duration::from_millis(700));
    let cmd = Command::new(jointctl()).args(["cmd", "torque", "q2", "--sine", "5", "--freq", "1", "--arm", &arm]).output().unwrap();
    let (out_ros2, out_json) = (rec_ros2.wait_with_output().unwrap(), rec_json.wait_with_output().unwrap());
    stop(&mut run);
    assert!(cmd.status.success(), "{}", String::from_utf8_lossy(&cmd.stderr));
    assert!(out_ros2.status.success() && out_json.status.success(), "{}", String::from_utf8_lossy(&out_ros2.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&out_ros2.stdout).expect("one JSON object");
    assert_eq!(summary["lost"], 0, "{summary}");

    // Outside readers: every message decodes, with the counts `record --json` gave.
    let py = Command::new(interop_python()).args(["-c", OUTSIDE_READERS]).arg(&ros2).output().unwrap();
    assert!(py.status.success(), "{}", String::from_utf8_lossy(&py.stderr));
    let v: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
    assert_eq!(v["profile"], "ros2");
    let expected_types = [
        ("/joint_states", "sensor_msgs/msg/JointState"),
        ("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
        ("/jointctl/joint_details", "jointctl_msgs/msg/JointDetails"),
        ("/jointctl/raw", "jointctl_msgs/msg/RawFrame"),
        ("/jointctl/commands", "jointctl_msgs/msg/CommandRecord"),
    ];
    for (topic, ty) in expected_types {
        assert_eq!(v["types"][topic], ty, "{v}");
        assert_eq!(v["counts"][topic], summary["messages"][topic], "rosbags, {topic}: {v}");
        assert_eq!(v["decoded"][topic], summary["messages"][topic], "mcap-ros2-support, {topic}: {v}");
    }
    assert_eq!(summary["messages"]["/jointctl/commands"], 1, "{summary}");
    assert_eq!(v["names"], serde_json::json!(["q1", "q2", "q3", "q4", "q5", "q6", "q7"]));

    // /joint_states against what jointctl reads from /jointctl/joint_details of the same file:
    // position and effort (the observed torque) sample for sample; stamps on the wall clock.
    let q4 = reader::joint_series(&ros2, "q4").unwrap();
    let rows = v["q4"].as_array().unwrap();
    assert_eq!(rows.len(), q4.len(), "one /joint_states message per joint state");
    let start_unix_ns = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos() as u64;
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[0].as_f64(), Some(q4.position_rad[i]).filter(|x| x.is_finite()), "q4 position, message {i}");
        assert_eq!(row[1].as_f64(), Some(q4.observed_torque_nm[i]).filter(|x| x.is_finite()), "q4 effort, message {i}");
        let stamp = row[2].as_u64().unwrap() * 1_000_000_000 + row[3].as_u64().unwrap();
        assert_eq!(stamp, row[4].as_u64().unwrap(), "header stamp = log time");
        assert!(start_unix_ns.abs_diff(stamp) < 120_000_000_000, "a wall-clock stamp: {stamp}");
    }

    // The jointctl readers: the cycles both files hold read the same in both forms.
    let (a, b) = (reader::read(&ros2).unwrap(), reader::read(&json).unwrap());
    let common: Vec<u64> = a.raw.iter().map(|r| r.cycle).filter(|c| b.raw.iter().any(|r| r.cycle == *c)).collect();
    assert!(common.len() > 100, "{} cycles in both", common.len());
    for c in &common {
        let (x, y) = (a.raw.iter().find(|r| r.cycle == *c).unwrap(), b.raw.iter().find(|r| r.cycle == *c).unwrap());
        assert_eq!(format!("{x:?}"), format!("{y:?}"), "raw frame of cycle {c}");
    }
    // Joint states by the cycles both files have a state of (a recorder that subscribed between
    // a cycle's state and its raw frame has that cycle's raw frame alone).
    for name in &b.joint_names {
        let (x, y) = (&a.joints[name], &b.joints[name]);
        let both: Vec<u64> = x.cycle.iter().copied().filter(|c| y.cycle.contains(c)).collect();
        assert!(both.len() > 100, "{name}: {} joint states in both", both.len());
        for c in &both {
            let (i, j) = (x.cycle.iter().position(|k| k == c).unwrap(), y.cycle.iter().position(|k| k == c).unwrap());
            let row = |s: &reader::JointSeries, i: usize| {
                format!("{:?}", (s.position_rad[i], s.deflection_rad[i], s.observed_torque_nm[i], s.sensor_torque_nm[i], s.reference_torque_nm[i], s.pivot_mm[i], s.stiffness_nm_per_rad[i], &s.mode[i]))
            };
            assert_eq!(row(x, i), row(y, j), "{name} at cycle {c}");
        }
    }
    assert_eq!(a.commands.len(), 1);
    assert_eq!(format!("{:?}", a.commands), format!("{:?}", b.commands), "the accepted command");
    assert_eq!(format!("{:?}", a.activation), format!("{:?}", b.activation), "the activation readings");

    // identify, replay and sim replay take the ROS 2 file as they take the JSON one.
    let identify = Command::new(jointctl()).args(["identify", "--joint", "q2", "--json", "--data"]).arg(&ros2).output().unwrap();
    assert!(identify.status.success(), "{}", String::from_utf8_lossy(&identify.stderr));
    let report: serde_json::Value = serde_json::from_slice(&identify.stdout).unwrap();
    assert!(report["samples"].as_u64().unwrap() + 1 >= q4.len() as u64, "{}", report["samples"]);
    let replay = Command::new(jointctl()).arg("replay").arg(&ros2).arg("--config").arg(&config).arg("--json").output().unwrap();
    assert!(replay.status.success(), "{}", String::from_utf8_lossy(&replay.stderr));
    let replayed: serde_json::Value = serde_json::from_slice(&replay.stdout).unwrap();
    let observed: Vec<f64> = replayed["channels"].as_array().unwrap().iter().filter(|c| c["channel"] == "observed_torque").filter_map(|c| c["rmse"].as_f64()).collect();
    assert!(!observed.is_empty() && observed.iter().all(|r| *r < 1e-9), "the recorded arm's own observers reproduce the ROS 2 recording: {observed:?}");
    let sim = Command::new(jointctl()).args(["sim", "replay"]).arg(&ros2).arg("--config").arg(&config).arg("--json").output().unwrap();
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));
}
