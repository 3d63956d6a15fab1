//! A slow log's noise floor read where the joint holds. The floor is read from the second
//! differences of what a line in the deflection and its rate leaves; at 20 Hz those also take
//! the curvature, between samples, of whatever the line misses (a dead zone's corners, a
//! friction's reversals), and that was taken for noise: on the blind generator's device C of
//! seed 51 (a dead zone, 50 ms means) the floor read 0.058 Nm for the generator's 0.0049, and
//! the report said "no cause, 1.3 times the noise floor" over a held-out error 15.6 times the
//! noise. Where the deflection holds, every modelled torque holds too, and what moves from
//! sample to sample is the sensor's noise. The records here are this file's own.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 44.0;
/// The dead zone's half-width [rad]: a play of 2 x 8 mrad, as a coupling's.
const HALF_WIDTH_RAD: f64 = 0.008;
/// The noise at 2 kHz [Nm]; its 50 ms means carry a tenth of it.
const NOISE_NM: f64 = 0.035;

/// 60 s at 2 kHz, written as 50 ms means: strokes to a level 0.02-0.06 rad from zero on
/// alternate sides, each 0.6-1.5 s long, the rate a half-sine (smooth starts and stops), then a
/// hold of 0.5-2 s (drawn from `seed`). Torque `K dz(phi) + 0.13 atan(100 dphi/dt)` with `dz` a
/// sharp dead zone, white noise, a 14-bit deflection.
fn record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::PI;
    let mut rng = jointctl_test_support::XorShift64::new(0x6a09_e667_f3bc_c909 ^ seed);
    let (mut x, mut v) = (Vec::new(), Vec::new());
    let (mut at, mut side) = (0.0, 1.0);
    while x.len() < 120_000 {
        let to = side * (0.02 + 0.04 * rng.uniform());
        let n = (2000.0 * (0.6 + 0.9 * rng.uniform())) as usize;
        for i in 0..n {
            let s = i as f64 / n as f64;
            x.push(at + (to - at) * 0.5 * (1.0 - (PI * s).cos()));
            v.push((to - at) * 0.5 * PI * (PI * s).sin() * 2000.0 / n as f64);
        }
        let hold = (2000.0 * (0.5 + 1.5 * rng.uniform())) as usize;
        x.extend(std::iter::repeat_n(to, hold));
        v.extend(std::iter::repeat_n(0.0, hold));
        (at, side) = (to, -side);
    }
    let q = std::f64::consts::TAU / 16384.0;
    let dead_zone = |x: f64| x.signum() * (x.abs() - HALF_WIDTH_RAD).max(0.0);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for bin in 0..1200 {
        let (mut x_sum, mut y_sum) = (0.0, 0.0);
        for i in bin * 100..(bin + 1) * 100 {
            x_sum += (x[i] / q).round() * q;
            y_sum += K_NM_PER_RAD * dead_zone(x[i]) + 0.13 * (100.0 * v[i]).atan() + NOISE_NM * rng.normal();
        }
        t_s.push(bin as f64 * 0.05);
        phi.push(x_sum / 100.0);
        tau.push(y_sum / 100.0);
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_slow_logs_floor_is_read_where_the_joint_holds() {
    // Measured on these four seeds: read over the whole record the floor was 0.0045-0.0052 Nm
    // for the means' 0.0035 (29-49 % high; the blind record's twelve times is not reproduced
    // here); read at rest 0.0031-0.0036 (11 % low to 3 % high). The dead zone is named either
    // way. The test asks the floor within 15 %.
    let binned_noise = NOISE_NM / 10.0;
    let mut wrong = Vec::new();
    for seed in 1..=4 {
        let report = identify(&record(seed), &IdentifyOptions::default()).unwrap();
        let floor = report.unexplained.noise_floor_nm;
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        if (floor / binned_noise - 1.0).abs() > 0.15 || named != ["dead_zone"] {
            wrong.push(format!("seed {seed}: floor {floor:.4} Nm for {binned_noise}, named {named:?}"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
