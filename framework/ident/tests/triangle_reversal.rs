//! A triangle wave turns its rate in one sample. The rate's usual intervals (three standard
//! errors of the deflection's scatter and the most its quantisation can tilt a slope) keep a
//! window across the corner as long as its slope's bias stays inside that bound, and the rate
//! is smeared over several samples at every reversal. Where a large viscous friction turns with
//! the rate, the torque jumps there and the smeared rate misses it: the baseline's error, and
//! every cause's gain, is lost at the corners. The data chooses sharper intervals when the
//! baseline's fit and then the whole model read better so (`bin_reading::choose_rate_reading`).

use jointctl_ident::identify::bin_reading::RateWindow;
use jointctl_ident::identify::{IdentifyOptions, identify};

/// A triangle of 0.08 rad, one period each at 0.2, 0.5 and 1 Hz in turn (0.064, 0.16 and
/// 0.32 rad/s: a viscous friction is told from eq. 3.5's arctan by the speeds), from its lowest
/// point, through a spring of 150 Nm/rad, eq. 3.5's friction `0.5 atan(30 v)` and a viscous
/// friction `b` [Nm s/rad]; 0.05 Nm of normal noise, 14-bit deflection, 1 kHz for 40 s.
fn record(b: f64) -> jointctl_ident::csv::Data {
    let q = std::f64::consts::TAU / 16384.0;
    let amplitude = 0.08;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let (mut start, mut period) = (0.0, 0);
    for i in 0..40_000 {
        let t = i as f64 / 1000.0;
        let mut frequency = [0.2, 0.5, 1.0][period % 3];
        if t >= start + 1.0 / frequency {
            (start, period) = (start + 1.0 / frequency, period + 1);
            frequency = [0.2, 0.5, 1.0][period % 3];
        }
        let phase = (t - start) * frequency;
        let rate = 4.0 * amplitude * frequency;
        let (x, v) = if phase < 0.5 { (-amplitude + rate * phase / frequency, rate) } else { (amplitude - rate * (phase - 0.5) / frequency, -rate) };
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(150.0 * x + 0.5 * (30.0 * v).atan() + b * v + 0.05 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_viscous_friction_on_a_triangle_is_fitted_with_the_rate_read_sharp_at_its_reversals() {
    // Issue 31, finding 1 (a large viscous friction gets no cause, its held-out residual several
    // times the noise), seen on the blind generator's seed-11 triangle at 250 Hz (77 Nm s/rad):
    // the baseline left 0.61 Nm held out for a noise floor of 0.13 and no cause was named; read
    // with intervals a quarter as wide, 0.38, and viscous friction named (0.28 after it). Here
    // the speeds differ enough for the viscous friction to be named either way; read with the
    // usual intervals it left 0.686 Nm held out, 14 times the noise, in the samples about each
    // reversal, where the torque jumps by up to 27 Nm. A corner's few samples stay hard to read
    // (a slope through them is a slope across the corner); ten times the noise is the bound.
    let report = identify(&record(40.0), &IdentifyOptions::default()).unwrap();
    eprintln!("held out {:.4} -> {:.4} Nm, rate {:?}", report.rmse_before, report.rmse_after, report.narrow_rate);
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let viscous = report.causes.iter().find(|c| c.effect == "viscous_friction");
    assert!(viscous.is_some() && named.len() == 1, "named {named:?}, rejected {:?}", report.rejected);
    let damping = viscous.map_or(0.0, |c| c.params["damping_nms_per_rad"]);
    assert!((damping - 40.0).abs() < 0.25 * 40.0, "damping {damping} for 40");
    assert!(report.rmse_after < 10.0 * 0.05, "held out {:.4} -> {:.4} Nm, rate {:?}", report.rmse_before, report.rmse_after, report.narrow_rate);
    assert!(matches!(report.narrow_rate.as_ref().map(|r| r.window), Some(RateWindow::Sharper { .. })), "{:?}", report.narrow_rate);
}

#[test]
fn a_triangle_without_viscous_friction_names_nothing() {
    // The sharper reading must not buy a cause where there is none: the baseline alone.
    let report = identify(&record(0.0), &IdentifyOptions::default()).unwrap();
    assert!(report.causes.is_empty(), "{:?}", report.causes.iter().map(|c| &c.effect).collect::<Vec<_>>());
}
