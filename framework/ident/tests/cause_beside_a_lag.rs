//! A torque channel behind a first-order lag (a sensor's filter), read with sines, triangles and
//! random multi-sines in turn. `identify` names a delay, reads it again as a lag (see
//! `identify/lag.rs`), and the causes named beside the pure delay must earn their place beside
//! the lag too: a pure delay misses a lag's rounding of a triangle's reversals, where the
//! deflection is largest, and a cubic stiffness takes part of that misfit. Found on the third
//! generator (seed 12's 044: a 54 ms lag, a cubic of -6746 +- 4298 Nm/rad^3 named beside it,
//! its gain against the lagged model 3e-7 Nm); the records here are this file's own.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 270.0;
/// The lag's time constant [s] (the third generator's record: 54.7 ms).
const TAU_S: f64 = 0.054;
const NOISE_NM: f64 = 0.042;
const AMPLITUDE_RAD: f64 = 0.0108;
const RATE_HZ: f64 = 500.0;

/// 250 s at 500 Hz: twenty 12.5 s tests, each a sine (0.35-3 Hz), a triangle (1.3-3 Hz) or a
/// sum of 50 sines (0.35-3 Hz, amplitudes 1/f) drawn from `seed`, tapered over 0.5 s at both
/// ends. Torque `K phi + 0.0415 atan(14.5 dphi/dt)` through a first-order lag of [`TAU_S`], white
/// noise, a 14-bit deflection.
fn record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ seed);
    let per_test = (12.5 * RATE_HZ) as usize;
    let mut x = Vec::new();
    for _ in 0..20 {
        let kind = (3.0 * rng.uniform()) as usize;
        let shape: Box<dyn Fn(f64) -> f64> = match kind {
            0 => {
                let f = 0.35 + 2.65 * rng.uniform();
                Box::new(move |t| (TAU * f * t).sin())
            }
            1 => {
                // A triangle through zero at t = 0.
                let f = 1.3 + 1.7 * rng.uniform();
                Box::new(move |t| {
                    let u = (f * t + 0.25).fract();
                    4.0 * (u - 0.5).abs() - 1.0
                })
            }
            _ => {
                let parts: Vec<(f64, f64)> = (0..50).map(|_| (0.35 + 2.65 * rng.uniform(), TAU * rng.uniform())).collect();
                let sum = move |t: f64| parts.iter().map(|(f, p)| (TAU * f * t + p).sin() / f).sum::<f64>();
                let peak = (0..per_test).map(|i| sum(i as f64 / RATE_HZ).abs()).fold(0.0, f64::max);
                Box::new(move |t| sum(t) / peak)
            }
        };
        for i in 0..per_test {
            let t = i as f64 / RATE_HZ;
            let taper = (t.min(12.5 - t) / 0.5).min(1.0);
            x.push(AMPLITUDE_RAD * shape(t) * taper);
        }
    }
    let n = x.len();
    let q = TAU / 16384.0;
    let alpha = (-1.0 / (RATE_HZ * TAU_S)).exp();
    let (mut t_s, mut phi, mut tau) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    let mut lagged = f64::NAN;
    for i in 0..n {
        // The rate by central differences, as the deflection's own slope.
        let v = (x[(i + 1).min(n - 1)] - x[i.saturating_sub(1)]) * RATE_HZ / if i == 0 || i == n - 1 { 1.0 } else { 2.0 };
        let torque = K_NM_PER_RAD * x[i] + 0.0415 * (14.5 * v).atan();
        lagged = if lagged.is_nan() { torque } else { alpha * lagged + (1.0 - alpha) * torque };
        t_s.push(i as f64 / RATE_HZ);
        phi.push((x[i] / q).round() * q);
        tau.push(lagged + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_cause_named_beside_a_pure_delay_leaves_when_the_delay_is_read_as_a_lag() {
    // Measured: with the causes not judged again once the lag was taken, seeds 1, 5 and 6
    // named a cubic beside the delay (5272, -3456 and -21981 Nm/rad^3); judged again, none. The
    // lag read 52-54 ms on every seed.
    let mut wrong = Vec::new();
    for seed in 1..=8 {
        let report = identify(&record(seed), &IdentifyOptions::default()).unwrap();
        let named: Vec<String> = report.causes.iter().filter(|c| c.effect != "dropout").map(|c| format!("{} {:?}", c.effect, c.params)).collect();
        let lag = report.causes.iter().find(|c| c.effect == "time_delay").and_then(|c| c.params.get("lag_s").copied());
        if named.len() != 1 || lag.is_none_or(|l| (l / TAU_S - 1.0).abs() > 0.25) {
            wrong.push(format!("seed {seed}: {named:?}"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
