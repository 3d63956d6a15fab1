//! Across processes: `jointctl run` publishes, an inspector process reads; SIGINT shuts down
//! cleanly; `jointctl check` exit codes.
//!
//! The tests live in modules by job: `inspect` (the inspector views), `faults` (signals, plugin
//! faults, stalled inspectors, command floods), `locks` (one runtime per arm and per CAN bus),
//! `shared_memory` (who may reach an arm: slot limits, permissions, leftovers) and `cli`
//! (`check`, `schema`, argument checks, completions); this file holds their helpers.

use std::io::Read;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use jointctl_tests::{arm_name, jointctl, rig_yaml, scratch};

mod cli;
mod faults;
mod inspect;
mod locks;
mod shared_memory;

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

// At the crate root on purpose: it re-runs this binary with `--exact` and its name, which is its
// path only here.
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
