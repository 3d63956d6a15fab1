//! What a fitted baseline's friction took on, reported with it and not as causes: a friction
//! record's Dahl pre-sliding, Stribeck dip and lag ([`NoSpring`]), and beside a spring a
//! Stribeck dip ([`FrictionDip`]). Which effects these are is `baseline::friction_parts`'.

use std::collections::BTreeMap;

use jointctl_models::effect::Effect;
use serde::Serialize;

use super::baseline::{BaselineModel, FRICTION_PARTS, NO_SPRING_SHARE, friction_parts, reads_as_friction};
use super::numeric::format_value;
use super::prepare::Prepared;
use super::Cause;

/// Beside a spring, a Stribeck dip of the fitted baseline's friction: a friction above its
/// Coulomb level at low speed that falls to it by the Stribeck speed, which eq. 3.5's arctan,
/// rising monotonically to its limit, cannot take. It is part of the friction, in the extended
/// model and not among the causes: what it corrects is the thesis' friction law, not an effect
/// of the element, and a dip left out leaves a structure at every reversal that hides the
/// element's own causes (the blind generator's Stribeck frictions: see `docs/benchmarks.md`).
/// It adds nothing to the observer's and the simulation's configuration: their friction is
/// eq. 3.5's.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FrictionDip {
    /// The dip's height and speed (the `stribeck_friction` candidate's parameters).
    pub params: BTreeMap<String, f64>,
    /// Their standard errors, as a cause's.
    pub uncertainty: BTreeMap<String, f64>,
    /// How much the held-out torque RMSE drops because of it [Nm].
    pub rmse_gain: f64,
    /// Why it was kept: the training BIC and the held-out judgement.
    pub evidence: String,
    /// One sentence for the report.
    pub note: String,
}

/// A record without a spring: what the baseline's friction took on for it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct NoSpring {
    /// The torque's variance share a line in the deflection explains, of the whole or beside
    /// the friction's sign and a line in the rate (< [`NO_SPRING_SHARE`]) [-].
    pub deflection_share: f64,
    /// The friction's Dahl pre-sliding, as the hysteresis cause reports it (in the extended
    /// model, not among the causes); empty when none was found.
    pub presliding: BTreeMap<String, f64>,
    /// The friction's Stribeck dip (the `stribeck_friction` candidate; beside a spring it is
    /// [`FrictionDip`]), in the extended model; empty when none was found.
    pub stribeck: BTreeMap<String, f64>,
    /// A lag between the torque and the position (the `time_delay` candidate), in the extended
    /// model, not among the causes: in a friction record the torque follows the motion through
    /// the friction's sign at each reversal, where the friction's own transition (a LuGre
    /// model's bristles, their damping) acts too, so the two are not told apart; empty when
    /// none was found.
    pub lag: BTreeMap<String, f64>,
    /// One sentence for the report.
    pub note: String,
}

/// A record without a spring (the first column a joint position): a Dahl loop is the
/// friction's pre-sliding (Dahl's model is a friction model), not an elastic element's
/// hysteresis: it stays in the extended model and is reported with the friction. So does a
/// time delay: the torque follows the motion through the friction's sign at the reversals,
/// where the friction's own transition acts, and the two cannot be told apart there.
///
/// Takes the parts out of `found` (the causes), `None` on a record with a spring.
pub(crate) fn no_spring(p: &Prepared, baseline: &BaselineModel, found: &mut Vec<Cause>) -> Option<NoSpring> {
    reads_as_friction(p.spring_share, baseline).then(|| {
        let mut take = |effect: Effect| found.iter().position(|c| c.effect == effect.name()).map(|i| found.remove(i).params);
        let [mut presliding, mut stribeck, lag] = FRICTION_PARTS.map(&mut take);
        // A Stribeck curve in the loop (`identify::presliding`) is the friction's dip, read
        // through the bristles' state instead of added on the rate; beside a dip added on the
        // rate it stays with the loop's parameters.
        let in_the_loop = presliding.as_mut().filter(|_| stribeck.is_none()).map(|loop_params| STRIBECK_KEYS.map(|k| loop_params.remove(k).map(|v| (k.to_string(), v)))).filter(|[a, b]| a.is_some() && b.is_some());
        let where_dip = if in_the_loop.is_some() { " (in the pre-sliding's state, as LuGre's bristles hold it)" } else { "" };
        if let Some(keys) = in_the_loop {
            stribeck = Some(keys.into_iter().flatten().collect());
        }
        let note = format!(
            "no spring: a line in the deflection explains {:.1} % of the torque's variance, of the whole or of what the friction's sign and a line in the rate leave (below {:.0} %), so the deflection column is read as a joint position and the torque as friction; {}{}{}",
            100.0 * p.spring_share,
            100.0 * NO_SPRING_SHARE,
            presliding.as_ref().map_or("no Dahl pre-sliding found".into(), |c| format!("the Dahl loop found is the friction's pre-sliding ({}), not hysteresis", listed(c))),
            stribeck.as_ref().map_or(String::new(), |c| format!("; its Stribeck dip{where_dip}: {}", listed(c))),
            lag.as_ref().map_or(String::new(), |c| format!("; a lag between torque and position ({}), not told apart from the friction's own transition after each reversal", listed(c))),
        );
        NoSpring { deflection_share: p.spring_share, presliding: presliding.unwrap_or_default(), stribeck: stribeck.unwrap_or_default(), lag: lag.unwrap_or_default(), note }
    })
}

/// Beside a spring, a Stribeck dip is the fitted baseline's friction's, not a cause: taken out
/// of `found` (the causes); `None` when none was found, on a friction record and against a
/// given characteristic.
pub(crate) fn friction_dip(p: &Prepared, baseline: &BaselineModel, found: &mut Vec<Cause>) -> Option<FrictionDip> {
    // On a friction record the dip is `NoSpring`'s, whichever is asked first.
    (!reads_as_friction(p.spring_share, baseline) && friction_parts(p.spring_share, baseline).contains(&Effect::StribeckFriction))
        .then(|| found.iter().position(|c| c.effect == Effect::StribeckFriction.name()))
        .flatten()
        .map(|i| {
            let dip = found.remove(i);
            let note = format!("the baseline's friction has a Stribeck dip ({}): above its Coulomb level at low speed, falling to it by the Stribeck speed, which eq. 3.5's arctan cannot take; it is in the extended model as part of the friction, not a cause, and not in the observer's or the simulation's configuration (their friction is eq. 3.5's)", listed(&dip.params));
            FrictionDip { params: dip.params, uncertainty: dip.uncertainty, rmse_gain: dip.rmse_gain, evidence: dip.evidence, note }
        })
}

/// The keys of a Stribeck dip, as the `stribeck_friction` candidate and a loop with the curve
/// in it report it.
const STRIBECK_KEYS: [&str; 2] = ["stribeck_nm", "stribeck_speed_rad_per_s"];

/// `name = value, ...` of a part's parameters, for its sentence.
fn listed(params: &BTreeMap<String, f64>) -> String {
    params.iter().map(|(k, v)| format!("{k} = {}", format_value(*v))).collect::<Vec<_>>().join(", ")
}
