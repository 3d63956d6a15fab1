//! An outside client: the Python inspector (tools/inspect_py, PyPI `iceoryx2` 0.10, ctypes
//! mirrors of the payloads) reads a running arm from shared memory and prints the same JSON as
//! `jointctl inspect echo --json`. This keeps the `#[repr(C)]` contract readable from another
//! language: a field added, reordered or retyped on the Rust side breaks this test.

use std::path::PathBuf;
use std::process::{Command, Stdio};

use jointctl_tests::{arm_name, jointctl, rig_yaml, scratch, stop};

fn root() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn python() -> PathBuf {
    jointctl_tests::interop_python()
}

const ELASTIC: &str = "  - name: b\n    plugin: elastic\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {stiffness_nm_per_rad: 113.78, output_per_motor: 2.0, position_pi: {kp: 0.2, ki: 0.5}}\n";

#[test]
fn the_python_inspector_reads_the_same_states_as_the_rust_one() {
    let arm = arm_name("py");
    let dir = scratch("py");
    let yaml = dir.join("rig.yaml");
    std::fs::write(&yaml, rig_yaml(&arm, 100.0, ELASTIC)).unwrap();
    let mut run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--duration", "20"]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    // The Rust inspector's first sample also tells that the runtime is up.
    let rust = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    // A position set-point for `a`, so that the states carry a moving, non-zero value.
    let cmd = Command::new(jointctl()).args(["cmd", "position", "a", "0.3", "--arm", &arm]).output().unwrap();
    let py = Command::new(python())
        .arg(root().join("tools/inspect_py/jointctl_inspect.py"))
        .args([&arm, "--count", "20", "--timeout", "10"])
        .output()
        .unwrap();
    stop(&mut run);
    assert!(cmd.status.success(), "cmd: {}", String::from_utf8_lossy(&cmd.stderr));
    assert!(py.status.success(), "python inspector: {}", String::from_utf8_lossy(&py.stderr));
    assert!(rust.status.success(), "rust inspector: {}", String::from_utf8_lossy(&rust.stderr));

    let py_samples: Vec<serde_json::Value> = String::from_utf8(py.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(py_samples.len(), 20);
    let rust_sample: serde_json::Value = serde_json::from_str(String::from_utf8(rust.stdout).unwrap().lines().next().unwrap()).unwrap();
    // Same keys in the same order, joint by joint, as the Rust inspector's documented shape.
    let keys = |v: &serde_json::Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
    for s in &py_samples {
        assert_eq!(keys(s), keys(&rust_sample));
        let (pj, rj) = (s["joints"].as_array().unwrap(), rust_sample["joints"].as_array().unwrap());
        assert_eq!(pj.len(), rj.len());
        for (p, r) in pj.iter().zip(rj) {
            assert_eq!(keys(p), keys(r));
            assert_eq!(p["name"], r["name"]);
            // Configuration-fixed values are read identically through both layouts.
            assert_eq!(p["stiffness"], r["stiffness"]);
            assert_eq!(p["valid"], true);
        }
        assert_eq!(pj[0]["torque"], serde_json::Value::Null, "a rigid joint's torque is unknown");
        assert_eq!(pj[0]["mode"], "position", "`a` was commanded to a position before the Python client started");
        assert!(s["wall_ns"].as_u64().is_some(), "a wall-clock stamp: {s}");
        assert!(pj[1]["torque"].is_f64());
    }
    // Live data: cycles increase, time stamps advance with them, and `a` moves towards 0.3 rad.
    for w in py_samples.windows(2) {
        assert!(w[1]["cycle"].as_u64() > w[0]["cycle"].as_u64());
        assert!(w[1]["stamp_ns"].as_u64() > w[0]["stamp_ns"].as_u64());
    }
    let positions: Vec<f64> = py_samples.iter().map(|s| s["joints"][0]["position"].as_f64().unwrap()).collect();
    assert!(positions.iter().all(|p| (-1.0..=1.0).contains(p)), "{positions:?}");
    // The Python client may start after `a` has reached 0.3 rad (it overshoots by a few mrad
    // and settles), so judge where it ends, not first against last: near the target, which the
    // Rust inspector's sample, taken before the command, was not.
    let last = positions[positions.len() - 1];
    let before = rust_sample["joints"][0]["position"].as_f64().unwrap();
    assert!((last - 0.3).abs() < 0.02 && (before - 0.3).abs() > 0.1, "a moves from {before} towards 0.3 rad: {positions:?}");
    // The Rust inspector ran before the Python one: an earlier cycle of the same run.
    assert!(rust_sample["cycle"].as_u64() < py_samples[0]["cycle"].as_u64());
}

/// The latest-state blackboard from Python (`--latest`): the Rust runtime writes it on iceoryx2's
/// thread-safe service kind, the PyPI client opens it as an ordinary `ipc` blackboard with a
/// `u32` key, and reads the same `ArmState` layout, a line per new cycle.
#[test]
fn the_python_inspector_reads_the_latest_state_blackboard() {
    let arm = arm_name("py-latest");
    let yaml = scratch("py-latest").join("rig.yaml");
    std::fs::write(&yaml, rig_yaml(&arm, 100.0, ELASTIC)).unwrap();
    let mut run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--duration", "20"]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let rust = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--latest", "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    let py = Command::new(python()).arg(root().join("tools/inspect_py/jointctl_inspect.py")).args([&arm, "--latest", "--count", "5", "--timeout", "10"]).output().unwrap();
    stop(&mut run);
    assert!(rust.status.success(), "rust inspector: {}", String::from_utf8_lossy(&rust.stderr));
    assert!(py.status.success(), "python inspector: {}", String::from_utf8_lossy(&py.stderr));
    let rust_sample: serde_json::Value = serde_json::from_str(String::from_utf8(rust.stdout).unwrap().lines().next().unwrap()).unwrap();
    let py_samples: Vec<serde_json::Value> = String::from_utf8(py.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(py_samples.len(), 5);
    let keys = |v: &serde_json::Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
    for s in &py_samples {
        assert_eq!(keys(s), keys(&rust_sample));
        assert_eq!((s["joints"][0]["name"].as_str(), s["joints"][1]["name"].as_str()), (Some("a"), Some("b")));
        assert_eq!(s["joints"][1]["stiffness"], rust_sample["joints"][1]["stiffness"]);
    }
    assert!(py_samples.windows(2).all(|w| w[1]["cycle"].as_u64() > w[0]["cycle"].as_u64()), "new cycles only");
    assert!(rust_sample["cycle"].as_u64() < py_samples[0]["cycle"].as_u64());
}

/// Finding: the Python client could not follow `ipc.domain` and had no diagnostics. Pass: an
/// arm in its own domain is found with `--domain` (and not without it, with a hint), and
/// `--diag` prints the diagnostics in `jointctl inspect diag --json`'s shape, key for key,
/// including a faulted joint's reason.
#[test]
fn the_python_inspector_follows_the_domain_and_reads_diagnostics() {
    let arm = arm_name("py-diag");
    let domain = format!("pyd{}", std::process::id());
    let yaml = scratch("py-diag").join("rig.yaml");
    let faulty = "  - name: b\n    plugin: faulty\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {fault_at: 3}\n";
    std::fs::write(&yaml, format!("{}ipc: {{domain: {domain}}}\n", rig_yaml(&arm, 100.0, faulty))).unwrap();
    let mut run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--duration", "20"]).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    let script = root().join("tools/inspect_py/jointctl_inspect.py");
    // Up, and past the fault at cycle 3.
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--domain", &domain, "--json", "--count", "10", "--timeout", "10"]).output().unwrap();
    let rust = Command::new(jointctl()).args(["inspect", "diag", "--arm", &arm, "--domain", &domain, "--json"]).output().unwrap();
    let py = Command::new(python()).arg(&script).args([&arm, "--domain", &domain, "--diag"]).output().unwrap();
    let py_state = Command::new(python()).arg(&script).args([&arm, "--domain", &domain, "--count", "1"]).output().unwrap();
    let lost = Command::new(python()).arg(&script).args([&arm, "--count", "1", "--timeout", "1"]).output().unwrap();
    stop(&mut run);
    jointctl_tests::forget_test_domain(&domain);
    assert!(up.status.success() && rust.status.success(), "{}", String::from_utf8_lossy(&rust.stderr));
    assert!(py.status.success(), "python --diag: {}", String::from_utf8_lossy(&py.stderr));
    assert!(py_state.status.success(), "python --domain: {}", String::from_utf8_lossy(&py_state.stderr));
    let err = String::from_utf8_lossy(&lost.stderr);
    assert!(!lost.status.success() && err.contains("--domain"), "without the domain: {err}");
    let (p, r): (serde_json::Value, serde_json::Value) = (serde_json::from_slice(&py.stdout).unwrap(), serde_json::from_slice(&rust.stdout).unwrap());
    let keys = |v: &serde_json::Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
    assert_eq!(keys(&p), keys(&r));
    assert_eq!(keys(&p["joints"][0]), keys(&r["joints"][0]));
    assert_eq!(keys(&p["devices"][0]), keys(&r["devices"][0]));
    let bounds = |v: &serde_json::Value| v["lateness_histogram"].as_array().unwrap().iter().map(|b| b["upper_us"].clone()).collect::<Vec<_>>();
    assert_eq!(bounds(&p), bounds(&r), "the same buckets");
    assert_eq!(p["lateness_histogram"].as_array().unwrap().len(), 16);
    assert_eq!(p["lateness_histogram"][15]["upper_us"], serde_json::Value::Null);
    assert_eq!(p["period_ns"], 10_000_000);
    let names = |v: &serde_json::Value, list: &str| v[list].as_array().unwrap().iter().map(|x| x["name"].clone()).collect::<Vec<_>>();
    assert_eq!(names(&p, "joints"), names(&r, "joints"));
    assert_eq!(names(&p, "devices"), names(&r, "devices"));
    assert_eq!((p["joints"][1]["fault_code"].as_u64(), p["joints"][1]["fault_count"].as_u64()), (Some(42), Some(1)), "{p}");
    assert_eq!(p["joints"][1]["fault_message"], r["joints"][1]["fault_message"]);
    assert!(p["joints"][1]["held"].as_bool().unwrap());
}
