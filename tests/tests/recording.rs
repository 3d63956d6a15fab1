//! `jointctl record`: a running arm into one MCAP file, read back by the `mcap` crate and by
//! an outside client (PyPI `mcap`, in the interop venv).

use std::process::{Child, Command, Stdio};

use jointctl_tests::{arm_name, interop_python, jointctl, scratch, sherpa_with, stop};

fn spawn_run(config: &std::path::Path) -> Child {
    Command::new(jointctl()).arg("run").arg(config).args(["--duration", "30"]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap()
}

/// The arm runs, q2 follows a torque sine, and `record --duration 3 --json` writes the file.
fn record_sine(test: &str) -> (std::path::PathBuf, serde_json::Value, String) {
    let arm = arm_name(test);
    let config = sherpa_with(test, &arm, &[]);
    let mut run = spawn_run(&config);
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the runtime is up: {}", String::from_utf8_lossy(&up.stderr));
    let out = scratch(&format!("{test}-out")).join("r.mcap");
    let mut record = Command::new(jointctl()).args(["record", "--arm", &arm, "--duration", "3", "--json", "--out"]).arg(&out).stdout(Stdio::piped()).spawn().unwrap();
    // The command after the recorder has subscribed: it is in the file.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let cmd = Command::new(jointctl()).args(["cmd", "torque", "q2", "--sine", "5", "--freq", "1", "--arm", &arm]).output().unwrap();
    let recorded = record.wait().unwrap();
    let mut stdout = String::new();
    std::io::Read::read_to_string(record.stdout.as_mut().unwrap(), &mut stdout).unwrap();
    stop(&mut run);
    assert!(cmd.status.success(), "{}", String::from_utf8_lossy(&cmd.stderr));
    assert!(recorded.success(), "record failed");
    let summary: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
    (out, summary, arm)
}

#[test]
fn a_recording_holds_every_channel_gapless_with_its_schema_metadata_and_config() {
    let (file, summary, arm) = record_sine("record");
    for key in ["file", "duration_s", "messages", "lost"] {
        assert!(summary.get(key).is_some(), "{key} in {summary}");
    }
    assert_eq!(summary["lost"], 0, "{summary}");
    let duration = summary["duration_s"].as_f64().unwrap();
    assert!((3.0..3.2).contains(&duration), "{summary}");
    // 40 Hz for 3 s: about 121 samples per cycle channel.
    for channel in ["raw", "joint_state", "diagnostics"] {
        let n = summary["messages"][channel].as_u64().unwrap();
        assert!((115..=125).contains(&n), "{channel}: {n} messages");
    }
    assert_eq!(summary["messages"]["commands"], 1, "the torque command");

    let bytes = std::fs::read(&file).unwrap();
    let summary_section = mcap::Summary::read(&bytes).unwrap().expect("an indexed file with a summary");
    let topics: std::collections::BTreeMap<String, (String, String, String)> = summary_section
        .channels
        .values()
        .map(|c| {
            let s = c.schema.as_ref().unwrap();
            (c.topic.clone(), (c.message_encoding.clone(), s.encoding.clone(), String::from_utf8_lossy(&s.data).into_owned()))
        })
        .collect();
    assert_eq!(topics.keys().collect::<Vec<_>>(), ["commands", "diagnostics", "joint_state", "raw"]);
    for (encoding, schema_encoding, schema) in topics.values() {
        assert_eq!((encoding.as_str(), schema_encoding.as_str()), ("json", "jsonschema"));
        let s: serde_json::Value = serde_json::from_str(schema).unwrap();
        assert_eq!(s["type"], "object");
    }
    let mut states = Vec::new();
    let mut raws = Vec::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        assert_eq!(m.log_time, v["stamp_ns"].as_u64().unwrap(), "log time is the cycle's stamp");
        match m.channel.topic.as_str() {
            "joint_state" => states.push(v),
            "raw" => raws.push(v),
            _ => {}
        }
    }
    // Consecutive cycles, and q2 in torque mode with its reference once the command arrived.
    assert!(states.windows(2).all(|w| w[1]["cycle"].as_u64() == w[0]["cycle"].as_u64().map(|c| c + 1)));
    let q2 = |s: &serde_json::Value| s["joints"].as_array().unwrap().iter().find(|j| j["name"] == "q2").unwrap().clone();
    let last = q2(states.last().unwrap());
    assert_eq!(last["mode"], "torque", "{last}");
    assert!(last["reference_torque_nm"].is_f64() && last["deflection_rad"].is_f64(), "{last}");
    // The raw frames name their 13 encoders and 9 drives, and the drives were sent set-points.
    let frame = raws.last().unwrap();
    assert_eq!(frame["encoders"].as_array().unwrap().len(), 13);
    assert_eq!(frame["drives"][1]["name"], "elmo_shoulder_a");
    assert!(raws.iter().any(|f| f["drives"][1]["action"] == "move"), "the shoulder's drives moved");
    // Metadata: the wall clock at the start; attachments: the arm's YAML and its includes.
    let metadata: Vec<(String, std::collections::BTreeMap<String, String>)> = summary_section
        .metadata_indexes
        .iter()
        .map(|i| {
            let m = mcap::read::metadata(&bytes, i).unwrap();
            (m.name, m.metadata)
        })
        .collect();
    let names: Vec<&str> = metadata.iter().map(|m| m.0.as_str()).collect();
    assert_eq!(names, ["jointctl", "activation"], "the start's metadata, and the readings the joints were activated with");
    assert_eq!(metadata[0].1["arm"], arm);
    let activation: serde_json::Value = serde_json::from_str(&metadata[1].1["raw"]).unwrap();
    assert_eq!(activation["encoders"].as_array().unwrap().len(), 13);
    let start: u64 = metadata[0].1["start_unix_ns"].parse().unwrap();
    assert!(start > 1_700_000_000_000_000_000, "wall-clock time in ns: {start}");
    let attached: Vec<String> = summary_section.attachment_indexes.iter().map(|a| a.name.clone()).collect();
    assert!(attached.iter().any(|n| n.ends_with(".yaml")) && attached.iter().any(|n| n == "sherpa_q2_characteristic.yaml"), "{attached:?}");
}

#[test]
fn sigint_finishes_a_valid_indexed_file() {
    let test = "record-sigint";
    let arm = arm_name(test);
    let config = sherpa_with(test, &arm, &[]);
    let mut run = spawn_run(&config);
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success());
    let out = scratch(&format!("{test}-out")).join("r.mcap");
    let record = Command::new(jointctl()).args(["record", "--arm", &arm, "--json", "--out"]).arg(&out).stdout(Stdio::piped()).spawn().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    // SAFETY: kill() with a child's pid and a valid signal number.
    unsafe { libc::kill(record.id() as i32, libc::SIGINT) };
    let done = record.wait_with_output().unwrap();
    stop(&mut run);
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&done.stdout).unwrap();
    let n = summary["messages"]["joint_state"].as_u64().unwrap();
    assert!(n > 20, "{summary}");
    let bytes = std::fs::read(&out).unwrap();
    let index = mcap::Summary::read(&bytes).unwrap().expect("SIGINT still writes the summary and index");
    let stats = index.stats.expect("statistics");
    assert_eq!(stats.channel_message_counts.values().sum::<u64>(), summary["messages"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum::<u64>());
}

#[test]
fn recording_an_arm_that_is_not_running_says_so() {
    let out = scratch("record-none").join("r.mcap");
    let r = Command::new(jointctl()).args(["record", "--arm", &arm_name("record-none"), "--timeout", "0.2", "--out"]).arg(&out).output().unwrap();
    assert_eq!(r.status.code(), Some(1));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("is `jointctl run` running this arm in this domain?"), "{err}");
    assert!(!out.exists(), "no file for nothing");
}

/// Issue item 6: an outside client reads the file as it is.
#[test]
fn pypi_mcap_reads_the_recording() {
    let (file, summary, _) = record_sine("record-py");
    let script = r#"
import json, sys
from mcap.reader import make_reader
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    s = reader.get_summary()
    counts = {s.channels[c].topic: n for c, n in s.statistics.channel_message_counts.items()}
    encodings = sorted({(c.message_encoding, s.schemas[c.schema_id].encoding) for c in s.channels.values()})
    state = None
    for schema, channel, message in reader.iter_messages(topics=["joint_state"]):
        state = json.loads(message.data)
    q2 = [j for j in state["joints"] if j["name"] == "q2"][0]
    print(json.dumps({"counts": counts, "encodings": encodings, "q2_mode": q2["mode"], "joints": len(state["joints"])}))
"#;
    let py = Command::new(interop_python()).args(["-c", script]).arg(&file).output().unwrap();
    assert!(py.status.success(), "{}", String::from_utf8_lossy(&py.stderr));
    let v: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
    for channel in ["raw", "joint_state", "diagnostics", "commands"] {
        assert_eq!(v["counts"][channel], summary["messages"][channel], "{v}");
    }
    assert_eq!(v["encodings"], serde_json::json!([["json", "jsonschema"]]));
    assert_eq!((v["q2_mode"].as_str(), v["joints"].as_u64()), (Some("torque"), Some(7)));
}

/// Issue item 4: `fit` and `identify` read a recording directly, one joint's deflection against
/// its F/T torque; a joint that is not there, or has no F/T sensor, is an error that says so.
#[test]
fn fit_and_identify_read_a_joint_from_the_recording() {
    let (file, summary, _) = record_sine("record-ident");
    let states = summary["messages"]["joint_state"].as_u64().unwrap();
    let out = Command::new(jointctl()).args(["identify", "--joint", "q2", "--json", "--data"]).arg(&file).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Every joint-state sample but the final one (the runtime stopping) has both signals.
    let samples = v["samples"].as_u64().unwrap();
    assert!(samples + 1 >= states && samples <= states, "{samples} samples of {states} states");
    let with_config = Command::new(jointctl())
        .args(["identify", "--joint", "q2", "--json", "--config"])
        .arg(jointctl_tests::root().join("configs/sherpa_arm.yaml"))
        .arg("--data")
        .arg(&file)
        .output()
        .unwrap();
    assert!(with_config.status.success(), "{}", String::from_utf8_lossy(&with_config.stderr));
    let fit = Command::new(jointctl()).arg("fit").arg(&file).args(["--joint", "q2", "--order", "3"]).output().unwrap();
    assert!(fit.status.success(), "{}", String::from_utf8_lossy(&fit.stderr));
    assert!(String::from_utf8_lossy(&fit.stdout).contains("characteristic:"));
    // The columns: a VSA's pivot to 0.1 mm, the reference, a 1-DOF joint's motor drive from the
    // attached arm description (the elbow's elmo_q4); a shoulder DOF has no single motor.
    let q2 = jointctl_record::reader::measured(&file, "q2").unwrap();
    assert_eq!(q2.t_s.len(), samples as usize);
    assert!(q2.pivot_mm.iter().all(|p| (p * 10.0 - (p * 10.0).round()).abs() < 1e-9) && !q2.pivot_mm.is_empty());
    assert!(q2.reference_torque_nm.iter().any(|r| r.is_finite()));
    assert!(q2.motor_position_rad.is_empty());
    let q4 = jointctl_record::reader::measured(&file, "q4").unwrap();
    assert_eq!(q4.motor_position_rad.len(), q4.t_s.len());
    assert!(q4.motor_position_rad.iter().all(|m| m.is_finite()), "the elbow's drive was read every cycle");
    // The wrist by its joint name: along the nearest of section 3.5.2's four directions, both
    // DOFs' deflections and F/T torques projected on it.
    let wrist = jointctl_record::reader::measured(&file, "wrist").unwrap();
    assert_eq!(wrist.angle_deg.len(), wrist.t_s.len());
    assert!(!wrist.t_s.is_empty() && wrist.angle_deg.iter().all(|a| [0.0, 45.0, 90.0, 135.0].contains(a)), "{:?}", &wrist.angle_deg[..5.min(wrist.angle_deg.len())]);
    let (q6, q7) = (jointctl_record::reader::joint_series(&file, "q6").unwrap(), jointctl_record::reader::joint_series(&file, "q7").unwrap());
    let k = wrist.t_s.len() / 2;
    let i = q6.t_s.iter().position(|t| *t == wrist.t_s[k]).unwrap();
    let a = wrist.angle_deg[k].to_radians();
    assert!((wrist.torque_nm[k] - (q6.sensor_torque_nm[i] * a.sin() + q7.sensor_torque_nm[i] * a.cos())).abs() < 1e-12);
    assert!((wrist.deflection_rad[k] - (q6.deflection_rad[i] * a.sin() + q7.deflection_rad[i] * a.cos())).abs() < 1e-12);
    for (args, expected) in [
        (vec!["identify", "--data"], "say which with --joint"),
        (vec!["identify", "--joint", "q9", "--data"], "no joint `q9` in the recording (joints: q1, q2, q3, q4, q5, q6, q7)"),
        (vec!["identify", "--joint", "q1", "--data"], "has no F/T torque (wire a `torque_sensor` to the joint)"),
    ] {
        let r = Command::new(jointctl()).args(&args).arg(&file).output().unwrap();
        assert_eq!(r.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(err.contains(expected), "{args:?}: {err}");
    }
}

fn channels(out: &std::process::Output) -> Vec<serde_json::Value> {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    v["channels"].as_array().unwrap().clone()
}

fn rmse(channels: &[serde_json::Value], joint: &str, channel: &str) -> f64 {
    channels.iter().find(|c| c["joint"] == joint && c["channel"] == channel).unwrap_or_else(|| panic!("no {joint} {channel}"))["rmse"].as_f64().unwrap()
}

/// Issue item 5: the recorded readings through the recorded arm's own observers give back the
/// recorded observed torque exactly (the observers' zeros come from the recorded activation); a
/// changed model gives its own, measured against the F/T sensor.
#[test]
fn replay_feeds_the_recorded_readings_through_a_configs_observers() {
    let (file, _, arm) = record_sine("replay");
    let config = std::env::temp_dir().join(format!("jointctl-test-{}-replay/sherpa.yaml", std::process::id()));
    assert!(config.exists(), "{}", config.display());
    let same = channels(&Command::new(jointctl()).arg("replay").arg(&file).arg("--config").arg(&config).arg("--json").output().unwrap());
    for c in same.iter().filter(|c| c["channel"] == "observed_torque" && c["rmse"].is_f64()) {
        assert!(c["rmse"].as_f64().unwrap() < 1e-9, "the recorded arm's own observers reproduce the recording: {c}");
    }
    // A channel a DOF does not have (the rigid q1 and q3 observe no torque) is left out, not a
    // row of NaN (null in the JSON) that the table printed.
    assert!(same.iter().all(|c| c["rmse"].is_f64()), "{same:?}");
    assert!(same.iter().any(|c| c["joint"] == "q2" && c["channel"] == "observed_torque"), "{same:?}");
    // A reader that has gone (`| head`) is no reason to panic.
    let mut gone = Command::new(jointctl()).arg("replay").arg(&file).arg("--config").arg(&config).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    drop(gone.stdout.take());
    let out = gone.wait_with_output().unwrap();
    assert!(out.status.success() && !String::from_utf8_lossy(&out.stderr).contains("panicked"), "{}", String::from_utf8_lossy(&out.stderr));
    // A changed model: the shoulder's observer with a 100 ms low-pass on its torque.
    let filtered = sherpa_with("replay-filtered", &arm, &[jointctl_tests::Edit::Set("joints[shoulder].params.torque_filter_s", 0.1.into())]);
    let changed = channels(&Command::new(jointctl()).arg("replay").arg(&file).arg("--config").arg(&filtered).arg("--json").output().unwrap());
    let (own, replayed) = (rmse(&changed, "q2", "recorded_observer_vs_ft"), rmse(&changed, "q2", "replayed_observer_vs_ft"));
    println!("q2 observer vs F/T: {own:.3} Nm recorded, {replayed:.3} Nm with a 100 ms filter");
    assert!(rmse(&changed, "q2", "observed_torque") > 0.05, "the filter lags a 1 Hz, 5 Nm sine");
    assert!(replayed > own, "a lagging observer is farther from the F/T sensor");
    assert!(rmse(&changed, "q4", "observed_torque") < 1e-9, "only the shoulder changed");
}

/// Issue item 5: the recorded commands re-run on the simulated arm; the same simulated arm
/// differs from its own recording only by the F/T sensor's noise; a different plant shows as
/// the channel it changes.
#[test]
fn sim_replay_reports_what_the_simulation_gets_wrong_per_channel() {
    let (file, _, arm) = record_sine("sim-replay");
    let config = std::env::temp_dir().join(format!("jointctl-test-{}-sim-replay/sherpa.yaml", std::process::id()));
    let same = channels(&Command::new(jointctl()).args(["sim", "replay"]).arg(&file).arg("--config").arg(&config).arg("--json").output().unwrap());
    let keys: Vec<&str> = same[0].as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(keys, ["joint", "channel", "rmse", "max_abs", "unit"]);
    // Two draws of the simulated Mini40's 0.01 Nm noise: about 0.014 Nm apart.
    let ft = rmse(&same, "q2", "ft_torque");
    assert!(ft < 0.03, "q2 F/T torque {ft} Nm");
    assert!(rmse(&same, "q2", "deflection") < 1e-3);
    // The report: a plot per joint with a torque, a line for a rigid joint without one (q1
    // has neither F/T sensor nor observer; its empty plot once failed the whole report).
    let dir = scratch("sim-replay-report");
    let r = Command::new(jointctl()).args(["sim", "replay"]).arg(&file).arg("--config").arg(&config).arg("--report").arg(&dir).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(dir.join("q2-torque.svg").exists() && md.contains("![q2](q2-torque.svg)"), "{md}");
    assert!(md.contains("q1: no torque recorded or replayed"), "{md}");
    // A plant with twice the shoulder's hysteresis band: the replay says where it shows.
    let wider = sherpa_with("sim-replay-wider", &arm, &[jointctl_tests::Edit::Set("joints[shoulder].sim.effects.hysteresis.limit_nm", 1.5.into())]);
    let changed = channels(&Command::new(jointctl()).args(["sim", "replay"]).arg(&file).arg("--config").arg(&wider).arg("--json").output().unwrap());
    let ft_changed = rmse(&changed, "q2", "ft_torque");
    assert!(ft_changed > 3.0 * ft, "q2 F/T torque {ft_changed} Nm with a wider band, {ft} Nm without");
    // A recording at another rate than the config is refused, with both rates.
    let fast = sherpa_with("sim-replay-fast", &arm, &[jointctl_tests::Edit::Set("rate_hz", 100.0.into())]);
    let r = Command::new(jointctl()).args(["sim", "replay"]).arg(&file).arg("--config").arg(&fast).output().unwrap();
    assert_eq!(r.status.code(), Some(1));
    // The recorded rate is measured from the recording's time stamps: 40.0 Hz on most runs,
    // 40.1 Hz on one, so it is read back and taken within 1 %.
    let stderr = String::from_utf8_lossy(&r.stderr);
    let recorded = stderr.split("recorded at ").nth(1).and_then(|rest| rest.split(" Hz, the config runs at 100 Hz").next()).and_then(|hz| hz.parse::<f64>().ok());
    assert!(recorded.is_some_and(|hz| (hz / 40.0 - 1.0).abs() < 0.01), "{stderr}");
}

/// A file named `.mcap` that is no recording (a CSV renamed, random bytes) was said to be "cut
/// short after N bytes ... Bad magic number" by identify, fit, replay and sim replay: a recording
/// to mend, where there is none. It is now said not to be MCAP, with what it begins with.
#[test]
fn a_file_that_is_not_mcap_is_said_to_be_none() {
    let dir = scratch("not-mcap");
    let csv = dir.join("data.mcap");
    std::fs::write(&csv, "t,deflection,torque\n0,0,0\n0.01,0.001,0.1\n").unwrap();
    let noise = dir.join("noise.mcap");
    std::fs::write(&noise, [0x96u8, 0xca, 0xfd, 0x80, 0xcb, 0xcb, 0xe3, 0x11, 0x00, 0x01]).unwrap();
    for (file, expected) in [(&csv, "not an MCAP file: it does not begin with MCAP's magic bytes but with text, `t,deflection,torque"), (&noise, "but with the bytes 96 ca fd 80 cb cb e3 11")] {
        for args in [&["identify", "--joint", "q2", "--data"][..], &["fit", "--joint", "q2"][..]] {
            let out = Command::new(jointctl()).args(args).arg(file).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(out.status.code() == Some(1) && err.contains(expected) && !err.contains("cut short"), "{args:?} {}: {err}", file.display());
        }
    }
}

/// Issue 40, finding 11: `record` killed with SIGKILL left a file that `fit`, `identify` and
/// `replay` called "not a readable MCAP file" and recovered nothing of, where a streaming reader
/// recovered 205 of ~260 cycles. Now every reader takes the file up to its last complete chunk
/// and says once what was lost. Cut here twice: by killing the recorder (its moment set by the
/// machine's load) and at random byte offsets of a complete recording (what a kill leaves: the
/// recorder writes its file front to back). `identify` on each cut uses the samples the reader
/// gives, or exits 1 naming the file and why (too few samples, nothing before the first chunk).
#[test]
fn a_recording_cut_short_is_read_up_to_its_last_complete_chunk() {
    let arm = arm_name("record-killed");
    let config = sherpa_with("record-killed", &arm, &[]);
    let mut run = spawn_run(&config);
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the runtime is up: {}", String::from_utf8_lossy(&up.stderr));
    let killed = scratch("record-killed-out").join("killed.mcap");
    let mut record = Command::new(jointctl()).args(["record", "--arm", &arm, "--duration", "60", "--out"]).arg(&killed).stdout(Stdio::null()).spawn().unwrap();
    let cmd = Command::new(jointctl()).args(["cmd", "torque", "q2", "--sine", "5", "--freq", "1", "--arm", &arm]).output().unwrap();
    assert!(cmd.status.success(), "{}", String::from_utf8_lossy(&cmd.stderr));
    std::thread::sleep(std::time::Duration::from_secs(6));
    record.kill().unwrap();
    record.wait().unwrap();
    stop(&mut run);
    // `identify` reads it too, alone and with the arm description (which also reads the
    // attachment the cut left): it says once that the file was cut and identifies on the rest.
    let mut identified = Vec::new();
    for with_config in [&[][..], &["--config".as_ref(), config.as_os_str()][..]] {
        let out = Command::new(jointctl()).args(["identify", "--joint", "q2", "--json", "--data"]).arg(&killed).args(with_config).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "identify {with_config:?}: {err}");
        assert_eq!(err.matches("the recording was cut short").count(), 1, "one warning: {err}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
        identified.push(v["samples"].as_u64().unwrap() as usize);
    }
    let replay = Command::new(jointctl()).arg("replay").arg(&killed).arg("--config").arg(&config).arg("--json").output().unwrap();
    let err = String::from_utf8_lossy(&replay.stderr);
    assert!(replay.status.success(), "{err}");
    assert!(err.contains("cut short") && err.matches("cut short").count() == 1, "one warning: {err}");
    let q2 = jointctl_record::reader::joint_series(&killed, "q2").unwrap();
    assert!(q2.t_s.len() >= 80, "at least two of the six seconds at 40 Hz are read: {}", q2.t_s.len());
    let fit = Command::new(jointctl()).arg("fit").arg(&killed).args(["--joint", "q2", "--order", "1"]).output().unwrap();
    assert!(fit.status.success(), "{}", String::from_utf8_lossy(&fit.stderr));
    let measured = jointctl_record::reader::measured(&killed, "q2").unwrap().t_s.len();
    assert!(measured >= 80 && identified.iter().all(|n| *n == measured), "identify used {identified:?} samples, the reader gives {measured}");

    let (file, _, _) = record_sine("record-cut");
    let bytes = std::fs::read(&file).unwrap();
    let whole = jointctl_record::reader::joint_series(&file, "q2").unwrap().t_s.len();
    let mut rng = jointctl_test_support::XorShift64::new(0x005e_ed0f_c075);
    let random = (0..5).map(|_| (bytes.len() as f64 * rng.range(0.3, 0.999)) as usize);
    // Finding: a cut between two records (the start of a chunk; a kill lands there when the
    // recorder has just written one) ended the reader's stream without an error, so the cut was
    // not said, and a cut right after the header read as a file without the joint.
    let records = mcap_record_starts(&bytes);
    let chunks: Vec<usize> = records.iter().filter(|&&(_, opcode)| opcode == MCAP_CHUNK).map(|&(at, _)| at).collect();
    assert!(chunks.len() >= 2, "a 3 s recording has several chunks: {records:?}");
    // A cut after the data section's end (in the summary the recorder writes last) loses no
    // message: each sample is read, and the cut is said without "the rest is lost".
    let data_end = records.iter().position(|&(_, opcode)| opcode == MCAP_DATA_END).expect("a complete file has its DataEnd record");
    let summary = &records[data_end + 1..];
    assert!(!summary.is_empty(), "a summary follows the data: {records:?}");
    // Its first record, one in its middle and the footer.
    let in_summary: Vec<usize> = [0, summary.len() / 2, summary.len() - 1].iter().map(|&i| summary[i].0).collect();
    for (k, at) in random.chain(chunks).chain(in_summary.iter().copied()).enumerate() {
        let cut = scratch("record-cut-out").join(format!("cut{k}.mcap"));
        std::fs::write(&cut, &bytes[..at]).unwrap();
        // `identify` on the same cut: the part the reader gives, or exit 1 naming the file and
        // why (too few samples, nothing before the first complete chunk); never "not a readable
        // MCAP file", never a panic, and always once that the file was cut.
        let ident = Command::new(jointctl()).args(["identify", "--joint", "q2", "--json", "--data"]).arg(&cut).output().unwrap();
        let ident_err = String::from_utf8_lossy(&ident.stderr);
        assert!(matches!(ident.status.code(), Some(0 | 1)) && !ident_err.contains("not a readable MCAP"), "cut at byte {at}: {:?} {ident_err}", ident.status);
        assert!(ident.status.success() || ident_err.contains(&format!("error: {}", cut.display())), "cut at byte {at}: {ident_err}");
        assert_eq!(ident_err.matches("the recording was cut short").count(), 1, "cut at byte {at}: {ident_err}");
        if in_summary.contains(&at) {
            assert!(!ident_err.contains("the rest is lost"), "cut at byte {at}, after the data: {ident_err}");
            assert_eq!(jointctl_record::reader::joint_series(&cut, "q2").map(|s| s.t_s.len()).ok(), Some(whole), "cut at byte {at}, after the data");
        }
        match jointctl_record::reader::joint_series(&cut, "q2") {
            Ok(s) => assert!(s.t_s.len() <= whole && s.t_s.windows(2).all(|w| w[1] > w[0]), "cut at byte {at} of {}", bytes.len()),
            // Cut before the first chunk was complete: said so, not "not a readable MCAP file".
            Err(e) => assert!(e.to_string().contains("before its first complete chunk"), "cut at byte {at}: {e}"),
        }
        match jointctl_record::reader::measured(&cut, "q2") {
            Ok(m) if ident.status.success() => {
                let v: serde_json::Value = serde_json::from_slice(&ident.stdout).expect("one JSON object");
                assert_eq!(v["samples"].as_u64(), Some(m.t_s.len() as u64), "cut at byte {at}");
            }
            // The reader gave samples and identify refused them: too few, or too little motion.
            Ok(_) => assert!(ident_err.contains("too few to identify") || ident_err.contains("too little excitation"), "cut at byte {at}: {ident_err}"),
            Err(_) => assert!(!ident.status.success() && ident_err.contains("before its first complete chunk"), "cut at byte {at}: {ident_err}"),
        }
        let replay = Command::new(jointctl()).arg("replay").arg(&cut).arg("--json").output().unwrap();
        let err = String::from_utf8_lossy(&replay.stderr);
        assert!(!err.contains("not a readable MCAP") && !err.contains("panicked"), "cut at byte {at}: {err}");
    }
}

/// MCAP's chunk record (the specification's opcode 0x06).
const MCAP_CHUNK: u8 = 0x06;
/// MCAP's data-end record (0x0F): the data section ends, the summary follows.
const MCAP_DATA_END: u8 = 0x0F;

/// Where each top-level record of a complete MCAP file starts, and its opcode: after the 8-byte
/// magic, each record is an opcode byte, a little-endian u64 length and that many bytes, up to
/// the closing 8-byte magic.
fn mcap_record_starts(bytes: &[u8]) -> Vec<(usize, u8)> {
    let mut starts = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        starts.push((at, bytes[at]));
        at += 9 + len;
    }
    assert_eq!(at, bytes.len() - 8, "the records end at the closing magic: {starts:?}");
    starts
}

/// Issue 40, finding 11 (its second half): a recording that filled the disk exited 1 with a
/// clear message, but `--json` printed no summary and the file was unreadable. Two ways a disk
/// fills: `/dev/full` refuses the file's first bytes (ENOSPC), and a file-size limit
/// (RLIMIT_FSIZE, SIGXFSZ ignored, EFBIG) stops it part way. Each exits 1 with the reason and
/// prints its summary; the part-way file is read back up to its last complete chunk.
#[test]
fn a_recording_that_fills_the_disk_prints_its_summary_and_the_reason() {
    use std::os::unix::process::CommandExt as _;
    let arm = arm_name("record-full");
    let config = sherpa_with("record-full", &arm, &[]);
    let mut run = spawn_run(&config);
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the runtime is up: {}", String::from_utf8_lossy(&up.stderr));
    let full = Command::new(jointctl()).args(["record", "--arm", &arm, "--duration", "20", "--json", "--out", "/dev/full"]).output().unwrap();
    let limited = scratch("record-full-out").join("limited.mcap");
    let mut record = Command::new(jointctl());
    record.args(["record", "--arm", &arm, "--duration", "20", "--json", "--out"]).arg(&limited);
    // SAFETY: between fork and exec only async-signal-safe calls (signal, setrlimit).
    unsafe {
        record.pre_exec(|| {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let limit = libc::rlimit { rlim_cur: 100_000, rlim_max: 100_000 };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let part_way = record.output().unwrap();
    stop(&mut run);
    for (out, reason, taken) in [(&full, "No space left on device", false), (&part_way, "File too large", true)] {
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(reason) && err.contains("the recording stopped after"), "{err}");
        let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("one JSON summary ({e}): {}", String::from_utf8_lossy(&out.stdout)));
        assert!(summary["error"].as_str().is_some_and(|e| e.contains(reason)), "{summary}");
        let states = summary["messages"]["joint_state"].as_u64().unwrap();
        assert_eq!(states > 0, taken, "{summary}");
        assert!(summary["duration_s"].as_f64().is_some_and(|d| d < 20.0), "{summary}");
    }
    let q2 = jointctl_record::reader::joint_series(&limited, "q2").unwrap();
    assert!(!q2.t_s.is_empty(), "the part-way file is read up to its last complete chunk");
}
