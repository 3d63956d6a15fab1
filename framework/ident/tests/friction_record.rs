//! A friction record of a rigid joint (the deflection column a joint position, no spring): a
//! Dahl loop there is the friction's pre-sliding and is reported with the friction, not named
//! `hysteresis`; a spring record's Dahl loop stays `hysteresis`.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 60 s at 1 kHz of a joint moved through sines of 0.2-0.8 Hz and 0.2-0.5 rad about -0.3 rad,
/// its torque a LuGre friction (Canudas de Wit et al. 1995: bristles of stiffness `sigma0`,
/// damping `sigma1`, a Stribeck curve from `fs` down to `fc`) plus viscous friction `b`, with
/// 0.01 Nm of noise; the position from a 17-bit encoder. Integrated here with 10 sub-steps a
/// sample, not with the project's Dahl or arctan.
fn lugre_record(b: f64, seed: u64) -> jointctl_ident::csv::Data {
    lugre_record_about(b, 0.0, -0.3, 1.0, seed)
}

/// [`lugre_record`] with a torque sensor's offset `offset_nm` added to every reading, the joint
/// moved about `centre_rad` with its amplitudes times `scale`.
fn lugre_record_about(b: f64, offset_nm: f64, centre_rad: f64, scale: f64, seed: u64) -> jointctl_ident::csv::Data {
    lugre_record_paced(b, offset_nm, centre_rad, scale, 1.0, seed)
}

/// [`lugre_record_about`] with its sines' frequencies times `pace`.
fn lugre_record_paced(b: f64, offset_nm: f64, centre_rad: f64, scale: f64, pace: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (rate, sub) = (1000.0, 10);
    let (fc, fs, vs, sigma0, sigma1) = (0.5, 0.65, 0.03, 900.0, 2.0);
    let q = TAU / 131072.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let (mut t_s, mut position, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let mut z = 0.0;
    let mut t = 0.0;
    while t < 60.0 {
        let (f, a) = (pace * (0.2 + 0.6 * rng.uniform()), scale * (0.2 + 0.3 * rng.uniform()));
        let start = t;
        let mut v = 0.0;
        let mut dz = 0.0;
        while t < start + 2.0 / f && t < 60.0 {
            for k in 0..sub {
                let local = t - start + k as f64 / (rate * sub as f64);
                v = a * TAU * f * (TAU * f * local).cos();
                let g = fc + (fs - fc) * (-(v / vs).powi(2)).exp();
                dz = v - sigma0 * v.abs() * z / g;
                z += dz / (rate * sub as f64);
            }
            let x = centre_rad + a * (TAU * f * (t + 1.0 / rate - start)).sin();
            t_s.push(t);
            position.push((x / q).round() * q);
            torque.push(sigma0 * z + sigma1 * dz + b * v + offset_nm + 0.01 * rng.normal());
            t += 1.0 / rate;
        }
    }
    jointctl_ident::csv::Data::from_columns(t_s, position, torque)
}

#[test]
fn a_friction_records_pre_sliding_is_reported_with_the_friction_not_as_hysteresis() {
    // Found on the shared real-like records l3-case008 and l3-case036 (an arm joint's LuGre
    // friction against its position): identify named `hysteresis` beside the friction, an extra
    // cause. The bristles' loop is Dahl's friction model; without a spring there is no elastic
    // element whose hysteresis it could be.
    let mut wrong = Vec::new();
    for (i, b) in [0.4, 1.2].into_iter().enumerate() {
        let report = identify(&lugre_record(b, 0x51ed_270b_a1c3_9f47 ^ i as u64), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let presliding = report.no_spring.as_ref().map(|n| n.presliding.clone()).unwrap_or_default();
        let damping = report.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
        let good = !named.contains(&"hysteresis") && damping.is_some_and(|d| (d / b - 1.0).abs() < 0.25) && presliding.contains_key("limit_nm");
        if !good {
            wrong.push(format!("b = {b}: named {named:?}, damping {damping:?}, no_spring {:?}", report.no_spring));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn a_friction_records_stribeck_dip_is_reported_with_the_friction_not_as_ringing() {
    // Found on l3-case008 (the same arm joint at 20 Hz) and on this file's record: with the
    // pre-sliding in, the Stribeck dip left after each reversal was taken by a
    // `reversal_ringing` (a 0.63 Hz "ring" at the damping grid's edge on l3-case008). Still
    // open: the record with b = 0.4 Nm s/rad gets a `time_delay` beside its viscous friction
    // (the bristles' damping lags the friction), so it is not checked here.
    let b = 1.2;
    let report = identify(&lugre_record(b, 0x51ed_270b_a1c3_9f47 ^ 1), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let stribeck = report.no_spring.as_ref().map(|n| n.stribeck.clone()).unwrap_or_default();
    assert_eq!(named, ["viscous_friction"], "{:?}", report.no_spring);
    // The dip's size: fs - fc = 0.15 Nm above the Coulomb level, its speed 0.03 rad/s.
    let (size, speed) = (stribeck.get("stribeck_nm").copied().unwrap_or(0.0), stribeck.get("stribeck_speed_rad_per_s").copied().unwrap_or(0.0));
    assert!(size > 0.05 && size < 0.3 && speed > 0.01 && speed < 0.1, "{stribeck:?}");
}

#[test]
fn a_friction_records_lag_is_reported_with_the_friction_not_as_a_time_delay() {
    // Found on this file's record with b = 0.4 Nm s/rad and on the blind generator's friction
    // records (063-067 on seeds 1-4: a `time_delay` named on 7 of 20, three of them clean or
    // beside the hidden cause): the torque follows a joint's motion through the friction's sign
    // at each reversal, where the bristles' own transition (their stiffness and damping) acts,
    // so a lag between the channels is not told apart from the friction's dynamics. A lead
    // beside the pre-sliding loop is read again as the loop's damping (`identify::presliding`):
    // this record's (LuGre's sigma1 / sigma0, 2.2 ms) reads 2 ms, reported with the pre-sliding.
    let b = 0.4;
    let report = identify(&lugre_record(b, 0x51ed_270b_a1c3_9f47), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let no_spring = report.no_spring.as_ref().expect("read as a friction record");
    assert_eq!(named, ["viscous_friction"], "{no_spring:?}");
    let as_lag = no_spring.lag.contains_key("delay_s") && no_spring.note.contains("lag");
    let as_damping = no_spring.presliding.get("presliding_damping_s").is_some_and(|d| *d > 0.5 * 2.0 / 900.0 && *d < 2.0 * 2.0 / 900.0);
    assert!(as_lag || as_damping, "{no_spring:?}");
}

#[test]
fn a_friction_records_sensor_offset_is_named_where_the_joint_moves_far_from_its_zero() {
    // Found on the blind generator's friction record with a hidden offset 065 (seed 2: 1.05 Nm,
    // the joint moved by 0.075 rad about -0.38 rad): the baseline's polynomial in the position,
    // taken through the position's zero as a spring's is through zero deflection, made the
    // offset its linear term times the motion's distance from that zero, and the offset was not
    // named. A joint position's zero is arbitrary: the polynomial is taken about the training
    // part's mean position. This record moves by 0.04-0.1 rad about -1.5 rad (before: the
    // viscous friction named, the offset not).
    let (b, offset) = (1.2, 0.3);
    let report = identify(&lugre_record_about(b, offset, -1.5, 0.2, 0x51ed_270b_a1c3_9f47 ^ 1), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let found = report.causes.iter().find(|c| c.effect == "sensor_offset").map(|c| c.params["offset_nm"]);
    assert!(found.is_some_and(|o| (o / offset - 1.0).abs() < 0.1), "named {named:?}, offset {found:?}");
}

#[test]
fn a_slow_friction_records_pre_sliding_is_found_once_its_offset_is_named() {
    // Found on the shared real-like l3-case036 (an arm joint's slow LuGre friction with an
    // offset): before the offset was named, the Dahl scale fitted best at 41 mrad; the next
    // step searched only the five scales nearest that, and the pre-sliding at 1.2 mrad was not
    // found (held out 0.244 Nm left, 7.5 times the noise; 0.122 with it). Here, at a quarter of
    // this file's pace: 0.105 Nm left without it.
    let data = lugre_record_paced(0.2, 0.3, -0.8, 1.0, 0.25, 0x51ed_270b_a1c3_9f47 ^ 8);
    let report = identify(&data, &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let limit = report.no_spring.as_ref().and_then(|n| n.presliding.get("limit_nm").copied());
    // The bristles hold between the Coulomb (0.5 Nm) and the static (0.65 Nm) friction.
    let good = named.contains(&"sensor_offset") && limit.is_some_and(|l| (0.4..0.8).contains(&l)) && report.rmse_after < 0.06;
    assert!(good, "named {named:?}, pre-sliding limit {limit:?}, held out {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after);
}

#[test]
fn a_friction_records_offset_is_not_taken_by_a_cubic_of_the_positions_arbitrary_zero() {
    // Found on the blind generator (seed 3's 066: a friction record moving about +0.7 rad, its
    // offset -3.8 Nm drifting): a cubic of the joint position (-27 Nm/rad^3) was named for the
    // offset, with a drift beside it. The baseline's polynomial was taken about the training
    // part's mean position, but a cause's cubic about the position's zero, where x^3 over a
    // stroke far from zero is nearly a constant and a line. Both are now about the same mean.
    // Here, this file's LuGre friction moved by 0.06-0.15 rad about 1.5 rad with a 0.5 Nm
    // offset (before: a cubic named instead of the offset on 2 of these 4 seeds), and the same
    // without the offset (neither an offset nor a cubic; the record's own viscous friction, 0.2
    // Nm s/rad, where it is named, within 25 %: since the pre-sliding is searched at its own
    // scale with LuGre's parts, seed 1 names it at 0.197, 0.0122 Nm held out, where before
    // nothing was named, a loop of 233 Nm/rad for the bristles' 900 and 0.0502 Nm left, five
    // times the noise).
    for seed in 0..4u64 {
        let report = identify(&lugre_record_about(0.2, 0.5, 1.5, 0.3, 0x51ed_270b_a1c3_9f47 ^ (100 + seed)), &IdentifyOptions::default()).unwrap();
        let named: Vec<(&str, f64)> = report.causes.iter().map(|c| (c.effect.as_str(), c.params.get("offset_nm").copied().unwrap_or(f64::NAN))).collect();
        assert!(matches!(named.as_slice(), [("sensor_offset", o)] if (o - 0.5).abs() < 0.025), "seed {seed}: {named:?}");
    }
    for seed in 0..2u64 {
        let report = identify(&lugre_record_about(0.2, 0.0, 1.5, 0.3, 0x51ed_270b_a1c3_9f47 ^ (100 + seed)), &IdentifyOptions::default()).unwrap();
        let named: Vec<(&str, f64)> = report.causes.iter().map(|c| (c.effect.as_str(), c.params.get("damping_nms_per_rad").copied().unwrap_or(f64::NAN))).collect();
        assert!(named.iter().all(|(e, b)| *e == "viscous_friction" && (b / 0.2 - 1.0).abs() < 0.25), "seed {seed} without an offset: {named:?}");
    }
}

#[test]
fn a_friction_records_stribeck_dip_is_read_in_the_presliding_loop_near_lugres() {
    // LuGre's Stribeck curve acts through the bristles (their deflection tends to g(v) /
    // sigma0): on this file's records the joint moves slower than the Stribeck speed (0.03
    // rad/s) over about 0.1 mrad after each turn, inside the pre-sliding (0.56 mrad). Added to
    // eq. 3.5's friction on the rate, the dip read 0.06-0.08 Nm at 0.10-0.16 rad/s on 10 of
    // these 16 records (and none on the other 6), half LuGre's height at 3.5-5 times its speed;
    // read in the loop (`identify::presliding`), 12 of 16 within a factor 2 of the height
    // (0.15 Nm) and 1.5 of the speed. Held to 10 of 16.
    let mut near = Vec::new();
    for b in [0.4, 1.2] {
        for k in 0..8u64 {
            let report = identify(&lugre_record(b, 0x51ed_270b_a1c3_9f47 ^ (200 + k)), &IdentifyOptions::default()).unwrap();
            let dip = report.no_spring.as_ref().map(|n| n.stribeck.clone()).unwrap_or_default();
            let (size, speed) = (dip.get("stribeck_nm").copied().unwrap_or(0.0), dip.get("stribeck_speed_rad_per_s").copied().unwrap_or(0.0));
            near.push((b, k, size, speed, (0.075..=0.3).contains(&size) && (0.02..=0.045).contains(&speed)));
        }
    }
    assert!(near.iter().filter(|r| r.4).count() >= 10, "{near:?}");
}
