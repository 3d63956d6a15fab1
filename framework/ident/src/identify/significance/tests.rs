//! Tests of the significance rule: its tables, and the findings that shaped it.

use super::*;

/// Per-sample squared errors of `n` samples a part, each part at its level.
fn parts(levels: &[f64], n: usize) -> Vec<f64> {
    levels.iter().flat_map(|l| std::iter::repeat_n(*l, n)).collect()
}

/// The judgement on held-out squared errors of 1000 samples a part, at the parts' levels
/// without the cause (`reduced`) and with it (`full`), the noise's variance 1.
fn judged(reduced: &[f64], full: &[f64]) -> Judgement {
    let (reduced, full) = (parts(reduced, 1000), parts(full, 1000));
    let diff: Vec<f64> = reduced.iter().zip(&full).map(|(a, b)| a - b).collect();
    judge(&reduced, &full, block_test(&diff), 1.0)
}

#[test]
fn a_large_gain_with_one_part_made_worse_is_consistent_when_every_other_part_gains() {
    // Finding (the blind generator's seed 4, 009: a Bouc-Wen loop, Dahl's fitted for it):
    // the Dahl loop took 86 % of the excess over the noise off the held-out part, 92-100 %
    // of it in three of the four parts, and made the third part worse by 0.063 Nm^2 (the
    // relevance threshold 0.040): refused, and no cause was named at 2.5 times the noise.
    // A cause that models an effect nearly right is worse somewhere; the parts' median and
    // their signs decide (hv-block cross-validation's rule), one part against three.
    let reduced = &[3.0, 7.0, 1.5, 2.0];
    let full = &[1.0, 1.0, 1.8, 1.0];
    let j = judged(reduced, full);
    assert!(j.consistent, "{j:?}");
    // Two parts made worse: not consistent, however large the rest.
    let full = &[1.0, 1.0, 1.8, 2.3];
    assert!(!judged(reduced, full).consistent);
    // One part worse and another without a relevant gain: not consistent either.
    let full = &[1.0, 1.0, 1.8, 1.95];
    assert!(!judged(reduced, full).consistent);
    // One part worse by more than the parts' median gain (gains 2, 6, -3.5 and 1: median
    // 1.5): not consistent.
    let full = &[1.0, 1.0, 5.0, 1.0];
    assert!(!judged(reduced, full).consistent);
}

#[test]
fn a_part_with_nothing_to_explain_counts_neither_way_beside_the_one_made_worse() {
    // Finding (the blind generator's device A of seed 46 at 20 Hz: a Bouc-Wen loop, a step held
    // in the held-out part): Dahl's loop took 90 % of the excess off the two parts of the hold,
    // left the third within the relevance threshold of where it was, and made the fourth worse
    // by 0.0130 Nm^2 (the threshold 0.0108) where the model without it was at the floor in
    // both: refused, for want of a gain in a part that had nothing to give, and "no cause" was
    // reported at 2.9 times the noise floor.
    let reduced = &[3.0, 7.0, 1.0, 1.0];
    let full = &[1.0, 1.0, 1.0, 1.3];
    let j = judged(reduced, full);
    assert!(j.consistent, "{j:?}");
    // The same with the third part holding something to explain that the cause leaves: refused.
    let reduced = &[3.0, 7.0, 2.0, 1.0];
    let full = &[1.0, 1.0, 2.0, 1.3];
    assert!(!judged(reduced, full).consistent);
    // Two parts with nothing to explain, both made worse: refused.
    let full = &[1.0, 1.0, 1.3, 1.3];
    let reduced = &[3.0, 7.0, 1.0, 1.0];
    assert!(!judged(reduced, full).consistent);
}

#[test]
fn a_gain_in_the_parts_that_hold_most_of_the_excess_is_consistent() {
    // Finding (the blind devices' seed 46, device A's 20 Hz bins, a Bouc-Wen loop): the held-out
    // window's first two parts left 0.51 and 0.41 Nm^2 above the floor, its slow last two
    // 0.027 and 0.025 (the floor's variance 5.9e-4, so 870, 700, 46 and 43 times it); a Dahl
    // loop took 0.45 and 0.36 off the first two and nothing off the others. Two of four parts:
    // refused, no cause named at 20 times the floor. Weighed by what is left there, the two
    // parts hold 95 % of it.
    let reduced = &[871.0, 701.0, 47.0, 44.0];
    let full = &[111.0, 83.0, 51.0, 49.0];
    let j = judged(reduced, full);
    assert!(j.consistent && j.named(), "{j:?}");
    // Two parts of four bettered that hold less than half of what is left: not consistent,
    // though the gain is large (150 of an excess of 350).
    let j = judged(&[301.0, 301.0, 401.0, 401.0], &[1.0, 1.0, 401.0, 401.0]);
    assert!(j.large && !j.consistent, "{j:?}");
}

#[test]
fn the_critical_value_matches_the_table() {
    // Student's t, one-sided 0.001: df 19 -> 3.579, df 9 -> 4.297 (standard tables).
    assert!((student_t(19.0) - 3.579).abs() < 0.02, "{}", student_t(19.0));
    assert!((student_t(9.0) - 4.297).abs() < 0.05, "{}", student_t(9.0));
}

#[test]
fn the_chi_square_quantile_matches_the_table() {
    // Chi-square, upper 0.001: k 2 -> 13.82, k 10 -> 29.59, k 40 -> 73.40 (standard tables).
    for (k, table, within) in [(2.0, 13.82, 0.025), (10.0, 29.59, 0.01), (40.0, 73.40, 0.005)] {
        assert!((chi_square(k) - table).abs() / table < within, "{k}: {}", chi_square(k));
    }
}

#[test]
fn noise_is_not_significant_and_a_steady_gain_is() {
    let mut rng = jointctl_test_support::XorShift64::new(7);
    let mut false_alarms = 0;
    for _ in 0..200 {
        let noise: Vec<f64> = (0..2000).map(|_| rng.normal()).collect();
        false_alarms += block_test(&noise).significant() as usize;
    }
    assert!(false_alarms <= 2, "{false_alarms} of 200");
    let gain: Vec<f64> = (0..2000).map(|_| 0.3 + rng.normal()).collect();
    assert!(block_test(&gain).significant());
}

#[test]
fn a_slow_wave_in_the_gains_does_not_pass_for_significance() {
    // Gains that swing with a period of 8 blocks and average zero: correlated blocks.
    let wave: Vec<f64> = (0..2000).map(|i| (i as f64 / 800.0 * std::f64::consts::TAU).sin() + 0.02).collect();
    assert!(!block_test(&wave).significant(), "{:?}", block_test(&wave));
}

/// Finding (issue 31): a ring was named beside a clean record's Stribeck friction (a gain of
/// 9 % of the excess, the held-out chi-square 1160 against 42) where the model without it
/// left four times the noise's variance above the floor: coefficients fitted on the
/// held-out part take part of any structure, so the chi-square alone is no evidence there.
#[test]
fn coefficients_fitted_on_a_structured_residual_need_a_consistent_gain() {
    // The reduced model leaves 5 times the noise's variance; the full one, with 16
    // coefficients fitted on the held-out part, takes 10 % of the excess in its first part.
    let (noise, n) = (1.0, 4000);
    let reduced = vec![5.0; n];
    let full: Vec<f64> = (0..n).map(|i| if i < n / 4 { 3.4 } else { 5.0 }).collect();
    let (rss_reduced, rss_full) = (reduced.iter().sum::<f64>(), full.iter().sum::<f64>());
    let test = added_coefficients_test(rss_reduced, rss_full, rss_full / (n - 16) as f64, 16);
    assert!(test.significant(), "{test}");
    let j = judge(&reduced, &full, test, noise);
    assert!(j.relevant() && j.structured && !j.consistent, "{j:?}");
    assert!(!j.named(), "{j}");
    // The same gain on a residual at the floor is named on the chi-square test.
    let (at_floor, less) = (vec![1.2; n], (0..n).map(|i| if i < n / 4 { 0.84 } else { 1.2 }).collect::<Vec<f64>>());
    let test = added_coefficients_test(at_floor.iter().sum(), less.iter().sum(), less.iter().sum::<f64>() / (n - 16) as f64, 16);
    assert!(judge(&at_floor, &less, test, noise).named());
}

/// Finding (issue 31, pattern 2: a ring named where there is none): on the blind
/// generator's seed 9, 003 (a viscous friction that eq. 3.5's nearly straight arctan
/// explains), a ring fitted on every reversal of the held-out part was named at 1.3 times the
/// noise floor: chi-square 770 against 36 for its 14 coefficients, a gain of 2.9e-4 Nm^2
/// where 2.1e-4 is relevant, 9 % of what the baseline left above the floor. Coefficients
/// fitted on the held-out part take part of whatever recurs at its reversals; where the
/// residual is not structure enough for the consistency rule, the gain must still be large.
#[test]
fn coefficients_fitted_on_the_held_out_part_need_a_large_share_of_the_excess() {
    let (noise, n) = (1.0, 4000);
    // The reduced model leaves 0.8 of the noise's variance above the floor (not structured);
    // the full one takes 9 % of it, evenly.
    let reduced = vec![1.8; n];
    let full = vec![1.8 - 0.072; n];
    let (rss_reduced, rss_full) = (reduced.iter().sum::<f64>(), full.iter().sum::<f64>());
    let test = added_coefficients_test(rss_reduced, rss_full, rss_full / (n - 14) as f64, 14);
    assert!(test.significant(), "{test}");
    let j = judge(&reduced, &full, test, noise);
    assert!(j.relevant() && !j.structured && !j.named(), "{j:?}");
    assert!(j.to_string().contains("20 % of what the model without them leaves"), "{j}");
    // A ring that takes most of that excess is named on the chi-square test.
    let full = vec![1.2; n];
    let test = added_coefficients_test(rss_reduced, full.iter().sum(), full.iter().sum::<f64>() / (n - 14) as f64, 14);
    assert!(judge(&reduced, &full, test, noise).named());
    // Below a quarter of the noise's variance above the floor, a relevant gain is large.
    let (reduced, full) = (vec![1.2; n], vec![1.2 - 0.06; n]);
    let test = added_coefficients_test(reduced.iter().sum(), full.iter().sum(), full.iter().sum::<f64>() / (n - 14) as f64, 14);
    assert!(judge(&reduced, &full, test, noise).named());
    // Nearer the floor, a significant and large gain below the relevance threshold is
    // negligible; not large, it is no evidence, and neither named nor negligible.
    let (reduced, full) = (vec![1.1; n], vec![1.1 - 0.03; n]);
    let test = added_coefficients_test(reduced.iter().sum(), full.iter().sum(), full.iter().sum::<f64>() / (n - 14) as f64, 14);
    assert!(test.significant() && judge(&reduced, &full, test, noise).negligible());
    let full = vec![1.1 - 0.015; n];
    let test = added_coefficients_test(reduced.iter().sum(), full.iter().sum(), full.iter().sum::<f64>() / (n - 14) as f64, 14);
    let j = judge(&reduced, &full, test, noise);
    assert!(test.significant() && !j.negligible() && !j.named(), "{j:?}");
}
