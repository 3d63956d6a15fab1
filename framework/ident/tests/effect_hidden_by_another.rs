//! A large effect can hide a small one on the training part: while the large one is left out,
//! the small one's columns take only a share of its error, earn less than BIC's threshold and
//! are never tested; and the large one alone, refused on the held-out part, is never the model
//! the small one is searched beside. A friction record's torque offset hid its Stribeck dip (eq.
//! 3.5's arctan cannot rise towards the static level at low speed): the offset alone worsened the
//! part of the held-out record that moved slowly, one way, where the dip's error lay, and was
//! refused; the dip alone earned 4 where BIC asks 10. Now the candidates that fell short of BIC's
//! threshold alone are searched again beside the first proposal whose held-out gain was relevant
//! and unconfirmed, as those impossible alone were (`select::beside_an_unconfirmed`).

use jointctl_ident::identify::{IdentifyOptions, identify};

mod through_the_reader;

/// Eq. 3.5's Coulomb level, the static level and the Stribeck speed of this file's friction
/// [Nm, Nm, rad/s] (Stribeck's law, `sign(v) (F_c + (F_s - F_c) exp(-(v/v_s)^2))`).
const COULOMB_NM: f64 = 2.0;
const STATIC_NM: f64 = 2.8;
const STRIBECK_RAD_PER_S: f64 = 0.05;
/// The torque sensor's offset at the record's middle [Nm] and its drift over the whole record
/// (a share of the offset).
const OFFSET_NM: f64 = -0.8;
const NOISE_NM: f64 = 0.03;
const RATE_HZ: f64 = 500.0;

/// A friction test of a rigid joint (the first column its position, 14-bit): 24 s of strokes
/// (a sine of 1.5-2.5 Hz, 0.06-0.1 rad), 10 s of slow moves (at the Stribeck speed, 0.05-0.12
/// rad each way, holds of 0.5-1.5 s between), 10 s at rest, then a slow move of 0.3 rad one way
/// and 10 s of strokes about where it ended: the held-out last 30 % moves slowly one way, then
/// fast, about a position the training part never reached. Offset `OFFSET_NM (1 - drift (t -
/// t_mid) / t_len)`, white noise.
fn record(seed: u64, drift: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x2f6d_8e41_c0b3_5a97 ^ seed);
    let dt = 1.0 / RATE_HZ;
    let samples = |s: f64| (s * RATE_HZ) as usize;
    let slow = STRIBECK_RAD_PER_S;
    let mut x: Vec<f64> = Vec::new();
    let strokes = |x: &mut Vec<f64>, rng: &mut jointctl_test_support::XorShift64, seconds: f64, centre: f64| {
        let (f, a) = (rng.range(1.5, 2.5), rng.range(0.06, 0.1));
        x.extend((0..samples(seconds)).map(|i| centre + a * (TAU * f * i as f64 * dt).sin()));
    };
    let centre = 0.7;
    strokes(&mut x, &mut rng, 24.0, centre);
    let (end, mut p, mut way) = (x.len() + samples(10.0), centre, 1.0);
    while x.len() < end {
        x.extend(std::iter::repeat_n(p, samples(rng.range(0.5, 1.5))));
        let steps = samples(rng.range(0.05, 0.12) / slow);
        x.extend((1..=steps).map(|i| p + way * slow * dt * i as f64));
        p = *x.last().unwrap_or(&p);
        way = -way;
    }
    x.truncate(end);
    x.extend(std::iter::repeat_n(centre, samples(10.0)));
    x.extend((0..samples(6.0)).map(|i| centre + (slow * dt * i as f64).min(0.3)));
    strokes(&mut x, &mut rng, 10.0, centre + 0.3);
    let n = x.len();
    let (t_len, t_mid) = (n as f64 * dt, 0.5 * n as f64 * dt);
    let q = TAU / 16384.0;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let t = i as f64 * dt;
        let v = (x[(i + 1).min(n - 1)] - x[i.saturating_sub(1)]) / (2.0 * dt);
        let level = COULOMB_NM + (STATIC_NM - COULOMB_NM) * (-(v / STRIBECK_RAD_PER_S).powi(2)).exp();
        let friction = v.signum() * level * (v.abs() / 1e-3).tanh();
        let offset = OFFSET_NM * (1.0 - drift * (t - t_mid) / t_len);
        t_s.push(t);
        phi.push((x[i] / q).round() * q);
        tau.push(friction + offset + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

/// The blind generator's record `name` of seed `seed`'s suite (that case alone generated),
/// through the CSV reader.
fn blind(seed: u64, name: &str) -> jointctl_ident::csv::Data {
    through_the_reader::suite_record(seed, name)
}

/// The causes named, less dropouts.
fn named(report: &jointctl_ident::identify::Report) -> Vec<String> {
    let mut named: Vec<String> = report.causes.iter().filter(|c| c.effect != "dropout").map(|c| c.effect.clone()).collect();
    named.sort();
    named
}

/// The finding's records, each "no cause" before: blind seed 59's 066 (a friction record, a
/// Stribeck friction and a drifting torque offset; 19 times the noise floor left) and seed 3's
/// 099 (a dead zone beside a stiffening spring read through a 2e-6 rad encoder: the cubic's
/// held-out gain relevant, not confirmed alone; the dead zone short of BIC's threshold alone).
#[test]
fn the_findings_records_name_what_was_hidden() {
    let mut wrong = Vec::new();
    for (seed, name, hidden) in [(59, "066_offset_friction_position-epoch", &["sensor_offset"][..]), (3, "099_deadzone-stiff_linear2e-6", &["dead_zone", "stiffness_nonlinearity"][..])] {
        let report = identify(&blind(seed, name), &IdentifyOptions::default()).unwrap();
        if named(&report) != hidden || report.rmse_after >= 0.8 * report.rmse_before {
            wrong.push(format!("seed {seed}, {name}: {:?}, held out {:.4} -> {:.4} Nm", named(&report), report.rmse_before, report.rmse_after));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// This file's own friction records: of seeds 1-16, with and without a drift of half the offset,
/// 4 of 32 got no cause before (seed 12 without drift, 6, 10 and 12 with it; checked by leaving
/// the short candidates out of the search beside an unconfirmed one), 2 now (10 and 12 with the
/// drift: there the offset, its drift and the dip are three, and the offset alone was no
/// better on the held-out part, so nothing was searched beside it). The two that gained: the
/// offset is named, within 25 % of the true one at the record's middle, and the friction's
/// Stribeck dip is reported with the friction.
#[test]
fn an_offset_that_hides_a_stribeck_dip_is_named_with_it() {
    let mut wrong = Vec::new();
    for (seed, drift) in [(12, 0.0), (6, 0.5)] {
        let report = identify(&record(seed, drift), &IdentifyOptions::default()).unwrap();
        let offset = report.causes.iter().find(|c| c.effect == "sensor_offset").and_then(|c| c.params.get("offset_nm").copied());
        let dip = report.no_spring.as_ref().is_some_and(|s| !s.stribeck.is_empty());
        if named(&report) != ["sensor_offset"] || !offset.is_some_and(|o| (o / OFFSET_NM - 1.0).abs() < 0.25) || !dip {
            wrong.push(format!("seed {seed}, drift {drift}: {:?}, offset {offset:?}, dip {dip}, held out {:.4} -> {:.4} Nm", named(&report), report.rmse_before, report.rmse_after));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}


/// A mode is not searched beside a mode: on blind seed 7's 084 (clean, 20 Hz bins, the
/// baseline's misfit at the reversals 7.9 times the floor) a steady vibration's gain was relevant
/// and unconfirmed, and a vibration that grows with speed, searched beside it, fitted the same
/// 4.60 Hz; the two were named together (0.1646 -> 0.1458 Nm), one mode read two ways.
#[test]
fn a_clean_record_gets_no_mode_beside_a_mode() {
    let report = identify(&blind(7, "084_none_bin20"), &IdentifyOptions::default()).unwrap();
    assert!(named(&report).is_empty(), "{:?}", named(&report));
}
