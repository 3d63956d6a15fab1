//! Every named cause earns its place again given the others (the end of [`super::select`]).

use super::{Judgement, Selection, carried_nm, held_out_errors, untold_from_zero, verdict, without_and_impossible};
use super::super::design::Model;
use super::super::parallel::parallel_map;
use super::super::prepare::Prepared;
use super::super::uncertainty::Jacobian;

/// Every cause must still earn its place given the others: the weakest that is not named any
/// more leaves the model, one at a time, until each is (at the end of the selection, and again
/// when a cause joins after it). A cause's place is judged against the model without it and
/// without the causes that turn physically impossible when it leaves, and those leave with it:
/// blind seed 8's 052 (a 3.2 ms lag: a 64 Hz filter and a 0.7 ms delay, 20 Hz bins) named the
/// delay and a viscous friction, the delay left as redundant, and the viscous friction stayed at
/// -0.13 Nm s/rad, the delay's lag under another name.
pub(crate) fn prune(model: &Model, p: &Prepared, s: &mut Selection, name: &(dyn Fn(usize) -> String + Sync)) {
    while let Some(full) = held_out_errors(model, &s.spec, p) {
        // The models without one cause each (and what turns impossible then), fitted side by
        // side, with the verdict on each.
        let margins = parallel_map(&s.chosen, |ch| {
            let (reduced, dropped) = without_and_impossible(model, &s.spec, ch.cause, p);
            (held_out_errors(model, &reduced, p).map(|r| verdict(&r, &full, p)), reduced, dropped)
        });
        // A cause named on consistency alone is held to its coefficients on the training part
        // too, and so is one that asks for it whatever the evidence (an offset's drift, see
        // `CandidateCause::held_to_its_coefficients`); the model's derivatives computed once for all.
        let mut jacobian = None;
        let mut margins: Vec<_> = margins
            .into_iter()
            .zip(&s.chosen)
            .map(|((judgement, reduced, dropped), ch)| {
                // A cause proposed by BIC is held to the same relevance as when it was named:
                // what its own term carries counts where its gain is below the threshold.
                let judgement = judgement.map(|j| if j.negligible() && ch.against.is_none() { carried_nm(model, &s.spec, ch.cause, p).map_or(j, |term| j.carrying(term, p.noise_floor_nm)) } else { j });
                // And one searched beside a proposal that has left: its place on the training
                // part was the pair's (a negative loop and a damping proposed together beside a
                // delay on 20 Hz bins, the loop gone for want of evidence: the damping, 0.58 +-
                // 0.23 Nm s/rad joint with the delay, a change of the delay by c / k, stayed on
                // its held-out test alone; `delay_at_a_parts_edge`).
                let partner_left = ch.partner.is_some_and(|p| s.chosen.iter().all(|o| o.cause != p));
                let held = |j: &Judgement| !j.test.significant() || model.causes[ch.cause].held_to_its_coefficients() || partner_left;
                let untold = judgement.filter(|j| j.named() && held(j)).and_then(|_| {
                    let jacobian = jacobian.get_or_insert_with(|| Jacobian::new(model, &s.spec, &full.fit, &p.train));
                    untold_from_zero(model, &s.spec, &full, jacobian, ch.cause, p)
                });
                (judgement, reduced, dropped, untold)
            })
            .collect();
        // The weakest that is not named any more goes first (its gain in units of its
        // relevance threshold).
        let weakest = margins.iter().enumerate().filter(|(_, m)| !m.0.is_some_and(|j| j.named()) || m.3.is_some()).min_by(|a, b| {
            let score = |j: &Option<Judgement>| j.map_or(f64::NEG_INFINITY, |j| j.gain_nm2 / j.relevant_nm2.max(1e-300));
            score(&a.1.0).total_cmp(&score(&b.1.0))
        });
        match weakest.map(|(i, _)| i) {
            Some(i) => {
                let gone = s.chosen.remove(i);
                let (judgement, reduced, dropped, untold) = margins.swap_remove(i);
                match (judgement, untold) {
                    (Some(j), Some(why)) if j.test.significant() => {
                        let beside = gone.partner.map_or(String::new(), |p| format!("searched beside {}, which left the model; ", name(p)));
                        s.rejected.push(format!("{} ({beside}better on the held-out part, but on the training part {why}: {j})", name(gone.cause)))
                    }
                    (Some(j), Some(why)) => s.rejected.push(format!("{} (a large gain consistent over the held-out part, but no test passed, and on the training part {why}: {j})", name(gone.cause))),
                    (Some(j), None) if j.negligible() => s.negligible.push((gone.cause, format!("once the others were in the model: {j}"))),
                    (Some(j), None) => s.rejected.push(format!("{} (no evidence once the others were in the model: {j})", name(gone.cause))),
                    (None, _) => s.rejected.push(format!("{} (no fit without it)", name(gone.cause))),
                }
                for (cause, why) in dropped {
                    s.chosen.retain(|ch| ch.cause != cause);
                    s.rejected.push(format!("{} ({why} once {} left the model)", name(cause), name(gone.cause)));
                }
                s.spec = reduced;
            }
            None => break,
        }
    }
}
