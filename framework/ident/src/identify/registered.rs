//! What a registered cause must be for identify to take it (see `IdentifyOptions::extra_candidates`).

use super::baseline::reads_as_friction;
use super::{RestSamples, BaselineModel, CandidateCause, FullRate, Samples, SearchContext, prepare};

/// A registered cause must not reuse a name and must give one column per coefficient, one value
/// per sample: checked once, up front, so that a mistake is an error rather than a cause that
/// silently contributes nothing.
pub(super) fn check(builtin: &[Box<dyn CandidateCause>], registered: &[Box<dyn CandidateCause>], p: &prepare::Prepared, baseline: &BaselineModel) -> Result<(), super::IdentifyError> {
    let baseline_fitted = matches!(baseline, BaselineModel::Polynomial(_));
    let taken: Vec<&str> = builtin.iter().map(|c| c.name()).chain(["dropout"]).collect();
    let part = &p.coarse;
    for (i, c) in registered.iter().enumerate() {
        let name = c.name();
        if taken.contains(&name) || registered[..i].iter().any(|o| o.name() == name) {
            return Err(super::IdentifyError::CauseNameTaken { name: name.into() });
        }
        if let Some(effect) = c.effect() {
            return Err(super::IdentifyError::CauseClaimsEffect { name: name.into(), effect });
        }
        let full_rate = FullRate { t_s: &p.stretch.t, velocity_rad_per_s: &p.stretch.v, residual_nm: &p.stretch.tau };
        let ctx = SearchContext::new(p.excitation, &part.t, &part.v, &part.tau, full_rate, RestSamples { t_s: p.at_rest.as_ref().map_or(&[][..], |r| &r.t), residual_nm: p.at_rest.as_ref().map_or(&[][..], |r| &r.tau) }, baseline_fitted, reads_as_friction(p.spring_share, baseline));
        let values: Vec<f64> = c.parameters(&ctx).iter().map(|p| p.grid.first().copied().unwrap_or(0.0)).collect();
        let model_nm = vec![0.0; part.len()];
        let samples = Samples { t_s: &part.t, deflection_rad: &part.d, velocity_rad_per_s: &part.v, elastic_rad: &part.d, pivot_mm: &part.pivot, repetition: &part.rep, history_rad: &part.warm, restarts: &part.restarts, model_nm: &model_nm, rate_edges_rad_per_s: &part.rate_edges, bin_width_s: part.bin_width_s, record_middle_s: p.record_middle_s };
        let columns = c.columns(&values, &samples);
        let expected = c.coefficient_names().len();
        if columns.len() != expected || columns.iter().any(|col| col.len() != part.len()) {
            let lengths: Vec<usize> = columns.iter().map(Vec::len).collect();
            return Err(super::IdentifyError::CauseColumns { name: name.into(), lengths, expected_columns: expected, samples: part.len() });
        }
    }
    Ok(())
}
