//! A mode's frequency is found at the record's resolution whatever the time stamps: uniform, or
//! repetitions concatenated with time jumps that are not whole sample periods.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// Three repetitions of a 22 s test at 250 Hz, each a 0.2 Hz, 0.05 rad sine on the thesis'
/// baseline (120 Nm/rad, eq. 3.5 friction `0.3 atan(80 v)`), restarted 4.6 s plus half a sample
/// period after the previous one ends (a logger that restarts is not phase-locked to its old
/// clock); a steady 0.4 Nm mode at `mode_hz` throughout; 14-bit deflection, 0.17 Nm noise.
fn repetitions(mode_hz: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (rate, per_rep, k) = (250.0, 5500, 120.0);
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for rep in 0..3 {
        let start = rep as f64 * (per_rep as f64 / rate + 4.6 + 0.5 / rate);
        for i in 0..per_rep {
            let local = i as f64 / rate;
            let t = start + local;
            let x = 0.05 * (TAU * 0.2 * local).sin();
            let v = 0.05 * TAU * 0.2 * (TAU * 0.2 * local).cos();
            t_s.push(t);
            deflection.push((x / q).round() * q);
            torque.push(k * x + 0.3 * (80.0 * v).atan() + 0.4 * (TAU * mode_hz * t).sin() + 0.17 * rng.normal());
        }
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// What is wrong unless the report names a vibration alone, at `mode_hz` (within 5 mHz) and
/// 0.4 Nm (within 10 %).
fn unless_the_mode_alone(report: &jointctl_ident::identify::Report, mode_hz: f64) -> Option<String> {
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let found = report.causes.first().filter(|_| named == ["vibration"]).map(|c| (c.params["frequency_hz"], c.params["amplitude_nm"]));
    match found {
        Some((f, a)) if (f - mode_hz).abs() < 0.005 && (a - 0.4).abs() < 0.04 => None,
        _ => Some(format!("{mode_hz} Hz: named {named:?}, {:?}", report.causes.iter().map(|c| &c.params).collect::<Vec<_>>())),
    }
}

#[test]
fn a_steady_mode_in_repetitions_with_time_jumps_is_found_at_its_frequency() {
    // Issue 31, finding 4: a steady vibration named `speed_vibration`. Time stamps off one
    // uniform grid (the jumps between repetitions) sent the frequency scan to a 240-point
    // logarithmic grid, 1.5 % apart, refined by golden section over a window full of side lobes:
    // it took one 0.13 Hz from the mode (the record resolves 0.015 Hz), where a steady sine
    // drifts through eight cycles of phase over the record and no longer fits.
    let mut missed = Vec::new();
    for mode_hz in [23.31, 31.77, 39.145, 47.93, 55.2, 63.61] {
        let report = identify(&repetitions(mode_hz), &IdentifyOptions::default()).unwrap();
        missed.extend(unless_the_mode_alone(&report, mode_hz));
    }
    assert!(missed.is_empty(), "{missed:#?}");
}

/// The same test logged one file per repetition and concatenated: the time restarts at 0 at
/// each one, and between them the rig ran on for `pause_s` (not in the file). The mode runs on
/// in real time, so its phase at each repetition's start is not what the file's time says.
fn restarted_repetitions(mode_hz: f64, pause_s: f64) -> jointctl_ident::csv::Data {
    restarted(mode_hz, pause_s, 250.0, 5500, 3, 0.0)
}

/// `repetitions` of `per_rep` samples at `rate` [Hz], as [`restarted_repetitions`], the torque
/// sensor reading `offset_nm` high.
fn restarted(mode_hz: f64, pause_s: f64, rate: f64, per_rep: usize, repetitions: usize, offset_nm: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let k = 120.0;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x7f4a_7c15_9e37_79b9);
    let mut text = String::from("t,deflection,torque\n");
    for rep in 0..repetitions {
        let start = rep as f64 * (per_rep as f64 / rate + pause_s);
        for i in 0..per_rep {
            let local = i as f64 / rate;
            let x = 0.05 * (TAU * 0.2 * local).sin();
            let v = 0.05 * TAU * 0.2 * (TAU * 0.2 * local).cos();
            let tau = k * x + 0.3 * (80.0 * v).atan() + 0.4 * (TAU * mode_hz * (start + local)).sin() + offset_nm + 0.17 * rng.normal();
            text.push_str(&format!("{local:.6},{:.12e},{tau:.6}\n", (x / q).round() * q));
        }
    }
    jointctl_ident::csv::parse(&text, "repetitions.csv".as_ref()).unwrap()
}

/// Finding (issue 31): on repetitions whose time restarted, a steady vibration was named with
/// a ring after every reversal beside it, or the ring instead of it (blind seeds 1, 2 and 4,
/// records 058 and 105). The reader lays each repetition 1 s after the one before; the phase at
/// its start is not known, and one phase for the record drifted. Its phase is now fitted on each
/// repetition apart, its frequency refined on the training part.
#[test]
fn a_steady_mode_in_repetitions_whose_time_restarted_is_named_alone() {
    let mut missed = Vec::new();
    for (mode_hz, pause_s) in [(24.57, 7.3), (31.77, 12.9), (42.14, 3.05)] {
        let data = restarted_repetitions(mode_hz, pause_s);
        assert_eq!(data.restarts.len(), 2, "{:?}", data.notes);
        let report = identify(&data, &IdentifyOptions::default()).unwrap();
        missed.extend(unless_the_mode_alone(&report, mode_hz));
    }
    assert!(missed.is_empty(), "{missed:#?}");
}

/// Parts of the record in different repetitions fit the vibration alike, per repetition
/// (decided for the record, see `repetition_starts`): two repetitions of 55 s at 1 kHz, a 0.1 Nm
/// offset besides. Found when the fits took the training part's first 50 000 samples, inside the
/// first repetition; they now spread over both, and the searches' full-rate stretch (16 000
/// samples) still lies inside the first while the held-out part is in the second.
#[test]
fn a_training_part_inside_the_first_repetition_fits_as_the_held_out_part_does() {
    let data = restarted(31.77, 9.1, 1000.0, 55_000, 2, 0.1);
    let report = identify(&data, &IdentifyOptions::default()).unwrap();
    let mut named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    named.sort();
    let vibration = report.causes.iter().find(|c| c.effect == "vibration").map(|c| (c.params["frequency_hz"], c.params["amplitude_nm"]));
    let offset = report.causes.iter().find(|c| c.effect == "sensor_offset").map(|c| c.params["offset_nm"]);
    assert!(named == ["sensor_offset", "vibration"] && vibration.is_some_and(|(f, a)| (f - 31.77).abs() < 0.005 && (a - 0.4).abs() < 0.04), "{named:?} {vibration:?}");
    assert!(offset.is_some_and(|o| (o - 0.1).abs() < 0.02), "{offset:?}");
    // The extension's held-out error is the noise's (0.17 Nm), not the vibration's on top.
    assert!(report.rmse_after < 0.19, "{} -> {}", report.rmse_before, report.rmse_after);
}
