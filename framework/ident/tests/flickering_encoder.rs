//! Hysteresis of a stiff spring read by a fine encoder that flickers between counts (issue 36,
//! item 5: a Dahl state driven by raw quantised steps rattles). Found on the shared real-like
//! l3-case002 (a Bouc-Wen loop, a 2e-6 rad linear encoder with 1.2 counts of flicker): identify
//! named the loop with a held-out residual at 8.8 times the noise and a `time_delay` beside it.
//! This record comes from another model: a generalized Maxwell-slip loop (Al-Bender, Lampaert and
//! Swevers 2005: elasto-plastic elements in parallel), on irregular time stamps.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 150 s of a 2000 Nm/rad spring with a four-element Maxwell-slip loop of 2.4 Nm in all: a
/// stiffness test, triangles between +-6 and +-12 mrad at 1-3 mrad/s (a count or two per logged
/// sample), the loop driven by the true deflection on a 0.2 ms grid; logged every 1.8 ms with
/// jitter, now and then 10 ms, and two gaps of 0.2 s; the deflection read by a 2e-6 rad encoder
/// with 1.2 counts of noise before the rounding, the torque with 0.05 Nm of noise.
fn maxwell_slip_record(seed: u64) -> jointctl_ident::csv::Data {
    maxwell_slip_record_after(0.0, 150.0, seed)
}

/// [`maxwell_slip_record`] of `duration_s`, the spring held at zero for its first `hold_s`.
fn maxwell_slip_record_after(hold_s: f64, duration_s: f64, seed: u64) -> jointctl_ident::csv::Data {
    let (k, lsb, dt) = (2000.0, 2e-6, 2e-4);
    // Each element: break-away torque [Nm] and the deflection at which it slips [rad].
    let elements = [(0.4, 0.2e-3), (0.6, 0.5e-3), (0.8, 1.0e-3), (0.6, 2.0e-3)];
    let mut z = [0.0f64; 4];
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let (mut t_s, mut read, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let (mut t, mut x) = (0.0f64, 0.0f64);
    let (mut target, mut rate) = (0.008, 2e-3);
    let mut next_log = 0.0;
    while t < duration_s {
        if t >= next_log {
            t_s.push(t);
            read.push(((x + 1.2 * lsb * rng.normal()) / lsb).round() * lsb);
            torque.push(k * x + z.iter().sum::<f64>() + 0.05 * rng.normal());
            let gap = if t_s.len() == 20_000 || t_s.len() == 50_000 {
                0.2
            } else if rng.uniform() < 0.01 {
                0.010
            } else {
                0.0018 * (0.7 + 0.6 * rng.uniform())
            };
            next_log = t + gap;
        }
        let step = if t < hold_s { 0.0 } else { (target - x).clamp(-rate * dt, rate * dt) };
        x += step;
        for (zi, (limit, slip)) in z.iter_mut().zip(elements) {
            *zi = (*zi + limit / slip * step).clamp(-limit, limit);
        }
        if x == target {
            target = -target.signum() * (0.006 + 0.006 * rng.uniform());
            rate = 1e-3 + 2e-3 * rng.uniform();
        }
        t += dt;
    }
    jointctl_ident::csv::Data::from_columns(t_s, read, torque)
}

#[test]
fn a_loop_read_through_a_flickering_fine_encoder_is_named_alone_and_explains_the_record() {
    let mut wrong = Vec::new();
    for seed in [0x6a09_e667_f3bc_c908u64, 0xbb67_ae85_84ca_a73b] {
        let report = identify(&maxwell_slip_record(seed), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let limit = report.causes.iter().find(|c| c.effect == "hysteresis").map(|c| c.params["limit_nm"]);
        let left = report.unexplained.times_noise;
        // The loop's limit: the elements' break-away torques sum to 2.4 Nm. The residual: a Dahl
        // loop is not a Maxwell-slip one, so some structure stays, but not the flicker's.
        if named != ["hysteresis"] || !limit.is_some_and(|l| (l / 2.4 - 1.0).abs() < 0.25) || left > 3.0 {
            wrong.push(format!("seed {seed:#x}: named {named:?}, limit {limit:?} Nm, left {left:.1} times the noise, rejected {:?}", report.rejected));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn a_loop_read_through_a_flickering_encoder_after_a_hold_gets_the_band_the_whole_record_needs() {
    // Found on the blind generator (seed 1's 013: a Dahl loop, a 2e-6 rad encoder that
    // flickers, a hold at the start): the band in front of the loop was chosen on the training
    // part's first 16 000 samples, the hold, where a band betters nothing; without it the
    // flicker walked the loop's state and 0.30 Nm was left held out (0.155 with it, the noise).
    // Here, before: no band, 6.7 times the noise left (0.337 Nm held out).
    let report = identify(&maxwell_slip_record_after(30.0, 100.0, 1), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let band = report.causes.iter().find(|c| c.effect == "hysteresis").and_then(|c| c.params.get("input_dead_band_rad").copied());
    let left = report.unexplained.times_noise;
    assert!(named == ["hysteresis"] && band.is_some() && left < 3.0, "named {named:?}, band {band:?} rad, left {left:.1} times the noise, rmse {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after);
}
