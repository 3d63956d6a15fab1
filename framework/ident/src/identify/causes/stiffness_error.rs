//! A configured characteristic that is off by a factor: `+ s tau_model(phi)`, the "inaccurately
//! fitted curve" the thesis blames for part of its offsets (sections 5.1, 5.2). Only against a
//! given characteristic (a joint from a config): a characteristic fitted on the data already
//! has its stiffness free.

use serde_json::json;

use super::{CandidateCause, InputSet, Fragments, Samples, SearchContext, object};
use jointctl_models::effect::Effect;

/// `+ s * tau_model(phi_elastic)` [Nm], `s` the relative error of the configured curve.
pub struct StiffnessError;

impl CandidateCause for StiffnessError {
    fn name(&self) -> &str {
        Effect::StiffnessError.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::ELASTIC
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::StiffnessError)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["relative_error".into()]
    }
    fn applicable(&self, context: &SearchContext) -> bool {
        !context.baseline_fitted
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![s.model_nm.to_vec()]
    }
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        // The curve would have to change sign: not an error of fit but a wrong curve.
        (c[0] <= -1.0).then(|| format!("a relative error of {:.2} turns the characteristic over", c[0]))
    }
    fn fragments(&self, _: &[f64], c: &[f64]) -> Fragments {
        // The plant is what it is; the observer's curve is what the data shows off.
        Fragments { plant: Default::default(), observer: object([("torque_scale", json!(1.0 + c[0]))]) }
    }
}
