//! Play in the element: no torque within `|phi| <= w`.

use serde_json::json;

use super::{CandidateCause, Fragments, Inputs, Parameter, Refine, Samples, SearchContext, log_grid, object};

/// The elastic model of `dz(phi, w) = sgn(phi) max(|phi| - w, 0)`.
pub struct DeadZone;

impl CandidateCause for DeadZone {
    fn name(&self) -> &str {
        "dead_zone"
    }
    fn coefficient_names(&self) -> Vec<String> {
        Vec::new()
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let a = c.excitation.amplitude_rad;
        vec![Parameter { name: "half_width_rad".into(), grid: log_grid(a * 2e-3, a * 0.5, 16), refine: Refine::Between }]
    }
    fn transforms(&self) -> bool {
        true
    }
    fn transform(&self, p: &[f64], inputs: &mut Inputs) {
        for x in &mut inputs.elastic_rad {
            *x = x.signum() * (x.abs() - p[0]).max(0.0);
        }
    }
    fn columns(&self, _: &[f64], _: &Samples) -> Vec<Vec<f64>> {
        Vec::new()
    }
    fn fragments(&self, p: &[f64], _: &[f64]) -> Fragments {
        Fragments { plant: object([("dead_zone_rad", json!(p[0]))]), observer: object([("dead_zone_rad", json!(p[0]))]) }
    }
}
