//! The hidden-effect suite (`jointctl_test_support::hidden_effects`: every effect of the
//! vocabulary, both vibration kinds, an encoder-side delay, pairs with the known confounds, lower
//! SNR, 20 clean controls) must meet issue 13's targets: at least 95 % of the cases with hidden
//! effects get every effect named, at most 1 of the 20 clean controls gets a cause, at least 90 %
//! of the parameters are within tolerance.

use jointctl_ident::csv::Data;
use jointctl_ident::identify::{IdentifyOptions, identify};
use jointctl_test_support::hidden_effects;

/// What identify names in a case, as the suite scores it.
fn found(case: &hidden_effects::Case) -> hidden_effects::Found {
    let data = Data::from_columns(case.t.clone(), case.deflection.clone(), case.torque.clone());
    let report = identify(&data, &IdentifyOptions::default()).unwrap();
    (report.causes.into_iter().map(|c| (c.effect, c.params)).collect(), report.rejected)
}

/// Prints the suite's outcome and holds it to issue 13's targets.
fn meets_the_targets(what: &str, score: &hidden_effects::Score, seconds: f64, controls: usize) {
    println!("{what}: confusion matrix (hidden -> named), in {seconds:.2} s:\n{}", score.report());
    for m in &score.misses {
        println!("  {m}");
    }
    assert_eq!(score.controls, controls);
    assert!(score.named as f64 >= 0.95 * score.with_effects as f64, "named in {} of {} cases (need 95 %)", score.named, score.with_effects);
    assert!(score.control_hits <= 1, "{} of {controls} clean controls produced a cause", score.control_hits);
    assert!(score.params_ok as f64 >= 0.9 * score.params_checked as f64, "{} of {} parameters within tolerance (need 90 %)", score.params_ok, score.params_checked);
}

#[test]
fn hidden_effects_and_pairs_are_named_with_their_parameters_and_controls_yield_nothing() {
    let start = std::time::Instant::now();
    let score = hidden_effects::run(found);
    meets_the_targets("60 s records", &score, start.elapsed().as_secs_f64(), 20);
}

/// The same scoring and targets on 500 s records (100 000 samples), whose searches run decimated
/// to 100 samples a cycle of the excitation: every single effect once and four clean controls.
#[test]
fn long_records_are_identified_as_the_short_ones() {
    let start = std::time::Instant::now();
    let score = hidden_effects::run_long(found);
    meets_the_targets("500 s records", &score, start.elapsed().as_secs_f64(), 4);
}

/// A structural mode above the decimated part's Nyquist frequency (a 500 s record decimated to
/// 100 samples a 0.2-0.4 Hz cycle samples at 20-40 Hz) is found at its own frequency, not at an
/// alias of it or not at all: both vibration kinds, 16.6 and 18.5 Hz.
#[test]
fn a_mode_above_the_search_parts_nyquist_frequency_is_found_at_its_frequency() {
    for (effect, seed) in [("vibration", 15851), ("speed_vibration", 7932)] {
        let case = hidden_effects::generate_samples(&[effect], seed, false, hidden_effects::LONG_SAMPLES);
        let truth = case.truths.iter().find(|(_, p, _)| *p == "frequency_hz").map(|t| t.2).unwrap();
        assert!(truth > 15.0, "{effect}: the case's mode is at {truth} Hz");
        let (causes, _) = found(&case);
        let (_, params) = causes.iter().find(|c| c.0 == effect).unwrap_or_else(|| panic!("{effect} at {truth:.2} Hz not named: {causes:?}"));
        let f = params["frequency_hz"];
        assert!((f - truth).abs() <= 0.05 * truth, "{effect}: {f} Hz for {truth} Hz");
    }
}

/// A Dahl hysteresis on top of eq. 3.5's arctan friction (a confound: both shape the torque at
/// each reversal) is named alone, with its limit, on a long record: the friction's `k_b` and the
/// Dahl scale are refined together until neither moves, not one step each (which left a cubic
/// stiffness to make up for the difference).
#[test]
fn hysteresis_beside_arctan_friction_is_named_alone_on_a_long_record() {
    let case = hidden_effects::generate_samples(&["hysteresis"], 7932, false, hidden_effects::LONG_SAMPLES);
    let (causes, _) = found(&case);
    let named: Vec<&str> = causes.iter().map(|c| c.0.as_str()).collect();
    assert_eq!(named, ["hysteresis"], "{causes:?}");
    let truth = case.truths.iter().find(|(_, p, _)| *p == "limit_nm").map(|t| t.2).unwrap();
    let limit = causes[0].1["limit_nm"];
    assert!((limit - truth).abs() <= 0.1 * truth, "limit {limit} Nm for {truth} Nm");
}
