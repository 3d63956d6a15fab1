//! Numbers from the command line and the config have ranges, and a value outside is refused
//! with the range and the value printed short, never a panic (issue 40, findings 6 and 8); output
//! to a reader that has gone ends quietly (finding 19).

use std::process::Command;

use jointctl_tests::{jointctl, replace_once, scratch};

#[test]
fn durations_and_rates_far_out_of_range_are_refused_with_the_range_not_a_panic() {
    let out = scratch("number_ranges").join("r.mcap");
    let out = out.to_str().unwrap();
    for (args, reason) in [
        (vec!["record", "--out", out, "--timeout", "1e300"], "must be in [0, 1e9] s, got 1.000e300"),
        (vec!["bridge", "foxglove", "--timeout", "1e300"], "must be in [0, 1e9] s, got 1.000e300"),
        (vec!["inspect", "echo", "--rate", "1e-300", "--timeout", "0.2"], "must be >= 1e-9 Hz, got 1.000e-300"),
        // Issue 40, finding 10: `fit --smooth 1e9` wrote a characteristic of -23 Nm/rad.
        (vec!["fit", "--smooth", "1000000000", "data.csv"], "1000000000 is not in 1..=1000"),
        (vec!["fit", "--smooth", "0", "data.csv"], "0 is not in 1..=1000"),
    ] {
        let o = Command::new(jointctl()).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(reason) && !err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn a_loop_rate_whose_period_is_not_a_time_is_refused_by_check() {
    let dir = scratch("number_ranges_rate");
    let text = std::fs::read_to_string(jointctl_tests::root().join("configs/sherpa_arm.yaml")).unwrap();
    let from = text.lines().find(|l| l.starts_with("rate_hz:")).unwrap().to_string();
    for (rate, shown) in [("1.0e-300", "1.000e-300"), ("1e-6", "1.000e-6")] {
        let yaml = dir.join(format!("rate_{shown}.yaml"));
        std::fs::write(&yaml, replace_once(&text, &from, &format!("rate_hz: {rate}"))).unwrap();
        // The included files are found next to the config.
        for f in ["sherpa_arm.urdf", "sherpa_q2_characteristic.yaml", "sherpa_q4_characteristic.yaml", "sherpa_wrist_characteristic.yaml"] {
            std::fs::copy(jointctl_tests::root().join("configs").join(f), dir.join(f)).unwrap();
        }
        let o = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(&format!("rate_hz: must be in [1, 10000] Hz, got {shown}")), "{rate}: {err}");
    }
}

#[test]
fn a_reader_that_goes_away_ends_the_output_not_the_program_with_a_panic() {
    // Issue 40, finding 19: `jointctl schema | head -1` panicked on the closed pipe, and
    // `jointctl check X | head -1` about half the time (whether the pipe closed before the
    // second line). Each is run ten times, the reader gone after its first line.
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let config = jointctl_tests::root().join("configs/sherpa_arm.yaml");
    for args in [vec!["schema".to_string()], vec!["check".to_string(), config.display().to_string()]] {
        for _ in 0..10 {
            let mut child = Command::new(jointctl()).args(&args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
            let mut first = String::new();
            BufReader::new(child.stdout.take().unwrap()).read_line(&mut first).unwrap();
            let out = child.wait_with_output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!first.is_empty() && !err.contains("panicked") && out.status.code() != Some(101), "{args:?}: {err}");
        }
    }
}

/// The ROS 2 bridge's DDS domain has the range RTPS maps to UDP ports (0-232): check refuses a
/// domain beyond it with the range and the field, and the bridge's `--domain-id` likewise.
#[test]
fn a_dds_domain_beyond_232_is_refused_with_the_range() {
    let arm = jointctl_tests::arm_name("number_ranges_dds");
    let network: serde_yaml::Value = serde_yaml::from_str("{ros2: {domain_id: 233}}").unwrap();
    let yaml = jointctl_tests::sherpa_with("number_ranges_dds", &arm, &[jointctl_tests::Edit::Set("network", network)]);
    let o = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("network.ros2.domain_id") && err.contains("must be 0-232"), "{err}");
    let o = Command::new(jointctl()).args(["bridge", "ros2", "--domain-id", "233"]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("233 is not in 0..=232"), "{err}");
}

/// `network.ros2.commands.allow` names command kinds: an unknown one or none is refused by check,
/// naming the entry.
#[test]
fn ros2_commands_allow_only_known_kinds() {
    for (i, (section, expected)) in [
        ("{ros2: {commands: {allow: [trajectory, fly]}}}", "network.ros2.commands.allow[1]: unknown command kind `fly` (one of hold, position"),
        ("{ros2: {commands: {allow: []}}}", "network.ros2.commands.allow: names no command kind"),
        ("{ros2: {commands: {allow: [hold], max_commands_per_s: 0}}}", "network.ros2.commands.max_commands_per_s: must be in [0.1, 1000]"),
    ]
    .into_iter()
    .enumerate()
    {
        let test = format!("number_ranges_ros2_{i}");
        let arm = jointctl_tests::arm_name(&test);
        let yaml = jointctl_tests::sherpa_with(&test, &arm, &[jointctl_tests::Edit::Set("network", serde_yaml::from_str(section).unwrap())]);
        let o = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(expected), "{section}: {err}");
    }
}
