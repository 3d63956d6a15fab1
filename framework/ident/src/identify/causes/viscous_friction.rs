//! Viscous friction in the element: `+ b dphi/dt`.

use serde_json::json;

use super::{CandidateCause, InputSet, Fragments, Samples, object};
use jointctl_models::effect::Effect;

/// `+ b * dphi/dt` [Nm], `b >= 0`.
pub struct ViscousFriction;

impl CandidateCause for ViscousFriction {
    fn name(&self) -> &str {
        Effect::ViscousFriction.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::VELOCITY
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::ViscousFriction)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["damping_nms_per_rad".into()]
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![s.velocity_rad_per_s.to_vec()]
    }
    fn baseline_can_absorb(&self) -> bool {
        // Eq. 3.5's arctan, bent into a line, takes the damping as its own.
        true
    }
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        (c[0] < 0.0).then(|| "negative viscous damping".into())
    }
    fn fragments(&self, _: &[f64], c: &[f64]) -> Fragments {
        Fragments { plant: object([("viscous_nms_per_rad", json!(c[0]))]), observer: object([("viscous_nms_per_rad", json!(c[0]))]) }
    }
}
