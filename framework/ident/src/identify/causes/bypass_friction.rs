//! Friction carried past the torque sensor, beside the element's own loop: a second loop that
//! runs the other way, `- F u(phi)`, `F >= 0`, `u` the unit Dahl state of its own scale. Where a
//! bearing lies beside the sensor (in parallel with it), it pre-slides with the sensor's small
//! deflection, which follows the element's torque, and the sensor reads the element's torque
//! less that bearing's friction: a loop of the other sign, narrower than the element's. The
//! hysteresis cause takes one loop of either sign; this one is the reading's second. Tried
//! beside a spring only: on a joint's friction record the torque is the friction itself.
//! Neither the observer nor the simulated plant has a term of its form: it writes no fragment.

use super::{CandidateCause, Hysteresis, InputSet, Parameter, Samples, SearchContext};
use jointctl_models::effect::Effect;

/// `- F u(phi; lambda)` [Nm], `F >= 0`.
pub struct BypassFriction;

impl CandidateCause for BypassFriction {
    fn name(&self) -> &str {
        Effect::BypassFriction.name()
    }
    fn reads(&self) -> InputSet {
        Hysteresis.reads()
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::BypassFriction)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["bypass_friction_nm".into()]
    }
    fn applicable(&self, c: &SearchContext) -> bool {
        !c.no_spring
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let mut scale = Hysteresis.parameters(c).swap_remove(0);
        scale.name = "bypass_lambda_rad".into();
        vec![scale]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let mut columns = Hysteresis.columns(&p[..1], s);
        columns.iter_mut().flatten().for_each(|x| *x = -*x);
        columns
    }
    /// Held to its coefficient: beside the element's loop, a second loop of the other sign
    /// can take up what the first one's shape misses (the blind generator's seed 72 `016`, a
    /// loop alone: a bypass of 0.029 +- 0.058 Nm named beside it on its held-out encompassing).
    fn held_to_its_coefficients(&self) -> bool {
        true
    }
    /// And as it joins: kept until the end, a bypass of 0.19 +- 0.07 Nm took the step of the
    /// ring on the rig generator's seed 3 `d4-full3` (`tests/ring_beside_a_held_cause.rs`).
    fn held_as_it_joins(&self) -> bool {
        true
    }
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        (c[0] <= 0.0).then(|| "a bypass that adds to the reading (the element's own loop)".into())
    }
    fn impossible_given(&self, p: &[f64], c: &[f64], excitation: &super::Excitation) -> Option<String> {
        self.impossible(p, c).or_else(|| Hysteresis.impossible_given(&p[..1], &[-c[0]], excitation))
    }
}
