//! Across processes: `jointctl run` publishes, an inspector process reads; SIGINT shuts down
//! cleanly; `jointctl check` exit codes.

use std::io::Read;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use jointctl_tests::{arm_name, jointctl, rig_yaml, scratch};

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
    let _ = run.kill();
    let _ = run.wait();
    assert!(out.status.success(), "inspect failed: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    let mut last_cycle = None;
    for line in lines {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let obj = v.as_object().unwrap();
        assert_eq!(obj.keys().collect::<Vec<_>>(), ["cycle", "stamp_ns", "joints"]);
        let cycle = v["cycle"].as_u64().unwrap();
        assert!(last_cycle.is_none_or(|c| cycle > c), "cycles increase");
        last_cycle = Some(cycle);
        assert!(v["stamp_ns"].as_u64().unwrap() > 0);
        let joints = v["joints"].as_array().unwrap();
        assert_eq!(joints.len(), 2);
        for j in joints {
            let keys: Vec<_> = j.as_object().unwrap().keys().map(String::as_str).collect();
            assert_eq!(keys, ["name", "position", "velocity", "deflection", "torque", "stiffness", "valid"]);
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

#[test]
fn sigint_holds_the_joints_publishes_a_final_state_and_releases_shared_memory() {
    let (arm, yaml) = write_rig("sigint", 200.0);
    let mut run = spawn_run(&yaml, &[]);
    // Subscribe from this process and wait for the loop to publish.
    let node = jointctl_ipc::create_node(None, &format!("test-sub-{}", std::process::id())).unwrap();
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
    // SAFETY: sending a signal to our own child.
    unsafe { libc::kill(run.id() as i32, libc::SIGINT) };
    let status = wait_with_timeout(&mut run, Duration::from_secs(5)).expect("stops within 5 s of SIGINT");
    let log = stderr_of(&mut run);
    assert!(status.success(), "exit {status:?}: {log}");
    assert!(log.contains("loop stopped, joints held"), "{log}");
    assert!(log.contains("interrupted=true"), "{log}");
    let mut saw_final = false;
    while let Some(s) = sub.receive().unwrap() {
        saw_final |= s.final_sample == 1;
    }
    assert!(saw_final, "a final state was published at shutdown");
    drop(sub);
    // Released: the same arm can start again at once.
    let again = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
}

#[test]
fn a_second_runtime_of_the_same_arm_is_refused() {
    let (_, yaml) = write_rig("twice", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let second = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    let _ = first.kill();
    let _ = first.wait();
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
    assert!(err.contains("broken.yaml:2:10: rate_hz: must be in (0, 10000] Hz, got -1"), "{err}");

    let missing = Command::new(jointctl()).args(["check", "/nonexistent/arm.yaml"]).output().unwrap();
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("cannot read the file"));

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
    // 9 drives: 9 RPDO + 9 TPDO + 1 SYNC per cycle; 6-byte PDOs 95-115 bits, SYNC 55-65 bits.
    assert!(text.contains("can0: 9 drives at 1000 kbit/s: 19 frames per cycle (1765-2135 bits) + 90 heartbeats/s"), "{text}");
    assert!(text.contains("highest loop rate 466 Hz"), "{text}");
    let fast = scratch("budget").join("fast.yaml");
    std::fs::write(&fast, jointctl_tests::replace_once(&std::fs::read_to_string(&cfg).unwrap(), "rate_hz: 40 ", "rate_hz: 1000 ")).unwrap();
    let out = Command::new(jointctl()).arg("check").arg(&fast).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("rate_hz: the CAN bus cannot carry this rate") && err.contains("load 214.1 %"), "{err}");
}
