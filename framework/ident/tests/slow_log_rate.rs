//! The rate of a slow log (20 Hz), read over a window as narrow as one sample either side where
//! the motion bends. The rate's window was at least two samples either side: on a 20 Hz log
//! that is +-0.1 s, and at a reversal of a motion of about 1 Hz the rate read so turned eq. 3.5's
//! friction late or early. Found on the blind generator's 20 Hz records of a softening spring
//! (seed 1's 033: the baseline left 0.50 Nm held out for 0.07 of noise, 0.32 read over +-1, and
//! the softening was not named). The records here are this file's own: a multi-sine of three
//! tones at 0.55-1.3 Hz sampled at 2 kHz through a softening spring, a friction whose sign turns
//! within 2 mrad/s, written as 50 ms means. Over the usual window the softening of seed 2 was
//! refused (held-out block t = 2.9); read over one sample either side, the baseline's training BIC
//! is better by 398-500 and every seed's is named, its cubic 1.4-5.2 % off.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 300.0;
/// The spring's cubic term [Nm/rad^3]: -0.54 Nm at 0.03 rad.
const K3_NM_PER_RAD3: f64 = -20_000.0;
const FRICTION_NM: f64 = 1.5;
const SIGN_SPEED_RAD_PER_S: f64 = 0.002;
/// The torque's noise on each 2 kHz reading [Nm]: 0.05 Nm on a 50 ms mean.
const NOISE_NM: f64 = 0.5;

/// 60 s, written at 20 Hz as the means of 100 readings at 2 kHz.
fn record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x6a09_e667_f3bc_c909 ^ seed);
    let tones: Vec<(f64, f64)> = [0.55, 0.85, 1.3].into_iter().map(|f| (f, rng.uniform() * TAU)).collect();
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for b in 0..1200 {
        let (mut x_sum, mut y_sum) = (0.0, 0.0);
        for i in b * 100..(b + 1) * 100 {
            let t = i as f64 / 2000.0;
            let (x, v) = tones.iter().fold((0.0, 0.0), |(x, v), (f, p)| (x + 0.012 * (TAU * f * t + p).sin(), v + 0.012 * TAU * f * (TAU * f * t + p).cos()));
            x_sum += x;
            y_sum += K_NM_PER_RAD * x + K3_NM_PER_RAD3 * x.powi(3) + FRICTION_NM * (v / SIGN_SPEED_RAD_PER_S).tanh() + NOISE_NM * rng.normal();
        }
        t_s.push(b as f64 * 0.05);
        phi.push(x_sum / 100.0);
        tau.push(y_sum / 100.0);
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_softening_spring_logged_at_20_hz_is_named() {
    for seed in 1..=3 {
        let report = identify(&record(seed), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let reading = report.narrow_rate.as_ref().unwrap_or_else(|| panic!("seed {seed}: the rate read over the usual window"));
        assert!(reading.bic_usual - reading.bic_narrow > 10.0, "seed {seed}: {reading:?}");
        let cubic = report.causes.iter().find(|c| c.effect == "stiffness_nonlinearity");
        let Some(cubic) = cubic else { panic!("seed {seed}: named {named:?}, baseline {} Nm held out, rejected {:?}", report.rmse_before, report.rejected) };
        let k3 = cubic.params["k3_nm_per_rad3"];
        assert!((k3 / K3_NM_PER_RAD3 - 1.0).abs() < 0.25, "seed {seed}: k3 {k3} for {K3_NM_PER_RAD3}");
    }
}
