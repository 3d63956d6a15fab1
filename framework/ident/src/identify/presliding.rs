//! A lead named beside a loop read again as the loop's pre-sliding damping. LuGre's friction
//! (Canudas de Wit et al. 1995) damps its bristles while they deflect, `sigma1 dz/dt`, a torque
//! that acts just after each turn, where the loop's state moves fastest; a Dahl loop has none,
//! and a lead of the whole torque took its place: on eight records of the blind generator's LuGre
//! loops (seeds 6-9 and 56-59; `sigma1 / sigma0` 5-60 ms) a delay of -2 to -20 ms was named
//! beside the loop. The damping is looked for only there, as the lag only behind a delay
//! already named (`lag`). Searched with every loop (a nested choice on the decimated training
//! part, kept where the whole model erred less with it on the held-out part), it was taken by
//! loops without it too: over 2292 generated records it took the cause beside the hidden ones
//! away on 11 and put one there on 8 (4 of them the blind devices', where it took none away),
//! and two records lost their hidden viscous friction to it.

use jointctl_models::effect::Effect;

use super::causes::{PRESLIDING_DAMPING_AT, presliding_damping_parameter};
use super::design::{Model, Spec};
use super::numeric::refine_log;
use super::parallel::parallel_map;
use super::prepare::Prepared;
use super::select::{Selection, bic, held_out_errors, prune, rmse};

/// How far the loop's scale is looked for either side of the one chosen beside the lead, as a
/// factor (an assumption; on the seven blind records whose lead gave way the scale moved by
/// 0.99-1.15 times, the loop's sigma each time towards the generator's).
const SCALE_REACH: f64 = 3.0;

/// The selection's lead beside a named loop replaced by the loop's pre-sliding damping, where
/// the loop with the damping and without the lead fits the training part better (BIC, charged
/// for the time constants looked over as the lead was for its delays) and errs no more on the
/// held-out part; the causes are then judged again (`select::prune`). The lead goes among the
/// rejected with the figures that decided it.
pub(crate) fn instead_of_a_lead(model: &Model, selection: &mut Selection, p: &Prepared, name: &(dyn Fn(usize) -> String + Sync)) {
    let is = |effect: Effect| move |t: &&super::design::Term| !t.baseline && model.causes[t.cause].effect() == Some(effect);
    let (Some(lead), Some(loop_term)) = (selection.spec.terms.iter().find(is(Effect::TimeDelay)), selection.spec.terms.iter().find(is(Effect::Hysteresis))) else {
        return;
    };
    if !lead.params.first().is_some_and(|d| *d < 0.0) || loop_term.params.len() != PRESLIDING_DAMPING_AT {
        return;
    }
    let (lead_cause, loop_cause) = (lead.cause, loop_term.cause);
    let n = p.train.len();
    let score = |s: &Spec| model.fit(s, &p.train).map(|f| bic(f.rss, n, f.parameters));
    let scale_rad = loop_term.params[0];
    let damped = |tau_d: f64, scale_rad: f64| {
        let mut s = selection.spec.without(lead_cause);
        if let Some(t) = s.terms.iter_mut().find(|t| t.cause == loop_cause) {
            t.params[0] = scale_rad;
            t.params.push(tau_d);
            t.grids.push(presliding_damping_parameter());
        }
        s
    };
    // Each time constant with the loop's scale fitted again beside it (the scale the search
    // chose beside the lead is a steeper loop's: the lead's torque after a turn read as one).
    let rss = |tau_d: f64, scale_rad: f64| model.fit(&damped(tau_d, scale_rad), &p.train).map_or(f64::INFINITY, |f| f.rss);
    let grid = presliding_damping_parameter().grid;
    let tried = parallel_map(&grid[1..], |&tau_d| {
        let scale = refine_log(|l| rss(tau_d, l), scale_rad / SCALE_REACH, scale_rad * SCALE_REACH, 12);
        let scale = if rss(tau_d, scale) < rss(tau_d, scale_rad) { scale } else { scale_rad };
        score(&damped(tau_d, scale)).map(|b| (b, damped(tau_d, scale)))
    });
    let Some((damped_bic, spec)) = tried.into_iter().flatten().min_by(|a, b| a.0.total_cmp(&b.0)) else {
        return;
    };
    let Some(lead_bic) = score(&selection.spec) else {
        return;
    };
    let held = |s: &Spec| held_out_errors(model, s, p).map(|h| rmse(&h.errors));
    let (Some(lead_nm), Some(damped_nm)) = (held(&selection.spec), held(&spec)) else {
        return;
    };
    // The time constants looked over are charged as a search's grid is (2 ln of their number).
    let charged = damped_bic + 2.0 * ((grid.len() - 1) as f64).ln();
    if !(charged < lead_bic && damped_nm <= lead_nm) {
        return;
    }
    let tau_d = spec.term(loop_cause).and_then(|t| t.params.get(PRESLIDING_DAMPING_AT)).copied().unwrap_or(0.0);
    selection.chosen.retain(|c| c.cause != lead_cause);
    selection.rejected.push(format!(
        "{} (a lead beside the loop, read as the loop's pre-sliding damping of {:.0} ms instead: training BIC {:.0} with the lead, {:.0} with the damping, its time constants looked over charged; held-out RMSE {:.4} -> {:.4} Nm)",
        name(lead_cause),
        1e3 * tau_d,
        lead_bic,
        charged,
        lead_nm,
        damped_nm
    ));
    selection.spec = spec;
    prune(model, p, selection, name);
}
