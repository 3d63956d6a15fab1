//! A short stroke through a coarse encoder, driven fast: about 45 counts of a 14-bit encoder
//! either side, a chirp from 2.5 Hz down to 0.5 Hz and then two slow sines, logged at 1 kHz, and
//! eq. 3.5's friction larger than the spring's torque. The usual rate window is sized on the
//! motion (a fiftieth of its local period either side: +-8 samples on the chirp's fast end) and
//! sees a count or two there: the rate is read through the encoder's staircase, and the
//! arctan, which turns wholly within a few counts of rate, turns at the wrong instants. The data
//! may choose wider windows (`prepare::WIDER_WINDOWS_PER_PERIOD`). The records are this file's
//! own: a spring, eq. 3.5's friction, the torque sensor's noise, and a viscous friction or none.

use jointctl_ident::identify::bin_reading::RateWindow;
use jointctl_ident::identify::{IdentifyOptions, identify};

/// The spring [Nm/rad] and eq. 3.5's friction: `k_a` [Nm], `k_b` [s/rad].
const K_NM_PER_RAD: f64 = 30.0;
const K_A_NM: f64 = 0.6;
const K_B_S_PER_RAD: f64 = 30.0;
/// The torque sensor's noise [Nm].
const NOISE_NM: f64 = 0.03;

/// 36 s at 1 kHz through a 14-bit encoder: a 12 s chirp of amplitude `amplitude_rad`, 2.5 ->
/// 0.5 Hz (its phase the integral of the falling frequency), then 24 s of two sines of
/// 0.3-0.4 and 0.6-0.8 Hz; a viscous friction of `damping` [Nm s/rad].
fn record(seed: u64, damping: f64) -> jointctl_ident::csv::Data {
    record_beside(seed, damping, 0.0)
}

/// [`record`] with the torque sensor reading `offset_nm` [Nm] high: a cause the baseline lacks.
fn record_beside(seed: u64, damping: f64, offset_nm: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x5851_f42d_4c95_7f2d ^ seed);
    let q = TAU / 16384.0;
    let dt = 1e-3;
    let amplitude_rad = 0.016 + 0.003 * rng.uniform();
    let (f0, f1, chirp_s) = (2.5, 0.5, 12.0);
    let f = [0.3 + 0.1 * rng.uniform(), 0.6 + 0.2 * rng.uniform()];
    let phase = [TAU * rng.uniform(), TAU * rng.uniform()];
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..36_000 {
        let t = i as f64 * dt;
        let (x, v) = if t < chirp_s {
            // Frequency falling linearly from f0 to f1: phase 2 pi (f0 t + (f1 - f0) t^2 / 2T).
            let phi = TAU * (f0 * t + (f1 - f0) * t * t / (2.0 * chirp_s));
            let w = TAU * (f0 + (f1 - f0) * t / chirp_s);
            (amplitude_rad * phi.sin(), amplitude_rad * w * phi.cos())
        } else {
            let s = t - chirp_s;
            let a = [0.6 * amplitude_rad, 0.4 * amplitude_rad];
            ((0..2).map(|k| a[k] * (TAU * f[k] * s + phase[k]).sin()).sum(), (0..2).map(|k| a[k] * TAU * f[k] * (TAU * f[k] * s + phase[k]).cos()).sum())
        };
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(offset_nm + K_NM_PER_RAD * x + K_A_NM * (K_B_S_PER_RAD * v).atan() + damping * v + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_short_fast_stroke_through_coarse_counts_reads_its_rate_over_wider_windows() {
    // Before (windows of at most a fiftieth of the local period either side): the baseline's
    // held-out error was 1.50, 1.67 and 1.56 times the noise on these seeds (the rate over the
    // usual windows, or with sharper intervals); after, the data chose windows of a 12.5th of
    // the period and it is 1.02-1.04 times the noise.
    let mut clean = 0;
    for seed in 1..=3 {
        let report = identify(&record(seed, 0.0), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let window = report.narrow_rate.as_ref().map(|r| r.window);
        assert!(report.rmse_before < 1.25 * NOISE_NM, "seed {seed}: baseline held out {:.4} Nm ({:.2} times the noise), rate read {window:?}, named {named:?}", report.rmse_before, report.rmse_before / NOISE_NM);
        assert!(matches!(window, Some(RateWindow::Wider { .. })), "seed {seed}: rate read {window:?}");
        clean += usize::from(named.is_empty());
    }
    assert!(clean >= 2, "no cause on {clean} of 3 clean records");
}

#[test]
fn a_viscous_friction_beside_it_is_not_taken_for_a_loop() {
    // 1 Nm s/rad beside the friction. Before: a Dahl loop of 0.018-0.020 Nm was named on seeds 1
    // and 2 for the rate's staircase (held out 1.55-1.73 times the noise), the viscous friction
    // on seed 3 at 0.73 Nm s/rad. After: nothing named on seeds 1 and 2 (eq. 3.5's arctan takes
    // the damping, 1.09-1.10 times the noise left: the pair the report calls confounded when it
    // is), the viscous friction on seed 3 at 1.04.
    for seed in 1..=3 {
        let report = identify(&record(seed, 1.0), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert!(named.iter().all(|c| *c == "viscous_friction"), "seed {seed}: named {named:?}");
        let damping = report.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
        assert!(damping.is_none_or(|b| (b - 1.0).abs() < 0.25), "seed {seed}: damping {damping:?}");
        assert!(report.rmse_after < 1.25 * NOISE_NM, "seed {seed}: held out {:.4} Nm after {named:?}", report.rmse_after);
    }
}

#[test]
fn a_cause_the_baseline_lacks_does_not_hide_the_wider_windows() {
    // The same strokes with the torque sensor reading 0.3 Nm high (ten times the noise). The
    // reading is judged on the baseline before any cause is in it; the offset it lacks is most
    // of what it leaves above the noise floor, and the wider windows' gain, judged as a share
    // of that (as a cause's relevance is), was refused: the usual windows' staircase stayed in
    // the whole model, which held out 1.50, 1.64 and 1.53 times the noise after the offset on
    // these seeds; over the wider windows, 1.02-1.04 times. (Found on the blind devices'
    // records of a play, a loop or an offset beside a viscous friction; this file's own strokes
    // test it.)
    for seed in 1..=3 {
        let report = identify(&record_beside(seed, 0.0, 0.3), &IdentifyOptions::default()).expect("identified");
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let window = report.narrow_rate.as_ref().map(|r| r.window);
        assert_eq!(named, ["sensor_offset"], "seed {seed}: rate read {window:?}");
        assert!(matches!(window, Some(RateWindow::Wider { .. })), "seed {seed}: rate read {window:?}, held out {:.4} Nm", report.rmse_after);
        assert!(report.rmse_after < 1.25 * NOISE_NM, "seed {seed}: held out {:.4} Nm ({:.2} times the noise)", report.rmse_after, report.rmse_after / NOISE_NM);
    }
}
