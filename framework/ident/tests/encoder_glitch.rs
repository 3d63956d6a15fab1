//! A deflection reading that leaps away and comes back within a few samples (an encoder's
//! misread) is left out, never used as a value: read as it stood, its rate reading was a spike
//! that outweighed the record, and identify named a loop and a cubic in place of the viscous
//! friction it names without the leap.

use jointctl_ident::identify::{IdentifyOptions, Report, identify};

/// 30 s at 1 kHz of a 0.02 rad, 0.125 Hz sine on a 138 Nm/rad spring with a viscous friction of
/// 100 Nm s/rad; 14-bit deflection, 0.07 Nm of torque noise. With `leap_counts`, readings
/// 10 000-10 002 read that many counts up (the torque does not follow: the joint did not move).
fn record(leap_counts: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..30_000 {
        let t = i as f64 / 1000.0;
        let (x, v) = (0.02 * (TAU * t / 8.0).sin(), 0.02 * TAU / 8.0 * (TAU * t / 8.0).cos());
        let leap = if (10_000..10_003).contains(&i) { leap_counts * q } else { 0.0 };
        t_s.push(t);
        deflection.push((x / q).round() * q + leap);
        torque.push(138.0 * x + 100.0 * v + 0.07 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

fn named(r: &Report) -> Vec<&str> {
    r.causes.iter().map(|c| c.effect.as_str()).collect()
}

#[test]
fn a_leap_of_three_readings_is_left_out_and_the_causes_stay() {
    let clean = identify(&record(0.0), &IdentifyOptions::default()).unwrap();
    assert_eq!(named(&clean), ["viscous_friction"], "{:?}", clean.rejected);
    assert_eq!(clean.glitch_samples, 0);
    let leap = identify(&record(6.0), &IdentifyOptions::default()).unwrap();
    assert_eq!(named(&leap), named(&clean), "rejected {:?}", leap.rejected);
    assert_eq!(leap.glitch_samples, 3);
    let b = |r: &Report| r.causes[0].params["damping_nms_per_rad"];
    assert!((b(&leap) - 100.0).abs() < 25.0 && (b(&leap) - b(&clean)).abs() < 1.0, "{} with the leap, {} without", b(&leap), b(&clean));
}
