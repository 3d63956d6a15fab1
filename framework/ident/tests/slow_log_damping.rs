//! A viscous friction logged as 20 Hz bin means is named with its damping, not one that makes
//! up for a rate read slow. A least-squares line through five 20 Hz samples reads a 2 Hz motion
//! 15 % slow: on the blind generator's 20 Hz devices each damping came out 5-18 % above its
//! full-rate variants and its truth. The records here are this file's own: a spring, eq. 3.5's
//! friction, a viscous friction and a torque offset under a multi-sine of 1.1-2.4 Hz sampled at
//! 2 kHz, written as 50 ms means. Read over the usual window or one sample either side, their
//! dampings came out 6.08 and 6.26 for 6 (seed 3 not reached); through the local cubic 5.79,
//! 5.96 and 5.87, the held-out error 0.047, 0.038 and 0.034 Nm for 0.051 and 0.049. A smaller
//! gain than on the blind devices: this multi-sine is slower, and the narrow window, which
//! reads it 2-4 % slow, was already taken. At 1.6-3.1 Hz the cubic reads the dampings 4-5 %
//! low and names a small loop beside them on one seed: what eq. 3.5's arctan leaves on means
//! across a reversal is not modelled.

use jointctl_ident::identify::{IdentifyOptions, identify};

const DAMPING_NMS_PER_RAD: f64 = 6.0;

/// 60 s, written at 20 Hz as the means of 100 readings at 2 kHz: 250 Nm/rad, eq. 3.5's friction
/// `0.3 atan(50 v)`, a viscous friction of [`DAMPING_NMS_PER_RAD`], a 0.2 Nm offset, 0.3 Nm of
/// noise on each reading (0.03 Nm on a mean).
fn record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0xbb67_ae85_84ca_a73b ^ seed);
    let tones: Vec<(f64, f64, f64)> = [(1.1, 0.010), (1.7, 0.007), (2.4, 0.005)].into_iter().map(|(f, a)| (f, a, rng.uniform() * TAU)).collect();
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for b in 0..1200 {
        let (mut x_sum, mut y_sum) = (0.0, 0.0);
        for i in b * 100..(b + 1) * 100 {
            let t = i as f64 / 2000.0;
            let (x, v) = tones.iter().fold((0.0, 0.0), |(x, v), (f, a, p)| (x + a * (TAU * f * t + p).sin(), v + a * TAU * f * (TAU * f * t + p).cos()));
            x_sum += x;
            y_sum += 250.0 * x + 0.3 * (50.0 * v).atan() + DAMPING_NMS_PER_RAD * v + 0.2 + 0.3 * rng.normal();
        }
        t_s.push(b as f64 * 0.05);
        phi.push(x_sum / 100.0);
        tau.push(y_sum / 100.0);
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_viscous_friction_logged_as_20_hz_means_is_named_with_its_damping() {
    for seed in 1..=3 {
        let report = identify(&record(seed), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let damping = report.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
        let Some(damping) = damping else { panic!("seed {seed}: named {named:?}") };
        eprintln!("seed {seed}: named {named:?}, damping {damping:.3} for {DAMPING_NMS_PER_RAD}, held out {:.4} Nm (floor {:.4}), rate reading {:?}", report.rmse_after, report.unexplained.noise_floor_nm, report.narrow_rate);
        assert!((damping / DAMPING_NMS_PER_RAD - 1.0).abs() < 0.04, "seed {seed}: damping {damping} for {DAMPING_NMS_PER_RAD}");
    }
}
