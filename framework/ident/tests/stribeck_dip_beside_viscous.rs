//! A friction record whose friction has a Stribeck dip and a viscous part: the dip is searched
//! among the fits it can physically have (above the Coulomb level), so that a viscous friction,
//! a friction rising with speed, is not taken for an upside-down dip as wide as the recorded
//! rates and rejected, with neither named.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 60 s at 1 kHz of a rigid joint moved back and forth at constant speeds, as a friction test
/// is run: six speeds from 0.05 to 1.5 rad/s, in a new order each round, each for three to six
/// strokes of 0.2-0.8 rad (their corners rounded by a 20 ms moving average of the rate) and a
/// hold of 0.2-1 s after; its torque a static Stribeck friction
/// `sign(v) (fc + (fs - fc) exp(-(v / vs)^2))` (the sign smoothed over 1 mrad/s) plus viscous
/// friction `b v` and 0.03 Nm of noise; the position from a 14-bit encoder. Written here from
/// Armstrong-Helouvry et al. (1994), not with the project's arctan or its dip.
fn stribeck_record(b: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (fc, fs, vs, dt) = (2.0, 2.9, 0.025, 1e-3);
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    // The rate's profile: strokes and holds.
    let mut rate = Vec::new();
    while rate.len() < 60_000 {
        let mut speeds: Vec<f64> = (0..6).map(|k| 0.05 * 30f64.powf(k as f64 / 5.0)).collect();
        for k in (1..speeds.len()).rev() {
            speeds.swap(k, (rng.uniform() * (k + 1) as f64) as usize % (k + 1));
        }
        for speed in speeds {
            let (stroke, strokes) = (0.2 + 0.6 * rng.uniform(), 3 + (rng.uniform() * 4.0) as usize);
            let each = (stroke / speed / dt).round() as usize;
            for k in 0..strokes {
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                // The first and last strokes half as long: the motion ends about where it began.
                let n = if k == 0 || k + 1 == strokes { each / 2 } else { each };
                rate.extend(std::iter::repeat_n(sign * speed, n));
            }
            rate.extend(std::iter::repeat_n(0.0, ((0.2 + 0.8 * rng.uniform()) / dt) as usize));
        }
    }
    rate.truncate(60_000);
    let smooth: Vec<f64> = (0..rate.len()).map(|i| rate[i.saturating_sub(19)..=i].iter().sum::<f64>() / 20.0).collect();
    let q = TAU / 16384.0;
    let (mut t_s, mut position, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let mut x = 0.4;
    for (i, v) in smooth.into_iter().enumerate() {
        x += v * dt;
        t_s.push(i as f64 * dt);
        position.push((x / q).round() * q);
        let friction = (v / 1e-3).tanh() * (fc + (fs - fc) * (-(v / vs).powi(2)).exp()) + b * v;
        torque.push(friction + 0.03 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, position, torque)
}

#[test]
fn a_viscous_friction_beside_a_stribeck_dip_is_named() {
    // Found on the blind generator's friction records (seed 49's 063: a viscous friction of
    // 0.38 Nm s/rad beside a Stribeck friction whose static level is 1.45 times its Coulomb
    // level): the dip, searched on its own, fitted best at the top of its speeds (0.52 rad/s)
    // upside down (-0.39 Nm), a friction rising with speed, and was rejected as impossible; the
    // viscous friction was refused beside it; no cause at 7.4 times the noise floor. Searched
    // among the dips it can have, it is found where it is and the viscous friction is named.
    // Before, on these 24 records: 13 named (nothing on seeds 8 and 10, nor at 0.3 Nm s/rad on
    // seeds 0 and 9, at 1.1-1.9 times the floor). Left open, and why 19 of 24 and not all:
    // seeds 3 (at 0.6), 4 and 6, where nothing is named at 5.2-9.3 times the floor, before and
    // after.
    let mut named_right = 0;
    let mut wrong = Vec::new();
    for seed in 0..12u64 {
        for b in [0.3, 0.6] {
            let report = identify(&stribeck_record(b, 0x7e3a_91c4_05d2_b86f ^ seed), &IdentifyOptions::default()).unwrap();
            let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
            let damping = report.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
            if named == ["viscous_friction"] && damping.is_some_and(|d| (d / b - 1.0).abs() < 0.25) {
                named_right += 1;
            } else {
                wrong.push(format!("seed {seed}, b = {b}: named {named:?}, damping {damping:?}, held out {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after));
            }
        }
    }
    assert!(named_right >= 19, "{named_right} of 24 named within 25 %: {wrong:#?}");
}
