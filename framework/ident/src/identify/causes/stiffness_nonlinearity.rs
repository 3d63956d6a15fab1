//! A stiffness that changes with deflection beyond the model: `+ k3 phi^3`.

use serde_json::json;

use super::{CandidateCause, InputSet, Fragments, Samples, object};
use jointctl_models::effect::Effect;

/// `+ k3 * phi_elastic^3` [Nm].
pub struct StiffnessNonlinearity;

impl CandidateCause for StiffnessNonlinearity {
    fn name(&self) -> &str {
        Effect::StiffnessNonlinearity.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::ELASTIC
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::StiffnessNonlinearity)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["k3_nm_per_rad3".into()]
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![s.elastic_rad.iter().map(|x| x.powi(3)).collect()]
    }
    fn fragments(&self, _: &[f64], c: &[f64]) -> Fragments {
        Fragments { plant: object([("cubic_nm_per_rad3", json!(c[0]))]), observer: object([("cubic_nm_per_rad3", json!(c[0]))]) }
    }
}
