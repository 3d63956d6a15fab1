//! A spring whose friction is LuGre's (Canudas de Wit et al. 1995): bristles of stiffness
//! `sigma0` that deflect by `z` before the joint slides, with a damping `sigma1 dz/dt` while they
//! deflect. A Dahl loop is LuGre without that damping; the damping acts just after each turn,
//! where the bristles' state moves fastest, and a lead of the whole torque took its place: on
//! eight records of the blind generator a delay of -2 to -20 ms was named beside the loop. A lead
//! beside a loop is now read again as the loop's pre-sliding damping, `F_c (u + tau_d du/dt)`
//! (`presliding_damping_s`, `sigma1 = sigma tau_d`; `identify::presliding`). The finding's own
//! records check that; this file's own LuGre records (a spring's), on which no lead was named
//! before, check that nothing else changes: beside a spring the damping is looked for only in
//! place of a lead (on a friction record beside the loop alone too, `tests/friction_record.rs`).

use jointctl_ident::identify::{IdentifyOptions, identify};

mod through_the_reader;

const K_NM_PER_RAD: f64 = 150.0;
/// The bristles' stiffness sigma0 [Nm/rad], Coulomb and static levels [Nm], Stribeck speed [rad/s].
const SIGMA0: f64 = 200.0;
const COULOMB_NM: f64 = 0.8;
const STATIC_NM: f64 = 1.1;
const STRIBECK_RAD_PER_S: f64 = 0.03;
/// The bristles' damping sigma1 [Nm s/rad]: sigma1 / sigma0 = 15 ms.
const SIGMA1: f64 = 3.0;
const NOISE_NM: f64 = 0.04;
const RATE_HZ: f64 = 500.0;

/// 120 s at 500 Hz: eight 15 s tests, each a sine (0.2-1.2 Hz) or a triangle (0.2-0.8 Hz) of
/// 0.03-0.06 rad drawn from `seed`, tapered over 1 s at both ends. Torque `K phi + sigma0 z +
/// sigma1 dz/dt` with LuGre's `dz/dt = v - sigma0 |v| z / g(v)`, integrated in 20 sub-steps a
/// sample; white noise; a 14-bit deflection.
fn record(seed: u64, sigma1: f64, static_nm: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x51ed_270b_a5c3_9e11 ^ seed);
    let per_test = (15.0 * RATE_HZ) as usize;
    let mut x = Vec::new();
    for _ in 0..8 {
        let amplitude = 0.03 + 0.03 * rng.uniform();
        let shape: Box<dyn Fn(f64) -> f64> = if rng.uniform() < 0.5 {
            let f = 0.2 + rng.uniform();
            Box::new(move |t| (TAU * f * t).sin())
        } else {
            let f = 0.2 + 0.6 * rng.uniform();
            Box::new(move |t| 4.0 * ((f * t + 0.25).fract() - 0.5).abs() - 1.0)
        };
        for i in 0..per_test {
            let t = i as f64 / RATE_HZ;
            let taper = (t.min(15.0 - t) / 1.0).min(1.0);
            x.push(amplitude * shape(t) * taper);
        }
    }
    let q = TAU / 16384.0;
    let g = |v: f64| COULOMB_NM + (static_nm - COULOMB_NM) * (-(v / STRIBECK_RAD_PER_S).powi(2)).exp();
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let mut z = 0.0;
    let steps = 20;
    for i in 0..x.len() {
        // The state at sample i from the motion since the sample before.
        let v = (x[i] - x[i.saturating_sub(1)]) * RATE_HZ;
        let mut dz_dt = 0.0;
        for _ in 0..steps {
            dz_dt = v - SIGMA0 * v.abs() * z / g(v);
            z += dz_dt / (RATE_HZ * steps as f64);
        }
        t_s.push(i as f64 / RATE_HZ);
        phi.push((x[i] / q).round() * q);
        tau.push(K_NM_PER_RAD * x[i] + SIGMA0 * z + sigma1 * dz_dt + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

/// The blind generator's record `name` of seed `seed`'s suite (that case alone generated),
/// through the CSV reader.
fn blind(seed: u64, name: &str) -> jointctl_ident::csv::Data {
    through_the_reader::suite_record(seed, name)
}

/// The finding's records (the blind generator's LuGre loops, `sigma1 / sigma0` 9-15 ms): before,
/// each named a lead beside the loop (-5, -4 and -5 ms); now the loop alone, with a damping.
#[test]
fn a_lead_beside_a_lugre_loop_is_read_as_its_bristle_damping() {
    let mut wrong = Vec::new();
    for (seed, name) in [(6, "012_hyst_plain"), (56, "010_hyst_plain"), (59, "010_hyst_plain")] {
        let report = identify(&blind(seed, name), &IdentifyOptions::default()).unwrap();
        let named: Vec<String> = report.causes.iter().filter(|c| c.effect != "dropout").map(|c| format!("{} {:?}", c.effect, c.params)).collect();
        let damping = report.causes.iter().find(|c| c.effect == "hysteresis").and_then(|c| c.params.get("presliding_damping_s").copied());
        if named.len() != 1 || damping.is_none() {
            wrong.push(format!("seed {seed}, {name}: {named:?}"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// This file's own LuGre loops with bristle damping (15 ms): the loop alone before and now, no
/// lead named, so no damping looked for.
#[test]
fn a_lugre_loop_without_a_lead_beside_it_is_left_as_it_was() {
    let mut wrong = Vec::new();
    for seed in 1..=4 {
        let report = identify(&record(seed, SIGMA1, STATIC_NM), &IdentifyOptions::default()).unwrap();
        let named: Vec<String> = report.causes.iter().filter(|c| c.effect != "dropout").map(|c| format!("{} {:?}", c.effect, c.params)).collect();
        let damping = report.causes.iter().find(|c| c.effect == "hysteresis").map(|c| c.params.get("presliding_damping_s").copied());
        if named.len() != 1 || damping != Some(None) {
            wrong.push(format!("seed {seed}: {named:?}"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// Without bristle damping, with LuGre's Stribeck rise (the bristles' limit falling from the
/// static level to the Coulomb level as the joint speeds up) and without it (a Dahl loop by
/// another name), the loop takes no damping.
#[test]
fn a_loop_without_bristle_damping_gets_none() {
    let mut wrong = Vec::new();
    for static_nm in [COULOMB_NM, STATIC_NM] {
        for seed in 1..=4 {
            let report = identify(&record(seed, 0.0, static_nm), &IdentifyOptions::default()).unwrap();
            let named: Vec<String> = report.causes.iter().filter(|c| c.effect != "dropout").map(|c| format!("{} {:?}", c.effect, c.params)).collect();
            let damping = report.causes.iter().find(|c| c.effect == "hysteresis").map(|c| c.params.get("presliding_damping_s").copied());
            if named.len() != 1 || damping != Some(None) {
                wrong.push(format!("static {static_nm} Nm, seed {seed}: {named:?}"));
            }
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
