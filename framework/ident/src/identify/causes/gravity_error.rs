//! A load that follows a joint's position as a link's weight does: `G cos(q - q_G)`, what a
//! gravity model leaves of the torque (a mass or a centre of mass off by a few per cent gives
//! exactly that form for a joint that moves alone; an arm joint's friction records are its
//! torque sensor less the vendor's gravity model, issue 36). Tried on records read as a joint's
//! friction only (the deflection column a joint position): beside a spring the same curvature
//! is the element's.
//!
//! Its columns are the load's curvature about the training part's mean position `q_m`, with the
//! value and the slope there taken out: `cos(q - q_m) - 1` and `sin(q - q_m) - (q - q_m)`. The
//! level and the slope are the offset's and the baseline's line (both in the vocabulary and asked
//! first): a cause that carried its own level took a plain offset's place on friction records
//! whose torque has an offset alone (blind seed 72's 065 and 066, the shared real-like
//! `l3-case036`, whose offset follows the position a little; `docs/benchmarks.md`, "What holds
//! the arm-joint records"). Over a stroke of `s` rad the columns span about `s^2 / 8` and
//! `s^3 / 48`: a stroke of a tenth of a radian leaves them nothing the noise does not hide.
//! Neither the observer nor the simulated plant has a term in a joint's position (their joints
//! are springs): it writes no fragment. Test: `tests/arm_joint_friction.rs`.

use super::{CandidateCause, InputSet, SearchContext, Samples};
use jointctl_models::effect::Effect;
use std::collections::BTreeMap;

/// `+ a (cos(q - q_m) - 1) + b (sin(q - q_m) - (q - q_m))` [Nm], `q_m` the training part's mean
/// position; reported as the load's amplitude `G = sqrt(a^2 + b^2)` and where it peaks,
/// `q_G - q_m = atan2(b, a)`.
pub struct GravityError;

impl CandidateCause for GravityError {
    fn name(&self) -> &str {
        Effect::GravityError.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::ELASTIC
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::GravityError)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["gravity_cos_nm".into(), "gravity_sin_nm".into()]
    }
    fn applicable(&self, c: &SearchContext) -> bool {
        c.no_spring
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![s.elastic_rad.iter().map(|e| e.cos() - 1.0).collect(), s.elastic_rad.iter().map(|e| e.sin() - e).collect()]
    }
    fn report(&self, _: &[f64], _: &[String], c: &[f64]) -> BTreeMap<String, f64> {
        let mut out: BTreeMap<String, f64> = self.coefficient_names().into_iter().zip(c.iter().copied()).collect();
        out.insert("gravity_amplitude_nm".into(), c[0].hypot(c[1]));
        out.insert("gravity_peak_from_mean_rad".into(), c[1].atan2(c[0]));
        out
    }
}

