//! Play whose contact stiffens over a band: the torque is taken up gradually around the play's
//! edge, as gear flanks and a coupling's elastomer take it up, not at once as an ideal dead zone.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 60 s at 1 kHz of a 0.4 Hz sine of 30 mrad beside a 0.13 Hz one of 10 mrad through a play of
/// `play_rad` whose contact follows `x - w tanh(x / w)` (the smooth play of the project's
/// assumed characteristic, not the identifier's quadratic blend: slope 0 at zero, the ideal
/// dead zone's asymptote `|x| - w` beyond about 2 w), 150 Nm/rad, a Dahl loop of
/// `hysteresis_nm` over 2 mrad, 0.03 Nm of noise, a 14-bit deflection.
fn record(play_rad: f64, hysteresis_nm: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let (mut z, mut last) = (0.0f64, 0.0);
    for i in 0..60_000 {
        let t = i as f64 * 1e-3;
        let x = 0.03 * (TAU * 0.4 * t).sin() + 0.01 * (TAU * 0.13 * t + 1.0).sin();
        let dx = x - last;
        z += dx / 0.002 * (1.0 - z * dx.signum());
        last = x;
        let elastic = if play_rad > 0.0 {
            x - play_rad * (x / play_rad).tanh()
        } else {
            x
        };
        t_s.push(t);
        phi.push((x / q).round() * q);
        tau.push(150.0 * elastic + hysteresis_nm * z + 0.03 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_play_that_is_taken_up_gradually_is_named_with_its_width() {
    // Found on the blind generator (a play whose contact stiffens over 85 % of its half width,
    // with hysteresis): an ideal dead zone left a residual around the play's edge that a time
    // delay took up, named beside the hidden causes. Here, on a smooth play of another shape,
    // the ideal dead zone read the width 13-28 % short and a cubic stiffness took up the rest.
    for hysteresis_nm in [0.0, 0.3] {
        for play_rad in [0.003, 0.005, 0.01] {
            let report = identify(
                &record(play_rad, hysteresis_nm),
                &IdentifyOptions::default(),
            )
            .unwrap();
            let width = report
                .causes
                .iter()
                .find(|c| c.effect == "dead_zone")
                .map(|c| c.params["half_width_rad"])
                .unwrap_or(f64::NAN);
            assert!(
                (width - play_rad).abs() < 0.15 * play_rad,
                "half width {width} rad for {play_rad} (hysteresis {hysteresis_nm} Nm)"
            );
        }
    }
    // Without hysteresis, a play of 3 and 5 mrad is named alone (a wider one still takes a cubic
    // beside it: the blend is not this shape, see docs/benchmarks.md).
    for play_rad in [0.003, 0.005] {
        let report = identify(&record(play_rad, 0.0), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        assert_eq!(
            named,
            ["dead_zone"],
            "play {play_rad} rad: rejected {:?}",
            report.rejected
        );
    }
}
