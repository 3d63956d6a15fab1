//! An offset of the torque sensor: `+ c`.

use serde_json::json;

use super::{CandidateCause, Fragments, Samples, object};
use jointctl_models::effect::Effect;

/// `+ c` [Nm].
pub struct SensorOffset;

impl CandidateCause for SensorOffset {
    fn name(&self) -> &str {
        Effect::SensorOffset.name()
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::SensorOffset)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["offset_nm".into()]
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![vec![1.0; s.t_s.len()]]
    }
    fn fragments(&self, _: &[f64], c: &[f64]) -> Fragments {
        Fragments { plant: object([("torque_offset_nm", json!(c[0]))]), observer: object([("torque_offset_nm", json!(c[0]))]) }
    }
}
