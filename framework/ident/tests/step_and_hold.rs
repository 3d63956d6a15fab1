//! A step-and-hold test (out to a deflection, a long hold, back): one reversal only.

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 30 s at 1 kHz on the thesis' baseline (150 Nm/rad, eq. 3.5 friction `0.4 atan(60 v)`): at
/// rest 4 s, out to `reach_rad` in 2 s (a smooth ramp), held 15 s, back in 2 s, at rest; the
/// torque sensor reads `offset_nm` high; 14-bit deflection, 0.05 Nm noise.
fn step_and_hold(reach_rad: f64, offset_nm: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::PI;
    let q = std::f64::consts::TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    // A half-cosine ramp from 0 to 1 over `s` seconds, and its rate.
    let ramp = |u: f64, s: f64| if u <= 0.0 { (0.0, 0.0) } else if u >= s { (1.0, 0.0) } else { (0.5 - 0.5 * (PI * u / s).cos(), 0.5 * PI / s * (PI * u / s).sin()) };
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..30_000 {
        let t = i as f64 / 1000.0;
        let ((up, v_up), (down, v_down)) = (ramp(t - 4.0, 2.0), ramp(t - 21.0, 2.0));
        let (x, v) = (reach_rad * (up - down), reach_rad * (v_up - v_down));
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(150.0 * x + 0.4 * (60.0 * v).atan() + offset_nm + 0.05 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// Finding (issue 31): records of one motion out and back were refused ("1 reversals;
/// identification needs ... 3 reversals"), their sensor offset, cubic or hysteresis unnamed
/// (an independent generator's hold tests). The held-out part still sees the return: the offset
/// is named, and a clean record gets no cause.
#[test]
fn a_step_and_hold_record_is_identified() {
    let report = identify(&step_and_hold(0.08, 0.6, 0x3c6e_f372_fe94_f82b), &IdentifyOptions::default()).unwrap();
    let named: Vec<(&str, f64)> = report.causes.iter().map(|c| (c.effect.as_str(), c.params.get("offset_nm").copied().unwrap_or(f64::NAN))).collect();
    assert!(matches!(named.as_slice(), [("sensor_offset", o)] if (o - 0.6).abs() < 0.06), "{named:?}");
    let clean = identify(&step_and_hold(0.08, 0.0, 0xa54f_f53a_5f1d_36f1), &IdentifyOptions::default()).unwrap();
    assert!(clean.causes.is_empty(), "{:?}", clean.causes.iter().map(|c| (&c.effect, &c.params)).collect::<Vec<_>>());
}
