//! A friction record with stops: the deflection column a joint position (no spring), the torque
//! its friction. At rest the friction is static and holds whatever holds the joint; no sliding
//! model predicts it (see `prepare::rest`). Found on the blind generator's friction-position
//! records, where the torque held at each stop left the held-out part at 12 times the noise with
//! the hidden offset unnamed. The records here are this file's own: strokes at 0.15-0.6 rad/s
//! with stops of 0.5-2 s between them, a friction of `FC tanh(v / V_EPS)` (a sign that turns
//! more sharply than eq. 3.5's arctan), and at each stop the drive pressing on to the breakaway
//! for a while and then easing off to a level drawn anew, sampled at 1 kHz through a 14-bit
//! encoder. With the stops in the fit and the judgement, the offset of the first test was not
//! named on its first seed (held-out block t = 0.1).

use jointctl_ident::identify::{IdentifyOptions, identify};

/// Coulomb level [Nm] and the speed over which the sign turns [rad/s].
const FC_NM: f64 = 1.5;
const V_EPS_RAD_PER_S: f64 = 0.004;
/// The torque sensor's noise [Nm].
const NOISE_NM: f64 = 0.02;

/// 60 s at 1 kHz: position [rad] and torque [Nm] with `offset_nm` on the torque.
fn record(seed: u64, offset_nm: f64) -> jointctl_ident::csv::Data {
    record_with(seed, offset_nm, 0.0)
}

/// [`record`]; where `settle_counts` is not zero, each stop begins with the joint settling: a
/// ringing of that many encoder counts (peak) at 12 Hz decaying over 0.1 s about the stop's
/// position, its friction turning with it.
fn record_with(seed: u64, offset_nm: f64, settle_counts: f64) -> jointctl_ident::csv::Data {
    record_damped(seed, offset_nm, settle_counts, 0.0)
}

/// [`record_with`] with a viscous friction of `damping` [Nm s/rad] beside the Coulomb friction.
fn record_damped(seed: u64, offset_nm: f64, settle_counts: f64, damping: f64) -> jointctl_ident::csv::Data {
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ seed);
    let q = std::f64::consts::TAU / 16384.0;
    let dt = 1e-3;
    // (position, torque) at each sample, before quantisation, offset and noise.
    let mut samples: Vec<(f64, f64)> = Vec::with_capacity(62_000);
    let (mut x, mut side) = (0.0f64, 1.0f64);
    while samples.len() < 60_000 {
        // A stroke: to a target on alternate sides, at a speed drawn for it, its speed ramped up
        // and down over 40 ms.
        let target = side * (0.2 + 0.5 * rng.uniform());
        let speed = 0.15 + 0.45 * rng.uniform();
        let duration = (target - x).abs() / speed + 0.04;
        let steps = (duration / dt) as usize;
        let mut friction = 0.0;
        for i in 0..steps {
            let s = i as f64 * dt;
            let ramp = (s / 0.04).min(1.0).min((duration - s) / 0.04).max(0.0);
            let v = side * speed * ramp;
            x += v * dt;
            friction = FC_NM * (v / V_EPS_RAD_PER_S).tanh() + damping * v;
            samples.push((x, friction));
        }
        // The settling: position x + A e^(-s/0.1) sin(2 pi 12 s), for 0.3 s.
        if settle_counts > 0.0 {
            let (w, a) = (std::f64::consts::TAU * 12.0, settle_counts * q);
            for i in 0..300 {
                let s = i as f64 * dt;
                let decay = (-s / 0.1).exp();
                let v = a * decay * (w * (w * s).cos() - (w * s).sin() / 0.1);
                samples.push((x + a * decay * (w * s).sin(), FC_NM * (v / V_EPS_RAD_PER_S).tanh()));
            }
        }
        // A stop: the drive presses on to the breakaway, 1.4 times the Coulomb level, for
        // 0.2-0.8 s, then eases off to a level within +-1 Nm with a time constant of 0.1 s, for
        // 0.5-2 s in all.
        let stop = (0.5 + 1.5 * rng.uniform()) / dt;
        let hold = (0.2 + 0.6 * rng.uniform()) / dt;
        let level = 2.0 * rng.uniform() - 1.0;
        friction *= 1.4;
        for i in 0..stop as usize {
            let after = (i as f64 - hold).max(0.0) * dt;
            samples.push((x, level + (friction - level) * (-after / 0.1).exp()));
        }
        side = -side;
    }
    let t_s = (0..samples.len()).map(|i| i as f64 * dt).collect();
    let position = samples.iter().map(|(x, _)| (x / q).round() * q).collect();
    let torque = samples.iter().map(|(_, tau)| tau + offset_nm + NOISE_NM * rng.normal()).collect();
    jointctl_ident::csv::Data::from_columns(t_s, position, torque)
}

#[test]
fn a_friction_records_stops_are_left_out_and_its_offset_named() {
    for seed in 1..=3 {
        let report = identify(&record(seed, 0.25), &IdentifyOptions::default()).expect("identified");
        let rest = report.at_rest.as_ref().unwrap_or_else(|| panic!("seed {seed}: no stops found"));
        assert!(rest.samples > 5_000 && rest.held_out_samples > 0, "seed {seed}: {rest:?}");
        // The stops' torque, held and let go, is what no sliding model predicts.
        assert!(rest.torque_range_nm[0].is_some_and(|lo| lo < -1.0) && rest.torque_range_nm[1].is_some_and(|hi| hi > 1.0), "seed {seed}: {rest:?}");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let offset = report.causes.iter().find(|c| c.effect == "sensor_offset").unwrap_or_else(|| panic!("seed {seed}: offset not named: {named:?}, {:?}", report.rejected));
        let value = offset.params["offset_nm"];
        assert!((value - 0.25).abs() < 0.25 * 0.25, "seed {seed}: offset {value} Nm for 0.25");
        assert_eq!(named, ["sensor_offset"], "seed {seed}");
        // The stops are what the model does not predict: over every held-out sample the error
        // is larger than over those that slide.
        assert!(rest.rmse_after_all_nm.is_some_and(|x| x > report.rmse_after), "seed {seed}: {rest:?}");
    }
}

#[test]
fn a_joint_that_settles_within_a_count_is_at_rest() {
    // Finding (the blind generator's Stribeck friction records, seed 12's 063): a joint that
    // comes to rest ringing by less than a count reads back and forth between two counts; the
    // rate's narrow windows read each tick as motion, the stop began only after the ringing,
    // and the ringing's friction, turning with a motion the encoder cannot see, was judged as
    // sliding. Here, before: on 4 of these 12 seeds a reversal ring beside the offset (3) or
    // no cause (1).
    for seed in 11..=22 {
        let report = identify(&record_with(seed, 0.25, 0.4), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert_eq!(named, ["sensor_offset"], "seed {seed}: {:?}", report.rejected);
        let value = report.causes[0].params["offset_nm"];
        assert!((value - 0.25).abs() < 0.25 * 0.25, "seed {seed}: offset {value} Nm for 0.25");
    }
}

#[test]
fn a_clean_friction_record_with_stops_gets_no_cause() {
    for seed in 4..=6 {
        let report = identify(&record(seed, 0.0), &IdentifyOptions::default()).expect("identified");
        assert!(report.at_rest.is_some(), "seed {seed}: no stops found");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert!(named.is_empty(), "seed {seed}: named {named:?}");
    }
}

#[test]
fn a_spring_that_holds_is_no_stick_phase() {
    // The same motion through a spring of 60 Nm/rad: at a stop the torque still follows the
    // deflection, and nothing is left out.
    let mut data = record(7, 0.0);
    for (tau, x) in data.torque.iter_mut().zip(&data.deflection) {
        *tau += 60.0 * x;
    }
    let report = identify(&data, &IdentifyOptions::default()).expect("identified");
    assert!(report.at_rest.is_none(), "{:?}", report.at_rest);
}

#[test]
fn a_slow_sines_reversals_are_no_stops() {
    // Finding (review): a slow sine comes to rest at each reversal as slowly as it leaves; read
    // as stops, a friction characterisation's reversals (the pre-sliding itself) were left out:
    // 2132 samples of a 0.05 Hz sine of 0.3 rad at 1 kHz. A stop is arrived at from motion.
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x3c6e_f372_fe94_f82b);
    for (amplitude, hz) in [(0.3, 0.05), (0.05, 0.2)] {
        let t: Vec<f64> = (0..120_000).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|t| amplitude * (TAU * hz * t).sin()).collect();
        let torque = t.iter().map(|t| FC_NM * (amplitude * TAU * hz * (TAU * hz * t).cos() / V_EPS_RAD_PER_S).tanh() + NOISE_NM * rng.normal()).collect();
        let position = x.iter().map(|x| (x / q).round() * q).collect();
        let report = identify(&jointctl_ident::csv::Data::from_columns(t, position, torque), &IdentifyOptions::default()).expect("identified");
        // No stop; its turns, where the reading stays on the count at which the sine turned,
        // are left out (see `friction_turns`), and they are a turn's few counts' worth, not the
        // pre-sliding that follows them (2284 samples of the first sine, 1.9 %: below 5 %).
        let (stops, turns) = report.at_rest.as_ref().map_or((0, 0), |r| (r.samples, r.turn_samples));
        assert!(stops == 0 && turns < 6_000, "{amplitude} rad at {hz} Hz: {:?}", report.at_rest);
    }
}

#[test]
fn a_rate_that_is_not_a_number_is_no_stop() {
    // Finding (review): a deflection that is not a number made the rate so, and the search for
    // stops never moved past it (identify hung). It is no stop; identify answers.
    let mut data = record(1, 0.25);
    data.deflection[55_000] = f64::NAN;
    let _ = identify(&data, &IdentifyOptions::default());
}


#[test]
fn a_stop_lasts_until_the_reading_leaves_its_count() {
    // Finding (the blind generator's seed 6's 065): at the end of a stop the rate, a slope over a
    // window centred on each sample, read the coming stroke's motion 10 ms before the reading's
    // first tick, and the model predicted the sliding friction where the joint still held the
    // stop's torque. Here each stroke sets off from a stop whose torque has eased to a level of
    // its own: before, the baseline's held-out error was 0.11-0.14 Nm (5-7 times the noise) and
    // the viscous friction was named on 3 of these 6 seeds; with the stop on until the reading
    // leaves its count, 0.025-0.035 Nm and all 6.
    let damping = 0.4;
    for seed in 1..=6 {
        let report = identify(&record_damped(seed, 0.0, 0.0, damping), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let found = report.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
        assert!(named == ["viscous_friction"] && found.is_some_and(|b| (b / damping - 1.0).abs() < 0.25), "seed {seed}: named {named:?}, damping {found:?}, held out {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after);
        assert!(report.rmse_before < 2.0 * NOISE_NM, "seed {seed}: the baseline's held-out error {:.4} Nm", report.rmse_before);
    }
}
