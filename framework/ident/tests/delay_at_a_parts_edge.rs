//! A delay longer than a sample period reaches, at the first samples of each part, before the
//! part's first sample. The delayed deflection there was held at the part's first value: at
//! 20 Hz a 56 ms delay of a fast motion then mispredicted the held-out part's first sample by
//! 1.57 Nm, and that one sample made the held-out error 7.6 times the noise floor (the blind
//! generator's device D of seed 46, binned to 20 Hz, its held-out window inside the record;
//! 0.099 Nm where a plain least-squares fit left 0.049). A part's inputs now begin with the
//! record's samples before it (its history), which the delay reads there. Before the record's
//! own first sample the first value is still held: this record starts in motion, and one seed
//! of three reads its delay 65 ms (71-73 ms extrapolated along the rate there, not taken: see
//! `causes/time_delay.rs`).

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 60 s at 1 kHz written as 20 Hz bin averages, written for this test: 200 Nm/rad, eq. 3.5's
/// friction `0.1 atan(40 v)`, a multi-sine of 0.4, 0.9 and 1.7 Hz (12, 8 and 4 mrad, phases
/// drawn from `seed`), the torque channel 70 ms late (1.4 bins), 0.03 Nm of noise at 1 kHz,
/// a 14-bit deflection.
fn binned_record(seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let phases = [rng.uniform() * TAU, rng.uniform() * TAU, rng.uniform() * TAU];
    let motion = |t: f64| {
        [(0.012, 0.4), (0.008, 0.9), (0.004, 1.7)].iter().zip(&phases).fold((0.0, 0.0), |(x, v), ((a, f), p)| (x + a * (TAU * f * t + p).sin(), v + a * TAU * f * (TAU * f * t + p).cos()))
    };
    // At 1 kHz, then each channel averaged over 50 samples.
    let full: Vec<(f64, f64)> = (0..60_000)
        .map(|i| {
            let t = i as f64 / 1000.0;
            let (x, _) = motion(t);
            let (late, rate) = motion(t - 0.07);
            ((x / q).round() * q, 200.0 * late + 0.1 * (40.0 * rate).atan() + 0.03 * rng.normal())
        })
        .collect();
    let mean = |bin: &[(f64, f64)], pick: fn(&(f64, f64)) -> f64| bin.iter().map(pick).sum::<f64>() / bin.len() as f64;
    let t_s = (0..full.len() / 50).map(|b| (b as f64 + 0.5) * 0.05).collect();
    let phi = full.chunks(50).map(|b| mean(b, |s| s.0)).collect();
    let tau = full.chunks(50).map(|b| mean(b, |s| s.1)).collect();
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_delay_longer_than_a_sample_is_named_with_its_held_out_error_near_the_floor() {
    let mut wrong = Vec::new();
    for seed in [0x5851_f42d_4c95_7f2d, 0x2545_f491_4f6c_dd1d, 0x9e37_79b9_7f4a_7c15] {
        let report = identify(&binned_record(seed), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let delay = report.causes.iter().find(|c| c.effect == "time_delay").map(|c| c.params["delay_s"]);
        let floor = report.unexplained.noise_floor_nm;
        // The held-out part's first sample, and the error over the whole part against the floor
        // (an assumption: the bins' noise, 4 mNm, and what a delay read between 20 Hz bins
        // leaves, within 3.5 times the floor; holding the edge left 4 to 11 times it); the
        // delay within issue 31's 25 %.
        let first = report.held_out.first().map_or(f64::NAN, |s| (s[3] - s[5]).abs());
        if named != ["time_delay"] || delay.is_none_or(|d| (d - 0.07).abs() > 0.25 * 0.07) || report.rmse_after > 3.5 * floor {
            wrong.push(format!("seed {seed:x}: named {named:?}, delay {delay:?}, held out {:.4} Nm for a floor of {floor:.4}, first held-out sample off by {first:.3} Nm", report.rmse_after));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
