//! A spring beside a friction with a Stribeck dip: eq. 3.5's arctan rises monotonically to its
//! limit and cannot take the dip, which then leaves a structure at every reversal that hides
//! the element's own causes. Found on the blind generator's seeds 31 and 32 (a quarter of its
//! records carry a Stribeck friction): a softening spring (031's 029) and a Bouc-Wen loop (032's
//! 011) got no cause at 3.9 and 5.6 times the noise floor. The dip is now taken into the fitted
//! baseline's friction beside a spring too, and reported with it (`friction_dip`), not named.
//!
//! The records here come from this file's own generator, not the blind one: a spring with a
//! cubic term, a Coulomb friction as eq. 3.5 writes it, a Stribeck dip above it
//! `(Fs - Fc) exp(-(v / vs)^2) tanh(v / 1 mrad/s)` (Armstrong-Helouvry et al. 1994) and a little
//! viscous friction, moved through multi-sines with random phases, read by a 14-bit encoder. (A
//! Coulomb level through `tanh(v / 1 mrad/s)`, as the blind generator writes it, leaves 1.9-2.3
//! times the floor beside the dip on two of these seeds, and a `reversal_ringing` on one: eq.
//! 3.5's arctan nears its limit as `1 / v`, a tanh at once. That is the arctan's shape, not the
//! dip, and is left out here.)

use jointctl_ident::identify::{IdentifyOptions, Report, identify};

/// 80 s at 500 Hz: a spring of 80 Nm/rad plus `k3_nm_per_rad3 x^3`, a friction of Coulomb level
/// `fc_nm` (eq. 3.5's arctan, `k_b` 200 s/rad) with a Stribeck dip to it from the static level
/// `fs_nm` by the Stribeck speed `vs_rad_per_s`, 0.3 Nm s/rad
/// of viscous friction, 0.03 Nm of noise; the deflection a sum of three sines of 0.1-0.6 Hz
/// (0.05 rad in all) with random phases, quantised to 14 bits.
fn record(k3_nm_per_rad3: f64, fc_nm: f64, fs_nm: f64, vs_rad_per_s: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let sines: Vec<(f64, f64, f64)> = (0..3).map(|_| (0.1 + 0.5 * rng.uniform(), 0.05 / 3.0, TAU * rng.uniform())).collect();
    let q = TAU / 16384.0;
    let (rate, k) = (500.0, 80.0);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..(80.0 * rate) as usize {
        let t = i as f64 / rate;
        let x: f64 = sines.iter().map(|(f, a, p)| a * (TAU * f * t + p).sin()).sum();
        let v: f64 = sines.iter().map(|(f, a, p)| a * TAU * f * (TAU * f * t + p).cos()).sum();
        let coulomb = fc_nm * std::f64::consts::FRAC_2_PI * (200.0 * v).atan();
        let friction = coulomb + (fs_nm - fc_nm) * (-(v / vs_rad_per_s).powi(2)).exp() * (v / 1e-3).tanh() + 0.3 * v;
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(k * x + k3_nm_per_rad3 * x.powi(3) + friction + 0.03 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

fn named(report: &Report) -> Vec<&str> {
    report.causes.iter().map(|c| c.effect.as_str()).collect()
}

/// The seeds of both tests.
const SEEDS: [u64; 4] = [0x5b1e_c0de_0000_0001, 0x5b1e_c0de_0000_0002, 0x5b1e_c0de_0000_0003, 0x5b1e_c0de_0000_0004];

#[test]
fn a_softening_spring_is_named_beside_a_stribeck_friction() {
    // A dip of 0.8 Nm over a Coulomb level of 0.2 Nm, a softening of 0.25 Nm at the peak
    // deflection: before the dip was taken, no cause on any of the four seeds (held-out RMSE
    // 0.170-0.183 Nm against a floor of 0.03). The first seed gets a `reversal_ringing` beside
    // the softening for what the 14-bit rate leaves at the reversals (see the next test).
    let mut wrong = Vec::new();
    for seed in SEEDS {
        let report = identify(&record(-2000.0, 0.2, 1.0, 0.01, seed), &IdentifyOptions::default()).unwrap();
        let k3 = report.causes.iter().find(|c| c.effect == "stiffness_nonlinearity").map(|c| c.params["k3_nm_per_rad3"]);
        if !k3.is_some_and(|k3| (k3 / -2000.0 - 1.0).abs() < 0.25) || named(&report).contains(&"stribeck_friction") || report.friction_dip.is_none() {
            wrong.push(format!("seed {seed:x}: named {:?}, k3 {k3:?}, held out {:.4} -> {:.4} Nm", named(&report), report.rmse_before, report.rmse_after));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn a_stribeck_dip_beside_a_spring_is_reported_with_the_friction_not_named() {
    let mut wrong = Vec::new();
    for seed in SEEDS {
        let report = identify(&record(0.0, 0.3, 0.6, 0.01, seed), &IdentifyOptions::default()).unwrap();
        let dip = report.friction_dip.as_ref();
        let speed = dip.map(|d| d.params["stribeck_speed_rad_per_s"]);
        // The dip's speed within 25 % of the generator's, and a gain from it. What is left
        // sits at the reversals, where the dip switches sign within 1 mrad/s and a 14-bit
        // encoder's rate cannot follow it: 1.4 and 1.7 times the floor on the first and the
        // last seed, where the first also gets a `reversal_ringing` (9.3 Hz) for it.
        let good = !named(&report).contains(&"stribeck_friction")
            && speed.is_some_and(|s| (s / 0.01 - 1.0).abs() < 0.25)
            && report.rmse_after < report.rmse_before;
        if !good {
            wrong.push(format!("seed {seed:x}: named {:?}, dip {:?}, held out {:.4} -> {:.4} Nm ({:.2} times the floor)", named(&report), dip.map(|d| &d.params), report.rmse_before, report.rmse_after, report.unexplained.times_noise));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

