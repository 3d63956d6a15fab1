//! A torque sensor whose offset drifts over the record, and one whose offset steps between
//! repetitions of a test (issue 36's real-data traits).

use jointctl_ident::csv::Data;
use jointctl_ident::identify::{Report, identify};

mod through_the_reader;

/// 60 s at 500 Hz of a 120 Nm/rad spring with eq. 3.5's friction `0.3 atan(50 v)`, moved by
/// 0.31 and 0.73 Hz sines of 0.03 rad each (random phases), 14-bit deflection, 0.03 Nm of noise,
/// and `extra(t, x, v)` [Nm] added (called once per sample, in order, with the unquantised
/// deflection and its rate).
fn record(mut extra: impl FnMut(f64, f64, f64) -> f64, seed: u64) -> Data {
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let phases = [rng.uniform() * TAU, rng.uniform() * TAU];
    let x = |t: f64| 0.03 * (TAU * 0.31 * t + phases[0]).sin() + 0.03 * (TAU * 0.73 * t + phases[1]).sin();
    let v = |t: f64| 0.03 * TAU * (0.31 * (TAU * 0.31 * t + phases[0]).cos() + 0.73 * (TAU * 0.73 * t + phases[1]).cos());
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..30_000 {
        let t = i as f64 / 500.0;
        t_s.push(t);
        deflection.push((x(t) / q).round() * q);
        torque.push(120.0 * x(t) + 0.3 * (50.0 * v(t)).atan() + extra(t, x(t), v(t)) + 0.03 * rng.normal());
    }
    Data::from_columns(t_s, deflection, torque)
}

/// A Dahl loop of `limit_nm` (`dz/dx = (1 - z sgn(dx)) / 0.004 rad`), stepped on the deflection.
fn dahl(limit_nm: f64) -> impl FnMut(f64, f64, f64) -> f64 {
    let (mut z, mut last) = (0.0f64, f64::NAN);
    move |_, x, _| {
        let step = if last.is_nan() { 0.0 } else { x - last };
        last = x;
        z += (1.0 - z * step.signum()) * step / 0.004;
        limit_nm * z
    }
}

fn named(report: &Report) -> Vec<(&str, &std::collections::BTreeMap<String, f64>)> {
    report.causes.iter().map(|c| (c.effect.as_str(), &c.params)).collect()
}

/// Finding (issue 36, a torque-sensor offset that drifts): the offset was one constant, so the
/// held-out part, later in the record, was read off by the drift since the training part's
/// mean. On the blind generator's drifting offsets the record was left at up to 9 times the
/// noise (seed 5's friction record 066, 2 Nm of drift), a hysteresis beside a drift of
/// 0.12 Nm/s was not named (seed 1's 096), and a cubic stood in for the drift (seed 3's 066).
/// Here 0.8 Nm drifting 0.02 Nm/s (1.2 Nm over the record) beside a 0.15 Nm loop: the offset is
/// named with its drift, the loop beside it, and what is left is the noise.
#[test]
fn a_drifting_offset_is_named_with_its_drift_and_the_loop_beside_it() {
    let report = {
        let mut loop_nm = dahl(0.15);
        identify(&record(move |t, x, v| loop_nm(t, x, v) + 0.8 + 0.02 * (t - 30.0), 0x51ed_2701_99aa_0b33), &Default::default())
    }.unwrap();
    let named = named(&report);
    let mut effects: Vec<&str> = named.iter().map(|(e, _)| *e).collect();
    effects.sort();
    assert_eq!(effects, ["hysteresis", "sensor_offset"], "{named:?}");
    let offset = report.causes.iter().find(|c| c.effect == "sensor_offset").unwrap();
    let (drift, mean) = (offset.params["drift_nm_per_s"], offset.params["offset_nm"]);
    assert!((drift - 0.02).abs() < 0.002, "drift {drift}");
    assert!((mean - 0.8).abs() < 0.04, "mean offset {mean}");
    assert!(offset.uncertainty.get("drift_nm_per_s").is_some_and(|e| *e > 0.0 && *e < 0.002), "{:?}", offset.uncertainty);
    assert!(report.unexplained.times_noise < 1.3, "{}", report.unexplained.summary);
}

/// Three repetitions of one test logged one file each and concatenated (the time restarts at
/// zero), the offset stepping between them (0.7, 1.0 and 0.6 Nm): no drift, and read through the
/// CSV reader as a user's file is. A line through the first two (the reader lays them 1 s
/// apart, their time between not known) misses the third, and the held-out part refuses it: the
/// offset is named alone, near the repetitions' mean (0.77 Nm).
#[test]
fn an_offset_that_steps_between_repetitions_is_no_drift() {
    let single = record(|_, _, _| 0.0, 0x0f1e_2d3c_4b5a_6978);
    let mut text = String::from("t,deflection,torque\n");
    for offset in [0.7, 1.0, 0.6] {
        // Each repetition the record's first 20 s.
        for i in 0..10_000 {
            text += &format!("{},{},{}\n", single.t[i], single.deflection[i], single.torque[i] + offset);
        }
    }
    let data = through_the_reader::through_a_file("drift-steps", |path| std::fs::write(path, text).unwrap());
    assert_eq!(data.restarts.len(), 2, "three repetitions read");
    let report = identify(&data, &Default::default()).unwrap();
    let named = named(&report);
    assert!(matches!(named.as_slice(), [("sensor_offset", p)] if !p.contains_key("drift_nm_per_s") && (p["offset_nm"] - 0.767).abs() < 0.1), "{named:?}");
    // The held-out part is the third repetition, 0.6 Nm where the offset fitted is near the
    // mean: what is left is said to be a constant, of about their difference.
    let left = &report.unexplained;
    assert!(left.summary.contains("mostly a constant") && (left.mean_nm - (0.6 - named[0].1["offset_nm"])).abs() < 0.02, "{} ({:+.4} Nm)", left.summary, left.mean_nm);
}

/// A loop alone, no offset: no offset or drift is named beside it.
#[test]
fn a_loop_alone_gets_no_offset_or_drift() {
    let report = identify(&record(dahl(0.15), 0x2b7e_1516_28ae_d2a6), &Default::default()).unwrap();
    let named = named(&report);
    assert!(matches!(named.as_slice(), [("hysteresis", _)]), "{named:?}");
}

/// The blind generator's record `name` of seed `seed`'s suite (that case alone generated),
/// through the CSV reader.
fn blind(seed: u64, name: &str) -> Data {
    through_the_reader::suite_record(seed, name)
}

/// Finding (the blind generator, seed 4's 037): an offset of 1.65 Nm drifting 0.032 Nm/s
/// (1.2 Nm over its 37 s) was named with a cubic stiffness that stood in for the drift, and
/// 2.5 times the noise was left. Now the offset is named alone, with its drift.
#[test]
fn a_drifting_offset_is_not_taken_for_a_cubic() {
    let report = identify(&blind(4, "037_offset_plain"), &Default::default()).unwrap();
    let named = named(&report);
    assert!(matches!(named.as_slice(), [("sensor_offset", p)] if (p["drift_nm_per_s"] - 0.0322).abs() < 0.003 && (p["offset_nm"] - 1.645).abs() < 0.08), "{named:?}");
    assert!(report.unexplained.times_noise < 1.3, "{}", report.unexplained.summary);
}

/// Found on the blind generator (seed 3's 010, a LuGre loop alone): what identify's Dahl loop
/// leaves of a LuGre friction drifts slowly over the record, and a line in time took it up
/// (-0.0017 +- 0.0008 Nm/s, two standard errors, with a held-out block t of 9.4) and was named a
/// drifting offset. Held to its coefficient on the training part, the drift is not named.
#[test]
fn a_lugre_loops_slow_misfit_is_no_drift() {
    let report = identify(&blind(3, "010_hyst_plain"), &Default::default()).unwrap();
    let named = named(&report);
    assert!(matches!(named.as_slice(), [("hysteresis", _)]), "{named:?}");
}
