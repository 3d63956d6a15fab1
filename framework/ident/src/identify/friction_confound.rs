//! Eq. 3.5's friction in the baseline against a viscous friction in its place. The arctan
//! `k_a atan(k_b dphi/dt)` saturates at `k_a pi/2` beyond a few times `1/k_b`; where the record's
//! rates stay below that, it is nearly a straight line in the rate, and a viscous friction
//! `b dphi/dt` is one. The baseline's arctan then takes a viscous friction as its own (its
//! held-out error sits at the noise floor, and `viscous_friction` adds nothing), and the data
//! cannot say which of the two the joint has: the report says so, by the same rule as for two
//! causes (see `docs/identify/significance.md`, "Confounds"). It proposes no experiment for
//! them: they part only where the arctan saturates, faster than the record went, and the
//! proposals stay within what the arm did.

use super::design::{Model, Spec, Term};
use super::prepare::Prepared;
use super::select::{CONFOUND_BIC, CONFOUND_SHARE, bic};

/// The arctan is "nearly straight" over the record when at the peak rate it still reaches this
/// share of its tangent's line at zero, `atan(x) / x` with `x = k_b` times the peak rate (an
/// assumption: 0.55 is `x = 2`, the arctan at 70 % of its limit; beyond, its bend shows within
/// the recorded rates and a line does not fit it).
pub const NEARLY_STRAIGHT: f64 = 0.55;

/// What was found: the training BICs of the model as it is, with a viscous friction in place of
/// the arctan, and with neither; the arctan's `k_b` [s/rad], the peak rate [rad/s] and the share
/// of its tangent the arctan reaches there.
pub(crate) struct FrictionConfound {
    pub friction: usize,
    pub viscous: usize,
    pub bic: [f64; 3],
    pub k_b_s_per_rad: f64,
    pub peak_rad_per_s: f64,
    pub share: f64,
}

/// The confound, when the baseline holds eq. 3.5's arctan nearly straight over the record, no
/// viscous friction is in `spec`, and a viscous friction in the arctan's place explains the
/// (decimated) training part about as well.
pub(crate) fn baseline_friction_confound(model: &Model, spec: &Spec, p: &Prepared) -> Option<FrictionConfound> {
    let position = |name: &str| model.causes.iter().position(|c| c.name() == name);
    let (friction, viscous) = (position("coulomb_friction")?, position("viscous_friction")?);
    if spec.term(viscous).is_some() {
        return None;
    }
    let at = spec.terms.iter().position(|t| t.baseline && t.cause == friction)?;
    let k_b_s_per_rad = *spec.terms[at].params.first()?;
    // The peak of the training part at its full rate (the fits below run on the decimated one,
    // as the confound rule's BICs do).
    let peak_rad_per_s = p.train.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let part = &p.coarse;
    let x = k_b_s_per_rad * peak_rad_per_s;
    let share = if x > 0.0 { x.atan() / x } else { 1.0 };
    if share < NEARLY_STRAIGHT {
        return None;
    }
    let score = |s: &Spec| model.fit(s, part).map(|f| (bic(f.rss, part.len(), f.parameters), f));
    let without = Spec { terms: spec.terms.iter().enumerate().filter(|(i, _)| *i != at).map(|(_, t)| t.clone()).collect() };
    let line = without.with(Term { cause: viscous, params: Vec::new(), grids: Vec::new(), baseline: false });
    let ((with, _), (before, _), (instead, fit)) = (score(spec)?, score(&without)?, score(&line)?);
    // A negative damping is no viscous friction.
    if model.causes[viscous].impossible(&[], fit.of(line.terms.len() - 1)).is_some() {
        return None;
    }
    let about_as_well = (with - instead).abs() < CONFOUND_BIC || before - instead >= CONFOUND_SHARE * (before - with);
    (about_as_well && before - with > 0.0).then_some(FrictionConfound { friction, viscous, bic: [with, instead, before], k_b_s_per_rad, peak_rad_per_s, share })
}
