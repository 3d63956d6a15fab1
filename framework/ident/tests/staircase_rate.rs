//! Holds and quick moves through a 14-bit encoder at 1 kHz: the deflection holds its reading on
//! most samples, and a move crosses a count every few milliseconds. Read over the usual windows
//! (a least-squares line through the readings), the rate is smeared where a move starts, stops
//! and bends, and eq. 3.5's arctan fits better straight than as it is: at its lowest `k_b` it
//! stands for a viscous friction beside it, which is then not told from zero. Such a record is
//! identified again with its rate read through the count's crossings, kept when the whole model
//! is better (`bin_reading::Reading::Crossings`). The records are this file's own: a spring,
//! eq. 3.5's friction, a viscous friction or none, the torque sensor's noise; each move a
//! minimum-jerk stroke between holds.

use jointctl_ident::identify::bin_reading::RateWindow;
use jointctl_ident::identify::{IdentifyOptions, identify};

/// The spring [Nm/rad], eq. 3.5's friction (`k_a` [Nm], `k_b` [s/rad]) and the torque sensor's
/// noise [Nm].
const K_NM_PER_RAD: f64 = 50.0;
const K_A_NM: f64 = 0.2;
const K_B_S_PER_RAD: f64 = 25.0;
const NOISE_NM: f64 = 0.027;

/// 45 s at 1 kHz through a 14-bit encoder: holds of 2-6 s, each followed by a minimum-jerk
/// move of 0.4-1.0 s to a new deflection within +-0.06 rad (peak rates about 0.1-0.3 rad/s); a
/// viscous friction of `damping` [Nm s/rad].
fn record(seed: u64, damping: f64) -> jointctl_ident::csv::Data {
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ seed);
    let q = std::f64::consts::TAU / 16384.0;
    let (dt, duration) = (1e-3, 45.0);
    // The moves: start time [s], length [s], from and to [rad].
    let mut moves = Vec::new();
    let (mut at, mut x) = (0.0, 0.0);
    while at < duration {
        let start = at + 2.0 + 4.0 * rng.uniform();
        let length = 0.4 + 0.6 * rng.uniform();
        let mut to = -0.06 + 0.12 * rng.uniform();
        if (to - x).abs() < 0.02 {
            to = if x > 0.0 { x - 0.04 } else { x + 0.04 };
        }
        moves.push((start, length, x, to));
        (at, x) = (start + length, to);
    }
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..(duration / dt) as usize {
        let t = i as f64 * dt;
        // Where the motion is: at rest after the last move begun, or within it.
        let (mut x, mut v) = (0.0, 0.0);
        for &(start, length, from, to) in &moves {
            if t < start {
                break;
            }
            let s = ((t - start) / length).min(1.0);
            x = from + (to - from) * s.powi(3) * (10.0 - 15.0 * s + 6.0 * s * s);
            v = if s < 1.0 { (to - from) / length * 30.0 * s * s * (1.0 - s).powi(2) } else { 0.0 };
        }
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(K_NM_PER_RAD * x + K_A_NM * (K_B_S_PER_RAD * v).atan() + damping * v + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// Seeds of each kind of record.
const SEEDS: std::ops::RangeInclusive<u64> = 1..=12;

#[test]
fn a_viscous_friction_between_holds_is_named_with_the_rate_read_through_the_crossings() {
    // 10 Nm s/rad beside eq. 3.5's arctan. Before (the rate over the usual windows): named on
    // 3 of the 12 seeds, at 8.96 +- 2.42, 5.97 +- 6.18 and 9.05 +- 1.44 Nm s/rad, and on the
    // others reported as confounded with the baseline's arctan at its lowest `k_b`. After: on
    // 11, 10 of them read through the crossings at 9.76-10.27 with errors of 0.03-0.21.
    let mut close = Vec::new();
    for seed in SEEDS {
        let report = identify(&record(seed, 10.0), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert!(named.iter().all(|c| *c == "viscous_friction"), "seed {seed}: named {named:?}");
        let Some(viscous) = report.causes.iter().find(|c| c.effect == "viscous_friction") else { continue };
        let damping = viscous.params["damping_nms_per_rad"];
        if (damping - 10.0).abs() < 0.05 * 10.0 {
            assert!(matches!(report.narrow_rate.as_ref().map(|r| r.window), Some(RateWindow::Crossings { .. })), "seed {seed}: {damping} Nm s/rad, rate read {:?}", report.narrow_rate);
            close.push(seed);
        }
    }
    assert!(close.len() >= 9, "within 5 % of the damping on seeds {close:?} only");
}

#[test]
fn without_one_nothing_is_named() {
    // No cause on any of the 12 seeds, before and after; the crossings were taken on 8.
    let with_a_cause: Vec<u64> = SEEDS.filter(|seed| !identify(&record(*seed, 0.0), &IdentifyOptions::default()).expect("identified").causes.is_empty()).collect();
    assert!(with_a_cause.len() <= 1, "a cause named on the clean seeds {with_a_cause:?}");
}
