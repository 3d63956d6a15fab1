//! Eq. 3.5's arctan friction is Coulomb friction smoothed through zero velocity. Fitted with a
//! smoothing speed above every recorded speed, it is a straight line in the rate: a viscous
//! friction under another name. The baseline's arctan must bend inside the recorded speeds, so
//! that a friction that grows with the rate is named `viscous_friction`.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// A 0.3 Hz, 0.08 rad sine plus a 0.1 Hz, 0.04 rad one (peak rate about 0.18 rad/s), 60 Nm/rad,
/// a small eq. 3.5 friction `0.01 atan(40 v)` (at the noise level) (its smoothing speed, 0.025 rad/s, well inside the
/// recorded speeds), a viscous friction `b` [Nm s/rad] and a cubic stiffness `k3` [Nm/rad^3];
/// 14-bit deflection, 0.01 Nm noise, 500 Hz for 60 s.
fn record(b: f64, k3: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (rate, n, k) = (500.0, 30_000, 60.0);
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x5851_f42d_4c95_7f2d);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let t = i as f64 / rate;
        let x = 0.08 * (TAU * 0.3 * t).sin() + 0.04 * (TAU * 0.1 * t).sin();
        let v = 0.08 * TAU * 0.3 * (TAU * 0.3 * t).cos() + 0.04 * TAU * 0.1 * (TAU * 0.1 * t).cos();
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(k * x + k3 * x.powi(3) + 0.01 * (40.0 * v).atan() + b * v + 0.01 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_friction_that_grows_with_the_rate_is_named_viscous_not_absorbed_by_the_arctan() {
    // Issue 31, finding 1: a large viscous friction (here 2 Nm s/rad, 0.35 Nm at top speed,
    // 2.4 % of the torque range) got no cause. The baseline's k_b grid reached down to a smoothing
    // speed of three times the peak rate, where the arctan is a straight line: the baseline took
    // the viscous friction as its own, and the cause had nothing left to explain.
    for (b, k3, other) in [(2.0, 0.0, None), (2.0, -3000.0, Some("stiffness_nonlinearity"))] {
        let report = identify(&record(b, k3), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let viscous = report.causes.iter().find(|c| c.effect == "viscous_friction");
        assert!(viscous.is_some(), "b = {b}, k3 = {k3}: named {named:?}, negligible {:?}, rejected {:?}", report.negligible, report.rejected);
        let found = viscous.unwrap().params["damping_nms_per_rad"];
        assert!((found - b).abs() < 0.25 * b, "b = {found} for {b}: {}", viscous.unwrap().evidence);
        if let Some(other) = other {
            assert!(named.contains(&other), "k3 = {k3}: named {named:?}");
        }
    }
    // The same record without the viscous friction: eq. 3.5's arctan alone, nothing to name.
    let clean = identify(&record(0.0, 0.0), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes);
}

/// A record whose last part moves faster than the rest: after a 3 s hold, a 0.2 Hz sine of
/// 0.03 rad under a Hann envelope until 21 s (peak rate about 0.04 rad/s: the training part),
/// then a 1.3 Hz sine of 0.027 rad under its own envelope until 30 s (about 0.2 rad/s, most of
/// the held-out part); 400 Nm/rad, eq. 3.5 friction `k_a atan(40 v)`, a viscous friction `b`;
/// 14-bit deflection, 0.2 Nm noise (drawn from `seed`), 1 kHz.
fn faster_at_the_end(k_a: f64, b: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let x = |t: f64| if t < 21.0 { 0.03 * hann(t, 3.0, 21.0) * (TAU * 0.2 * (t - 3.0)).sin() } else { 0.027 * hann(t, 21.0, 30.0) * (TAU * 1.3 * (t - 21.0)).sin() };
    sampled(1000.0, 30_000, x, |x, v| 400.0 * x + k_a * (40.0 * v).atan() + b * v, 0.2, 0x2545_f491_4f6c_dd1d ^ seed)
}

/// `sin^2` of the share of `[a, b]` that `t` has covered: a Hann envelope over that span.
fn hann(t: f64, a: f64, b: f64) -> f64 {
    (std::f64::consts::PI * ((t - a) / (b - a)).clamp(0.0, 1.0)).sin().powi(2)
}

/// `n` samples at `rate` [Hz] of the deflection `x(t)` [rad] (14-bit) and the torque
/// `torque(x, v)` [Nm] (`v` its rate) plus `noise` [Nm] of normal noise drawn from `seed`.
fn sampled(rate: f64, n: usize, x: impl Fn(f64) -> f64, torque: impl Fn(f64, f64) -> f64, noise: f64, seed: u64) -> jointctl_ident::csv::Data {
    let q = std::f64::consts::TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let (mut t_s, mut deflection, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let t = i as f64 / rate;
        let v = (x(t + 1e-6) - x(t - 1e-6)) / 2e-6;
        t_s.push(t);
        deflection.push((x(t) / q).round() * q);
        tau.push(torque(x(t), v) + noise * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, tau)
}

#[test]
fn a_viscous_friction_the_training_part_cannot_tell_from_the_arctan_is_decided_on_the_held_out_part() {
    // Found on the blind generator's seed 8 (000: 52 Nm s/rad beside an arctan of 0.71 Nm, the
    // record's last part far faster than the rest): over the training part's rates eq. 3.5's
    // arctan is nearly straight and takes the viscous friction as its own, BIC never proposes
    // one, and the report said "no listed cause explains it" at 12 times the noise. The
    // held-out part moves faster, where the arctan saturates and the damping does not: it
    // decides, as for any proposal. Measured on these eight records (10 Nm s/rad, 2.9 times the
    // noise): viscous friction named alone on 0 of them before, on 6 after (held-out RMSE
    // 0.51-0.58 -> 0.22-0.25 Nm, noise 0.2); a time delay stands in for it on one, nothing on
    // another. Held out as the last 30 % (`--held-out last`): by default the window held out
    // moves to one like the rest, the training part then holds the fast part, and BIC proposes
    // the viscous friction itself (checked at the end).
    let last = IdentifyOptions { held_out: jointctl_ident::identify::prepare::HeldOut::Last, ..IdentifyOptions::default() };
    let mut alone = 0;
    for (k_a, seed) in [0.3, 0.7].into_iter().flat_map(|k_a| (1..=4).map(move |s| (k_a, s))) {
        let report = identify(&faster_at_the_end(k_a, 10.0, seed), &last).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        println!("k_a {k_a}, seed {seed}: {named:?}, held-out {:.3} -> {:.3} Nm", report.rmse_before, report.rmse_after);
        if named == ["viscous_friction"] {
            alone += 1;
            // Named by the held-out decision, not by BIC.
            assert!(report.causes[0].evidence.contains("cannot tell it from eq. 3.5's nearly straight arctan"), "{}", report.causes[0].evidence);
            assert!(report.rmse_after < 1.5 * report.unexplained.noise_floor_nm, "{} Nm left, noise {}", report.rmse_after, report.unexplained.noise_floor_nm);
        }
    }
    assert!(alone >= 6, "viscous friction named alone on {alone} of 8");
    // Not beyond the causes asked for.
    let none = identify(&faster_at_the_end(0.3, 10.0, 1), &IdentifyOptions { max_causes: 0, held_out: last.held_out, ..IdentifyOptions::default() }).unwrap();
    assert!(none.causes.is_empty(), "max_causes 0: {:?}", none.causes);
    // Without the viscous friction: nothing to name.
    for k_a in [0.3, 0.7] {
        let clean = identify(&faster_at_the_end(k_a, 0.0, 1), &last).unwrap();
        assert!(clean.causes.is_empty(), "k_a {k_a}: {:?}", clean.causes);
        let clean = identify(&faster_at_the_end(k_a, 0.0, 1), &IdentifyOptions::default()).unwrap();
        assert!(clean.causes.is_empty(), "k_a {k_a}, the window like the rest: {:?}", clean.causes);
    }
    // By default: the viscous friction named on the window like the rest.
    let report = identify(&faster_at_the_end(0.3, 10.0, 1), &IdentifyOptions::default()).unwrap();
    assert!(report.held_out_window.moved.is_some(), "{:?}", report.held_out_window);
    assert!(report.causes.iter().any(|c| c.effect == "viscous_friction"), "{:?}", report.causes.iter().map(|c| &c.effect).collect::<Vec<_>>());
}

/// A long record whose training part speeds up near its end: 2 kHz for 46 s (92 000 samples, the
/// training part's 64 400 more than the fits' 50 000); a 0.2 Hz sine of 0.025 rad under a Hann
/// envelope until 20 s (peak rate about 0.03 rad/s), then a 1 Hz sine of 0.025 rad under its own
/// (about 0.16 rad/s at its widest, 33 s) from 20 s to the end; 90 Nm/rad, eq. 3.5 friction
/// `0.07 atan(60 v)`, a viscous friction `b`; 14-bit deflection, 0.1 Nm noise (drawn from `seed`).
fn faster_late_in_a_long_record(b: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let x = |t: f64| if t < 20.0 { 0.025 * hann(t, 0.0, 20.0) * (TAU * 0.2 * t).sin() } else { 0.025 * hann(t, 20.0, 46.0) * (TAU * 1.0 * (t - 20.0)).sin() };
    sampled(2000.0, 92_000, x, |x, v| 90.0 * x + 0.07 * (60.0 * v).atan() + b * v, 0.1, 0x9e37_79b9_7f4a_7c15 ^ seed)
}

#[test]
fn the_fits_see_the_whole_training_part_of_a_long_record() {
    // Found on the blind generator's seed 7 (000: 13.6 Nm s/rad beside an arctan of 0.07 Nm,
    // 2 kHz for 46 s, the sweep faster from 27 s): the fits took the training part's first
    // 50 000 samples (its first 25 s), at a tenth of the rates it reached; the arctan took the
    // viscous friction for its own, and nothing was named at 1.2 times the noise.
    let mut named_by_bic = 0;
    for seed in 1..=4 {
        let report = identify(&faster_late_in_a_long_record(13.0, seed), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        println!("seed {seed}: {named:?}, held-out {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after);
        let Some(viscous) = report.causes.iter().find(|c| c.effect == "viscous_friction") else { continue };
        let found = viscous.params["damping_nms_per_rad"];
        assert!((found - 13.0).abs() < 0.25 * 13.0, "seed {seed}: b = {found} for 13: {}", viscous.evidence);
        // Proposed by BIC on the training part: the fits saw its fast end.
        if viscous.evidence.starts_with("BIC") && named == ["viscous_friction"] {
            named_by_bic += 1;
        }
    }
    assert!(named_by_bic >= 3, "viscous friction named alone by BIC on {named_by_bic} of 4");
    let clean = identify(&faster_late_in_a_long_record(0.0, 1), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes);
}
