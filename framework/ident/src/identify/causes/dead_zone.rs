//! Play in the element: no torque within `|phi| <= w`, the contact stiffening over a band
//! around `w` (see [`jointctl_models::play`]).

use serde_json::json;

use jointctl_models::play::elastic_deflection;

use super::{CandidateCause, InputSet, Fragments, Inputs, Parameter, Refine, Samples, SearchContext, log_grid, object};
use jointctl_models::effect::Effect;

/// The elastic model of `dz(phi, w, r)`: `sgn(phi) max(|phi| - w, 0)` beyond `w + r`, nothing
/// within `w - r`, the quadratic blend between ([`jointctl_models::play::elastic_deflection`]).
/// The ramp is searched as a share of the half width, from 0 (ideal play) to 1 (a contact that
/// stiffens from zero deflection on).
///
/// Why a ramp: real play is taken up through a contact that stiffens (gear flanks, a coupling's
/// elastomer). An ideal dead zone fitted to such an element leaves a residual around `|phi| = w`
/// that other causes then take up: on a record of a ramped play (a contact band of 85 % of
/// the half width) an ideal dead zone was named with a 71 ms lead of the torque, which the
/// ramped one explains without.
pub struct DeadZone;

/// The ramp shares searched (a share of the half width): 0 is the ideal dead zone.
const RAMP_SHARES: [f64; 6] = [0.0, 0.15, 0.3, 0.5, 0.75, 1.0];

/// The contact band [rad] of parameters `[half_width_rad, ramp_share]`.
fn ramp_rad(p: &[f64]) -> f64 {
    p[0] * p.get(1).copied().unwrap_or(0.0)
}

impl CandidateCause for DeadZone {
    fn name(&self) -> &str {
        Effect::DeadZone.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::ELASTIC
    }
    fn writes(&self) -> InputSet {
        InputSet::ELASTIC
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::DeadZone)
    }
    fn coefficient_names(&self) -> Vec<String> {
        Vec::new()
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let a = c.excitation.amplitude_rad;
        vec![
            Parameter { name: "half_width_rad".into(), grid: log_grid(a * 2e-3, a * 0.5, 16), refine: Refine::Between },
            Parameter { name: "ramp_share".into(), grid: RAMP_SHARES.to_vec(), refine: Refine::Between },
        ]
    }
    fn transforms(&self) -> bool {
        true
    }
    fn transform(&self, p: &[f64], inputs: &mut Inputs) {
        let ramp_rad = ramp_rad(p);
        for x in &mut inputs.elastic_rad {
            *x = elastic_deflection(*x, p[0], ramp_rad);
        }
    }
    fn columns(&self, _: &[f64], _: &Samples) -> Vec<Vec<f64>> {
        Vec::new()
    }
    fn fragments(&self, p: &[f64], _: &[f64]) -> Fragments {
        let keys = || object([("dead_zone_rad", json!(p[0])), ("dead_zone_ramp_rad", json!(ramp_rad(p)))]);
        Fragments { plant: keys(), observer: keys() }
    }
}
