//! The inspector views of a running arm: `inspect echo` (JSON, rate and joint filters, a closed
//! pipe), `inspect diag`, `inspect joints` and `inspect top` without a terminal.

use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use jointctl_tests::{jointctl, stop};

use super::{spawn_run, stderr_of, wait_with_timeout, write_rig};

#[test]
fn an_inspector_process_prints_the_live_states_as_json() {
    let (arm, yaml) = write_rig("echo", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "20"]);
    let out = Command::new(jointctl())
        .args(["inspect", "echo", "--arm", &arm, "--json", "--count", "5", "--timeout", "10"])
        .output()
        .unwrap();
    stop(&mut run);
    assert!(out.status.success(), "inspect failed: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    let mut last_cycle = None;
    for line in lines {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let obj = v.as_object().unwrap();
        assert_eq!(obj.keys().collect::<Vec<_>>(), ["cycle", "stamp_ns", "wall_ns", "joints"]);
        let cycle = v["cycle"].as_u64().unwrap();
        assert!(last_cycle.is_none_or(|c| cycle > c), "cycles increase");
        last_cycle = Some(cycle);
        assert!(v["stamp_ns"].as_u64().unwrap() > 0);
        let joints = v["joints"].as_array().unwrap();
        assert_eq!(joints.len(), 2);
        for j in joints {
            let keys: Vec<_> = j.as_object().unwrap().keys().map(String::as_str).collect();
            assert_eq!(keys, [
                "name", "position", "velocity", "deflection", "torque", "stiffness", "valid", "pivot", "reference_torque", "sensor_torque", "gravity", "mode", "enabled",
                "fault_code"
            ]);
            assert_eq!(j["mode"], "hold");
        }
        assert_eq!(joints[0]["name"], "a");
        assert_eq!(joints[0]["torque"], serde_json::Value::Null, "a rigid joint's torque is unknown, not 0");
        assert_eq!(joints[0]["stiffness"], 83000.0);
        assert_eq!(joints[1]["name"], "b");
        assert_eq!(joints[1]["stiffness"], 113.78);
        assert_eq!(joints[1]["valid"], true);
        assert!(joints[1]["torque"].is_f64());
    }
}

/// `inspect echo --latest`: the arm's latest-state blackboard, each new cycle the inspector sees
/// (the newest only: cycles may be skipped, never repeated), the same JSON as the stream; and
/// an error that names the blackboard when no arm runs.
#[test]
fn inspect_echo_latest_reads_the_latest_state_blackboard() {
    let (arm, yaml) = write_rig("echo-latest", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "20"]);
    let out = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--latest", "--json", "--count", "5", "--timeout", "10"]).output().unwrap();
    stop(&mut run);
    assert!(out.status.success(), "inspect failed: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let cycles: Vec<u64> = text.lines().map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["cycle"].as_u64().unwrap()).collect();
    assert_eq!(cycles.len(), 5, "{text}");
    assert!(cycles.windows(2).all(|w| w[1] > w[0]), "new cycles only: {cycles:?}");
    let first: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    assert_eq!((first["joints"][0]["name"].as_str(), first["joints"][1]["name"].as_str()), (Some("a"), Some("b")));
    assert!(first["wall_ns"].as_u64().is_some(), "{first}");
    // --latest reads this machine's shared memory; with --zenoh it is refused by the parser.
    let out = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--latest", "--zenoh", "tcp/127.0.0.1:1"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    // No arm running: the error names the blackboard.
    let out = Command::new(jointctl()).args(["inspect", "echo", "--arm", "no-such-arm-latest", "--latest", "--timeout", "0.2"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(1) && err.contains("no-such-arm-latest/latest_state"), "{err}");
}

/// Findings: `inspect echo` had no rate limit and no joint filter, its JSON lacked the mode,
/// the torque reference and the pivot and carried only a monotonic stamp, and it panicked on a
/// closed pipe (`| head`). Pass: `--rate` and `--joint` filter, the fields and a wall-clock stamp
/// are there, and a closed pipe ends it quietly with exit 0.
#[test]
fn inspect_echo_filters_by_rate_and_joint_stamps_wall_clock_and_ends_quietly_on_a_closed_pipe() {
    let (arm, yaml) = write_rig("echo-filters", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let out = Command::new(jointctl())
        .args(["inspect", "echo", "--arm", &arm, "--json", "--count", "4", "--timeout", "10", "--rate", "10", "--joint", "b"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let samples: Vec<serde_json::Value> = String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(samples.len(), 4);
    let now_ns = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos() as f64;
    for pair in samples.windows(2) {
        // 100 Hz loop at most 10 Hz printed: at least about ten cycles apart.
        let gap = pair[1]["cycle"].as_u64().unwrap() - pair[0]["cycle"].as_u64().unwrap();
        assert!(gap >= 9, "--rate 10 on a 100 Hz loop printed samples {gap} cycles apart");
        let (wall, stamp) = (pair[1]["wall_ns"].as_f64().unwrap() - pair[0]["wall_ns"].as_f64().unwrap(), pair[1]["stamp_ns"].as_f64().unwrap() - pair[0]["stamp_ns"].as_f64().unwrap());
        assert!((wall - stamp).abs() < 2e6, "the wall clock follows the cycle stamps: {wall} vs {stamp} ns");
    }
    for v in &samples {
        let joints = v["joints"].as_array().unwrap();
        assert_eq!(joints.len(), 1, "--joint b: {v}");
        assert_eq!(joints[0]["name"], "b");
        assert_eq!(joints[0]["mode"], "hold");
        assert!(joints[0].get("reference_torque").is_some() && joints[0].get("pivot").is_some());
        let wall = v["wall_ns"].as_f64().unwrap();
        assert!((now_ns - wall).abs() < 30e9, "wall_ns {wall} is the cycle's UNIX time (now {now_ns})");
    }
    // A reader that goes away after one line: the inspector ends quietly, exit 0.
    let mut echo = Command::new(jointctl())
        .args(["inspect", "echo", "--arm", &arm, "--timeout", "10"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 64];
    let mut stdout = echo.stdout.take().unwrap();
    stdout.read_exact(&mut first).unwrap();
    drop(stdout);
    let status = wait_with_timeout(&mut echo, Duration::from_secs(10)).expect("the inspector ends when its reader is gone");
    let err = stderr_of(&mut echo);
    stop(&mut run);
    assert!(status.success() && err.is_empty(), "exit {status:?}, stderr: {err}");
}

/// Finding: the diagnostics service (overruns, lateness histogram, clamps, watchdog trips,
/// per-device losses, faults) had no reader. Pass: `inspect diag --json` prints them, devices
/// by their full names; without a runtime it says which domain it looked in.
#[test]
fn inspect_diag_prints_the_arms_counters_and_devices() {
    let (arm, yaml) = write_rig("diag", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let out = Command::new(jointctl()).args(["inspect", "diag", "--arm", &arm, "--json", "--timeout", "10"]).output().unwrap();
    let human = Command::new(jointctl()).args(["inspect", "diag", "--arm", &arm, "--timeout", "10"]).output().unwrap();
    stop(&mut run);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The newest sample when it asked (cycle 0 if the loop had just started).
    assert!(v["cycle"].is_u64() && v["period_ns"] == 10_000_000, "{v}");
    for key in ["overruns", "missed_deadlines", "hal_errors", "publish_drops", "max_compute_ns", "max_lateness_ns"] {
        assert!(v[key].is_u64(), "{key}: {v}");
    }
    assert_eq!(v["lateness_histogram"].as_array().unwrap().len(), 16);
    let joints: Vec<&str> = v["joints"].as_array().unwrap().iter().map(|j| j["name"].as_str().unwrap()).collect();
    assert_eq!(joints, ["a", "b"]);
    let devices: Vec<&str> = v["devices"].as_array().unwrap().iter().map(|d| d["name"].as_str().unwrap()).collect();
    assert_eq!(devices, ["m0", "m1", "m2", "m3", "e0", "e1", "e2", "e3"], "the rig's drives, then its encoders");
    let text = String::from_utf8_lossy(&human.stdout);
    assert!(human.status.success() && text.contains("lateness histogram") && text.contains("m1") && text.contains("fault"), "{text}");
    // No runtime: the domain hint.
    let out = Command::new(jointctl()).args(["inspect", "diag", "--arm", "nobody-runs-this", "--timeout", "0.2"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--domain D"), "{err}");
}

/// Finding: nothing showed what runs (`ros2 control list_controllers`). Pass: `inspect joints
/// --json` names each joint's plugin, version and library, and its DOFs' mode, enabled, fault and
/// validity, following a `disable` command.
#[test]
fn inspect_joints_lists_each_plugin_and_its_dofs_state() {
    let (arm, yaml) = write_rig("joints", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let joints = |extra: &[&str]| Command::new(jointctl()).args(["inspect", "joints", "--arm", &arm, "--timeout", "10"]).args(extra).output().unwrap();
    let before = joints(&["--json"]);
    let disabled = Command::new(jointctl()).args(["cmd", "--arm", &arm, "disable", "a"]).output().unwrap();
    let mut after = serde_json::Value::Null;
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(5) {
        let out = joints(&["--json"]);
        after = serde_json::from_slice(&out.stdout).unwrap_or_default();
        if after["joints"][0]["dofs"][0]["enabled"] == false {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let human = joints(&[]);
    stop(&mut run);
    assert!(before.status.success(), "{}", String::from_utf8_lossy(&before.stderr));
    assert!(disabled.status.success(), "{}", String::from_utf8_lossy(&disabled.stderr));
    let v: serde_json::Value = serde_json::from_slice(&before.stdout).unwrap();
    assert_eq!(v["rate_hz"], 100.0, "{v}");
    let a = &v["joints"][0];
    assert_eq!((a["name"].as_str(), a["plugin"].as_str()), (Some("a"), Some("rigid")), "{v}");
    assert_eq!(a["version"].as_str(), Some(env!("CARGO_PKG_VERSION")), "the plugins share the workspace's version: {v}");
    let library = a["library"].as_str().unwrap_or_default();
    assert!(library.ends_with("libjointctl_plugin_rigid.so"), "loaded from its library: {v}");
    let dof = &a["dofs"][0];
    assert_eq!((dof["name"].as_str(), dof["mode"].as_str()), (Some("a"), Some("hold")), "{v}");
    assert_eq!((dof["enabled"].as_bool(), dof["valid"].as_bool(), dof["held"].as_bool()), (Some(true), Some(true), Some(false)), "{v}");
    assert!(dof["observed"].as_array().unwrap().iter().any(|f| f == "position"), "{v}");
    assert_eq!((dof["fault_code"].as_u64(), dof["fault"].as_str()), (Some(0), Some("none")), "{v}");
    assert_eq!(after["joints"][0]["dofs"][0]["enabled"], false, "disabled: {after}");
    assert_eq!(after["joints"][1]["dofs"][0]["enabled"], true, "only `a` was disabled: {after}");
    let text = String::from_utf8_lossy(&human.stdout);
    assert!(human.status.success() && text.contains("rigid") && text.contains("libjointctl_plugin_rigid.so"), "{text}");
}

/// `inspect top` is a terminal view; piped, it says so and where the same data is, instead of
/// writing escape codes into a file.
#[test]
fn inspect_top_without_a_terminal_points_to_the_json_views() {
    let out = Command::new(jointctl()).args(["inspect", "top", "--arm", "nobody-runs-this"]).stdout(Stdio::piped()).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("needs a terminal") && err.contains("inspect joints --json"), "{err}");
}
