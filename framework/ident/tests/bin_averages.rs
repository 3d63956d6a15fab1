//! A slow log of bin averages: a logger that lowers the rate keeps the mean of each interval's
//! readings. Eq. 3.5's arctan averaged over an interval where the rate turns is flatter than the
//! arctan of the interval's mean rate, and a baseline evaluated at the mean rate leaves a
//! residual at every reversal (found on the blind generator's 20 Hz records: a clean one left at
//! six times its noise, `k_b` at half its value, and a Dahl loop named on another split). The
//! records here are this file's own: a multi-sine sampled at 2 kHz, written as 50 ms means or
//! read every 50 ms. What remains on the bins (0.024-0.026 Nm held out for 0.005 of noise) is
//! mostly the error of a rate read from 20 Hz means (not changed here).

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 80.0;
const KA_NM: f64 = 0.4;
const KB_S_PER_RAD: f64 = 150.0;

/// The deflection [rad] at 2 kHz for 60 s, a multi-sine of 0.21, 0.47 and 0.83 Hz, 0.1 rad each
/// (phases from `seed`; up to about 1 rad/s, as a hand moves a joint in section 3.3.1's
/// characterisation), and its rate [rad/s].
fn motion(seed: u64) -> (Vec<f64>, Vec<f64>) {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x5851_f42d_4c95_7f2d ^ seed);
    let sines: Vec<(f64, f64)> = [0.21, 0.47, 0.83].into_iter().map(|f| (f, rng.uniform() * TAU)).collect();
    (0..120_000)
        .map(|i| {
            let t = i as f64 / 2000.0;
            sines.iter().fold((0.0, 0.0), |(x, v), (f, p)| (x + 0.1 * (TAU * f * t + p).sin(), v + 0.1 * TAU * f * (TAU * f * t + p).cos()))
        })
        .unzip()
}

/// `K phi + KA atan(KB dphi/dt)` with 0.05 Nm of noise and a 14-bit deflection, sampled at
/// 2 kHz; written as the means of each `bin` samples (`binned`) or as every `bin`-th sample.
fn record(seed: u64, bin: usize, binned: bool) -> jointctl_ident::csv::Data {
    let (x, v) = motion(seed);
    let q = std::f64::consts::TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d ^ seed);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for b in 0..x.len() / bin {
        let (mut x_sum, mut y_sum) = (0.0, 0.0);
        let samples = if binned { b * bin..(b + 1) * bin } else { b * bin..b * bin + 1 };
        let count = samples.len() as f64;
        for i in samples {
            x_sum += (x[i] / q).round() * q;
            y_sum += K_NM_PER_RAD * x[i] + KA_NM * (KB_S_PER_RAD * v[i]).atan() + 0.05 * rng.normal();
        }
        t_s.push(b as f64 * bin as f64 / 2000.0);
        phi.push(x_sum / count);
        tau.push(y_sum / count);
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_clean_20_hz_log_of_bin_averages_is_read_as_such_and_its_arctan_found() {
    for seed in 1..=3 {
        let report = identify(&record(seed, 100, true), &IdentifyOptions::default()).unwrap();
        assert!(report.causes.is_empty(), "seed {seed}: {:?}", report.causes);
        let Some(bins) = report.bin_averages.as_ref() else { panic!("seed {seed}: read as point samples") };
        let k_b = bins.k_b_bins_s_per_rad;
        assert!((k_b - KB_S_PER_RAD).abs() < 0.25 * KB_S_PER_RAD, "seed {seed}: k_b {k_b} s/rad for {KB_S_PER_RAD} ({bins:?})");
        // What the reading is for: the arctan at each interval's mean rate takes k_b far too low.
        assert!(bins.k_b_points_s_per_rad < 0.5 * KB_S_PER_RAD, "seed {seed}: {bins:?}");
    }
}

#[test]
fn the_same_motion_read_every_50_ms_stays_point_samples() {
    for seed in 1..=3 {
        let report = identify(&record(seed, 100, false), &IdentifyOptions::default()).unwrap();
        assert!(report.bin_averages.is_none(), "seed {seed}: {:?}", report.bin_averages);
        assert!(report.causes.is_empty(), "seed {seed}: {:?}", report.causes);
        assert!(report.rmse_before < 1.6 * 0.05, "seed {seed}: {} Nm held out for 0.05 Nm of noise", report.rmse_before);
    }
}

#[test]
fn a_fast_log_is_never_read_as_bins() {
    // At 200 Hz (5 ms a sample, below BIN_READING_MIN_STEP_S) the bins are read as points, as
    // every record was before.
    let report = identify(&record(1, 10, true), &IdentifyOptions::default()).unwrap();
    assert!(report.bin_averages.is_none(), "{:?}", report.bin_averages);
}
