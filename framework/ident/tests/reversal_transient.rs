//! A transient after each reversal that is not a ring (a torque sensor's low-pass filter
//! smoothing the friction's step) is not named `reversal_ringing`.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 60 s at 1 kHz on the thesis' baseline (130 Nm/rad, eq. 3.5 friction `0.8 atan(200 v)`: a
/// sharp step at each reversal), sines of 0.3-0.9 Hz and 0.02-0.05 rad, the torque read through a
/// first-order low-pass of `filter_s` (an F/T sensor's filter), 14-bit deflection, 0.05 Nm noise.
fn filtered_record(filter_s: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let rate = 1000.0;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let (mut t, mut read) = (0.0, 0.0);
    let alpha = 1.0 - (-1.0 / (rate * filter_s)).exp();
    while t < 60.0 {
        let (f, a) = (0.3 + 0.6 * rng.uniform(), 0.02 + 0.03 * rng.uniform());
        let start = t;
        while t < start + 3.0 / f && t < 60.0 {
            let local = t - start;
            let (x, v) = (a * (TAU * f * local).sin(), a * TAU * f * (TAU * f * local).cos());
            read += alpha * (130.0 * x + 0.8 * (200.0 * v).atan() - read);
            t_s.push(t);
            deflection.push((x / q).round() * q);
            torque.push(read + 0.05 * rng.normal());
            t += 1.0 / rate;
        }
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_filters_transient_after_reversals_is_not_named_a_ring() {
    let mut wrong = Vec::new();
    for (i, filter_s) in [0.004, 0.008, 0.015].into_iter().enumerate() {
        let report = identify(&filtered_record(filter_s, 0x2f7a_0c1d_93e5_b468 ^ i as u64), &IdentifyOptions::default()).unwrap();
        let named: Vec<String> = report.causes.iter().map(|c| format!("{} {:?}", c.effect, c.params)).collect();
        println!("{filter_s} s: {named:?}");
        if report.causes.iter().any(|c| c.effect == "reversal_ringing") {
            wrong.push(format!("{filter_s} s: {named:?}"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
