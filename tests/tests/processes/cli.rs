//! The command line without a running arm: `check` (exit codes, the reference configs, the CAN
//! bus budget, refusing what `run` refuses), the committed schema, bad durations, completions.

use std::process::Command;

use jointctl_tests::{jointctl, scratch};

use super::write_rig;

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
    // 9 drives: 9 RPDO + 9 TPDO + 1 SYNC per cycle; 6-byte RPDOs 95-115 bits, 8-byte TPDOs (the
    // drives' torque read: `rated_torque_nm`) 111-135 bits, SYNC 55-65 bits; heartbeats: 9
    // drives at 100 ms and the host's at 50 ms (which the drives consume).
    assert!(text.contains("can0: 9 drives at 1000 kbit/s: 19 frames per cycle (1909-2315 bits) + 110 heartbeats/s"), "{text}");
    assert!(text.contains("highest loop rate 429 Hz"), "{text}");
    let fast = scratch("budget").join("fast.yaml");
    std::fs::write(&fast, jointctl_tests::replace_once(&std::fs::read_to_string(&cfg).unwrap(), "rate_hz: 40 ", "rate_hz: 1000 ")).unwrap();
    let out = Command::new(jointctl()).arg("check").arg(&fast).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("rate_hz: the CAN bus cannot carry this rate") && err.contains("load 232.2 %"), "{err}");
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
