//! Friction of eq. 3.5, `k_a atan(k_b dphi/dt)`: Coulomb-like friction smoothed through zero
//! velocity. In the baseline only when the configured model has it; otherwise a cause to name.

use serde_json::json;

use super::{CandidateCause, InputSet, Fragments, Parameter, Refine, Samples, SearchContext, log_grid, object};
use crate::identify::numeric::interval_mean;
use jointctl_models::effect::Effect;

/// `+ k_a atan(k_b dphi/dt)` [Nm], `k_a >= 0`.
pub struct CoulombFriction;

impl CandidateCause for CoulombFriction {
    fn name(&self) -> &str {
        Effect::CoulombFriction.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::VELOCITY
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::CoulombFriction)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["friction_ka_nm".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        // k_b from "the smoothing speed 1/k_b at the peak speed" to "a step at a three-hundredth
        // of it" (the peak speed from the data): beyond, the arctan is a sign function. Below, it
        // would not bend inside the recorded speeds: a straight line in the rate, a viscous
        // friction under another name (the baseline's arctan took a large viscous friction as
        // its own, and the cause that names it had nothing left to explain). At the bound the
        // arctan reaches half its limit at the peak speed.
        // An assumption of this project (eq. 3.5 gives the form, not a range for k_b).
        let peak = c.peak_speed_rad_per_s().max(1e-9);
        vec![Parameter { name: "friction_kb_s_per_rad".into(), grid: log_grid(1.0 / peak, 300.0 / peak, 11), refine: Refine::Between }]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let k = p[0];
        if s.rate_edges_rad_per_s.len() != s.velocity_rad_per_s.len() || !(k > 0.0 && k.is_finite()) {
            return vec![s.velocity_rad_per_s.iter().map(|v| (k * v).atan()).collect()];
        }
        // Read as bin averages: the arctan's mean over each interval, from its antiderivative
        // `v atan(k v) - ln(1 + k^2 v^2) / 2k`. The rate's profile runs through the sample's
        // rate, so its mean is off that rate by a quarter of its edges' sum. Shifted to keep
        // the mean, the bins' test records came out better (0.0229 against 0.0250 Nm held out)
        // but a point-sampled record with corners was read as bins (`tests/bin_averages.rs`,
        // k_b 496 s/rad for 60, its held-out error 0.1074 against 0.1091 as points): not taken.
        let integral = |v: f64| v * (k * v).atan() - (k * v).powi(2).ln_1p() / (2.0 * k);
        vec![s.velocity_rad_per_s.iter().zip(s.rate_edges_rad_per_s).map(|(v, e)| interval_mean(|x| (k * x).atan(), integral, *v, *e)).collect()]
    }
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        (c[0] < 0.0).then(|| "negative friction".into())
    }
    fn fragments(&self, p: &[f64], c: &[f64]) -> Fragments {
        Fragments {
            plant: object([("arctan_friction", json!({"k_a_nm": c[0], "k_b_s_per_rad": p[0]}))]),
            observer: object([("friction", json!({"ka_nm": c[0], "kb_s_per_rad": p[0]}))]),
        }
    }
}
