//! A characterisation that rests for its first half and moves in the second: the grid searches
//! must look at the motion, wherever in the training part it is.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// Deflection [rad]: a ramp to 1.5 mrad over 5 s, a hold to 26 s, back to zero by 28 s, then two
/// sines of 1 mrad each (1.3 and 3.1 Hz, 1.1 rad apart) to 60 s.
fn deflection(t: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    match t {
        t if t < 5.0 => 0.0015 * t / 5.0,
        t if t < 26.0 => 0.0015,
        t if t < 28.0 => 0.0015 * (28.0 - t) / 2.0,
        t => 0.001 * ((tau * 1.3 * (t - 28.0)).sin() + (tau * 3.1 * (t - 28.0) + 1.1).sin()),
    }
}

/// The two sines alone, from the record's start: a motion the searches' pieces all see.
fn moving(t: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    0.001 * ((tau * 1.3 * t).sin() + (tau * 3.1 * t + 1.1).sin())
}

/// 60 s at 200 Hz: 1500 Nm/rad seen `delay_s` late by the torque channel, 0.06 Nm of noise, the
/// deflection read in steps of 2e-6 rad.
fn record(delay_s: f64) -> jointctl_ident::csv::Data {
    record_of(deflection, delay_s)
}

fn record_of(deflection: fn(f64) -> f64, delay_s: f64) -> jointctl_ident::csv::Data {
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..12_000 {
        let t = i as f64 * 5e-3;
        t_s.push(t);
        phi.push((deflection(t) / 2e-6).round() * 2e-6);
        tau.push(1500.0 * deflection((t - delay_s).max(0.0)) + 0.06 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_delay_is_named_when_the_motion_comes_after_the_first_seconds() {
    // Found on the blind generator (seed 6, record 051: a ramp, a 28 s hold, then a chirp at
    // 200 Hz with a 27 ms delay): the searches took the first 5000 training samples, the ramp and
    // the hold, found the delay at -40 ms there, which made the held-out part worse, and no
    // cause was named at 4.2 times the noise floor.
    let report = identify(&record(0.025), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let delay = report.causes.iter().find(|c| c.effect == "time_delay");
    assert!(delay.is_some(), "named {named:?}, rejected {:?}", report.rejected);
    let d = delay.unwrap().params["delay_s"];
    assert!((d - 0.025).abs() <= 0.005, "delay {d} s for 0.025 s");
    let clean = identify(&record(0.0), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes);
}

#[test]
fn a_lead_of_the_torque_is_named_when_the_searches_run_in_pieces() {
    // Found in review: with the searches' samples in pieces, the delay's transform gave the last
    // samples of each piece the next piece's first deflection (the value after a gap), so a
    // negative delay (the torque leading) fitted badly on every piece and went unnamed (-15 and
    // -25 ms: a viscous friction named instead), where a9640be had found them.
    let mut wrong = Vec::new();
    for truth in [-0.015, -0.025] {
        let report = identify(&record_of(moving, truth), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        match report.causes.iter().find(|c| c.effect == "time_delay").map(|c| c.params["delay_s"]) {
            // Within a sample and a half (a9640be, before the pieces: -15 and -20 ms).
            Some(d) if (d - truth).abs() <= 0.0075 && named.len() == 1 => {}
            found => wrong.push(format!("{truth} s: delay {found:?}, named {named:?}")),
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
