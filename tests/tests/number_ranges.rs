//! Numbers from the command line and the config have ranges, and a value outside is refused
//! with the range and the value printed short, never a panic (issue 40, findings 6 and 8).

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
