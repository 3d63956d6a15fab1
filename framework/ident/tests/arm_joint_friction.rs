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
//! - A joint's friction pre-slides over its contact's own scale, a fraction of a milliradian,
//!   whatever the range the joint moves over; its loop was searched no narrower than a thousandth
//!   of that range (1.5 mrad over 1.5 rad), and a coarser loop or a time delay stood in for it
//!   (seed 3's `a2-sine-v2`: a delay of 173 ms named, 1.46 times the reference's held-out error).
//!   Checked on the strokes below and on a sine over one side of a range (`sine_record`).
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

/// A sine over `range` [rad] at `hz`, LuGre's friction as [`record`]'s, a gravity model's error of
/// 3 % of the link's load, a torque offset `offset_nm`, white noise and an 18-bit encoder, 1 kHz,
/// `seconds` long.
fn sine_record(seed: u64, range: (f64, f64), hz: f64, offset_nm: f64, seconds: f64) -> jointctl_ident::csv::Data {
    let mut rng = jointctl_test_support::XorShift64::new(0x05e1_e0f5 ^ seed);
    let count = std::f64::consts::TAU / f64::from(1u32 << 18);
    let dt = 1e-3;
    let (mid, half) = (0.5 * (range.0 + range.1), 0.5 * (range.1 - range.0));
    let w = std::f64::consts::TAU * hz;
    let mut z = 0.0f64;
    let n = (seconds / dt) as usize;
    let (mut t_s, mut position, mut torque) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let t = i as f64 * dt;
        let q = mid + half * (w * t).sin();
        let v = half * w * (w * t).cos();
        let g = FC_NM + (FS_NM - FC_NM) * (-(v / VS_RAD_PER_S).powi(2)).exp();
        let rate = SIGMA0 * v.abs() / g;
        let z_end = if rate > 0.0 { v / rate + (z - v / rate) * (-rate * dt).exp() } else { z };
        let dz = (z_end - z) / dt;
        z = z_end;
        t_s.push(t);
        position.push((q / count).round() * count);
        torque.push(SIGMA0 * z + SIGMA1 * dz + VISCOUS * v + LINK_NM * 0.03 * (q + 0.4).cos() + offset_nm + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, position, torque)
}

/// LuGre's pre-sliding scale, the Coulomb level over the bristles' stiffness [rad] (0.4 mrad).
const PRESLIDING_RAD: f64 = FC_NM / SIGMA0;

#[test]
fn a_joints_presliding_narrower_than_a_thousandth_of_its_range_is_found_at_its_own_scale() {
    for seed in 10..=12 {
        // Strokes over 1 rad on one side of the load's peak, read as a friction record: before,
        // the loop was searched no narrower than a thousandth of 1.46 rad and took 0.44-0.46 Nm
        // at 298-323 Nm/rad (a scale of 1.4-1.5 mrad), 3.4-3.9 times the noise left.
        let report = identify(&record(seed, (-1.46, -0.46), (0.04, -0.03)), &IdentifyOptions::default()).expect("identified");
        let presliding = report.no_spring.as_ref().map(|n| n.presliding.clone()).unwrap_or_else(|| panic!("seed {seed}: read as a spring"));
        let (limit, sigma) = (presliding["limit_nm"], presliding["sigma_nm_per_rad"]);
        assert!((0.8 * FC_NM..=1.1 * FS_NM).contains(&limit), "seed {seed}: {presliding:?}");
        let scale = limit / sigma;
        assert!((scale / PRESLIDING_RAD - 1.0).abs() < 0.4, "seed {seed}: a scale of {scale} rad for {PRESLIDING_RAD}: {presliding:?}");
        assert!(report.rmse_after < 2.0 * NOISE_NM, "seed {seed}: {} Nm left", report.rmse_after);
    }
}

#[test]
fn a_sine_over_one_side_of_a_joints_range_leaves_its_friction_to_the_presliding_loop() {
    for seed in 1..=3 {
        // A line in the position takes the gravity model's error here, and the record reads as
        // a spring's; the loop is the friction's pre-sliding all the same. Before, its scale
        // stopped at a thousandth of 1.46 rad and 5.9 times the noise was left.
        let report = identify(&sine_record(seed, (-1.46, -0.46), 0.15, 1.6, 120.0), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let ring = report.causes.iter().find(|c| c.effect == "hysteresis").unwrap_or_else(|| panic!("seed {seed}: no loop: {named:?}"));
        let scale = ring.params["limit_nm"] / ring.params["sigma_nm_per_rad"];
        assert!((scale / PRESLIDING_RAD - 1.0).abs() < 0.4, "seed {seed}: a scale of {scale} rad: {:?}", ring.params);
        assert!(!named.contains(&"time_delay") && report.rmse_after < 2.5 * NOISE_NM, "seed {seed}: {named:?}, {} Nm left", report.rmse_after);
    }
}
