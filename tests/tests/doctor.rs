//! `jointctl doctor` (issue 37, finding 7: a user could not tell whether a machine is fit to run
//! the arm) and `timing.lock_memory`.

use std::process::Command;
use std::time::Duration;

use jointctl_tests::{jointctl, root, scratch};

/// Pass: on the simulated arm's config every check is reported (exit 0: nothing there can stop
/// the arm); on the socketcan config with a CAN interface this machine does not have, exit 1
/// with that interface and the command that brings it up; `--json` gives every check.
#[test]
fn doctor_reports_every_check_and_fails_only_what_stops_the_arm() {
    let sim = Command::new(jointctl()).arg("doctor").arg(root().join("configs/sherpa_arm.yaml")).args(["--seconds", "0.2"]).output().unwrap();
    let text = String::from_utf8_lossy(&sim.stdout);
    assert!(sim.status.success(), "{text}{}", String::from_utf8_lossy(&sim.stderr));
    for name in ["real-time kernel", "memory lock", "SCHED_FIFO", "loop CPU", "1 kHz lateness"] {
        assert!(text.contains(&format!("  {name}: ")), "{name} missing:\n{text}");
    }
    let dir = scratch("doctor");
    let yaml = dir.join("can.yaml");
    let interface = format!("jcdoc{}", std::process::id() % 100_000);
    let config = std::fs::read_to_string(root().join("configs/sherpa_arm_socketcan.yaml")).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&config, &[jointctl_tests::Edit::Set("buses.can[0].interface", interface.clone().into())])).unwrap();
    for f in ["sherpa_arm.urdf", "sherpa_q2_characteristic.yaml", "sherpa_q4_characteristic.yaml", "sherpa_wrist_characteristic.yaml"] {
        std::fs::copy(root().join("configs").join(f), dir.join(f)).unwrap();
    }
    let can = Command::new(jointctl()).arg("doctor").arg(&yaml).args(["--seconds", "0.1", "--json"]).output().unwrap();
    assert_eq!(can.status.code(), Some(1), "{}", String::from_utf8_lossy(&can.stderr));
    let checks: serde_json::Value = serde_json::from_slice(&can.stdout).unwrap();
    let bus = checks.as_array().unwrap().iter().find(|c| c["name"] == format!("CAN interface {interface}")).expect("the interface is checked");
    assert_eq!(bus["status"], "fail");
    assert!(bus["advice"].as_str().unwrap().contains(&format!("ip link set {interface} up type can bitrate 1000000")), "{bus}");
    // The config's priority is the one tried.
    let fifo = checks.as_array().unwrap().iter().find(|c| c["name"] == "SCHED_FIFO").unwrap();
    assert!(fifo["found"].as_str().unwrap().contains("80"), "{fifo}");
}

/// Pass: a run with `timing.lock_memory` either holds its memory locked (VmLck > 0 in
/// /proc/PID/status) or says on stderr that it could not and how to allow it; it runs either way.
#[test]
fn lock_memory_locks_the_runtime_or_says_why_not() {
    let (arm, yaml) = {
        let arm = jointctl_tests::arm_name("lock-memory");
        let yaml = scratch("lock-memory").join("rig.yaml");
        std::fs::write(&yaml, jointctl_tests::rig_yaml(&arm, 100.0, "").replace("timing: {spin_us: 100}", "timing: {spin_us: 100, lock_memory: true}")).unwrap();
        (arm, yaml)
    };
    assert!(std::fs::read_to_string(&yaml).unwrap().contains("lock_memory: true"), "the edit took");
    let run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--duration", "3", "--no-ipc"]).stderr(std::process::Stdio::piped()).spawn().unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let status = std::fs::read_to_string(format!("/proc/{}/status", run.id())).unwrap_or_default();
    let locked_kb: u64 = status.lines().find_map(|l| l.strip_prefix("VmLck:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok()).unwrap_or(0);
    let out = run.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{arm}: {err}");
    assert!(locked_kb > 0 || err.contains("could not lock the runtime's memory (timing.lock_memory)"), "VmLck {locked_kb} kB, stderr: {err}");
    println!("VmLck {locked_kb} kB");
}

/// A CPU the machine lacks, asked for in `timing.cpu`: the runtime says so for the loop and for
/// the thread that publishes its state, and runs on unpinned.
#[test]
fn a_cpu_the_machine_cannot_give_is_a_warning_for_the_loop_and_its_publisher() {
    let arm = jointctl_tests::arm_name("cpu-warning");
    let yaml = scratch("cpu-warning").join("rig.yaml");
    // Beyond what a CPU set holds (1024): no machine grants it, whatever its quota.
    let missing_cpu = 5000;
    std::fs::write(&yaml, jointctl_tests::rig_yaml(&arm, 200.0, "").replace("timing: {spin_us: 100}", &format!("timing: {{spin_us: 100, cpu: {missing_cpu}}}"))).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "20"]).env("RUST_LOG", "warn").output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("could not pin the loop thread") && err.contains("could not pin the publisher thread beside the loop"), "{err}");
    assert!(err.contains("20 cycles"), "{err}");
}
