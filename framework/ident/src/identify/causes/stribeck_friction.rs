//! The Stribeck dip of a joint's friction: `+ s tanh(v / (v_s / 10)) exp(-(v / v_s)^2)`, the
//! friction above its Coulomb level at low speed that falls to it by the Stribeck speed `v_s`
//! (Armstrong-Helouvry et al. 1994). Tried where the baseline is fitted on the data: on friction
//! records (no spring: the deflection column a joint position) and beside a spring, where eq.
//! 3.5's arctan, which rises monotonically to its limit, has no dip. Either way it is reported
//! with the friction, not as a cause of its own (see `baseline::is_friction_part`).

use super::{CandidateCause, InputSet, Parameter, Refine, Samples, SearchContext, log_grid};
use crate::identify::numeric::interval_mean;
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
    /// The dip's speed near its last value only: searched whole at every step, a dip at the
    /// top of its speeds, a slope of the friction, took part of a viscous friction (blind seed
    /// 2's `092`: the damping 67 -> 46 +- 44 Nm s/rad for 59, held out 0.207 -> 0.242 Nm) and
    /// left one named beside a loop (blind seed 1's device A at one drive amplitude).
    fn scale_searched_whole(&self) -> bool {
        false
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
        let v_s = p[0];
        let dip = |v: f64| (10.0 * v / v_s).tanh() * (-(v / v_s).powi(2)).exp();
        if s.rate_edges_rad_per_s.len() != s.velocity_rad_per_s.len() || !(v_s > 0.0 && v_s.is_finite()) {
            return vec![s.velocity_rad_per_s.iter().map(|v| dip(*v)).collect()];
        }
        // Read as bin averages: the dip's mean over each interval, as eq. 3.5's arctan is read
        // there (`coulomb_friction.rs`). At its bin's mean rate a dip narrower than the rates a
        // 20 Hz bin runs through at a reversal is another curve: blind seeds 48's and 53's 033
        // (a Stribeck friction at 0.006 rad/s in 20 Hz bins) fitted it upside down and said "no
        // cause" at 15 times the noise (on 53's the dip is still not found; on twelve blind 20
        // Hz records, 48's among them, its mean lowers the held-out error). The mean is taken of
        // `sgn(v) exp(-(v / v_s)^2) + tanh(10 v / v_s) - sgn(v)`, the dip with its tanh's
        // departure from the sign taken where the Gaussian is still 1 (it is above 0.98 within 0.13 v_s, where the two differ by more
        // than 13 %), whose antiderivative is `v_s sqrt(pi) / 2 erf(|v| / v_s) + v_s / 10 (ln(1
        // + exp(-20 |v| / v_s)) - ln 2)`: as smooth through zero as the dip, so that a rate that
        // flickers about zero in a hold does not switch the full dip on a bin either.
        let integral = |v: f64| dip_integral(v, v_s);
        vec![s.velocity_rad_per_s.iter().zip(s.rate_edges_rad_per_s).map(|(v, e)| interval_mean(dip, integral, *v, *e)).collect()]
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

/// An antiderivative of the dip's bin form (see [`StribeckFriction`]'s columns), zero at zero.
fn dip_integral(v: f64, v_s: f64) -> f64 {
    let x = v.abs() / v_s;
    0.5 * v_s * std::f64::consts::PI.sqrt() * libm::erf(x) + 0.1 * v_s * ((-20.0 * x).exp().ln_1p() - std::f64::consts::LN_2)
}

#[cfg(test)]
mod tests {
    use super::dip_integral;

    #[test]
    fn the_bin_forms_integrand_is_the_dip_through_zero_and_beyond() {
        // Its derivative against the dip `tanh(10 v / v_s) exp(-(v / v_s)^2)`: within 0.3 % of
        // the dip's peak everywhere, so a rate that flickers about zero gives the tanh's small
        // values, not the full dip (the sign's antiderivative alone gave 1 at 1e-5 rad/s).
        let v_s = 0.006;
        for k in -300..=300 {
            let v = k as f64 * v_s / 100.0;
            let h = 1e-7;
            let slope = (dip_integral(v + h, v_s) - dip_integral(v - h, v_s)) / (2.0 * h);
            let dip = (10.0 * v / v_s).tanh() * (-(v / v_s).powi(2)).exp();
            assert!((slope - dip).abs() < 3e-3, "v {v}: {slope} for {dip}");
        }
        let near_zero = (dip_integral(1e-5 + 1e-8, v_s) - dip_integral(1e-5, v_s)) / 1e-8;
        assert!(near_zero < 0.02, "{near_zero}");
    }
}
