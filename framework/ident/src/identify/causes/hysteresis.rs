//! Dahl hysteresis in the element: `+ F_c u(phi; lambda)` with `du/dphi = (1 - u sgn(dphi)) / lambda`.

use serde_json::json;

use super::{CandidateCause, Fragments, Parameter, Refine, Samples, SearchContext, log_grid, object};

/// `+ F_c * u`, `u` the unit Dahl state; deflection scale `lambda = F_c / sigma` [rad].
pub struct Hysteresis;

/// The unit Dahl response (limit 1) to a deflection history with scale `lambda`, exact per step.
///
/// ```
/// let u = jointctl_ident::identify::causes::dahl_unit(&[0.0, 1.0, 2.0], 0.1);
/// assert!(u[2] > 0.999);
/// ```
pub fn dahl_unit(d: &[f64], lambda: f64) -> Vec<f64> {
    let mut u = 0.0;
    let mut out = Vec::with_capacity(d.len());
    let mut prev = d.first().copied().unwrap_or(0.0);
    for &x in d {
        let step = x - prev;
        if step != 0.0 {
            let target = step.signum();
            u = target + (u - target) * (-step.abs() / lambda).exp();
        }
        out.push(u);
        prev = x;
    }
    out
}

impl CandidateCause for Hysteresis {
    fn name(&self) -> &str {
        "hysteresis"
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["limit_nm".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        // Deflection scales up to a third of the amplitude (an assumption: a loop that has not
        // reached its limit within a third of the stroke is, on a sine, a phase lag that viscous
        // friction explains as well; such a fit names the wrong cause).
        let a = c.excitation.amplitude_rad;
        vec![Parameter { name: "lambda_rad".into(), grid: log_grid(a * 1e-3, a / 3.0, 16), refine: Refine::Between }]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let mut history = s.history_rad.to_vec();
        history.extend_from_slice(s.deflection_rad);
        vec![dahl_unit(&history, p[0])[s.history_rad.len()..].to_vec()]
    }
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        (c[0] <= 0.0).then(|| "negative hysteresis width".into())
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        [("limit_nm".to_string(), c[0]), ("sigma_nm_per_rad".to_string(), c[0] / p[0])].into_iter().collect()
    }
    fn fragments(&self, p: &[f64], c: &[f64]) -> Fragments {
        let h = json!({"sigma_nm_per_rad": c[0] / p[0], "limit_nm": c[0]});
        Fragments { plant: object([("hysteresis", h.clone())]), observer: object([("hysteresis", h)]) }
    }
}
