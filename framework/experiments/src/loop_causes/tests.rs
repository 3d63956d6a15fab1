//! Tests of the loop's helpers: interpolation, rates, the fits' objective, and what a report
//! writes.

use super::*;

fn value(name: &str, key: &str, value: f64, cause: bool) -> LoopValue {
    LoopValue { name: name.into(), key: key.into(), value, configured: 0.03, rmse_configured: 1.0, rmse_identified: 0.5, t: 1.0, critical: 3.6, cause }
}

/// A named command latency is written with the feedback latencies estimated beside it,
/// named or not (their sums are what the data tells); without it none is written.
#[test]
fn a_command_latency_is_written_with_the_feedback_latencies_it_was_fitted_beside() {
    let mut report = LoopReport {
        values: vec![value("feedback_latency_can", "hal.sim.can_feedback_latency_s", 0.025, false), value("feedback_latency_spi", "hal.sim.spi_latency_s", 0.021, false)],
        configured_can_feedback_s: 0.03,
        ..Default::default()
    };
    assert!(report.hal_sim().is_empty());
    report.values.push(value("command_latency", "hal.sim.can_latency_s", 0.045, true));
    let sim = report.hal_sim();
    assert_eq!((sim["can_latency_s"].as_f64(), sim["can_feedback_latency_s"].as_f64(), sim["spi_latency_s"].as_f64()), (Some(0.045), Some(0.025), Some(0.021)));
    // No estimate of the readings' age (the drives did not move): the configured age stays.
    report.values.retain(|v| v.name == "command_latency");
    assert_eq!(report.hal_sim()["can_feedback_latency_s"].as_f64(), Some(0.03));
    assert!(!report.hal_sim().contains_key("spi_latency_s"));
}

#[test]
fn interpolation_and_rate_say_unknown_where_they_do_not_know() {
    let t = [0.0, 1.0, 2.0];
    assert_eq!(at(&t, &[0.0, 2.0, 4.0], 1.5), 3.0);
    assert!(at(&t, &[0.0, 2.0, 4.0], 2.5).is_nan());
    assert!(at(&t, &[0.0, f64::NAN, 4.0], 0.5).is_nan());
    let r = rate(&t, &[0.0, 2.0, 4.0]);
    assert!(r[0].is_nan() && r[1] == 2.0 && r[2].is_nan());
}

/// A joint whose drives also move a DOF without an F/T sensor needs their torque readings for
/// its load: a drive without them is named, with the fix, and no drive response is identified
/// (rather than one fitted against a load that leaves the unmeasured DOF out).
#[test]
fn a_drive_without_torque_readings_is_named_and_its_response_not_identified() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/sherpa_arm.yaml");
    let loaded = jointctl_config::load(&path).unwrap();
    let t: Vec<f64> = (0..800).map(|k| f64::from(k) * 0.025).collect();
    let motion: Vec<f64> = t.iter().map(|x| 0.2 * (2.0 * x).sin()).collect();
    let drive = |name: &str, torque_nm: f64| DriveTrace {
        name: name.into(),
        setpoint_rad: motion.clone(),
        position_rad: motion.clone(),
        load_nm: vec![0.0; t.len()],
        torque_nm: vec![torque_nm; t.len()],
        elmo: loaded.config.hal.sim.elmo,
    };
    let rec = LoopRecording {
        dof: "q2".into(),
        t_s: t.clone(),
        sensor_torque_nm: motion.iter().map(|m| 50.0 * m).collect(),
        drives: vec![drive("elmo_shoulder_a", 1.0), drive("elmo_shoulder_b", f64::NAN)],
        encoders: Vec::new(),
        unmeasured_dofs: vec!["q3".into()],
        unmeasured_rows: vec![vec![0.5, -0.5]],
    };
    let report = identify_loop(&rec, &loaded);
    assert!(
        report.notes.iter().any(|n| n.contains("`elmo_shoulder_b` reported no torque") && n.contains("rated_torque_nm")),
        "names the drive and the fix: {:?}",
        report.notes
    );
    assert!(!report.values.iter().any(|v| v.name == "command_latency" || v.name == "drive_kp"), "{:?}", report.values);
}

/// Issue finding (CI): a shoulder session's command latency was fitted at 24 ms for 50, with the
/// profile and the position loop right. A replayed drive can part from the recorded one for a
/// few hundred milliseconds where its profile lands on a crossed set-point and the plant's did
/// not (0.126 rad off, where the rest of the session is 1e-3 rad; seen on two sessions of six),
/// and whether it does turns on a millisecond of timing. The fits' objective must not let one
/// such stretch outweigh the rest: a replay right everywhere but there scores better than one
/// three times worse everywhere (the plain RMS ranked them the other way, 0.018 against 0.003;
/// the blocks' geometric mean ranks them 0.0012 against 0.003).
#[test]
fn one_stretch_where_the_replay_parts_does_not_outweigh_the_rest_of_the_session() {
    let n = 700;
    let parted: Vec<f64> = (0..n).map(|i| if (300..315).contains(&i) { 0.126f64.powi(2) } else { 1e-3f64.powi(2) }).collect();
    let worse = vec![3e-3f64.powi(2); n];
    let all = |_: usize| true;
    assert!(rms_where(&parted, all) > rms_where(&worse, all), "the plain mean of squares prefers the replay that is worse everywhere");
    let (p, w) = (block_rms_where(&parted, all), block_rms_where(&worse, all));
    assert!(p < w, "the fits' objective: {p} for the replay that parts in one stretch, {w} for the one three times worse everywhere");
    assert!((w - 3e-3).abs() < 1e-12, "a uniform error is its own RMS: {w}");
    // Unknown samples are left out, not counted as zero error.
    let mut gaps = worse.clone();
    gaps[10] = f64::NAN;
    assert!((block_rms_where(&gaps, all) - 3e-3).abs() < 1e-12);
    assert!(block_rms_where(&[f64::NAN; 5], all).is_nan());
    // A block of exactly zero error (a noise-free record at rest) is floored, not minus infinity.
    let mut exact = worse.clone();
    exact[..35].fill(0.0);
    let e = block_rms_where(&exact, all);
    assert!(e.is_finite() && e > 0.0 && e < 3e-3, "{e}");
    // As many blocks as samples at most: one sample is its own RMS.
    assert!((block_rms_where(&[4e-6], all) - 2e-3).abs() < 1e-15);
}
