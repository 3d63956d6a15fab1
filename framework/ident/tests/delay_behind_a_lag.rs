//! A torque channel that reaches the log through a transport delay and a first-order lag (a
//! sensor's filter behind a bus), read by one device's tests at two excitation speeds. A pure
//! delay stands for a lag of time constant `tau` only at frequencies well below `1 / tau`; at
//! `omega` it reads `atan(omega tau) / omega`, shorter the faster the motion. On the blind
//! generator's device D (a transport delay and a low-pass), the delays read on one device's
//! variants (irregular, 20 Hz bins, one and three repetitions) disagreed beyond their errors on
//! 66 of 120 pairs, and read 1-25 ms short. The records here are this file's own: the lag acts
//! on the torque (the sensor's side), as identify's lag does (on every column of its model).

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 60.0;
/// The transport delay [s] and the lag's time constant [s]: the delay at low frequency is their
/// sum, 70 ms.
const TRANSPORT_S: f64 = 0.030;
const TAU_S: f64 = 0.040;
const NOISE_NM: f64 = 0.02;

/// 60 s at 1 kHz: a sum of three sines of 0.02 rad with phases drawn from `seed` at
/// `base_hz`, 2.3 and 4.1 times it. Torque `K phi + 0.15 atan(50 dphi/dt)` delayed by
/// [`TRANSPORT_S`] and through a first-order lag of [`TAU_S`], white noise, a 14-bit deflection.
fn record(base_hz: f64, seed: u64) -> jointctl_ident::csv::Data {
    record_behind(base_hz, seed, TRANSPORT_S, TAU_S)
}

/// [`record`] with the torque delayed by `transport_s` and lagged by `tau_s`.
fn record_behind(base_hz: f64, seed: u64, transport_s: f64, tau_s: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x3c6e_f372_fe94_f82b ^ seed);
    let (rate, n) = (1000.0, 60_000);
    let sines: Vec<(f64, f64)> = [1.0, 2.3, 4.1].iter().map(|m| (m * base_hz, TAU * rng.uniform())).collect();
    let at = |t: f64| sines.iter().map(|(f, p)| (0.02 * (TAU * f * t + p).sin(), 0.02 * TAU * f * (TAU * f * t + p).cos())).fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let q = TAU / 16384.0;
    let alpha = (-1.0 / (rate * tau_s)).exp();
    let mut filtered = f64::NAN;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let t = i as f64 / rate;
        let (x_then, v_then) = at(t - transport_s);
        let torque = K_NM_PER_RAD * x_then + 0.15 * (50.0 * v_then).atan();
        filtered = if filtered.is_nan() { torque } else { alpha * filtered + (1.0 - alpha) * torque };
        t_s.push(t);
        phi.push((at(t).0 / q).round() * q);
        tau.push(filtered + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn one_devices_delay_reads_alike_at_two_excitation_speeds() {
    // Measured on these seeds, read as a pure delay: 66-67 +- 1.0-1.3 ms at 0.2 Hz and 58-59
    // +- 1.1-1.3 ms at 0.9 Hz (4.5-5.9 errors apart, 17 % short of the 70 ms at low
    // frequency), the 0.9 Hz records' held-out error 7.2 times the noise floor. As a transport
    // delay and a lag of the torque: 71 +- 0.5-0.7 ms and 69-70 +- 0.6-0.8 ms (1.1-2.7 errors
    // apart: the errors are those of a model fitted to one test, and the two tests differ by a
    // millisecond, the delay's step here), the lag's time constant 39.5-47.2 ms for 40, the
    // 0.9 Hz held-out error 1.8-2.5 times the floor. The test asks three errors, 5 % and 25 %.
    let delay = |base_hz: f64, seed: u64| {
        let report = identify(&record(base_hz, seed), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let cause = report.causes.iter().find(|c| c.effect == "time_delay").unwrap_or_else(|| panic!("no delay named ({base_hz} Hz, seed {seed}): {named:?}"));
        let lag_s = cause.params.get("lag_s").copied().unwrap_or(0.0);
        (cause.params["delay_s"], cause.uncertainty.get("delay_s").copied().unwrap_or(0.0), lag_s, named.len())
    };
    let mut wrong = Vec::new();
    for seed in 1..=3 {
        let (slow, fast) = (delay(0.2, seed), delay(0.9, seed));
        let apart = (slow.0 - fast.0).abs() / (slow.1.powi(2) + fast.1.powi(2)).sqrt();
        let off = [slow.0, fast.0].map(|d| (d / (TRANSPORT_S + TAU_S) - 1.0).abs());
        let lag_off = [slow.2, fast.2].map(|l| (l / TAU_S - 1.0).abs());
        if apart > 3.0 || off.iter().any(|o| *o > 0.05) || lag_off.iter().any(|o| *o > 0.25) || slow.3 != 1 || fast.3 != 1 {
            wrong.push(format!(
                "seed {seed}: {:.1} +- {:.2} ms (lag {:.1} ms) at 0.2 Hz, {:.1} +- {:.2} ms (lag {:.1} ms) at 0.9 Hz ({apart:.1} errors apart), causes {} and {}",
                slow.0 * 1e3,
                slow.1 * 1e3,
                slow.2 * 1e3,
                fast.0 * 1e3,
                fast.1 * 1e3,
                fast.2 * 1e3,
                slow.3,
                fast.3
            ));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// `data` as 20 Hz bin means: each 50 ms of samples averaged, time stamps too (a logger's
/// binned export).
fn binned_20_hz(data: &jointctl_ident::csv::Data) -> jointctl_ident::csv::Data {
    let means = |v: &[f64]| -> Vec<f64> { v.chunks(50).map(|c| c.iter().sum::<f64>() / c.len() as f64).collect() };
    jointctl_ident::csv::Data::from_columns(means(&data.t), means(&data.deflection), means(&data.torque))
}

#[test]
fn the_lag_behind_a_delay_reads_alike_from_20_hz_bins() {
    // The lag on a slow log ran along lines between the samples, itself a low-pass of a 50 ms
    // bin. A 60 ms transport delay and a 20 ms lag (a sensor's 8 Hz filter, as the blind
    // generator's device D has one of 7-11 Hz), read from these records' 20 Hz bins, came out
    // as a lag of 8.1-9.1 ms at 0.5 Hz and 6.3-6.9 ms at 0.9 Hz (seeds 1-3), where the same
    // records at full rate read 18.1-19.5 ms. Along the cubic through the samples with their
    // neighbours' chords (`numeric::lagged`): 14.0-16.0 and 14.2-14.8 ms. What is left is not
    // the lag's: the delayed deflection between the bins is read along the rate read against
    // noise (`causes::time_delay`). The whole delay reads 75-80 ms (78-80 at full rate, of 80).
    // The test asks 35 % of the lag, 10 % of the whole delay.
    let (transport_s, tau_s) = (0.060, 0.020);
    let mut wrong = Vec::new();
    for (base_hz, seed) in [(0.5, 1), (0.5, 2), (0.5, 3), (0.9, 1), (0.9, 2), (0.9, 3)] {
        let report = identify(&binned_20_hz(&record_behind(base_hz, seed, transport_s, tau_s)), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let Some(cause) = report.causes.iter().find(|c| c.effect == "time_delay") else {
            wrong.push(format!("{base_hz} Hz, seed {seed}: no delay named: {named:?}"));
            continue;
        };
        let (delay_s, lag_s) = (cause.params["delay_s"], cause.params.get("lag_s").copied().unwrap_or(0.0));
        if (delay_s / (transport_s + tau_s) - 1.0).abs() > 0.1 || (lag_s / tau_s - 1.0).abs() > 0.35 || named.len() != 1 {
            wrong.push(format!("{base_hz} Hz, seed {seed}: delay {:.1} ms, lag {:.1} ms, causes {named:?}", delay_s * 1e3, lag_s * 1e3));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
