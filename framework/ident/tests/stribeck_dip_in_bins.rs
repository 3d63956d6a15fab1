//! A slow log of bin averages whose friction has a Stribeck dip: the dip is averaged over each
//! interval as eq. 3.5's arctan is. At the interval's mean rate, a dip narrower than the rates a
//! 50 ms interval runs through at a reversal is another curve: found on the blind generator's
//! 20 Hz records (seeds 48's and 53's 033: a Stribeck friction at 0.006 rad/s), where the dip
//! fitted best upside down, was rejected as impossible, and "no cause" was said at 15 times the
//! noise. The records here are this file's own: a spring moved by a multi-sine, simulated at
//! 2 kHz and written as 50 ms means.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 450.0;
/// The friction's Coulomb and static levels [Nm] and its Stribeck speed [rad/s]: a static
/// level 1.5 times the Coulomb level, within the range Armstrong-Helouvry et al. (1994) survey.
const FC_NM: f64 = 1.0;
const FS_NM: f64 = 1.5;
const VS_RAD_PER_S: f64 = 0.006;

/// 60 s at 2 kHz of `K phi + sign(v) (fc + (fs - fc) exp(-(v / vs)^2))` (the sign smoothed over
/// 1 mrad/s), a multi-sine deflection of 0.11, 0.23 and 0.41 Hz, 0.012 rad each (phases from
/// `seed`; up to about 0.06 rad/s), 0.1 Nm of noise and a 14-bit deflection, written as the mean
/// of each 50 ms. Not the project's dip (a tanh under a Gaussian): Armstrong-Helouvry's static
/// form.
fn record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ seed);
    let sines: Vec<(f64, f64)> = [0.11, 0.23, 0.41].into_iter().map(|f| (f, rng.uniform() * TAU)).collect();
    let q = TAU / 16384.0;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for bin in 0..1200 {
        let (mut x_sum, mut y_sum) = (0.0, 0.0);
        for i in bin * 100..(bin + 1) * 100 {
            let t = i as f64 / 2000.0;
            let (x, v) = sines.iter().fold((0.0, 0.0), |(x, v), (f, p)| (x + 0.012 * (TAU * f * t + p).sin(), v + 0.012 * TAU * f * (TAU * f * t + p).cos()));
            let friction = (v / 1e-3).tanh() * (FC_NM + (FS_NM - FC_NM) * (-(v / VS_RAD_PER_S).powi(2)).exp());
            x_sum += (x / q).round() * q;
            y_sum += K_NM_PER_RAD * x + friction + 0.1 * rng.normal();
        }
        t_s.push(bin as f64 * 0.05);
        phi.push(x_sum / 100.0);
        tau.push(y_sum / 100.0);
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_stribeck_dip_in_bin_averages_is_averaged_over_each_interval() {
    // Measured on seeds 1-6 (seed 2 is read as point samples and left alone): evaluated at each
    // interval's mean rate, the dip came out 0.38-0.41 Nm at 0.0076-0.0080 rad/s (for 0.5
    // at 0.006: the speed 27-33 % off), held out 0.032-0.049 Nm; averaged over the interval,
    // 0.52-0.59 Nm at 0.0063-0.0065 rad/s (5-8 % off), held out 0.024-0.044 Nm. The test asks
    // the speed within 20 % and the height within 25 % on every record read as bins, and at
    // least four such records.
    let mut read_as_bins = 0;
    let mut wrong = Vec::new();
    for seed in 1..=6 {
        let report = identify(&record(seed), &IdentifyOptions::default()).unwrap();
        if report.bin_averages.is_none() {
            continue;
        }
        read_as_bins += 1;
        let dip = report.friction_dip.as_ref().map(|d| (d.params["stribeck_nm"], d.params["stribeck_speed_rad_per_s"]));
        let right = dip.is_some_and(|(height, speed)| ((height / (FS_NM - FC_NM)) - 1.0).abs() < 0.25 && (speed / VS_RAD_PER_S - 1.0).abs() < 0.2);
        if !right || !report.causes.is_empty() {
            wrong.push(format!("seed {seed}: dip (Nm, rad/s) {dip:?}, causes {:?}, held out {:.4} -> {:.4} Nm", report.causes, report.rmse_before, report.rmse_after));
        }
    }
    assert!(read_as_bins >= 4, "{read_as_bins} of 6 records read as bins");
    assert!(wrong.is_empty(), "{wrong:#?}");
}
