//! What `fit` refuses to write, with the reason: too few samples for the parameters, a
//! deflection or torque that does not move, a curve that does not rise over the data (issue 40,
//! findings 9 and 10). Nothing is written that the runtime would refuse to load.

use jointctl_models::characteristic::CurveSpec;

use super::FitRunError;

/// Samples a fit needs per parameter. Assumption: 5, so that the held-out fifth of the samples
/// that chooses the order still outnumbers the parameters.
pub const SAMPLES_PER_PARAMETER: usize = 5;
/// Samples a group needs at least. Assumption: 20; with fewer, the held-out fifth that chooses
/// the order holds fewer than 4 samples.
pub const MIN_SAMPLES: usize = 20;

/// Distinct deflection values a group needs (an assumption: with one value a "stiffness" is the
/// mean torque over that deflection, whatever the torque does; with two, a line through zero
/// cannot be told from an offset; issue 40 found a constant deflection fitted at 0.021 Nm/rad with
/// an RMSE of 6.8 Nm and passed on to a joint).
pub const MIN_DISTINCT_DEFLECTIONS: usize = 3;

pub(super) fn moving_deflection(group: &str, x: &[f64]) -> Result<(), FitRunError> {
    let mut sorted: Vec<f64> = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted.dedup();
    if sorted.len() < MIN_DISTINCT_DEFLECTIONS {
        let span_rad = sorted.last().zip(sorted.first()).map_or(0.0, |(a, b)| a - b);
        return Err(FitRunError::NoExcitation { group: group.into(), distinct: sorted.len(), span_rad });
    }
    Ok(())
}

/// `x` printed short (a 1e9 coefficient must not come back as ten digits and a fraction).
pub(super) fn short(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) { format!("{x:.4}") } else { format!("{x:.3e}") }
}

/// Refuses a torque that does not move (fewer than [`MIN_DISTINCT_DEFLECTIONS`] values: nothing
/// to fit a spring to), a linear stiffness that is not positive, and a curve whose torque does
/// not rise from the data's smallest deflection to its largest. A curve that dips locally (a
/// polynomial through a dead zone, section 3.3.2's way) is kept.
pub(super) fn rises(group: &str, curve: &CurveSpec, x: &[f64], y: &[f64]) -> Result<(), FitRunError> {
    let mut values: Vec<f64> = y.to_vec();
    values.sort_by(f64::total_cmp);
    values.dedup();
    if values.len() < MIN_DISTINCT_DEFLECTIONS {
        return Err(FitRunError::ConstantTorque { group: group.into(), distinct: values.len() });
    }
    let [lo, hi] = jointctl_models::characteristic::deflection_range(x);
    let torque = |at: f64| -> f64 {
        let poly = |c: &[f64]| c.iter().rev().fold(0.0, |acc, ck| (acc + ck) * at);
        match (&curve.coefficients, &curve.positive, &curve.negative) {
            (Some(c), _, _) => poly(c),
            (None, Some(p), Some(n)) => poly(if at >= 0.0 { p } else { n }),
            _ => f64::NAN,
        }
    };
    let rise = torque(hi) - torque(lo);
    if !(curve.stiffness_nm_per_rad > 0.0 && rise > 0.0) {
        return Err(FitRunError::NotIncreasing { group: group.into(), lo_rad: lo, hi_rad: hi, rise_nm: rise, stiffness_nm_per_rad: curve.stiffness_nm_per_rad });
    }
    // The check the runtime makes when it loads the file: nothing is written that it refuses.
    jointctl_models::characteristic::check_curve(curve).map_err(|e| FitRunError::Falls { group: group.into(), message: e.message })
}

pub(super) fn enough_samples(group: &str, samples: usize, parameters: usize) -> Result<(), FitRunError> {
    let needed = (SAMPLES_PER_PARAMETER * parameters).max(MIN_SAMPLES);
    if samples < needed {
        return Err(FitRunError::TooFewSamples { group: group.into(), samples, parameters, needed });
    }
    Ok(())
}

#[cfg(test)]
mod rising {
    use crate::fit::*;

    /// Issue 40, finding 10: a constant torque under a moving deflection was fitted at order 6
    /// (coefficients of -3.8e6 and 8.8e8, a stiffness of 1.8e-15 Nm/rad) and written, exit 0.
    #[test]
    fn a_curve_that_does_not_rise_is_refused() {
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..2000 {
            let t = i as f64 * 0.01;
            text += &format!("{t},{},1.5\n", 0.05 * (std::f64::consts::TAU * 0.5 * t).sin());
        }
        let data = crate::csv::parse(&text, "constant.csv".as_ref()).unwrap();
        let e = fit(&data, &FitOptions::default()).unwrap_err();
        assert!(matches!(e, FitRunError::ConstantTorque { distinct: 1, .. }), "{e}");
        // A torque that falls as the deflection grows: no spring either.
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..2000 {
            let t = i as f64 * 0.01;
            let x = 0.05 * (std::f64::consts::TAU * 0.5 * t).sin();
            text += &format!("{t},{x},{}\n", -80.0 * x + 0.01 * (i % 7) as f64);
        }
        let data = crate::csv::parse(&text, "falling.csv".as_ref()).unwrap();
        let e = fit(&data, &FitOptions::default()).unwrap_err();
        assert!(matches!(e, FitRunError::NotIncreasing { .. }), "{e}");
        assert!(e.to_string().contains("a spring's torque must rise with its deflection"), "{e}");
        // Rising from one end to the other but falling in between (around +-0.05 rad): fit
        // compared the ends only and wrote a curve that the runtime now refuses.
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..2000 {
            let t = i as f64 * 0.01;
            let x = 0.1 * (std::f64::consts::TAU * 0.5 * t).sin();
            text += &format!("{t},{x},{}\n", 100.0 * x - 25_000.0 * x.powi(3) + 2.0e6 * x.powi(5));
        }
        let data = crate::csv::parse(&text, "dipping.csv".as_ref()).unwrap();
        let e = fit(&data, &FitOptions { order: Order::Fixed(5), ..FitOptions::default() }).unwrap_err();
        assert!(matches!(e, FitRunError::Falls { .. }) && e.to_string().contains("does not rise with deflection"), "{e}");
        // A spring that softens but still rises is fitted.
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..2000 {
            let t = i as f64 * 0.01;
            let x = 0.1 * (std::f64::consts::TAU * 0.5 * t).sin();
            text += &format!("{t},{x},{}\n", 100.0 * x - 3000.0 * x.powi(3));
        }
        let data = crate::csv::parse(&text, "soft.csv".as_ref()).unwrap();
        assert!(fit(&data, &FitOptions::default()).is_ok());
    }
}

#[cfg(test)]
mod too_few_samples {
    use crate::fit::*;

    /// Finding: `fit` fitted a stiffness from 2 samples.
    #[test]
    fn fit_refuses_fewer_samples_than_its_parameters_need() {
        let data = crate::csv::parse("t,deflection,torque\n0,0.01,1.1\n0.01,0.02,2.3\n", "two.csv".as_ref()).unwrap();
        let e = fit(&data, &FitOptions { order: Order::Fixed(1), ..FitOptions::default() }).unwrap_err();
        assert!(matches!(e, FitRunError::TooFewSamples { samples: 2, needed: 20, .. }), "{e}");
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..40 {
            let phi = 0.1 * (i as f64 * 0.3).sin();
            text += &format!("{},{phi},{}\n", i as f64 * 0.01, 100.0 * phi + 50.0 * phi.powi(3));
        }
        let data = crate::csv::parse(&text, "forty.csv".as_ref()).unwrap();
        // Order 6 with branches: 6 parameters per branch, 30 samples each needed; about 20 each.
        let e = fit(&data, &FitOptions { order: Order::Fixed(6), branches: true, ..FitOptions::default() }).unwrap_err();
        assert!(matches!(e, FitRunError::TooFewSamples { parameters: 6, needed: 30, .. }), "{e}");
        assert!(fit(&data, &FitOptions { order: Order::Fixed(3), ..FitOptions::default() }).is_ok());
    }
}

#[cfg(test)]
mod deflection_that_does_not_move {
    use crate::fit::*;

    fn data(deflection: impl Fn(usize) -> f64) -> Data {
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..200 {
            text += &format!("{},{:e},{}\n", i as f64 * 0.01, deflection(i), 0.1 * (i % 7) as f64);
        }
        crate::csv::parse(&text, "x.csv".as_ref()).unwrap()
    }

    /// Issue 40, findings 9 and 10: a constant, non-zero deflection was fitted at 5.94 Nm/rad
    /// (RMSE 0.2 Nm, the torque's own spread) and a subnormal one gave an infinite stiffness;
    /// both exited 0 with a file a joint would load.
    #[test]
    fn a_constant_or_subnormal_deflection_is_refused_with_why() {
        let opts = FitOptions { smoothing_window: 1, order: Order::Fixed(1), branches: false, through_zero: true };
        let e = fit(&data(|_| 0.05), &opts).unwrap_err();
        assert!(matches!(e, FitRunError::NoExcitation { distinct: 1, .. }), "{e}");
        assert!(e.to_string().contains("the deflection takes 1 distinct value(s)"), "{e}");
        let e = fit(&data(|i| [1e-310, 2e-310, 3e-310][i % 3]), &opts).unwrap_err();
        assert!(matches!(e, FitRunError::NotFinite { .. }), "{e}");
        // Three values that move: a stiffness.
        assert!(fit(&data(|i| [0.01, 0.02, 0.03][i % 3]), &opts).is_ok());
    }
}
