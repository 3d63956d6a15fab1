//! Across processes: `jointctl run` publishes, an inspector process reads; SIGINT shuts down
//! cleanly; `jointctl check` exit codes.

use std::io::Read;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use jointctl_tests::{arm_name, jointctl, rig_yaml, scratch, stop};

const ELASTIC: &str = "  - name: b\n    plugin: elastic\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {stiffness_nm_per_rad: 113.78, output_per_motor: 2.0, position_pi: {kp: 0.2, ki: 0.5}}\n";

fn write_rig(test: &str, rate_hz: f64) -> (String, std::path::PathBuf) {
    let arm = arm_name(test);
    let dir = scratch(test);
    let yaml = dir.join("rig.yaml");
    std::fs::write(&yaml, rig_yaml(&arm, rate_hz, ELASTIC)).unwrap();
    (arm, yaml)
}

fn spawn_run(yaml: &std::path::Path, extra: &[&str]) -> Child {
    Command::new(jointctl())
        .arg("run")
        .arg(yaml)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn jointctl run")
}

fn wait_with_timeout(child: &mut Child, timeout: Duration) -> Option<std::process::ExitStatus> {
    let t = Instant::now();
    while t.elapsed() < timeout {
        if let Some(s) = child.try_wait().unwrap() {
            return Some(s);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    None
}

fn stderr_of(child: &mut Child) -> String {
    let mut s = String::new();
    child.stderr.take().unwrap().read_to_string(&mut s).unwrap();
    s
}

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

/// Finding: a fault's reason reached the log only, and commands left no trace there. Pass:
/// `inspect diag --json` carries the plugin's reason with the fault code; the runtime logs the
/// fault and every accepted and refused command at `RUST_LOG=info`, from its publisher thread.
#[test]
fn fault_reasons_reach_diagnostics_and_commands_are_logged() {
    let arm = arm_name("fault-log");
    let yaml = scratch("fault-log").join("rig.yaml");
    let faulty = "  - name: b\n    plugin: faulty\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {panic_in_observe_at: 5}\n";
    std::fs::write(&yaml, rig_yaml(&arm, 100.0, faulty)).unwrap();
    let mut run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--duration", "30"]).env("RUST_LOG", "info").stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let mut fault_message = String::new();
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(10) {
        let out = Command::new(jointctl()).args(["inspect", "diag", "--arm", &arm, "--json", "--timeout", "10"]).output().unwrap();
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
        if v["joints"][1]["fault_code"] == 1 {
            fault_message = v["joints"][1]["fault_message"].as_str().unwrap_or_default().to_string();
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let accepted = Command::new(jointctl()).args(["cmd", "--arm", &arm, "position", "a", "0.1"]).output().unwrap();
    let refused = Command::new(jointctl()).args(["cmd", "--arm", &arm, "position", "b", "0.1"]).output().unwrap();
    // SAFETY: signalling our own child.
    unsafe { libc::kill(run.id() as i32, libc::SIGINT) };
    let _ = wait_with_timeout(&mut run, Duration::from_secs(5));
    let log = stderr_of(&mut run);
    assert!(fault_message.contains("deliberate panic in observe at cycle 5"), "the plugin's reason: `{fault_message}`");
    assert!(accepted.status.success() && !refused.status.success());
    assert!(log.contains("joint faulted and is held") && log.contains("deliberate panic in observe"), "{log}");
    assert!(log.lines().any(|l| l.contains("accepted:") && l.contains("command=\"position\"") && l.contains("joint=\"a\"")), "{log}");
    assert!(log.contains("refused: joint `b` is faulted"), "{log}");
}

/// Finding: SIGHUP (an SSH disconnect), SIGQUIT and SIGUSR1 ended the runtime without holding
/// the joints, without a final sample, leaving stale shared memory. Pass, for every terminating
/// signal: exit 0 within 5 s, "joints held" logged with the signal's name, a final sample
/// published, and the same arm starts again at once (shared memory and lock released).
fn a_signal_holds_the_joints_publishes_a_final_state_and_releases_shared_memory(signal: i32, name: &str) {
    let (arm, yaml) = write_rig(&format!("signal-{signal}"), 200.0);
    let mut run = spawn_run(&yaml, &[]);
    // Subscribe from this process and wait for the loop to publish.
    let node = jointctl_ipc::create_node(None, &format!("test-sub-{}-{signal}", std::process::id())).unwrap();
    let names = jointctl_ipc::ServiceNames::for_arm(&arm);
    let t = Instant::now();
    let sub = loop {
        if let Ok(s) = jointctl_ipc::joint_state_service(&node, &names.joint_state) {
            break s.subscriber_builder().create().unwrap();
        }
        assert!(t.elapsed() < Duration::from_secs(10), "the arm never created its service");
        std::thread::sleep(Duration::from_millis(20));
    };
    let t = Instant::now();
    while sub.receive().unwrap().is_none() {
        assert!(t.elapsed() < Duration::from_secs(10), "no sample");
        std::thread::sleep(Duration::from_millis(5));
    }
    let sent = Instant::now();
    // SAFETY: sending a signal to our own child.
    unsafe { libc::kill(run.id() as i32, signal) };
    let status = wait_with_timeout(&mut run, Duration::from_secs(5)).expect("stops within 5 s of the signal");
    eprintln!("{name}: the runtime ended {:.0} ms after the signal", sent.elapsed().as_secs_f64() * 1e3);
    let log = stderr_of(&mut run);
    assert!(status.success(), "{name}: exit {status:?}: {log}");
    assert!(log.contains("loop stopped, joints held"), "{name}: {log}");
    assert!(log.contains(&format!("signal={name}")), "{name}: {log}");
    let mut saw_final = false;
    while let Some(s) = sub.receive().unwrap() {
        saw_final |= s.final_sample == 1;
    }
    assert!(saw_final, "{name}: a final state was published at shutdown");
    drop(sub);
    // Released: the same arm can start again at once.
    let again = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    assert!(again.status.success(), "{name}: {}", String::from_utf8_lossy(&again.stderr));
}

macro_rules! signal_tests {
    ($($test:ident: $signal:ident,)*) => {$(
        #[test]
        fn $test() {
            a_signal_holds_the_joints_publishes_a_final_state_and_releases_shared_memory(libc::$signal, stringify!($signal));
        }
    )*};
}

signal_tests! {
    sigint_holds_the_joints: SIGINT,
    sigterm_holds_the_joints: SIGTERM,
    sighup_holds_the_joints: SIGHUP,
    sigquit_holds_the_joints: SIGQUIT,
    sigusr1_holds_the_joints: SIGUSR1,
    sigusr2_holds_the_joints: SIGUSR2,
    sigalrm_holds_the_joints: SIGALRM,
    // Issue 40, finding 18: sent with `kill`, SIGSEGV and SIGBUS were ignored (the run went on to
    // its --duration) and the others ended the runtime without holding the joints.
    sigsegv_sent_by_kill_holds_the_joints: SIGSEGV,
    sigbus_sent_by_kill_holds_the_joints: SIGBUS,
    sigill_sent_by_kill_holds_the_joints: SIGILL,
    sigfpe_sent_by_kill_holds_the_joints: SIGFPE,
    sigtrap_sent_by_kill_holds_the_joints: SIGTRAP,
    sigsys_sent_by_kill_holds_the_joints: SIGSYS,
    sigabrt_sent_by_kill_holds_the_joints: SIGABRT,
}

/// Finding: with `hal: socketcan`, a second runtime built and activated the HAL (an NMT
/// broadcast to every drive) before it found the arm already running. Pass: a second runtime of
/// a running arm, configured for a CAN interface that does not exist, is refused as "already
/// running": it never got as far as opening the bus (which would have failed first).
#[test]
fn a_second_runtime_is_refused_before_it_opens_the_hardware() {
    let (arm, yaml) = write_rig("lock-first", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let can_yaml = yaml.with_file_name("can.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&can_yaml, jointctl_tests::yaml_with(&text, &[
        jointctl_tests::Edit::Set("hal.backend", "socketcan".into()),
        jointctl_tests::Edit::Set("buses.can[0].interface", "jcnone0".into()),
    ])).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    stop(&mut first);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("arm `{arm}` is already running (process {})", first.id())), "{err}");
    assert!(!err.contains("jcnone0"), "the bus was never opened: {err}");
    // Alone, the same config does try the bus: the refusal above came before it.
    let alone = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    assert!(String::from_utf8_lossy(&alone.stderr).contains("jcnone0"), "{}", String::from_utf8_lossy(&alone.stderr));
}

/// Finding: a plugin panic stalled the loop ~200 ms with `RUST_BACKTRACE=1` (the backtrace was
/// printed on the control thread). Pass: with `RUST_BACKTRACE=1`, a plugin that panics in a
/// cycle prints no panic message or backtrace (its message reaches the log through the fault
/// report, outside the timed cycle) and the loop has no overrun.
#[test]
fn a_plugin_panic_prints_nothing_on_the_control_thread() {
    let arm = arm_name("quiet-panic");
    let dir = scratch("quiet-panic");
    let yaml = dir.join("rig.yaml");
    let faulty = "  - name: b\n    plugin: faulty\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {panic_in_observe_at: 20}\n";
    std::fs::write(&yaml, rig_yaml(&arm, 100.0, faulty)).unwrap();
    let out = Command::new(jointctl())
        .arg("run")
        .arg(&yaml)
        .args(["--cycles", "60", "--no-ipc"])
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("deliberate panic in observe at cycle 20"), "the fault is reported: {err}");
    assert!(!err.contains("panicked at") && !err.contains("stack backtrace"), "nothing printed by a panic hook: {err}");
    assert!(err.contains("60 cycles, 0 overruns"), "{err}");
}

#[test]
fn a_second_runtime_of_the_same_arm_is_refused() {
    let (_, yaml) = write_rig("twice", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let second = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    stop(&mut first);
    assert_eq!(second.status.code(), Some(1));
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(err.contains("is already running"), "{err}");
}

#[test]
fn check_exit_codes() {
    let (_, yaml) = write_rig("check", 40.0);
    let ok = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
    assert_eq!(ok.status.code(), Some(0), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(String::from_utf8_lossy(&ok.stdout).contains("OK, 40 Hz, 2 joint(s)"));

    let broken = yaml.with_file_name("broken.yaml");
    let text = jointctl_tests::replace_once(&std::fs::read_to_string(&yaml).unwrap(), "rate_hz: 40", "rate_hz: -1");
    std::fs::write(&broken, text).unwrap();
    let bad = Command::new(jointctl()).arg("check").arg(&broken).output().unwrap();
    assert_eq!(bad.status.code(), Some(1));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("broken.yaml:2:10: rate_hz: must be in [1, 10000] Hz, got -1"), "{err}");

    let missing = Command::new(jointctl()).args(["check", "/nonexistent/arm.yaml"]).output().unwrap();
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("cannot read the config"));

    let usage = Command::new(jointctl()).args(["check"]).output().unwrap();
    assert_eq!(usage.status.code(), Some(2), "missing argument is a usage error");
}

#[test]
fn the_reference_sherpa_config_checks() {
    let cfg = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let out = Command::new(jointctl()).arg("check").arg(&cfg).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let dofs: Vec<&str> = text.lines().filter_map(|l| l.split_once(" DOF ")).flat_map(|(_, d)| d.split(", ")).collect();
    assert_eq!(dofs, ["q1", "q2", "q3", "q4", "q5", "q6", "q7"], "{text}");
    for plugin in ["rigid", "vsa_shoulder", "elastic", "vsa_wrist"] {
        assert!(text.contains(&format!("plugin {plugin}")), "{text}");
    }
}

#[test]
fn the_committed_schema_is_up_to_date() {
    let committed = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/jointctl.schema.json");
    let out = Command::new(jointctl()).arg("schema").output().unwrap();
    let current = String::from_utf8(out.stdout).unwrap();
    let saved = std::fs::read_to_string(&committed).unwrap_or_default();
    assert_eq!(saved.trim(), current.trim(), "regenerate with: jointctl schema > configs/jointctl.schema.json");
}

#[test]
fn check_prints_the_can_bus_budget_and_refuses_a_rate_the_bus_cannot_carry() {
    let cfg = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm_socketcan.yaml");
    let out = Command::new(jointctl()).arg("check").arg(&cfg).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    // 9 drives: 9 RPDO + 9 TPDO + 1 SYNC per cycle; 6-byte PDOs 95-115 bits, SYNC 55-65 bits;
    // heartbeats: 9 drives at 100 ms and the host's at 50 ms (which the drives consume).
    assert!(text.contains("can0: 9 drives at 1000 kbit/s: 19 frames per cycle (1765-2135 bits) + 110 heartbeats/s"), "{text}");
    assert!(text.contains("highest loop rate 465 Hz"), "{text}");
    let fast = scratch("budget").join("fast.yaml");
    std::fs::write(&fast, jointctl_tests::replace_once(&std::fs::read_to_string(&cfg).unwrap(), "rate_hz: 40 ", "rate_hz: 1000 ")).unwrap();
    let out = Command::new(jointctl()).arg("check").arg(&fast).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("rate_hz: the CAN bus cannot carry this rate") && err.contains("load 214.2 %"), "{err}");
}

/// Finding: `check` passed what `run` refused (a simulation matrix of the wrong shape). Pass:
/// both refuse it with the same located message; `check` builds the simulated backend as `run`
/// does (it touches no hardware).
#[test]
fn check_refuses_what_run_refuses() {
    let (_, yaml) = write_rig("check-run", 100.0);
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set(
        "joints[b].sim",
        serde_yaml::from_str("{drives: [m1], matrix: [[2.0, 1.0]]}").unwrap(),
    )])).unwrap();
    let check = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
    let run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3", "--no-ipc"]).output().unwrap();
    let (check_err, run_err) = (String::from_utf8_lossy(&check.stderr), String::from_utf8_lossy(&run.stderr));
    assert_eq!(run.status.code(), Some(1), "{run_err}");
    assert_eq!(check.status.code(), Some(1), "check must refuse it too: {}{check_err}", String::from_utf8_lossy(&check.stdout));
    let message = |s: &str| s.lines().find(|l| l.starts_with("error:")).map(str::to_string);
    assert_eq!(message(&check_err), message(&run_err));
    assert!(check_err.contains("joints[1].sim"), "{check_err}");
}

/// Finding: 16 idle clients locked out `jointctl cmd stop` (`ExceedsMaxSupportedClients`),
/// 16 idle subscribers locked out `inspect`. Pass: with every client slot taken, `cmd stop`
/// still stops the runtime (it signals it) and the runtime ends cleanly, joints held; with
/// every subscriber slot taken, `inspect` says which limit to raise; and `ipc.max_subscribers`
/// in the YAML raises it.
#[test]
fn idle_clients_cannot_lock_out_stop_and_the_limits_come_from_yaml() {
    let (arm, yaml) = write_rig("lockout", 100.0);
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", serde_yaml::from_str("{max_clients: 3, max_subscribers: 2}").unwrap())])).unwrap();
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let node = jointctl_ipc::create_node(None, &format!("lockout-{}", std::process::id())).unwrap();
    let names = jointctl_ipc::ServiceNames::for_arm(&arm);
    let t = Instant::now();
    let state = loop {
        if let Ok(s) = jointctl_ipc::joint_state_service(&node, &names.joint_state) {
            break s;
        }
        assert!(t.elapsed() < Duration::from_secs(10), "the arm never came up");
        std::thread::sleep(Duration::from_millis(20));
    };
    // Idle subscribers take every slot: inspect is refused with the limit's name.
    let idle_subs: Vec<_> = (0..2).map(|_| state.subscriber_builder().create().unwrap()).collect();
    let out = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--count", "1", "--timeout", "2"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("every subscriber slot") && err.contains("ipc.max_subscribers"), "{err}");
    drop(idle_subs);
    // Idle clients take every slot: a command is refused with the limit's name, a stop is not.
    let command = jointctl_ipc::command_service(&node, &jointctl_ipc::command_service_name(&arm), None).unwrap();
    let idle_clients: Vec<_> = (0..3).map(|_| command.client_builder().create().unwrap()).collect();
    let out = Command::new(jointctl()).args(["cmd", "--arm", &arm, "hold"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("ipc.max_clients"), "{}", String::from_utf8_lossy(&out.stderr));
    let out = Command::new(jointctl()).args(["cmd", "--arm", &arm, "stop"]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}{}", String::from_utf8_lossy(&out.stderr));
    assert!(said.contains(&format!("sent SIGTERM to the runtime, process {}", run.id())), "{said}");
    let status = wait_with_timeout(&mut run, Duration::from_secs(5)).expect("the runtime stops");
    let log = stderr_of(&mut run);
    assert!(status.success() && log.contains("loop stopped, joints held") && log.contains("signal=SIGTERM"), "{log}");
    drop(idle_clients);
}

/// Runs `jointctl` as user `nobody` (uid 65534), as another local user would.
fn jointctl_as_nobody(args: &[&str]) -> std::process::Output {
    Command::new("setpriv").args(["--reuid=65534", "--regid=65534", "--clear-groups"]).arg(jointctl()).args(args).output().expect("setpriv")
}

/// Finding: any local user could lock everyone out of the arm (the domain's management file
/// in /dev/shm was mode 0666; overwriting it made every `cmd`, `inspect` and `run` fail with
/// `UnableToGenerateUniqueNodeId`), and another user's permission failures read
/// "InternalError". Pass, with `ipc: {domain, root}` in the YAML: the root folder is 0700 and
/// the management segment 0600 while the arm runs; another user can neither overwrite the
/// segment nor attach, and is told which file belongs to whom; the owner still commands the arm;
/// a segment another user planted for a domain is refused with that reason. Needs root (to act
/// as `nobody`), which CI has.
#[test]
fn another_user_can_neither_tamper_with_nor_squat_the_shared_memory() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    if jointctl_ipc::access::effective_uid() != 0 {
        eprintln!("skipped: needs root to act as another user");
        return;
    }
    let (arm, yaml) = write_rig("tamper", 100.0);
    let domain = format!("sec{}", std::process::id());
    let root = yaml.parent().unwrap().join("ipc-root");
    let text = std::fs::read_to_string(&yaml).unwrap();
    let ipc: serde_yaml::Value = serde_yaml::from_str(&format!("{{domain: {domain}, root: {}}}", root.display())).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", ipc)])).unwrap();
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let scope = jointctl_ipc::IpcScope { domain: Some(domain.clone()), root: Some(root.clone()), group: None };
    let node = jointctl_ipc::create_node_in(&scope, "tamper-watch").unwrap();
    let t = Instant::now();
    while jointctl_ipc::joint_state_service(&node, &jointctl_ipc::ServiceNames::for_arm(&arm).joint_state).is_err() {
        assert!(t.elapsed() < Duration::from_secs(10), "the arm never came up");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(std::fs::metadata(&root).unwrap().permissions().mode() & 0o777, 0o700, "root folder owner-only");
    let segment = jointctl_ipc::access::management_segment(&domain).expect("the domain's management segment");
    assert_eq!(std::fs::metadata(&segment).unwrap().mode() & 0o777, 0o600, "{}", segment.display());
    // Another user cannot overwrite it...
    let tamper = Command::new("setpriv")
        .args(["--reuid=65534", "--regid=65534", "--clear-groups", "sh", "-c"])
        .arg(format!("printf 0123456789abcdef > {}", segment.display()))
        .output()
        .unwrap();
    assert!(!tamper.status.success(), "another user overwrote {}", segment.display());
    // ...nor attach, and is told why.
    let root_arg = root.display().to_string();
    let out = jointctl_as_nobody(&["inspect", "echo", "--arm", &arm, "--domain", &domain, "--ipc-root", &root_arg, "--count", "1", "--timeout", "1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("{} belongs to uid 0 (mode 0600), this process is uid 65534: permission denied", segment.display())), "{err}");
    // The owner still commands the arm.
    let out = Command::new(jointctl()).args(["cmd", "--arm", &arm, "--domain", &domain, "--ipc-root", &root_arg, "hold"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    stop(&mut run);
    // A segment planted by another user for a domain is refused, with whose it is.
    let planted_domain = format!("sq{}", std::process::id());
    let hash_and_rest = segment.file_name().unwrap().to_str().unwrap().strip_prefix(&domain).unwrap().to_string();
    let planted = std::path::Path::new("/dev/shm").join(format!("{planted_domain}{hash_and_rest}"));
    let plant = Command::new("setpriv")
        .args(["--reuid=65534", "--regid=65534", "--clear-groups", "sh", "-c"])
        .arg(format!("umask 0; printf 0123456789abcdef > {}", planted.display()))
        .output()
        .unwrap();
    assert!(plant.status.success(), "{}", String::from_utf8_lossy(&plant.stderr));
    let ipc: serde_yaml::Value = serde_yaml::from_str(&format!("{{domain: {planted_domain}, root: {}}}", root.display())).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", ipc)])).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    let _ = std::fs::remove_file(&planted);
    jointctl_tests::forget_test_domain(&domain);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("belongs to uid 65534") && err.contains("another user created this domain's management segment"), "{err}");
}

/// Subscribes to a running arm's diagnostics from this process, waiting for the arm to come up.
fn diagnostics_of(node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>, arm: &str) -> iceoryx2::port::subscriber::Subscriber<iceoryx2::prelude::ipc::Service, jointctl_ipc::Diagnostics, ()> {
    let names = jointctl_ipc::ServiceNames::for_arm(arm);
    let t = Instant::now();
    loop {
        if let Ok(s) = jointctl_ipc::diagnostics_service(node, &names.diagnostics) {
            return s.subscriber_builder().create().unwrap();
        }
        assert!(t.elapsed() < Duration::from_secs(10), "the arm never came up");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The newest diagnostics sample, waiting up to 5 s for one.
fn latest_diagnostics(sub: &iceoryx2::port::subscriber::Subscriber<iceoryx2::prelude::ipc::Service, jointctl_ipc::Diagnostics, ()>) -> jointctl_ipc::Diagnostics {
    let t = Instant::now();
    let mut last = None;
    loop {
        while let Some(s) = sub.receive().unwrap() {
            last = Some(*s);
        }
        if let Some(d) = last {
            return d;
        }
        assert!(t.elapsed() < Duration::from_secs(5), "no diagnostics");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Fault suite: an inspector stopped (SIGSTOP) and then killed (SIGKILL). Pass: the loop never
/// waits for it (no record dropped between loop and publisher, the cycle counter advances at the
/// loop rate while it is stopped), and its subscriber slot is reclaimed after the kill, so a new
/// inspector gets in even with `ipc.max_subscribers: 2`.
#[test]
fn a_stopped_or_killed_inspector_never_stalls_the_loop_or_keeps_its_slot() {
    let (arm, yaml) = write_rig("stopped-inspector", 200.0);
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", serde_yaml::from_str("{max_subscribers: 2}").unwrap())])).unwrap();
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let node = jointctl_ipc::create_node(None, &format!("inspector-fault-{}", std::process::id())).unwrap();
    let diag = diagnostics_of(&node, &arm);
    let mut inspector = Command::new(jointctl())
        .args(["inspect", "echo", "--arm", &arm, "--json", "--timeout", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: signals to our own children.
    unsafe { libc::kill(inspector.id() as i32, libc::SIGSTOP) };
    let before = latest_diagnostics(&diag);
    std::thread::sleep(Duration::from_secs(2));
    let during = latest_diagnostics(&diag);
    let cycles = during.cycle - before.cycle;
    eprintln!("inspector stopped 2 s: {cycles} cycles at 200 Hz, {} publish drops, overruns {} -> {}", during.publish_drops, before.overruns, during.overruns);
    assert!(cycles >= 360, "the loop ran {cycles} cycles in 2 s at 200 Hz while the inspector was stopped");
    assert_eq!(during.publish_drops, 0, "the publisher thread never fell behind");
    // The joint-state service admits 2 subscribers: the stopped inspector holds one.
    // SAFETY: a signal to our own child.
    unsafe { libc::kill(inspector.id() as i32, libc::SIGKILL) };
    let _ = inspector.wait();
    let mut second = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--timeout", "20"]).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    let third = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "3", "--timeout", "5"]).output().unwrap();
    stop(&mut second);
    stop(&mut run);
    assert!(third.status.success(), "the killed inspector's slot was reclaimed: {}", String::from_utf8_lossy(&third.stderr));
    assert_eq!(String::from_utf8_lossy(&third.stdout).lines().count(), 3);
}

/// Fault suite: a command flood (4 clients, each with 4 requests in flight, for 3 s). Pass:
/// every request is answered (accepted, or refused with a reason such as a full queue), the loop
/// keeps its rate (>= 95 % of 100 Hz x elapsed) and the command after the flood takes effect.
#[test]
fn a_command_flood_is_answered_and_does_not_slow_the_loop() {
    let (arm, yaml) = write_rig("flood", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let node = jointctl_ipc::create_node(None, &format!("flood-{}", std::process::id())).unwrap();
    let diag = diagnostics_of(&node, &arm);
    let service = jointctl_ipc::command_service(&node, &jointctl_ipc::command_service_name(&arm), None).unwrap();
    let clients: Vec<_> = (0..4).map(|_| service.client_builder().create().unwrap()).collect();
    let before = latest_diagnostics(&diag);
    let t0 = Instant::now();
    let (mut sent, mut answered, mut accepted, mut full) = (0u64, 0u64, 0u64, 0u64);
    while t0.elapsed() < Duration::from_secs(3) {
        let mut pending = Vec::new();
        for client in &clients {
            for _ in 0..4 {
                let target = if sent % 2 == 0 { 0.2 } else { -0.2 };
                pending.push(client.send_copy(jointctl_ipc::CommandRequest::new(jointctl_ipc::CommandKind::POSITION, "a", &[target])).unwrap());
                sent += 1;
            }
        }
        let t = Instant::now();
        for p in &pending {
            loop {
                if let Some(r) = p.receive().unwrap() {
                    answered += 1;
                    accepted += u64::from(r.accepted);
                    full += u64::from(r.text().contains("queue is full"));
                    assert!(r.accepted == 1 || r.text().contains("queue is full"), "{}", r.text());
                    break;
                }
                assert!(t.elapsed() < Duration::from_secs(2), "request {sent} got no answer");
                std::thread::sleep(Duration::from_micros(200));
            }
        }
    }
    let elapsed = t0.elapsed().as_secs_f64();
    let after = latest_diagnostics(&diag);
    let last = clients[0].send_copy(jointctl_ipc::CommandRequest::new(jointctl_ipc::CommandKind::POSITION, "a", &[0.3])).unwrap();
    while last.receive().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(1));
    }
    let watch = jointctl_ipc::joint_state_service(&node, &jointctl_ipc::ServiceNames::for_arm(&arm).joint_state).unwrap().subscriber_builder().create().unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let mut q = f64::NAN;
    while let Some(s) = watch.receive().unwrap() {
        q = s.joints[0].position_rad;
    }
    stop(&mut run);
    eprintln!(
        "flood: {sent} requests in {elapsed:.1} s, {answered} answered, {accepted} accepted, {full} refused (queue full); loop {} cycles, overruns {} -> {}, missed deadlines {} -> {}",
        after.cycle - before.cycle,
        before.overruns,
        after.overruns,
        before.missed_deadlines,
        after.missed_deadlines
    );
    assert_eq!(answered, sent);
    assert!((after.cycle - before.cycle) as f64 >= 0.95 * 100.0 * elapsed, "{} cycles in {elapsed:.2} s", after.cycle - before.cycle);
    assert!((q - 0.3).abs() < 0.01, "the command after the flood took effect: q = {q}");
}

/// Fault suite: SIGKILL (no handler can run), then a restart. Pass: the same arm starts again at
/// once: the lock died with the process and the dead node's shared memory is cleaned up.
#[test]
fn sigkill_then_restart() {
    let (arm, yaml) = write_rig("sigkill", 100.0);
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let node = jointctl_ipc::create_node(None, &format!("sigkill-{}", std::process::id())).unwrap();
    let diag = diagnostics_of(&node, &arm);
    latest_diagnostics(&diag);
    drop(diag);
    stop(&mut run);
    let again = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "20"]).output().unwrap();
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    assert!(String::from_utf8_lossy(&again.stderr).contains("20 cycles"));
}

/// A negative or NaN duration panicked in `Duration` (`inspect --timeout=-1`, `cmd
/// --timeout=-1`) or ended a run at once without a word (`run --duration NaN`). Pass: each is
/// refused where it is typed (exit 2) with the reason.
#[test]
fn bad_durations_are_refused_where_they_are_typed() {
    let (_, yaml) = write_rig("bad-durations", 100.0);
    let yaml = yaml.display().to_string();
    for args in [
        vec!["inspect", "echo", "--timeout=-1"],
        vec!["cmd", "--timeout=-1", "hold"],
        vec!["cmd", "--timeout", "NaN", "hold"],
        vec!["run", yaml.as_str(), "--duration", "NaN"],
        vec!["run", yaml.as_str(), "--duration=-2"],
    ] {
        let out = Command::new(jointctl()).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("must be in [0, 1e9] s") || err.contains("must be a finite number"), "{args:?}: {err}");
    }
}

/// Finding: no shell completions. Pass: `jointctl completions bash` is a script that bash
/// sources, and completing `jointctl insp` and `jointctl inspect j` gives `inspect` and `joints`.
#[test]
fn bash_completes_subcommands() {
    let script = Command::new(jointctl()).args(["completions", "bash"]).output().unwrap();
    assert!(script.status.success());
    let file = scratch("completions").join("jointctl.bash");
    std::fs::write(&file, &script.stdout).unwrap();
    let complete = |words: &[&str]| {
        let quoted: Vec<String> = words.iter().map(|w| format!("'{w}'")).collect();
        let line = words.join(" ");
        let body = format!(
            "source {}; COMP_WORDS=({}); COMP_CWORD={}; COMP_LINE='{line}'; COMP_POINT=${{#COMP_LINE}}; _jointctl jointctl \"${{COMP_WORDS[COMP_CWORD]}}\" \"${{COMP_WORDS[COMP_CWORD-1]}}\"; echo \"${{COMPREPLY[@]}}\"",
            file.display(),
            quoted.join(" "),
            words.len() - 1
        );
        let out = Command::new("bash").args(["-c", &body]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    };
    assert_eq!(complete(&["jointctl", "insp"]), "inspect");
    assert_eq!(complete(&["jointctl", "inspect", "j"]), "joints");
    let bridges = complete(&["jointctl", "bridge", ""]);
    assert!(bridges.split_whitespace().any(|w| w == "zenoh"), "{bridges}");
}

/// `inspect top` is a terminal view; piped, it says so and where the same data is, instead of
/// writing escape codes into a file.
#[test]
fn inspect_top_without_a_terminal_points_to_the_json_views() {
    let out = Command::new(jointctl()).args(["inspect", "top", "--arm", "nobody-runs-this"]).stdout(Stdio::piped()).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("needs a terminal") && err.contains("inspect joints --json"), "{err}");
}

/// The other half of finding 18's fix: a fault signal the process raises on itself (a bad
/// address, `abort`, a raised SIGILL) still ends it by its default action once the runtime's
/// handlers are installed; only a signal another process sends is a stop request. Pass: each
/// child dies by its signal, none lives on.
#[test]
fn the_processs_own_faults_still_end_it_by_default() {
    use std::os::unix::process::ExitStatusExt as _;
    if let Ok(which) = std::env::var("JOINTCTL_TEST_OWN_FAULT") {
        let _stop = jointctl_runtime::signals::StopRequest::install().unwrap();
        match which.as_str() {
            "abort" => std::process::abort(),
            // SAFETY: none: this child exists to fault on an unmapped address.
            "segv" => unsafe { std::ptr::without_provenance_mut::<u8>(8).write_volatile(1) },
            // SAFETY: raising a signal on this process.
            _ => unsafe {
                libc::raise(libc::SIGILL);
            },
        }
        std::thread::sleep(Duration::from_millis(500));
        std::process::exit(0);
    }
    for (which, signal) in [("abort", libc::SIGABRT), ("segv", libc::SIGSEGV), ("ill", libc::SIGILL)] {
        let out = Command::new(std::env::current_exe().unwrap())
            .args(["--exact", "the_processs_own_faults_still_end_it_by_default", "--nocapture", "--test-threads", "1"])
            .env("JOINTCTL_TEST_OWN_FAULT", which)
            .output()
            .unwrap();
        assert_eq!(out.status.signal(), Some(signal), "{which}: {:?} {}", out.status, String::from_utf8_lossy(&out.stderr));
    }
}

/// Issue 40, finding 18 (its leftovers): `cmd --domain` with a typo left a management segment
/// for that domain in /dev/shm, for good. Pass: a command to a domain nobody runs is refused as
/// "no runtime" and leaves no file of that domain behind.
#[test]
fn a_command_to_a_domain_nobody_runs_leaves_nothing_in_dev_shm() {
    let domain = format!("typo{}", std::process::id());
    let out = Command::new(jointctl()).args(["cmd", "enable", "q1", "--arm", "sherpa", "--domain", &domain]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no runtime is running arm `sherpa`"), "{err}");
    let left: Vec<String> = std::fs::read_dir("/dev/shm").unwrap().filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with(&domain)).collect();
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
}

/// Issue 40, finding 16: the one-runtime lock held per domain and root, and a copy of a
/// SocketCAN config in another domain went on to open `can0` beside the running arm: two hosts
/// would drive the same bus. Pass: while another process holds a CAN interface's machine-wide
/// lock, a runtime of another arm in another domain on that interface is refused, naming the
/// interface and the holder, before it opens the bus (alone, it tries the bus).
#[test]
fn a_second_runtime_on_the_same_can_interface_is_refused_whatever_its_domain() {
    let (_, yaml) = write_rig("bus-lock", 100.0);
    let interface = format!("jcb{}", std::process::id() % 100_000);
    let can_yaml = yaml.with_file_name("can.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap();
    let edited = jointctl_tests::yaml_with(&text, &[
        jointctl_tests::Edit::Set("hal.backend", "socketcan".into()),
        jointctl_tests::Edit::Set("buses.can[0].interface", interface.clone().into()),
    ]);
    std::fs::write(&can_yaml, format!("{edited}\nipc:\n  domain: other{}\n", std::process::id())).unwrap();
    let held = jointctl_runtime::lock::MachineLock::bus(&jointctl_runtime::lock::machine_lock_dir(), &interface).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    drop(held);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("CAN interface `{interface}` is driven by another runtime (process {})", std::process::id())), "{err}");
    let alone = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    jointctl_tests::forget_test_domain(&format!("other{}", std::process::id()));
    let err = String::from_utf8_lossy(&alone.stderr);
    assert!(err.contains(&interface) && !err.contains("driven by another runtime"), "{err}");
}

/// Issue 40, finding 16 (the arm half): the one-runtime lock held per domain and root, so the
/// same arm ran in two domains at once, both driving its drives. Pass: while a runtime of the
/// arm runs in its domain, a runtime of the same arm in another domain is refused, naming the
/// arm and the holder; once the first has stopped, it runs.
#[test]
fn a_second_runtime_of_the_same_arm_is_refused_whatever_its_domain() {
    let (arm, yaml) = write_rig("arm-machine-lock", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let other = yaml.with_file_name("other-domain.yaml");
    let domain = format!("other{}", std::process::id());
    std::fs::write(&other, format!("{}\nipc:\n  domain: {domain}\n", std::fs::read_to_string(&yaml).unwrap())).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&other).args(["--cycles", "3"]).output().unwrap();
    stop(&mut first);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("arm `{arm}` is already running on this machine (process {})", first.id())), "{err}");
    let alone = Command::new(jointctl()).arg("run").arg(&other).args(["--cycles", "3"]).output().unwrap();
    jointctl_tests::forget_test_domain(&domain);
    assert!(alone.status.success(), "{}", String::from_utf8_lossy(&alone.stderr));
}

/// Issue 40, finding 15: `ipc.root` in a world-writable sticky folder (`root: /tmp`) was
/// accepted; another user could make the arm's `services/`, `nodes/` and `jointctl/` folders
/// there first, open to all, and later empty `services/`, cutting `inspect` and `cmd` off the
/// running arm. Pass: a root of mode 1777 is refused before anything is created in it, naming
/// the folder and its mode; the same folder at 0700 runs.
#[test]
fn an_ipc_root_writable_by_others_is_refused_even_when_sticky() {
    use std::os::unix::fs::PermissionsExt as _;
    let (_, yaml) = write_rig("sticky-root", 100.0);
    let root = yaml.with_file_name("shared-root");
    std::fs::create_dir_all(&root).unwrap();
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&yaml, format!("{text}\nipc:\n  domain: sticky{}\n  root: {}\n", std::process::id(), root.display())).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3", "--no-ipc"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("{} is writable by other users (mode 1777)", root.display())), "{err}");
    assert_eq!(std::fs::read_dir(&root).unwrap().count(), 0, "nothing was created in it");
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o700)).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3", "--no-ipc"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
