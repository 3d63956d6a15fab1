//! A logger that stalls and then writes its buffered samples in a burst, stamped when written
//! (tens of microseconds apart) although taken at its usual step: the rate read at those stamps
//! leaps at every burst. The rig generator's logger does this
//! (`tools/ident_reference/rig_generator`); this file's records are its own: a spring with a
//! viscous friction, logged at 550 Hz, stalling for 16 ms every quarter second.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 500.0;
const DAMPING_NMS_PER_RAD: f64 = 3.0;
const NOISE_NM: f64 = 0.005;
const RATE_HZ: f64 = 550.0;
const STEP_RAD: f64 = 2e-6;

/// 60 s of a 0.02 rad, 0.5 Hz sine (with a second sine, 0.008 rad at 1.3 Hz, so that the rate is
/// not the deflection's quadrature alone), taken every 1/550 s; with `bursts`, every 0.25 s the
/// logger stalls for 16 ms and stamps the samples taken meanwhile 10 us apart after it.
fn record(bursts: bool, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0xb0a5_7ed1_0660_0001 ^ seed);
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let mut written_until = f64::NEG_INFINITY;
    for k in 0..(60.0 * RATE_HZ) as usize {
        let t = k as f64 / RATE_HZ;
        let d = 0.02 * (TAU * 0.5 * t).sin() + 0.008 * (TAU * 1.3 * t + 0.7).sin();
        let v = 0.02 * TAU * 0.5 * (TAU * 0.5 * t).cos() + 0.008 * TAU * 1.3 * (TAU * 1.3 * t + 0.7).cos();
        let phase = t % 0.25;
        let stamp = if bursts && phase > 0.1 && phase < 0.116 {
            // Taken during the stall: written when it ends, after the ones before it.
            written_until = (t - phase + 0.116).max(written_until + 1e-5);
            written_until
        } else {
            t
        };
        t_s.push(stamp.max(written_until));
        phi.push((d / STEP_RAD).round() * STEP_RAD);
        tau.push(K_NM_PER_RAD * d + DAMPING_NMS_PER_RAD * v + NOISE_NM * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

/// The damping is named, and within 10 % of the plant's, with the bursts as without them.
#[test]
fn a_viscous_friction_logged_in_bursts_is_read_as_without_them() {
    for bursts in [false, true] {
        let r = identify(&record(bursts, 1), &IdentifyOptions::default()).unwrap();
        let named: Vec<(&str, &std::collections::BTreeMap<String, f64>)> = r.causes.iter().map(|c| (c.effect.as_str(), &c.params)).collect();
        let damping = r.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
        assert!(damping.is_some_and(|b| (b / DAMPING_NMS_PER_RAD - 1.0).abs() < 0.1), "bursts {bursts}: named {named:?}, held out {} -> {}", r.rmse_before, r.rmse_after);
    }
}
