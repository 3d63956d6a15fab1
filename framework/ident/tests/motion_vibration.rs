//! A vibration that runs while the joint moves (a motor's or a gear's) and dies down in the
//! holds is named `vibration`, with its amplitude in motion; a steady one over the same motion
//! stays steady.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// A characterisation record of 60 s at 500 Hz on the thesis' baseline (110 Nm/rad, eq. 3.5
/// friction `0.25 atan(60 v)`): strokes of 0.3-1.1 Hz and 0.02-0.06 rad, each followed by a hold
/// of 0.5-2 s (hand-like motion, section 3.3.1). The vibration's envelope is a smoothstep of the
/// speed up to `full_speed` (0 for steady), its phase at `t = 0` `phase` [rad]: a shape of this test's own, not the cause's `tanh`.
/// 14-bit deflection, 0.12 Nm noise.
fn record(mode_hz: f64, amplitude_nm: f64, phase: f64, full_speed: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let (rate, k) = (500.0, 110.0);
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let mut t = 0.0;
    while t < 60.0 {
        // One stroke: a whole period of a sine, then a hold at zero.
        let (f, a) = (0.3 + 0.8 * rng.uniform(), 0.02 + 0.04 * rng.uniform());
        let hold = 0.5 + 1.5 * rng.uniform();
        let stroke = 1.0 / f;
        let start = t;
        while t < start + stroke + hold && t < 60.0 {
            let local = t - start;
            let (x, v) = if local < stroke { (a * (TAU * f * local).sin(), a * TAU * f * (TAU * f * local).cos()) } else { (0.0, 0.0) };
            let gate = if full_speed > 0.0 {
                let s = (v.abs() / full_speed).min(1.0);
                s * s * (3.0 - 2.0 * s)
            } else {
                1.0
            };
            t_s.push(t);
            deflection.push((x / q).round() * q);
            torque.push(k * x + 0.25 * (60.0 * v).atan() + gate * amplitude_nm * (TAU * mode_hz * t + phase).sin() + 0.12 * rng.normal());
            t += 1.0 / rate;
        }
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// The records whose vibration was not named alone with its amplitude within 25 % (its
/// standard error below 25 % of it).
fn misses(full_speed: f64) -> Vec<String> {
    let mut missed = Vec::new();
    for (i, (mode_hz, amplitude, phase)) in [(17.3, 0.5, 0.01), (22.9, 0.9, 1.3), (31.4, 0.6, 2.9), (44.1, 0.8, 4.4)].into_iter().enumerate() {
        let report = identify(&record(mode_hz, amplitude, phase, full_speed, 0x9e37_79b9_7f4a_7c15 ^ i as u64), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
        let found = report.causes.first().filter(|_| named == ["vibration"]).map(|c| (c.params["frequency_hz"], c.params["amplitude_nm"]));
        // The amplitude's standard error: the amplitude is the hypotenuse of a sine's and a
        // cosine's coefficient; it took the relative error of the smaller one (one near zero
        // when the mode's phase is near the sine's: 0.44 Nm on l1-case007's 1.0 Nm). It is now
        // the delta method's, with the onset speed's error (a higher onset leaves fewer
        // vibrating samples and a larger amplitude) and the block error (this envelope is not
        // the cause's `tanh`): 3-14 % of the amplitude here. The amplitude is 10-20 % off, up to
        // 3.7 errors at 22.9 Hz: the envelope's misspecification is a bias no error of the fit
        // holds. Bounded by the tolerance itself.
        let se = report.causes.first().and_then(|c| c.uncertainty.get("amplitude_nm").copied()).unwrap_or(f64::NAN);
        match found {
            Some((f, a)) if (f - mode_hz).abs() < 0.05 && (a / amplitude - 1.0).abs() < 0.25 && se < 0.25 * a => {}
            _ => missed.push(format!("{mode_hz} Hz, {amplitude} Nm: named {named:?}, {:?}, amplitude's standard error {se}", report.causes.iter().map(|c| &c.params).collect::<Vec<_>>())),
        }
    }
    missed
}

#[test]
fn a_vibration_that_runs_with_motion_is_named_vibration() {
    // Found on the independent generator's l1-case007: a 0.94 Nm mode at 22.9 Hz while the joint
    // moved, 0.06-0.2 Nm in its holds, one phase throughout. Neither the steady vibration (its
    // holds are quiet) nor `speed_vibration` (in proportion to the speed) is that shape; identify
    // named `speed_vibration` and a `reversal_ringing` beside it.
    let missed = misses(0.15);
    assert!(missed.is_empty(), "{missed:#?}");
}

#[test]
fn a_steady_vibration_over_strokes_and_holds_stays_a_vibration() {
    let missed = misses(0.0);
    assert!(missed.is_empty(), "{missed:#?}");
}
