//! Confounds as a result: when another candidate explains the training part about as well as a
//! named cause, the report names the pair.

use jointctl_ident::identify::{IdentifyOptions, identify};

mod through_the_reader;

/// A sine deflection of `amp` rad at 0.25 Hz (plus, when `second`, a fifth of it at 1.55 Hz) on
/// the thesis' baseline (120 Nm/rad, eq. 3.5 friction `0.3 atan(80 v)`), 14-bit deflection,
/// 0.02 Nm noise, 200 Hz for 80 s, plus `extra(deflection, velocity)` [Nm].
fn record(amp: f64, second: bool, mut extra: impl FnMut(f64, f64) -> f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let q = TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x0123_4567_89ab_cdef);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let s = if second { 0.2 } else { 0.0 };
    for i in 0..16_000 {
        let t = f64::from(i) / 200.0;
        let x = amp * ((TAU * 0.25 * t).sin() + s * (TAU * 1.55 * t).sin());
        let v = amp * (TAU * 0.25 * (TAU * 0.25 * t).cos() + s * TAU * 1.55 * (TAU * 1.55 * t).cos());
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(120.0 * x + 0.3 * (80.0 * v).atan() + extra(x, v) + 0.02 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// A Dahl hysteresis of `limit` [Nm] and deflection scale `lambda` [rad] (the state follows
/// the deflection's steps).
fn dahl(limit: f64, lambda: f64) -> impl FnMut(f64, f64) -> f64 {
    let (mut z, mut prev) = (0.0f64, 0.0f64);
    move |x, _| {
        let step = x - prev;
        prev = x;
        if step != 0.0 {
            let s = step.signum();
            z = s + (z - s) * (-step.abs() / lambda).exp();
        }
        limit * z
    }
}

#[test]
fn a_hysteresis_on_one_sine_is_reported_confounded_and_a_second_frequency_resolves_it() {
    // Issue 32, finding 4: confounded causes stay confounded, and the report names one of them
    // without saying that the data cannot tell them apart. On one sine a Dahl loop (0.1 Nm,
    // lambda 0.05 rad on a 0.08 rad stroke) is fitted to 95 % as well by a 5 ms delay (and a
    // cubic): whichever is named, the pair is reported.
    let pair = |a: &str, b: &str| [a, b].contains(&"hysteresis") && [a, b].contains(&"time_delay");
    let one = identify(&record(0.08, false, dahl(0.1, 0.05)), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = one.causes.iter().map(|c| c.effect.as_str()).collect();
    assert!(named.contains(&"hysteresis") || named.contains(&"time_delay"), "{named:?}");
    let confound = one.confounded.iter().find(|c| pair(&c.effect, &c.alternative));
    assert!(confound.is_some(), "named {named:?}, confounded {:?}", one.confounded);
    assert!(confound.unwrap().evidence.contains("explains the training part about as well"), "{:?}", confound);
    // A second frequency (a fifth of the amplitude at 1.55 Hz) tells them apart: the hysteresis
    // is named and confounded with nothing.
    let two = identify(&record(0.08, true, dahl(0.1, 0.05)), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = two.causes.iter().map(|c| c.effect.as_str()).collect();
    assert!(named.contains(&"hysteresis") && !named.contains(&"time_delay"), "{named:?}");
    assert!(two.confounded.iter().all(|c| c.effect != "hysteresis" && c.alternative != "hysteresis"), "{:?}", two.confounded);
}

/// A fast small sine (0.0115 rad at 1.2 Hz: up to 0.087 rad/s) of a stiff spring (235 Nm/rad)
/// with a viscous friction of `b` Nm s/rad beside a small eq. 3.5 friction `0.094 atan(33 v)`,
/// through a 17-bit encoder, 0.045 Nm noise, 800 Hz for 22 s.
fn viscous_record(b: f64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let q = TAU / 131_072.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x6a09_e667_f3bc_c908);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..17_600 {
        let t = f64::from(i) / 800.0;
        let (x, v) = (0.0115 * (TAU * 1.2 * t).sin(), 0.0115 * TAU * 1.2 * (TAU * 1.2 * t).cos());
        t_s.push(t);
        deflection.push((x / q).round() * q);
        torque.push(235.0 * x + 0.094 * (33.0 * v).atan() + b * v + 0.045 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

/// Finding (issue 31, pattern 1, and issue 32's confounds): a viscous friction beside a small
/// eq. 3.5 arctan, at rates where the baseline's arctan is fitted nearly straight, got no cause
/// and no word: the arctan took the viscous torque as its own (the blind generator's 008 of
/// seed 2: a viscous torque of 37 times the noise, the baseline's held-out error at the noise
/// floor). The report names the pair as confounded (eq. 3.5's friction in the baseline,
/// `coulomb_friction`, or `viscous_friction`) and proposes an experiment that goes where they
/// part: beyond the recorded rates, the one proposal that does (until 2026-12-02, none). The
/// thesis' sharp arctan bends within the rates: no such entry.
/// Where BIC proposes the damping and the held-out part confirms it, it is named since its own
/// term's size counts (`absorbed_damping.rs`): at 4 Nm s/rad here (held-out t = 4.0, its term
/// 0.197 Nm RMS against a floor of 0.045), where this test once asked for the pair; at 2 Nm s/rad
/// BIC does not propose it and the pair is reported.
#[test]
fn a_viscous_friction_taken_by_a_nearly_straight_arctan_is_reported_confounded() {
    // 2 Nm s/rad: 0.17 Nm at the peak rate, 4 times the noise.
    let report = identify(&viscous_record(2.0), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    let pair = report.confounded.iter().find(|c| c.effect == "coulomb_friction" && c.alternative == "viscous_friction");
    assert!(!named.contains(&"viscous_friction"), "named {named:?}: the confound this test is about did not arise");
    let pair = pair.unwrap_or_else(|| panic!("named {named:?}, confounded {:?}", report.confounded));
    assert!(pair.evidence.contains("nearly straight") && pair.evidence.contains("beyond what the arm did"), "{}", pair.evidence);
    let experiment = report.experiment.as_ref().unwrap_or_else(|| panic!("no experiment for {pair:?}"));
    assert!(experiment.purpose[0].starts_with("coulomb_friction or viscous_friction") && experiment.purpose[0].contains("3 / k_b"), "{:?}", experiment.purpose);
    // 4 Nm s/rad: 0.35 Nm at the peak rate, 8 times the noise, named for what its term carries.
    let report = identify(&viscous_record(4.0), &IdentifyOptions::default()).unwrap();
    let viscous = report.causes.iter().find(|c| c.effect == "viscous_friction").unwrap_or_else(|| panic!("{:?}", report.negligible));
    let b = viscous.params["damping_nms_per_rad"];
    assert!((b - 4.0).abs() < 1.0 && viscous.evidence.contains("its own term carries"), "b = {b}: {}", viscous.evidence);
    // The thesis' baseline alone (0.3 atan(80 v) at up to 0.16 rad/s): the arctan bends.
    let clean = identify(&record(0.1, false, |_, _| 0.0), &IdentifyOptions::default()).unwrap();
    assert!(clean.confounded.iter().all(|c| c.effect != "coulomb_friction"), "{:?}", clean.confounded);
}

/// Eq. 3.5's arctan held nearly straight, where the held-out part does tell it from a viscous
/// friction by a negligible amount: the confound's sentence says so. Finding (the blind
/// generator's seed 4, device E, 38 Nm s/rad beside a 0.74 Nm arctan, logged at ~790 Hz with
/// gaps): the viscous friction passed forecast encompassing at t = 7.5 with a held-out gain below
/// the relevance threshold, and the report said "the data cannot tell these apart ... the
/// held-out part did not decide it". That record's damping, proposed by BIC, is named now for
/// what its term carries (2.8 times the floor); the sentence is checked on the blind seed 10's
/// 032 (a cubic on a 2e-6 rad encoder, no viscous friction hidden), where a damping gains
/// significantly and negligibly on the held-out part alone (encompassing t = 9.0). The seed's
/// 094 (a loop and a dead zone) served until the consistency rule weighed the held-out parts by
/// what is left there (`significance::MOST_BY_EXCESS`): its dead zone is then named first, and
/// the damping is no longer tried beside the arctan.
#[test]
fn a_friction_confound_says_what_the_held_out_part_said() {
    let (case, _) = jointctl_blind_gen::suite_plan(10).into_iter().find(|s| s.name == "032_stiff_linear2e-6").unwrap().generate().unwrap();
    let report = identify(&through_the_reader::blind_case(&case, "confound"), &IdentifyOptions::default()).unwrap();
    let confound = report.confounded.iter().find(|c| c.effect == "coulomb_friction" && c.alternative == "viscous_friction").expect("the arctan confounded with a viscous friction");
    let viscous_negligible = report.negligible.iter().any(|n| n.effect == "viscous_friction");
    assert!(viscous_negligible && report.causes.iter().all(|c| c.effect != "viscous_friction"), "{:?}", report.negligible);
    assert!(!confound.evidence.contains("did not decide"), "{}", confound.evidence);
    assert!(confound.evidence.contains("tells them apart") && confound.evidence.contains("encompassing t ="), "{}", confound.evidence);
    // Device E's irregular record: its damping named.
    let case = jointctl_blind_gen::device_variants(4).into_iter().find(|c| c.name.starts_with("devE_1_irregular")).expect("device E's irregular record");
    let report = identify(&through_the_reader::blind_case(&case, "confound"), &IdentifyOptions::default()).unwrap();
    let viscous = report.causes.iter().find(|c| c.effect == "viscous_friction").unwrap_or_else(|| panic!("{:?}", report.negligible));
    let b = viscous.params["damping_nms_per_rad"];
    assert!((b - 38.4).abs() < 0.25 * 38.4, "b = {b} for 38.4: {}", viscous.evidence);
}

/// A viscous friction refused beside eq. 3.5's nearly straight arctan as a negative damping is
/// judged again as the confound's sentence reads it: an arctan that saturates within the
/// recorded rates, beside a damping that keeps rising. Finding (the blind generator's seed 5,
/// record 000: 23 Nm s/rad beside a 0.43 Nm x 116 s/rad arctan, 250 Hz, 14-bit): with the
/// arctan's `k_b` free, the training part's optimum bent the arctan into the damping's place
/// beside a negative damping, the pair was refused as physically impossible, and nothing was
/// named at 1.6 times the noise; the held-out part, which moves faster, tells the two readings
/// apart.
#[test]
fn a_viscous_friction_beside_a_saturating_arctan_is_named_where_the_held_out_part_tells_them_apart() {
    let (case, _) = jointctl_blind_gen::suite_plan(5).into_iter().find(|s| s.name == "000_viscous_plain").unwrap().generate().unwrap();
    assert_eq!(case.answer.effect, "viscous_friction");
    let report = identify(&through_the_reader::blind_case(&case, "saturating-arctan"), &IdentifyOptions::default()).unwrap();
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    assert_eq!(named, ["viscous_friction"], "{}", report.unexplained.summary);
    let viscous = &report.causes[0];
    assert!(viscous.evidence.contains("nearly straight arctan"), "{}", viscous.evidence);
    // A damping, not a number the search's bound makes up: the generator's is 23.1 Nm s/rad.
    let b = viscous.params["damping_nms_per_rad"];
    assert!((5.0..40.0).contains(&b), "{b} Nm s/rad");
    // Its gain is the held-out test's, against the model with the arctan as it was.
    assert!(viscous.rmse_gain > 0.0 && viscous.rmse_gain <= report.rmse_before - report.rmse_after + 1e-9, "{} of {} -> {}", viscous.rmse_gain, report.rmse_before, report.rmse_after);
}
