//! An arm joint's friction record (issue 36): the deflection column a joint position, the torque a
//! link-side sensor's less a gravity model. Two findings on the rig generator's arm joints:
//!
//! - The gravity model leaves a few per cent of the link's weight, `G (e_m cos(q + phi) + e_a
//!   sin(q + phi))` (a mass and a centre-of-mass angle off). That load is even about the
//!   motion's middle as well as odd: the baseline's line and a cubic take its odd part only, and
//!   an offset its mean; before `gravity_error` seed 4's `a2-sweep-v2` (position -2.0 to 0.7
//!   rad) got no cause at 0.1149 Nm held out where the plain least-squares reference with its
//!   raw cube left 0.0752.
//! - At a stop the joint holds the friction it stopped with; the stops are left out of the fit
//!   and the judgement, and over every held-out sample they were predicted as sliding at zero
//!   rate, with no friction (seed 2's `a2-sweep-v3`: 0.2612 Nm over every held-out sample, 2476
//!   of them at rest, against the reference's 0.1868).
//!
//! The records are this file's own, not built from identify's causes: LuGre's friction (bristles
//! of stiffness `SIGMA0`, a Stribeck breakaway, integrated exactly over each step at a constant
//! rate; its state held at the stops), strokes between targets drawn over the range with stops of
//! 0.3-1.5 s between them, a torque offset, white noise and an 18-bit encoder, 1 kHz, 150 s.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// LuGre: bristle stiffness [Nm/rad], Coulomb and breakaway levels [Nm], Stribeck speed [rad/s],
/// viscous coefficient [Nm s/rad].
const SIGMA0: f64 = 2.0e3;
const FC_NM: f64 = 0.8;
const FS_NM: f64 = 1.0;
const VS_RAD_PER_S: f64 = 0.03;
const VISCOUS: f64 = 0.05;
/// LuGre's bristle damping [Nm s/rad].
const SIGMA1: f64 = 0.5;
/// The link's gravity torque at its largest [Nm] (a distal link of an arm).
const LINK_NM: f64 = 7.0;
const NOISE_NM: f64 = 0.01;
const OFFSET_NM: f64 = 0.15;

/// 150 s at 1 kHz over positions `range` [rad]; the gravity model's errors `(e_m, e_a)`.
fn record(seed: u64, range: (f64, f64), errors: (f64, f64)) -> jointctl_ident::csv::Data {
    let mut rng = jointctl_test_support::XorShift64::new(0x51a7_e0f5 ^ seed);
    let count = std::f64::consts::TAU / f64::from(1u32 << 18);
    let dt = 1e-3;
    let phi = 0.4;
    let (mut q, mut z) = (0.5 * (range.0 + range.1), 0.0f64);
    // (position, friction) at each sample, before the gravity model's error, quantisation,
    // offset and noise.
    let mut samples: Vec<(f64, f64)> = Vec::with_capacity(152_000);
    while samples.len() < 150_000 {
        let target = range.0 + (range.1 - range.0) * rng.uniform();
        let speed = 0.1 + 0.5 * rng.uniform();
        let side = (target - q).signum();
        let duration = (target - q).abs() / speed + 0.1;
        for i in 0..(duration / dt) as usize {
            let s = i as f64 * dt;
            let v = side * speed * (s / 0.05).min(1.0).min((duration - s) / 0.05).max(0.0);
            q += v * dt;
            // dz/dt = v - sigma0 |v| z / g(v): exact over the step at a constant rate.
            let g = FC_NM + (FS_NM - FC_NM) * (-(v / VS_RAD_PER_S).powi(2)).exp();
            let rate = SIGMA0 * v.abs() / g;
            let z_end = if rate > 0.0 { v / rate + (z - v / rate) * (-rate * dt).exp() } else { z };
            let dz = (z_end - z) / dt;
            z = z_end;
            samples.push((q, SIGMA0 * z + SIGMA1 * dz + VISCOUS * v));
        }
        for _ in 0..((0.3 + 1.2 * rng.uniform()) / dt) as usize {
            samples.push((q, SIGMA0 * z));
        }
    }
    let t_s = (0..samples.len()).map(|i| i as f64 * dt).collect();
    let position = samples.iter().map(|(q, _)| (q / count).round() * count).collect();
    let gravity = |q: f64| LINK_NM * (errors.0 * (q + phi).cos() + errors.1 * (q + phi).sin());
    let torque = samples.iter().map(|(q, friction)| friction + gravity(*q) + OFFSET_NM + NOISE_NM * rng.normal()).collect();
    jointctl_ident::csv::Data::from_columns(t_s, position, torque)
}

#[test]
fn a_gravity_models_error_over_a_joints_range_is_named_beside_its_offset() {
    for seed in 1..=3 {
        let (e_m, e_a) = (0.04, -0.03);
        // Swept about the load's peak (`q = -phi + atan2(e_a, e_m)`, -1.04 rad: a link swept
        // through the horizontal), where the load is even about the middle: a line in the
        // position takes little of it, and the record reads as a joint's friction (see "Left"
        // in `docs/benchmarks.md`: where a line takes more, as over a range to one side of the
        // peak, the record reads as a spring's, and the load is the spring's).
        let report = identify(&record(seed, (-2.3, 0.2), (e_m, e_a)), &IdentifyOptions::default()).expect("identified");
        assert!(report.no_spring.is_some(), "seed {seed}: read as a spring");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let g = report.causes.iter().find(|c| c.effect == "gravity_error").unwrap_or_else(|| panic!("seed {seed}: not named: {named:?}, {:?}", report.rejected));
        let amplitude = g.params["gravity_amplitude_nm"];
        let truth = LINK_NM * e_m.hypot(e_a);
        assert!((amplitude - truth).abs() < 0.25 * truth, "seed {seed}: {amplitude} Nm for {truth}");
        assert!(named.contains(&"sensor_offset"), "seed {seed}: {named:?}");
    }
}

#[test]
fn a_friction_record_without_one_gets_no_gravity_error() {
    // The same motions with the gravity model exact, over the wide range and a narrow one.
    for (seed, range) in [(4, (-2.3, 0.2)), (5, (-2.3, 0.2)), (6, (-1.3, -0.8))] {
        let report = identify(&record(seed, range, (0.0, 0.0)), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert!(!named.contains(&"gravity_error"), "seed {seed}: {named:?}");
    }
}

#[test]
fn a_joints_stops_are_predicted_holding_the_friction_it_stopped_with() {
    for seed in 7..=9 {
        let report = identify(&record(seed, (-2.3, 0.2), (0.04, -0.03)), &IdentifyOptions::default()).expect("identified");
        let rest = report.at_rest.as_ref().unwrap_or_else(|| panic!("seed {seed}: no stops found"));
        assert!(rest.held_out_samples > 2_000, "seed {seed}: {rest:?}");
        // What the stops hold beyond the model's own prediction there, with the friction's Dahl
        // pre-sliding, whose state holds at rest too: LuGre's state at a stop, between the
        // Coulomb level and the breakaway.
        let held = rest.held_nm.unwrap_or_else(|| panic!("seed {seed}: {rest:?}"));
        let presliding = report.no_spring.as_ref().and_then(|n| n.presliding.get("limit_nm").copied()).unwrap_or(0.0);
        assert!((0.9 * FC_NM..=1.1 * FS_NM).contains(&(held + presliding)), "seed {seed}: held {held} Nm beside a pre-sliding loop of {presliding}");
        // The stops predicted about as well as the samples that slide: a stop read as sliding at
        // zero rate misses the friction held there by 0.8-1 Nm.
        let all = rest.rmse_after_all_nm.unwrap_or(f64::INFINITY);
        assert!(all < 1.5 * report.rmse_after, "seed {seed}: {all} Nm over every held-out sample, {} over those that slide", report.rmse_after);
    }
}
