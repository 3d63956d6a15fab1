//! Causes held to their coefficients as they join the model (see `CandidateCause::held_as_it_joins`).

use super::super::design::{Model, Spec};
use super::super::prepare::Prepared;
use super::super::uncertainty::{Jacobian, untold_from_zero};
use super::held_out_errors;

/// The first of `causes` joining the model `spec` that asks to be held to its coefficients as it
/// joins (`CandidateCause::held_as_it_joins`) and is not told from zero on the training part,
/// with why: such a cause is held to them as it joins, not at the end alone, where it would have
/// taken the step another cause would have had (a bypass friction of 0.19 +- 0.07 Nm in the place
/// of a ring on the rig generator's seed 3 `d4-full3`, 0.163 -> 0.193 Nm held out; a bypass
/// joining with a delay as a pair on blind device 72 A at 20 Hz, both pruned at the end, the
/// element's loop polished beside them, 0.0183 -> 0.0187 Nm).
pub(super) fn held_untold_as_it_joins(model: &Model, spec: &Spec, causes: &[usize], p: &Prepared) -> Option<(usize, String)> {
    let held: Vec<usize> = causes.iter().copied().filter(|c| model.causes[*c].held_to_its_coefficients() && model.causes[*c].held_as_it_joins()).collect();
    if held.is_empty() {
        return None;
    }
    let full = held_out_errors(model, spec, p)?;
    let jacobian = Jacobian::new(model, spec, &full.fit, &p.train);
    held.into_iter().find_map(|c| untold_from_zero(model, spec, &full, &jacobian, c, p).map(|why| (c, why)))
}
