//! A configured characteristic off by a factor (the thesis' "inaccurately fitted curve",
//! sections 5.1, 5.2) is a cause of its own against a given baseline: named with its size when
//! the curve is off, silent when it is right, and never tried when the baseline's stiffness is
//! fitted on the data (it would be the baseline itself).

mod common;

use jointctl_ident::identify::{BaselineModel, IdentifyOptions, identify};

/// The synthetic experiment's spring is 120 Nm/rad with eq. 3.5 friction in the baseline.
fn against(k_model: f64) -> IdentifyOptions {
    IdentifyOptions { baseline: BaselineModel::Given(Box::new(move |d, _| k_model * d)), ..IdentifyOptions::default() }
}

#[test]
fn a_curve_three_percent_too_stiff_is_named_with_its_relative_error() {
    let data = common::sine_experiment(|_, _, _| 0.0);
    let report = identify(&data, &against(123.6)).unwrap();
    let names: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    assert_eq!(names, ["stiffness_error"], "{:?}", report.causes);
    let e = report.causes[0].params["relative_error"];
    assert!((e - (120.0 / 123.6 - 1.0)).abs() < 0.002, "relative error {e}");
    assert!(report.rmse_after < report.rmse_before / 5.0, "{} -> {}", report.rmse_before, report.rmse_after);
    assert!(report.causes[0].fragments.plant.is_empty(), "the plant is what it is");
    assert!((report.causes[0].fragments.observer["torque_scale"].as_f64().unwrap() - 120.0 / 123.6).abs() < 0.002);
}

#[test]
fn the_right_curve_gets_no_stiffness_error() {
    let data = common::sine_experiment(|_, _, _| 0.0);
    let report = identify(&data, &against(120.0)).unwrap();
    assert!(report.causes.is_empty(), "{:?}", report.causes);
}

#[test]
fn a_fitted_baseline_never_names_a_stiffness_error() {
    // A cubic the fitted line cannot follow: the line's slope moves with it, and a stiffness
    // error would be the same column as the baseline's own.
    let data = common::sine_experiment(|_, x, _| 400.0 * x.powi(3));
    let report = identify(&data, &IdentifyOptions::default()).unwrap();
    assert!(report.causes.iter().all(|c| c.effect != "stiffness_error"), "{:?}", report.causes);
    assert!(report.causes.iter().any(|c| c.effect == "stiffness_nonlinearity"), "{:?}", report.causes);
}
