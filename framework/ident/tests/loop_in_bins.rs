//! A hysteresis loop on a slow log of bin averages: a logger that lowers the rate averages the
//! loop's torque over each interval too, and where the deflection moves several loop scales
//! within one interval the loop's state at the interval's mean deflection is not the mean of its
//! states. Found on the blind generator's 20 Hz devices (Bouc-Wen loops: 7.6 and 9.0 times the
//! noise floor left on the bins where the full-rate variants left 1.0-1.3, the loop's limit 0.70
//! Nm for the full-rate records' 0.89-1.02, and a cubic or a delay named beside it). The records
//! here are this file's own: a Dahl loop integrated at 2 kHz on a multi-sine, written as 50 ms
//! means.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 80.0;
const KA_NM: f64 = 0.2;
const KB_S_PER_RAD: f64 = 100.0;
const LIMIT_NM: f64 = 0.5;
/// The loop's deflection scale [rad]: at the multi-sine's fastest (about 1 rad/s) a 50 ms
/// interval spans five of it.
const LAMBDA_RAD: f64 = 0.005;
const NOISE_NM: f64 = 0.05;

/// 60 s at 2 kHz of a multi-sine of 0.21, 0.47 and 0.83 Hz, 0.1 rad each (phases from `seed`),
/// through `K phi + KA atan(KB dphi/dt) + LIMIT u` with `du = (1 - u sgn(dphi)) dphi / LAMBDA`
/// (Dahl's law, a forward step per sample: 5e-4 rad or less, a tenth of the scale), 0.05 Nm
/// of white noise and a 14-bit deflection; written as the means of each 100 samples (20 Hz).
fn record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ seed);
    let sines: Vec<(f64, f64)> = [0.21, 0.47, 0.83].into_iter().map(|f| (f, rng.uniform() * TAU)).collect();
    let q = TAU / 16384.0;
    let (mut u, mut prev) = (0.0, None);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let (mut x_sum, mut y_sum) = (0.0, 0.0);
    for i in 0..120_000 {
        let t = i as f64 / 2000.0;
        let (x, v) = sines.iter().fold((0.0, 0.0), |(x, v), (f, p)| (x + 0.1 * (TAU * f * t + p).sin(), v + 0.1 * TAU * f * (TAU * f * t + p).cos()));
        if let Some(before) = prev {
            let dx: f64 = x - before;
            u += (1.0 - u * dx.signum()) * dx / LAMBDA_RAD;
        }
        prev = Some(x);
        x_sum += (x / q).round() * q;
        y_sum += K_NM_PER_RAD * x + KA_NM * (KB_S_PER_RAD * v).atan() + LIMIT_NM * u + NOISE_NM * rng.normal();
        if (i + 1) % 100 == 0 {
            t_s.push((i + 1 - 100) as f64 / 2000.0);
            phi.push(x_sum / 100.0);
            tau.push(y_sum / 100.0);
            (x_sum, y_sum) = (0.0, 0.0);
        }
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_loop_on_bin_averages_is_named_alone_with_its_limit_and_scale_and_leaves_the_noise() {
    for seed in 1..=3 {
        let report = identify(&record(seed), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert_eq!(named, ["hysteresis"], "seed {seed}: {:?}", report.causes);
        assert!(report.bin_averages.is_some(), "seed {seed}: read as point samples");
        // Read at each interval's mean deflection the loop took 0.45 Nm and 79-85 Nm/rad.
        let (limit, sigma) = (report.causes[0].params["limit_nm"], report.causes[0].params["sigma_nm_per_rad"]);
        assert!((limit - LIMIT_NM).abs() < 0.05 * LIMIT_NM, "seed {seed}: limit {limit} Nm for {LIMIT_NM}");
        let true_sigma = LIMIT_NM / LAMBDA_RAD;
        assert!((sigma - true_sigma).abs() < 0.1 * true_sigma, "seed {seed}: {sigma} Nm/rad for {true_sigma}");
        // What is left: the noise of 20 Hz means (0.05 / sqrt(100) = 0.005 Nm) and little more
        // (1.7-2.7 times the floor read at the means).
        let floor = report.unexplained.noise_floor_nm;
        assert!(report.rmse_after < 1.5 * floor, "seed {seed}: held out {} Nm, floor {floor}", report.rmse_after);
    }
}
