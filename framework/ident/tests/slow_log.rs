//! A slow log: a characterisation sampled at 1 kHz and written as 20 Hz bin averages (what a
//! data logger or a base station's recorder keeps). Holds and ramps meet at corners; a window of
//! +-2 to +-7 samples (0.2-0.7 s) around a corner reads a rate that is not there, and a delay
//! between the channels is smeared out with it.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// The deflection [rad] at `t` [s]: a hold, a ramp up, a hold, a 0.4 Hz sine, a ramp down, a
/// hold, a ramp back to zero: 20 s, repeated.
fn deflection(t: f64) -> f64 {
    use std::f64::consts::TAU;
    let t = t % 20.0;
    match t {
        t if t < 2.0 => 0.0,
        t if t < 4.0 => 0.06 * (t - 2.0),
        t if t < 7.0 => 0.12,
        t if t < 12.0 => 0.12 - 0.05 * (1.0 - (TAU * 0.4 * (t - 7.0)).cos()),
        t if t < 15.0 => 0.12 - 0.22 / 3.0 * (t - 12.0),
        t if t < 17.0 => -0.10,
        t => -0.10 + 0.05 * (t - 17.0),
    }
}

/// 40 s at 1 kHz, 50 Nm/rad, eq. 3.5's friction `0.3 atan(50 v)`, the torque channel `delay_s`
/// late, 0.05 Nm of noise, 14-bit deflection; written as 20 Hz bin averages of both channels.
fn binned_record(delay_s: f64) -> jointctl_ident::csv::Data {
    let (rate, n, k) = (1000.0, 40_000, 50.0);
    let q = std::f64::consts::TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let rate_at = |t: f64| (deflection(t + 5e-4) - deflection(t - 5e-4)) / 1e-3;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for bin in 0..n / 50 {
        let (mut x_sum, mut y_sum) = (0.0, 0.0);
        for i in bin * 50..(bin + 1) * 50 {
            let t = i as f64 / rate;
            let late = t - delay_s;
            x_sum += (deflection(t) / q).round() * q;
            y_sum += k * deflection(late) + 0.3 * (50.0 * rate_at(late)).atan() + 0.05 * rng.normal();
        }
        t_s.push((bin as f64 + 0.5) * 0.05);
        phi.push(x_sum / 50.0);
        tau.push(y_sum / 50.0);
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_delay_on_a_20_hz_log_is_named_and_a_clean_one_gets_nothing() {
    // Issue 36 (consistency across variants; found on the blind generator's devices): an 85 ms
    // delay named at full rate was not named once the record was binned to 20 Hz. The rate was
    // read over +-2 to +-7 samples, sized on the strokes between reversals; at the corners
    // between holds and ramps that is a rate the deflection does not have.
    let report = identify(&binned_record(0.06), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let delay = report.causes.iter().find(|c| c.effect == "time_delay");
    assert!(delay.is_some(), "named {named:?}, rejected {:?}", report.rejected);
    let found = delay.unwrap().params["delay_s"];
    assert!((found - 0.06).abs() < 0.25 * 0.06, "delay {found} s for 0.06 s: {}", delay.unwrap().evidence);
    assert_eq!(named, ["time_delay"], "{:?}", report.causes);
    let clean = identify(&binned_record(0.0), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes);
}

/// The torque channel `delay_s` late, read every 50 ms (20 Hz samples, not bins): `k` [Nm/rad],
/// a multi-sine of 0.23, 0.51 and 0.97 Hz (0.04 rad each, random phases drawn from `seed`),
/// eq. 3.5's friction `0.05 atan(80 v)`, 6 mNm of noise, 14-bit deflection, 50 s.
fn late_at_20_hz(k: f64, delay_s: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ seed);
    let phases = [rng.uniform() * TAU, rng.uniform() * TAU, rng.uniform() * TAU];
    let sines = [0.23, 0.51, 0.97].into_iter().zip(phases);
    let x = |t: f64| sines.clone().map(|(f, p)| 0.04 * (TAU * f * t + p).sin()).sum::<f64>();
    let v = |t: f64| sines.clone().map(|(f, p)| 0.04 * TAU * f * (TAU * f * t + p).cos()).sum::<f64>();
    let q = TAU / 16384.0;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..1000 {
        let (t, late) = (i as f64 * 0.05, i as f64 * 0.05 - delay_s);
        t_s.push(t);
        phi.push((x(t) / q).round() * q);
        tau.push(k * x(late) + 0.05 * (80.0 * v(late)).atan() + 0.006 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_delay_of_a_fraction_of_a_20_hz_sample_is_refined_finer_than_a_tenth_of_it() {
    // Finding (blind seeds 4, 6 and 8: 20 Hz records with delays of 3-5 ms): on samples 50 ms
    // apart a delay was refined in tenths of a sample, 5 ms, though its transform interpolates
    // between samples; a 3 ms delay was 0 or 5 ms, and a viscous friction made up the
    // difference. Measured here before the change: the delay named alone on 8 of 12 records
    // (a viscous friction beside it on 2, nothing on 2), within 25 % on none (5 or 20 ms).
    // Now in milliseconds: 12 and 12.
    for (k, delay) in [(35.0, 0.003), (35.0, 0.0075), (60.0, 0.003), (60.0, 0.0125)] {
        for seed in 1..=3 {
            let report = identify(&late_at_20_hz(k, delay, seed), &IdentifyOptions::default()).unwrap();
            let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
            assert_eq!(named, ["time_delay"], "k {k}, delay {delay} s, seed {seed}: {:?}", report.causes);
            let found = report.causes[0].params["delay_s"];
            assert!((found - delay).abs() < 0.25 * delay, "k {k}, seed {seed}: delay {found} s for {delay} s");
        }
    }
}
