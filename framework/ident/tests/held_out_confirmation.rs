//! Causes are selected on the training part and must be confirmed on the held-out part: one
//! that only the training part shows is dropped, not reported.

mod common;

use jointctl_ident::identify::{IdentifyOptions, identify};

#[test]
fn a_cause_only_the_training_part_shows_is_not_confirmed() {
    // A 0.3 Nm, 7 Hz mode that rings during the first half of the experiment only (a loose
    // cover that was later tightened): BIC on the training part selects it, the held-out part
    // (the last 30 %) has none of it.
    let transient = common::sine_experiment(|t, _, _| if t < 40.0 { 0.3 * (std::f64::consts::TAU * 7.0 * t).sin() } else { 0.0 });
    let report = identify(&transient, &IdentifyOptions::default()).unwrap();
    assert!(report.causes.iter().all(|c| c.effect != "vibration"), "{:?}", report.causes);
    assert!(report.rejected.iter().any(|r| r.starts_with("vibration (proposed by BIC, no evidence on the held-out part")), "{:?}", report.rejected);
    assert!(report.rmse_after <= report.rmse_before + 1e-12, "{} vs {}", report.rmse_after, report.rmse_before);

    // The same mode ringing throughout is confirmed, with its frequency.
    let lasting = common::sine_experiment(|t, _, _| 0.3 * (std::f64::consts::TAU * 7.0 * t).sin());
    let report = identify(&lasting, &IdentifyOptions::default()).unwrap();
    assert_eq!(report.causes.first().map(|c| c.effect.as_str()), Some("vibration"), "{:?}", report.causes);
    assert!((report.causes[0].params["frequency_hz"] - 7.0).abs() < 0.01, "{:?}", report.causes[0].params);
}

/// A slow characterisation (0.05 Hz, 0.1 rad) with a burst of fast motion (2 Hz, 0.03 rad, 3 s)
/// every 20 s, on the thesis' baseline (120 Nm/rad, eq. 3.5 friction `0.3 atan(80 v)`), 14-bit
/// deflection, 0.02 Nm noise, 200 Hz for 200 s, plus a viscous friction of `b` [Nm s/rad].
fn bursts(b: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (rate, n, k) = (200.0, 40_000, 120.0);
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15);
    let mut data = jointctl_ident::csv::Data::default();
    for i in 0..n {
        let t = i as f64 / rate;
        let burst = t % 20.0 > 17.0;
        let (x, v) = (0.1 * (TAU * 0.05 * t).sin(), 0.1 * TAU * 0.05 * (TAU * 0.05 * t).cos());
        let (bx, bv) = if burst { (0.03 * (TAU * 2.0 * t).sin(), 0.03 * TAU * 2.0 * (TAU * 2.0 * t).cos()) } else { (0.0, 0.0) };
        let (x, v) = (x + bx, v + bv);
        data.t.push(t);
        data.deflection.push((x / q).round() * q);
        data.torque.push(k * x + 0.3 * (80.0 * v).atan() + b * v + 0.02 * rng.normal());
        for col in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque] {
            col.push(f64::NAN);
        }
    }
    data
}

#[test]
fn a_viscous_friction_that_acts_only_in_fast_bursts_is_confirmed() {
    // Issue 31, finding 1: a viscous friction large at top speed and nothing while the joint
    // moves slowly got no cause. Most held-out blocks carry none of it, and the block t-test of
    // squared-error gains drowned the few that do in their spread.
    // Two causes, each checked by leaving its fix out: the rate read low in the bursts (a window
    // sized on the slow fundamental) made 0.25 Nm s/rad a 0.35; with the rate right, the block
    // t-test of squared-error gains finds neither 0.25 nor 0.12 (t = 3.3 at 0.25), forecast
    // encompassing finds both.
    for truth in [0.25, 0.12] {
        let report = identify(&bursts(truth), &IdentifyOptions::default()).unwrap();
        let viscous = report.causes.iter().find(|c| c.effect == "viscous_friction");
        assert!(viscous.is_some(), "{truth}: causes {:?}, rejected {:?}", report.causes, report.rejected);
        let b = viscous.unwrap().params["damping_nms_per_rad"];
        assert!((b - truth).abs() < 0.25 * truth, "b = {b} for {truth}: {}", viscous.unwrap().evidence);
    }
    // The same record without it: nothing to name.
    let clean = identify(&bursts(0.0), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes);
}

#[test]
fn a_time_delay_seen_in_one_fast_stretch_of_the_held_out_part_is_confirmed() {
    // Issue 31, finding 2: time delays not named. Where the held-out part moves fast in one
    // stretch only, a delay's correction sits in one block of twenty, and blocks of equal
    // length leave its test one block's worth of certainty (a critical t of 318). A slow 0.05 Hz,
    // 0.1 rad sine with a 3 s, 2 Hz, 0.03 rad stretch 30 s before the end and one at 60 s, in the
    // training part; the torque lags the encoder by `delay_s`; 120 Nm/rad, eq. 3.5 friction,
    // 14-bit deflection, 0.02 Nm noise, 200 Hz.
    //
    // The training part's stretch is for BIC: on the slow sine alone, a 20 ms delay is to first
    // order a torque in the rate (120 Nm/rad times 20 ms: 2.4 Nm s/rad), which the baseline's
    // eq. 3.5 friction, odd in the rate as well, also fits; and the delay was proposed through
    // 14 bits on 4 of 4 noise draws but through 17 or 20 bits on 1 of 4: it rested on the
    // encoder's staircase (docs/identification.md, held counts). With the stretch, 4 of 4 at
    // each, 20 ms each time.
    use std::f64::consts::TAU;
    let record = |delay_s: f64| {
        let fast = |t: f64, from: f64| if (from..from + 3.0).contains(&t) { 0.03 * (TAU * 2.0 * (t - from)).sin() } else { 0.0 };
        let deflection = |t: f64| 0.1 * (TAU * 0.05 * t).sin() + fast(t, 170.0) + fast(t, 60.0);
        let q = TAU / 16384.0;
        let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d);
        let mut data = jointctl_ident::csv::Data::default();
        for i in 0..40_000 {
            let t = i as f64 / 200.0;
            let (x, lagged) = (deflection(t), deflection(t - delay_s));
            let v = (deflection(t - delay_s + 1e-4) - deflection(t - delay_s - 1e-4)) / 2e-4;
            data.t.push(t);
            data.deflection.push((x / q).round() * q);
            data.torque.push(120.0 * lagged + 0.3 * (80.0 * v).atan() + 0.02 * rng.normal());
            for col in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque] {
                col.push(f64::NAN);
            }
        }
        data
    };
    let report = identify(&record(0.02), &IdentifyOptions::default()).unwrap();
    let delay = report.causes.iter().find(|c| c.effect == "time_delay");
    assert!(delay.is_some(), "causes {:?}, rejected {:?}", report.causes, report.rejected);
    let d = delay.unwrap().params["delay_s"];
    // Delays are whole samples at 200 Hz (5 ms); the slow sine's rate, where friction is still
    // near-linear in the rate, trades a sample of delay against the friction.
    assert!((d - 0.02).abs() <= 0.005 + 1e-9, "delay {d} s");
    let clean = identify(&record(0.0), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes);
}

#[test]
fn a_held_out_part_beyond_the_trainings_reach_is_said_to_be() {
    // An excitation that grows over the record (0.03 rad at 0.2 Hz, then 0.1 rad at 1 Hz for
    // the last 30 %): held out as the last 30 % (`--held-out last`), the causes are judged where
    // the model was not fitted, and the report says so. The same record at one amplitude does
    // not get the sentence. By default the window held out moves to one like the rest.
    use std::f64::consts::TAU;
    let record = |grows: bool| {
        let q = TAU / 16384.0;
        let mut rng = jointctl_test_support::XorShift64::new(0x5851_f42d_4c95_7f2d);
        let mut data = jointctl_ident::csv::Data::default();
        for i in 0..40_000 {
            let t = i as f64 / 200.0;
            let (a, f) = if grows && t >= 140.0 { (0.1, 1.0) } else { (0.03, 0.2) };
            let (x, v) = (a * (TAU * f * t).sin(), a * TAU * f * (TAU * f * t).cos());
            data.t.push(t);
            data.deflection.push((x / q).round() * q);
            data.torque.push(120.0 * x + 0.3 * (80.0 * v).atan() + 0.02 * rng.normal());
            for col in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque] {
                col.push(f64::NAN);
            }
        }
        data
    };
    let last = IdentifyOptions { held_out: jointctl_ident::identify::prepare::HeldOut::Last, ..IdentifyOptions::default() };
    let grown = identify(&record(true), &last).unwrap();
    let [rate, range] = grown.unexplained.held_out_reach;
    assert!(rate > 10.0 && range > 2.5, "{rate} {range}");
    assert!(grown.unexplained.summary.contains("judged where the model was not fitted"), "{}", grown.unexplained.summary);
    let moved = identify(&record(true), &IdentifyOptions::default()).unwrap();
    assert!(moved.held_out_window.moved.is_some(), "{:?}", moved.held_out_window);
    assert!(!moved.unexplained.summary.contains("not fitted"), "{}", moved.unexplained.summary);
    let steady = identify(&record(false), &last).unwrap();
    assert!(steady.unexplained.held_out_reach.iter().all(|r| (r - 1.0).abs() < 0.2), "{:?}", steady.unexplained.held_out_reach);
    assert!(!steady.unexplained.summary.contains("not fitted"), "{}", steady.unexplained.summary);
}
