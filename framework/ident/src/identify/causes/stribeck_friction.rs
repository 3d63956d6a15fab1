//! The Stribeck dip of a joint's friction: `+ s tanh(v / (v_s / 10)) exp(-(v / v_s)^2)`, the
//! friction above its Coulomb level at low speed that falls to it by the Stribeck speed `v_s`
//! (Armstrong-Helouvry et al. 1994). Tried where the baseline is fitted on the data: on friction
//! records (no spring: the deflection column a joint position) and beside a spring, where eq.
//! 3.5's arctan, which rises monotonically to its limit, has no dip. Either way it is reported
//! with the friction, not as a cause of its own (see `baseline::is_friction_part`).

use super::{CandidateCause, InputSet, Parameter, Refine, Samples, SearchContext, log_grid};
use jointctl_models::effect::Effect;

/// `+ s tanh(10 v / v_s) exp(-(v / v_s)^2)` [Nm], `s >= 0`.
pub struct StribeckFriction;

impl CandidateCause for StribeckFriction {
    fn name(&self) -> &str {
        Effect::StribeckFriction.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::VELOCITY
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::StribeckFriction)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["stribeck_nm".into()]
    }
    fn applicable(&self, c: &SearchContext) -> bool {
        // Against a given characteristic (a configured joint) the friction is the config's, and
        // a dip would be a cause of its own: not tried there.
        c.no_spring || c.baseline_fitted
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        // From a three-hundredth of the peak speed to a third of it (an assumption: beyond, the
        // dip spans the recorded speeds and is a slope of the friction, viscous friction's).
        let peak = c.peak_speed_rad_per_s().max(1e-9);
        vec![Parameter { name: "stribeck_speed_rad_per_s".into(), grid: log_grid(peak / 300.0, peak / 3.0, 11), refine: Refine::Between }]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        // The sign through a tanh a tenth of the Stribeck speed wide: a rate that flickers about
        // zero in a hold does not switch the full dip.
        vec![s.velocity_rad_per_s.iter().map(|v| (10.0 * v / p[0]).tanh() * (-(v / p[0]).powi(2)).exp()).collect()]
    }
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        (c[0] < 0.0).then(|| "a friction below its Coulomb level at low speed".into())
    }
    fn searched_within_bounds(&self) -> bool {
        // Upside down and as wide as the recorded rates, the dip is a friction that rises with
        // speed: a viscous friction's. Searched on its own beside a Stribeck friction with a
        // viscous friction, it took that width (blind seed 49's 063: 0.52 rad/s, -0.39 Nm, for
        // a dip of 0.95 Nm at 0.027 rad/s) and was rejected, and neither was named.
        true
    }
}
