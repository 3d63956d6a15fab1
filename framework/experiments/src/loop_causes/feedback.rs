//! The readings' feedback latency: the lag at which their rates explain the F/T torque's rate.

use super::search::search;
use super::{LoopRecording, MAX_LATENCY_S, at, rate, rms_where};

/// A feedback latency is fitted on samples whose readings moved one way this long before them
/// [s]. Measured on the shoulder's and the elbow's closed-loop sessions (readings 20 ms old,
/// encoders 15 ms): with every sample the shoulder's SPI latency came out 21.5-25 ms and the
/// elbow's CAN latency 22.5 ms, and a clean session's SPI latency was named (t = 4.6); with 0.1 s,
/// over seven sessions each, 20.5-23.5 ms and 21.5-22 ms, and t <= 3.0 on the clean sessions
/// (0.2 s did no better). Assumption: the hysteresis loop closes within that time at the
/// sessions' speeds.
const SETTLED_S: f64 = 0.1;

/// Per-sample squared residuals of `y ~ c0 + sum c_j x_j` fitted by least squares on the samples
/// `fit` selects (NaN where a value is unknown, everywhere when the fit is not determined).
///
/// By SVD with the minimum-norm solution, not identify's QR (`least_squares`, which refuses
/// dependent columns): a joint's readings are often dependent by construction (the shoulder's
/// deflection encoder reads a combination of its pulley encoders), and only the fit's residual
/// is wanted here, not its coefficients.
fn regression_residuals(y: &[f64], xs: &[Vec<f64>], fit: impl Fn(usize) -> bool) -> Vec<f64> {
    let usable = |i: usize| y[i].is_finite() && xs.iter().all(|x| x[i].is_finite());
    let rows: Vec<usize> = (0..y.len()).filter(|&i| fit(i) && usable(i)).collect();
    let cols = xs.len() + 1;
    if rows.len() <= cols {
        return vec![f64::NAN; y.len()];
    }
    let a = nalgebra::DMatrix::from_fn(rows.len(), cols, |r, c| if c == 0 { 1.0 } else { xs[c - 1][rows[r]] });
    let b = nalgebra::DVector::from_iterator(rows.len(), rows.iter().map(|&i| y[i]));
    let Ok(coef) = a.svd(true, true).solve(&b, 1e-12) else { return vec![f64::NAN; y.len()] };
    (0..y.len()).map(|i| if usable(i) { (y[i] - coef[0] - xs.iter().enumerate().map(|(j, x)| coef[j + 1] * x[i]).sum::<f64>()).powi(2) } else { f64::NAN }).collect()
}

/// The feedback latency of a group of readings: the `L` at which the readings' rates, taken `L`
/// later, explain the F/T torque's rate best on the training part (before `split_s`; 0.5 ms
/// resolution). Returns the per-sample squared residuals at a latency (the regression fitted on
/// the training part), for scoring; `None` when no latency gives a fit.
pub(super) fn feedback_latency(rec: &LoopRecording, group: &[&[f64]], split_s: f64) -> Option<(f64, impl Fn(f64) -> Vec<f64>)> {
    let t = rec.t_s.clone();
    let torque_rate = rate(&t, &rec.sensor_torque_nm);
    let group: Vec<Vec<f64>> = group.iter().map(|x| x.to_vec()).collect();
    // Only samples before which no reading reversed for `SETTLED_S`: a reversal starts the
    // element's hysteresis loop and friction, whose torque changes lead the deflection's, and a
    // regression on the rates alone takes that lead for a later reading. The mask comes from the
    // unshifted readings, so that every latency is scored on the same samples. A rate of zero (a
    // quantised reading at rest) is no direction. The window ends at the sample, although the
    // readings of its state come one latency later: extended by the latest latency searched, the
    // elbow's estimates came out right (20.5 ms for 20) but the shoulder's clean sessions' were
    // erratic (13-33.5 ms for 30, from the few samples left) and one got a command latency named.
    let rates: Vec<Vec<f64>> = group.iter().map(|x| rate(&t, x)).collect();
    let settled: Vec<bool> = (0..t.len())
        .map(|i| {
            let from = t.partition_point(|s| *s < t[i] - SETTLED_S);
            rates.iter().all(|r| one_way(&r[from..=i]))
        })
        .collect();
    let residuals = move |latency: f64| {
        // The reading at t + L is the device's state at t.
        let xs: Vec<Vec<f64>> = group.iter().map(|x| rate(&t, &t.iter().map(|&q| at(&t, x, q + latency)).collect::<Vec<_>>())).collect();
        let mut r = regression_residuals(&torque_rate, &xs, |i| t[i] < split_s && settled[i]);
        r.iter_mut().zip(&settled).filter(|(_, ok)| !**ok).for_each(|(r, _)| *r = f64::NAN);
        r
    };
    let score = |l: f64| rms_where(&residuals(l), |i| rec.t_s[i] < split_s);
    let best = search(0.0, MAX_LATENCY_S, 0.0005, score);
    score(best).is_finite().then_some((best, residuals))
}

/// Whether rates keep one direction: all known, and no two of opposite signs (zeros ignored).
fn one_way(rates: &[f64]) -> bool {
    rates.iter().all(|r| r.is_finite()) && !(rates.iter().any(|r| *r > 0.0) && rates.iter().any(|r| *r < 0.0))
}

#[cfg(test)]
mod tests {
    use super::one_way;

    #[test]
    fn a_reversal_breaks_one_way_and_a_rest_does_not() {
        assert!(one_way(&[0.1, 0.0, 0.2]) && one_way(&[-0.1, 0.0, -0.3]) && one_way(&[0.0, 0.0]));
        assert!(!one_way(&[0.1, 0.0, -0.2]), "a reversal across a rest");
        assert!(!one_way(&[0.1, f64::NAN]), "an unknown rate");
    }
}
