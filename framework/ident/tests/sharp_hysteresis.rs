//! A hysteresis loop that turns sharper at its limit than Dahl's exponential approach (a
//! Bouc-Wen loop with exponent n > 1, the common model of joints, gears and rubber dampers):
//! named as hysteresis alone, with its shape, and no cubic stiffness or offset beside it.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 50 s at 1 kHz: a spring of 120 Nm/rad with eq. 3.5's friction (0.1 Nm, 40 s/rad) and a
/// textbook Bouc-Wen loop in time, `dz/dt = A v - beta |v| |z|^(n-1) z - gamma v |z|^n`, with
/// `A` the loop's first slope, `beta + gamma = A / F^n` for its limit `F`, and
/// `beta = beta_share (beta + gamma)` (identify's own form has `gamma = 0`, a share of 1),
/// integrated by Euler in 20 sub-steps per sample. The deflection: sines of 12, 25 and 45 mrad
/// at 0.35, 0.5 and 0.8 Hz one after the other, read by a 14-bit encoder; 0.04 Nm of noise.
fn record(limit_nm: f64, sigma_nm_per_rad: f64, n: f64, beta_share: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15);
    let a = sigma_nm_per_rad;
    let beta_plus_gamma = a / limit_nm.powf(n);
    let (beta, gamma) = (beta_share * beta_plus_gamma, (1.0 - beta_share) * beta_plus_gamma);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let mut z = 0.0f64;
    let deflection = |t: f64| {
        let (amplitude, hz, start) = match t {
            t if t < 16.0 => (0.012, 0.35, 0.0),
            t if t < 32.0 => (0.025, 0.5, 16.0),
            _ => (0.045, 0.8, 32.0),
        };
        amplitude * (TAU * hz * (t - start)).sin()
    };
    let dt = 1e-3;
    for i in 0..50_000 {
        let t = i as f64 * dt;
        let sub = dt / 20.0;
        for k in 0..20 {
            let ts = t + k as f64 * sub;
            let v = (deflection(ts + sub) - deflection(ts)) / sub;
            z += sub * (a * v - beta * v.abs() * z.abs().powf(n - 1.0) * z - gamma * v * z.abs().powf(n));
        }
        let x = deflection(t);
        let rate = (deflection(t + 1e-4) - deflection(t - 1e-4)) / 2e-4;
        t_s.push(t);
        phi.push((x / q).round() * q);
        tau.push(120.0 * x + 0.1 * (40.0 * rate).atan() + z + 0.04 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_loop_sharper_than_dahls_is_named_alone() {
    // Found on the blind generator's devices (Bouc-Wen loops of n = 2.3-2.5): Dahl's loop left
    // 1.6 times the noise, and a cubic stiffness or an offset was named beside it, or in its
    // place, on 5 of 8 seeds' hysteresis device. Here, on another Bouc-Wen (another split of beta and gamma,
    // integrated in time, another excitation), Dahl's shape named a time delay beside the loop
    // at n = 2.
    for n in [2.0, 3.0] {
        let report = identify(&record(0.6, 150.0, n, 0.65), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let shape = report.causes.iter().find(|c| c.effect == "hysteresis").and_then(|c| c.params.get("shape").copied());
        assert_eq!(named, ["hysteresis"], "n = {n}: rmse {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after);
        assert!(shape.is_some_and(|s| s > 1.0), "n = {n}: shape {shape:?}");
    }
}

#[test]
fn a_dahl_loop_keeps_dahls_shape() {
    // Bouc-Wen at n = 1 with gamma = 0 is Dahl's loop: the simpler shape is kept.
    let report = identify(&record(0.6, 150.0, 1.0, 1.0), &IdentifyOptions::default()).unwrap();
    let hysteresis = report.causes.iter().find(|c| c.effect == "hysteresis");
    assert!(hysteresis.is_some_and(|c| !c.params.contains_key("shape")), "{:?}", report.causes);
}
