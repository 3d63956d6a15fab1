//! `jointctl identify`'s arguments and records that do not fit the baseline asked for: errors
//! that say what and where, never a silently changed result.

use std::process::Command;

use jointctl_tests::{jointctl, root, scratch};

#[test]
fn bad_identify_arguments_are_errors_not_silently_changed() {
    let data = root().join("tests/data/q4_worn_elbow.csv");
    for (args, expected) in [
        (vec!["--baseline-order", "9"], "--baseline-order must be 1-6, got 9"),
        (vec!["--config", "configs/sherpa_arm.yaml", "--joint", "q9"], "no joint `q9`"),
    ] {
        let out = Command::new(jointctl()).current_dir(root()).arg("identify").arg("--data").arg(&data).args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "expected `{expected}` in: {err}");
    }
    // Pivot settings the baseline does not have: several without --config were pooled into one
    // characteristic (q2's curves differ fourteenfold: a 0.46 s delay and a 10 Nm loop were
    // named); against q2's table a record without its setting was read at 0 mm, one at 200 mm
    // at 45 mm, both without a word.
    let pivots = scratch("identify-pivots");
    let write = |name: &str, header: &str, pivot: &dyn Fn(usize) -> String| {
        let path = pivots.join(name);
        let rows: String = (0..600).map(|i| format!("{},{},{}{}\n", i as f64 * 0.01, 0.05 * (i as f64 * 0.05).sin(), 4.0 * (i as f64 * 0.05).sin(), pivot(i))).collect();
        std::fs::write(&path, format!("t,deflection,torque{header}\n{rows}")).unwrap();
        path
    };
    for (file, config, expected) in [
        (write("two-settings.csv", ",pivot_mm", &|i| format!(",{}", if i < 300 { 10 } else { 35 })), false, "2 pivot settings (10.00, 35.00 mm): without --config the baseline is one characteristic"),
        (write("no-setting.csv", "", &|_| String::new()), true, "sample 1 (t = 0 s): no pivot setting: the joint's model changes with its pivot (0-45 mm)"),
        (write("beyond.csv", ",pivot_mm", &|_| ",200".into()), true, "sample 1 (t = 0 s): pivot setting 200 mm is outside the joint's characteristic (0-45 mm)"),
    ] {
        let mut cmd = Command::new(jointctl());
        cmd.current_dir(root()).arg("identify").arg("--data").arg(&file);
        if config {
            cmd.args(["--config", "configs/sherpa_arm.yaml", "--joint", "q2"]);
        }
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.code() == Some(1) && err.contains(expected), "expected `{expected}` in: {err}");
    }
    // A wrist DOF against the wrist's table: a record along the other DOF's axis names the DOF to
    // identify from it, an axis reversed (its torque and deflection negated) the axes, and a record of several directions the sample where the direction changes
    // (a diagonal's record alone is identified against the table along it, and one along both
    // diagonals each apart: tests/model_loop.rs).
    let dir = scratch("identify-wrist-directions");
    let write = |name: &str, angle: &dyn Fn(usize) -> f64| {
        let path = dir.join(name);
        // A NaN direction is an empty cell.
        let cell = |a: f64| if a.is_nan() { String::new() } else { a.to_string() };
        let rows: String = (0..400).map(|i| format!("{},{},{},20,{}\n", i as f64 * 0.01, 0.05 * (i as f64 * 0.05).sin(), 1.0 * (i as f64 * 0.05).sin(), cell(angle(i)))).collect();
        std::fs::write(&path, format!("t,deflection,torque,pivot_mm,angle_deg\n{rows}")).unwrap();
        path
    };
    for (file, expected) in [
        (write("q7-axis.csv", &|_| 0.0), "deflection direction 0 deg is the other wrist DOF's axis: identify `q7` from this record (`q6` from one along 90 deg)"),
        (write("q6-axis-reversed.csv", &|_| 270.0), "deflection direction 270 deg is a wrist axis reversed: record q7 along 0 deg and q6 along 90 deg"),
        (write("two-directions.csv", &|i| if i < 200 { 45.0 } else { 90.0 }), "sample 201: deflection direction 90 deg after 45 deg: identify one direction's record at a time"),
        // From a review: one empty direction in a record along both diagonals was told to give
        // one direction at a time; a direction is not guessed.
        (write("a-gap.csv", &|i| if i == 250 { f64::NAN } else if i < 200 { 45.0 } else { 135.0 }), "sample 251 (t = 2.5 s): no deflection direction (angle_deg)"),
    ] {
        let out = Command::new(jointctl()).current_dir(root()).arg("identify").arg("--data").arg(&file).args(["--config", "configs/sherpa_arm.yaml", "--joint", "q6"]).output().unwrap();
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "expected `{expected}` in: {err}");
    }
}
