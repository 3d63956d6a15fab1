//! A viscous friction that eq. 3.5's arctan takes as its own. Fitted with its `k_b` free, the
//! baseline's arctan bends toward a line over the recorded rates and takes most of a damping
//! beside it: the model with the damping then predicts the held-out torque only a little better,
//! though the damping itself carries more torque than the noise. Such a cause, proposed by BIC
//! on the training part and significant on the held-out part, is named when its own term
//! carries at least the noise floor's RMS there, whatever its gain (`Judgement::carrying`).

use jointctl_ident::identify::{IdentifyOptions, identify};

/// A spring of 400 Nm/rad driven by 40 sines from 0.3 to 3 Hz (log-spaced, amplitudes falling as
/// `1/f`, phases drawn from `seed`), scaled to 0.01 rad RMS (about 0.04 rad/s RMS); eq. 3.5's
/// friction `0.3 atan(40 v)`, a viscous friction `b` [Nm s/rad]; 14-bit deflection, 0.2 Nm of
/// noise, 1 kHz for 120 s.
fn record(b: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (rate, n, q) = (1000.0, 120_000, TAU / 16384.0);
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d ^ seed);
    let sines: Vec<(f64, f64, f64)> = (0..40)
        .map(|i| {
            let f = 0.3 * 10f64.powf(i as f64 / 39.0);
            (1.0 / f, f, rng.range(0.0, TAU))
        })
        .collect();
    let raw = |t: f64| sines.iter().map(|(a, f, p)| a * (TAU * f * t + p).sin()).sum::<f64>();
    let rms = ((0..n).map(|i| raw(i as f64 / rate).powi(2)).sum::<f64>() / n as f64).sqrt();
    let scale = 0.01 / rms;
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let t = i as f64 / rate;
        let x = scale * raw(t);
        let v = scale * sines.iter().map(|(a, f, p)| a * TAU * f * (TAU * f * t + p).cos()).sum::<f64>();
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(400.0 * x + 0.3 * (40.0 * v).atan() + b * v + 0.2 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_damping_the_arctan_takes_as_its_own_is_named_when_it_carries_the_noise() {
    // Found on the third generator (seed 1's 037: 29 Nm s/rad beside `0.22 atan(25 v)`, the
    // damping carrying 2.7 times the noise floor, proposed by BIC, held-out encompassing t = 6.5,
    // and listed as negligible: 4.1e-3 Nm^2 gained where 4.8e-3 is relevant) and on the blind
    // generator (seed 6's and 8's 007, device E of seed 4). On these eight records the damping
    // was proposed by BIC, significant on the held-out part and listed as negligible on each
    // before, named on none; after, named on 8 of 8 at 7.7-10.1 Nm s/rad.
    let mut named = 0;
    for seed in 1..=8 {
        let report = identify(&record(10.0, seed), &IdentifyOptions::default()).unwrap();
        let effects: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let damping = report.causes.iter().find_map(|c| c.params.get("damping_nms_per_rad"));
        println!("seed {seed}: {effects:?} (b {damping:?}), held-out {:.4} -> {:.4} Nm, negligible {:?}", report.rmse_before, report.rmse_after, report.negligible.iter().map(|n| &n.effect).collect::<Vec<_>>());
        assert!(effects.iter().all(|e| *e == "viscous_friction"), "seed {seed}: {effects:?}");
        if let Some(viscous) = report.causes.iter().find(|c| c.effect == "viscous_friction") {
            named += 1;
            let b = viscous.params["damping_nms_per_rad"];
            assert!((b - 10.0).abs() < 2.5, "seed {seed}: b = {b} for 10: {}", viscous.evidence);
            assert!(viscous.evidence.contains("its own term carries"), "seed {seed}: {}", viscous.evidence);
        }
    }
    assert!(named >= 2, "viscous friction named on {named} of 8");
    // Without the damping: nothing named on any of them.
    for seed in 1..=8 {
        let clean = identify(&record(0.0, seed), &IdentifyOptions::default()).unwrap();
        assert!(clean.causes.is_empty(), "seed {seed}, clean: {:?}", clean.causes.iter().map(|c| &c.effect).collect::<Vec<_>>());
    }
}
