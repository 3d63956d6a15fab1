//! A large viscous friction beside a small Coulomb friction that saturates within the training
//! part's rates, on a record whose held-out part moves faster. Over the training part, eq. 3.5's
//! arctan with its `k_b` free bends to a nearly straight line and takes most of the damping: the
//! viscous friction beside it is fitted small (blind device E of seed 42: 0.26 +- 0.41 Nm s/rad
//! on its 20 Hz bins for 5.7, refused as "not told from zero" at 13 times the noise; 1.6 and 3.1
//! on two other variants of the same device). The confound's other reading, the damping beside
//! an arctan held to saturate within the training part's rates, is judged on the held-out part
//! too, and taken where the training part tells its damping from zero and the held-out part
//! errs less with it.
//!
//! The records come from this file's own generator: a spring, eq. 3.5's arctan of `k_a` with a
//! sharp `k_b`, a viscous friction; the deflection a triangle at two rates (a characterisation's
//! constant-speed strokes, over which a friction is seen at two rates only), then sines with
//! random phases, faster, through the part held out; a 14-bit encoder, 100 Hz, normal noise on the
//! torque.

use jointctl_ident::identify::{IdentifyOptions, Report, identify};

/// 60 s at 100 Hz: 40 Nm/rad, `k_a atan(40 v)`, `b_nms_per_rad` of viscous friction, 0.01 Nm of
/// noise. The deflection holds for 3 s, runs a triangle of 0.04 rad at 0.08 rad/s to 22 s and at
/// 0.03 rad/s to 41 s (two rates each way: eq. 3.5's arctan meets a friction at two rates with
/// one `k_b` or another), then four sines of 0.3-0.9 Hz with random phases, 0.04 rad in all
/// under a rising envelope (up to about 0.25 rad/s, most of the held-out part).
fn record(k_a_nm: f64, b_nms_per_rad: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let sines: Vec<(f64, f64)> = (0..4).map(|_| (0.3 + 0.6 * rng.uniform(), TAU * rng.uniform())).collect();
    // The distance the triangle has run [rad]: 0.08 rad/s from 3 s, 0.03 rad/s from 22 s.
    let run = |t: f64| 0.08 * (t.min(22.0) - 3.0).max(0.0) + 0.03 * (t - 22.0).max(0.0);
    let triangle = |t: f64| {
        let phase = (run(t) / 0.04 + 1.0).rem_euclid(4.0);
        0.04 * if phase < 2.0 { phase - 1.0 } else { 3.0 - phase }
    };
    // From 41 s the sines rise over 3 s from where the triangle stopped.
    let x = |t: f64| {
        if t < 41.0 {
            triangle(t)
        } else {
            let rise = ((t - 41.0) / 3.0).min(1.0);
            triangle(41.0) * (1.0 - rise) + rise * 0.01 * sines.iter().map(|(f, p)| (TAU * f * (t - 41.0) + p).sin()).sum::<f64>()
        }
    };
    let q = TAU / 16384.0;
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..6_000 {
        let t = i as f64 / 100.0;
        let v = (x(t + 1e-6) - x(t - 1e-6)) / 2e-6;
        t_s.push(t);
        deflection.push((x(t) / q).round() * q);
        torque.push(40.0 * x(t) + k_a_nm * (40.0 * v).atan() + b_nms_per_rad * v + 0.01 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// 120 s at 100 Hz: 40 Nm/rad, `k_a atan(30 v)`, `b_nms_per_rad` of viscous friction, 0.01 Nm
/// of noise; the deflection four sines of 0.15-0.45 Hz with random phases, their amplitude
/// 0.005 rad each over the first 10 s growing to three times that at the end (the rate grows
/// with it), read by a 14-bit encoder.
fn growing(k_a_nm: f64, b_nms_per_rad: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(seed);
    let sines: Vec<(f64, f64)> = (0..4).map(|_| (0.15 + 0.3 * rng.uniform(), TAU * rng.uniform())).collect();
    let envelope = |t: f64| 0.005 * (1.0 + 2.0 * ((t - 10.0) / 110.0).clamp(0.0, 1.0));
    let x = |t: f64| envelope(t) * sines.iter().map(|(f, p)| (TAU * f * t + p).sin()).sum::<f64>();
    let q = TAU / 16384.0;
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..12_000 {
        let t = i as f64 / 100.0;
        let v = (x(t + 1e-6) - x(t - 1e-6)) / 2e-6;
        t_s.push(t);
        deflection.push((x(t) / q).round() * q);
        torque.push(40.0 * x(t) + k_a_nm * (30.0 * v).atan() + b_nms_per_rad * v + 0.01 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

fn named(report: &Report) -> Vec<&str> {
    report.causes.iter().map(|c| c.effect.as_str()).collect()
}

/// `Ok` when the viscous friction alone is named, within 25 % of 4 Nm s/rad; otherwise what was
/// named (also printed either way).
fn not_the_damping_alone_at_size(report: &Report, seed: u64) -> Result<(), String> {
    let b = report.causes.iter().find(|c| c.effect == "viscous_friction").map(|c| c.params["damping_nms_per_rad"]);
    let line = format!("seed {seed:x}: named {:?}, b {b:?}, held out {:.4} -> {:.4} Nm", named(report), report.rmse_before, report.rmse_after);
    println!("{line}");
    if named(report) == ["viscous_friction"] && b.is_some_and(|b| (b / 4.0 - 1.0).abs() < 0.25) { Ok(()) } else { Err(line) }
}

const SEEDS: [u64; 4] = [0xd3e5_0000_0000_0001, 0xd3e5_0000_0000_0002, 0xd3e5_0000_0000_0003, 0xd3e5_0000_0000_0004];

#[test]
fn a_large_damping_beside_a_small_saturating_arctan_is_named_at_its_size() {
    // Held out as the last 30 % (`--held-out last`), the part that moves fastest. Measured
    // before the other reading was judged on a naming: no cause on seeds 2 and 4 (held-out RMSE
    // 0.0282 and 0.0306 Nm, noise 0.01), the damping named there with `k_b` free but not told
    // from zero on the training part. Now named on them at 4.13 and 4.17 Nm s/rad. On seeds 1 and
    // 3 BIC proposes it; on seed 1 at 1.69 (the training part's optimum bends the arctan to take
    // the rest, and the saturating reading, 4.29 there, errs more on the held-out part: 0.0173
    // against 0.0164 Nm), as before.
    let last = IdentifyOptions { held_out: jointctl_ident::identify::prepare::HeldOut::Last, ..IdentifyOptions::default() };
    let (mut wrong, mut at_size) = (Vec::new(), 0);
    for seed in SEEDS {
        let report = identify(&record(0.04, 4.0, seed), &last).unwrap();
        match not_the_damping_alone_at_size(&report, seed) {
            Ok(()) => at_size += 1,
            Err(line) if named(&report) != ["viscous_friction"] => wrong.push(line),
            Err(_) => {}
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
    assert!(at_size >= 3, "the damping within 25 % of 4 Nm s/rad on {at_size} of 4");
}

#[test]
fn a_damping_that_misses_the_coulomb_step_in_the_arctans_place_is_still_a_confound() {
    // Twice the Coulomb friction: a viscous friction in the arctan's place explains 84 % of what
    // the arctan does on the training part (under the confound rule's 90 %), so no confound was
    // reported, the damping beside the bent arctan was refused as negative, and the held-out part
    // was never asked: no cause on any seed (1.7-4.8 times the floor). The other reading, the
    // damping beside an arctan held to saturate, is the confound's too: now named on 4 of 4.
    let last = IdentifyOptions { held_out: jointctl_ident::identify::prepare::HeldOut::Last, ..IdentifyOptions::default() };
    let mut wrong = Vec::new();
    for seed in SEEDS {
        let report = identify(&record(0.08, 4.0, seed), &last).unwrap();
        wrong.extend(not_the_damping_alone_at_size(&report, seed).err());
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
    for seed in SEEDS {
        for held_out in [last.held_out, IdentifyOptions::default().held_out] {
            let report = identify(&record(0.08, 0.0, seed), &IdentifyOptions { held_out, ..IdentifyOptions::default() }).unwrap();
            assert!(report.causes.is_empty(), "clean, seed {seed:x}, held out {held_out:?}: {:?}", named(&report));
        }
    }
}

#[test]
fn a_damping_named_by_bic_is_split_from_the_arctan_as_the_held_out_part_reads_it() {
    // BIC names the damping here, beside an arctan that bends (`k_b` free) to take part of it.
    // Measured before the split was read on the held-out part: seed 3 named it at 2.24 Nm s/rad
    // with a time delay beside it (held out 0.0153 Nm); now at 4.63 alone (0.0136 Nm), the delay
    // no longer earning its place beside the arctan held to saturate. The other seeds' split
    // stands (the bent arctan errs less on their held-out part).
    let last = IdentifyOptions { held_out: jointctl_ident::identify::prepare::HeldOut::Last, ..IdentifyOptions::default() };
    let mut wrong = Vec::new();
    for seed in SEEDS {
        let report = identify(&growing(0.06, 4.0, seed), &last).unwrap();
        wrong.extend(not_the_damping_alone_at_size(&report, seed).err());
        let clean = identify(&growing(0.06, 0.0, seed), &last).unwrap();
        if !clean.causes.is_empty() {
            wrong.push(format!("clean, seed {seed:x}: named {:?}", named(&clean)));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn the_small_arctan_alone_gets_no_viscous_friction() {
    for seed in SEEDS {
        for held_out in [jointctl_ident::identify::prepare::HeldOut::Last, IdentifyOptions::default().held_out] {
            let report = identify(&record(0.04, 0.0, seed), &IdentifyOptions { held_out, ..IdentifyOptions::default() }).unwrap();
            assert!(report.causes.is_empty(), "seed {seed:x}, held out {held_out:?}: {:?}", named(&report));
        }
    }
}
