//! A spring beside a friction several times its torque: a straight line in the deflection
//! explains little of the whole torque, whose friction turns with the rate's sign, and the record
//! was read as a friction record (its first column a joint position, no spring). Found on the
//! third generator (a clean record of 41 Nm/rad on 0.018 rad beside eq. 3.5's 0.96 Nm: 5 % of
//! the torque's variance, and an offset named on it). The records here are this file's own: two
//! sines of random phase, a spring, eq. 3.5's friction, 1 kHz, a 14-bit encoder.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 40 s at 1 kHz: deflection [rad] and torque [Nm] of a spring of `k` [Nm/rad] beside eq. 3.5's
/// friction `1.0 atan(60 v)`, 0.04 Nm of noise.
fn record(seed: u64, k: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d ^ (seed << 8));
    let q = TAU / 16384.0;
    let f = [0.6 + 0.4 * rng.uniform(), 1.7 + 0.8 * rng.uniform()];
    let a = [0.012 + 0.002 * rng.uniform(), 0.005 + 0.002 * rng.uniform()];
    let phase = [TAU * rng.uniform(), TAU * rng.uniform()];
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..40_000 {
        let t = i as f64 * 1e-3;
        let x: f64 = (0..2).map(|j| a[j] * (TAU * f[j] * t + phase[j]).sin()).sum();
        let v: f64 = (0..2).map(|j| a[j] * TAU * f[j] * (TAU * f[j] * t + phase[j]).cos()).sum();
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(k * x + (60.0 * v).atan() + 0.04 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_spring_beside_a_larger_friction_is_read_as_a_spring() {
    // Before: seed 1 was read as a friction record (the spring's share of the whole torque's
    // variance 9.4 %, below 20 %). After: the deflection's share of what the friction's sign and a
    // line in the rate leave is counted too, and each seed is read as a spring.
    for seed in 1..=3 {
        let report = identify(&record(seed, 40.0), &IdentifyOptions::default()).expect("identified");
        assert!(report.no_spring.is_none(), "seed {seed}: read as friction: {:?}", report.no_spring.map(|n| n.note));
    }
}

#[test]
fn the_same_friction_without_the_spring_is_still_a_friction_record() {
    for seed in 4..=6 {
        let report = identify(&record(seed, 0.0), &IdentifyOptions::default()).expect("identified");
        assert!(report.no_spring.is_some(), "seed {seed}: read as a spring");
    }
}
