//! One step of the unit hysteresis state: Dahl's model, and its generalisation with a shape
//! exponent (the Bouc-Wen form with `beta = 1`, `gamma = 0`), shared by `identify` (which fits
//! it) and the online evaluator (which runs what was fitted), so that both compute the same
//! state from the same readings.

/// The largest number of sub-steps one reading's step is integrated in (a bound on the control
/// cycle's work): up to `MAX_SUBSTEPS * SUBSTEP_IN_SCALES` scales; what a longer step moves
/// beyond that is taken in closed form near the limit (see [`loop_step`]).
const MAX_SUBSTEPS: usize = 64;

/// Sub-step length in deflection scales `lambda`: a tenth. Fourth-order Runge-Kutta at a tenth
/// of the scale is within about 1e-5 of the exact state (shape 2's closed forms; the sub-step
/// that crosses zero costs the most), a hundred-thousandth of the loop's limit. A control
/// cycle's step is far shorter than a tenth of the scale: one sub-step.
const SUBSTEP_IN_SCALES: f64 = 0.1;

/// The unit state `u` (limit 1) after a deflection step `step_rad` from `u`, for a loop of scale
/// `lambda_rad` (`F_c / sigma`) and shape exponent `shape` (>= 1):
/// `du/dphi = (1 - sgn(dphi) u |u|^(shape - 1)) / lambda`.
///
/// `shape = 1` is Dahl's model, solved exactly: `u <- s + (u - s) exp(-|dphi| / lambda)`,
/// `s = sgn(dphi)`. A larger shape keeps the slope near `sigma` longer on the way to the limit
/// and turns sharper at it (Bouc-Wen's exponent `n`; a loop of `n = 2.5` fitted with Dahl's
/// shape left 1.6 times a record's noise in a least-squares sketch). It is integrated by
/// fourth-order Runge-Kutta in sub-steps of a tenth of the scale, for at most 6.4 scales; beyond
/// them the state is within 0.3 % of its limit and approaches it as `1 - w` decays with
/// `exp(-shape xi)` (the equation linearised at the limit), taken in closed form.
///
/// ```
/// use jointctl_models::extension::loop_step;
/// // Dahl: one scale from zero reaches 1 - 1/e.
/// assert!((loop_step(0.0, 0.1, 0.1, 1.0) - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
/// // Shape 2 is tanh on the way up from zero: tanh(1).
/// assert!((loop_step(0.0, 0.1, 0.1, 2.0) - 1f64.tanh()).abs() < 1e-5);
/// // No step, no change; a long step reaches the limit, from either side.
/// assert_eq!(loop_step(0.3, 0.0, 0.1, 2.0), 0.3);
/// assert!((loop_step(-1.0, -50.0, 0.1, 3.0) + 1.0).abs() < 1e-9);
/// assert!((loop_step(-1.0, 10.0, 0.1, 3.0) - 1.0).abs() < 1e-9);
/// ```
pub fn loop_step(u: f64, step_rad: f64, lambda_rad: f64, shape: f64) -> f64 {
    if step_rad == 0.0 {
        return u;
    }
    let s = step_rad.signum();
    if shape == 1.0 {
        return s + (u - s) * (-step_rad.abs() / lambda_rad).exp();
    }
    // In the direction of motion: w = s u, dw/dxi = 1 - w |w|^(shape - 1), xi = |dphi| / lambda.
    let xi = step_rad.abs() / lambda_rad;
    let integrated = xi.min(MAX_SUBSTEPS as f64 * SUBSTEP_IN_SCALES);
    let substeps = ((integrated / SUBSTEP_IN_SCALES).ceil() as usize).clamp(1, MAX_SUBSTEPS);
    let h = integrated / substeps as f64;
    let f = |w: f64| 1.0 - odd_power(w, shape);
    let mut w = s * u;
    for _ in 0..substeps {
        let k1 = f(w);
        let k2 = f(w + 0.5 * h * k1);
        let k3 = f(w + 0.5 * h * k2);
        let k4 = f(w + h * k3);
        w = (w + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)).clamp(-1.0, 1.0);
    }
    let rest = xi - integrated;
    if rest > 0.0 {
        w = 1.0 - (1.0 - w) * (-shape * rest).exp();
    }
    s * w
}

/// The unit state's rate `du/dt` [1/s] at state `u` and deflection rate `rate_rad_per_s`, from
/// the loop's law `du/dphi = (1 - sgn(dphi) u |u|^(shape - 1)) / lambda` (see [`loop_step`]):
/// what a pre-sliding damping multiplies (LuGre's `sigma1 dz/dt`).
///
/// ```
/// use jointctl_models::extension::loop_rate;
/// // From the middle of the loop the state moves at rate / lambda; at its limit, not at all.
/// assert!((loop_rate(0.0, 0.2, 0.1, 1.0) - 2.0).abs() < 1e-12);
/// assert_eq!(loop_rate(1.0, 0.2, 0.1, 3.0), 0.0);
/// // Just after a turn it moves at twice that.
/// assert!((loop_rate(1.0, -0.2, 0.1, 1.0) + 4.0).abs() < 1e-12);
/// ```
pub fn loop_rate(u: f64, rate_rad_per_s: f64, lambda_rad: f64, shape: f64) -> f64 {
    if rate_rad_per_s == 0.0 {
        return 0.0;
    }
    (1.0 - rate_rad_per_s.signum() * odd_power(u, shape)) * rate_rad_per_s / lambda_rad
}

/// `w |w|^(shape - 1)`, by multiplication for the whole shapes identify searches (1-4): `powf`
/// here was about a tenth of identify's CPU time on the 100 000-sample benchmark record.
fn odd_power(w: f64, shape: f64) -> f64 {
    match shape {
        1.0 => w,
        2.0 => w * w.abs(),
        3.0 => w * w * w,
        4.0 => w * w * w * w.abs(),
        _ => w * w.abs().powf(shape - 1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::loop_step;

    /// Many small steps and one large step of the same length give the same state (the
    /// sub-steps integrate the same equation), for every shape, from either side of zero.
    #[test]
    fn the_state_does_not_depend_on_how_the_path_is_sampled() {
        for shape in [1.0, 1.5, 2.0, 3.0, 4.0] {
            for start in [-1.0, -0.4, 0.0, 0.7] {
                let whole = loop_step(start, 0.03, 0.01, shape);
                let mut u = start;
                for _ in 0..300 {
                    u = loop_step(u, 1e-4, 0.01, shape);
                }
                assert!((whole - u).abs() < 1e-5, "shape {shape}, from {start}: {whole} vs {u}");
            }
        }
    }

    /// A step far longer than the scale ends at the limit it moves towards, from any state and
    /// for every shape (with the sub-steps stretched to cover it, it ended at the opposite limit
    /// or part-way: from 0 by 100 scales at shape 3, -1).
    #[test]
    fn a_long_step_ends_at_the_limit_it_moves_towards() {
        for shape in [1.5, 2.0, 3.0, 4.0, 8.0] {
            for start in [-1.0, -0.5, 0.0, 0.9] {
                for scales in [7.0, 23.0, 45.0, 100.0, 1e4] {
                    let up = loop_step(start, scales * 0.01, 0.01, shape);
                    let down = loop_step(-start, -scales * 0.01, 0.01, shape);
                    assert!(up > 0.99 && down < -0.99, "shape {shape}, from {start}, {scales} scales: {up}, {down}");
                }
            }
            // Beyond the integrated part: the same as many small steps, within 1e-4.
            let whole = loop_step(-1.0, 0.1, 0.01, shape);
            let mut u = -1.0;
            for _ in 0..1000 {
                u = loop_step(u, 1e-4, 0.01, shape);
            }
            assert!((whole - u).abs() < 1e-4, "shape {shape}: {whole} vs {u}");
        }
    }

    /// The whole shapes stepped by multiplication give what `powf` gives: against the next
    /// representable shape (which takes `powf`), from states of either sign, both directions.
    #[test]
    fn whole_shapes_by_multiplication_agree_with_powf() {
        for shape in [2.0f64, 3.0, 4.0] {
            let beside = f64::from_bits(shape.to_bits() + 1);
            for u in [-1.0, -0.73, -0.2, 0.0, 0.31, 0.9, 1.0] {
                for step in [-0.05, -0.003, 1e-5, 0.002, 0.04] {
                    let (a, b) = (loop_step(u, step, 0.01, shape), loop_step(u, step, 0.01, beside));
                    assert!((a - b).abs() < 1e-12, "shape {shape}, u {u}, step {step}: {a} vs {b}");
                }
            }
        }
    }

    /// Shape 2 has closed forms: tanh on the way to the limit, tan from the other side of zero.
    #[test]
    fn shape_two_matches_its_closed_form() {
        let lambda = 0.02;
        let u = loop_step(0.2, 0.01, lambda, 2.0);
        assert!((u - (0.2f64.atanh() + 0.5).tanh()).abs() < 1e-6, "{u}");
        // From -0.5 upwards: w' = 1 + w^2 while w < 0, so w = tan(atan(-0.5) + xi).
        let xi = -(-0.5f64).atan() * 0.9;
        let u = loop_step(-0.5, xi * lambda, lambda, 2.0);
        assert!((u - ((-0.5f64).atan() + xi).tan()).abs() < 1e-6, "{u}");
    }
}
