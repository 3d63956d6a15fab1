//! An offset of the torque sensor: `+ c`, and its drift: `+ r t`.

use serde_json::json;

use super::{CandidateCause, Fragments, Samples, object};
use crate::identify::Cause;
use jointctl_models::effect::Effect;

/// `+ c` [Nm].
pub struct SensorOffset;

impl CandidateCause for SensorOffset {
    fn name(&self) -> &str {
        Effect::SensorOffset.name()
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::SensorOffset)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["offset_nm".into()]
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![vec![1.0; s.t_s.len()]]
    }
    fn fragments(&self, _: &[f64], c: &[f64]) -> Fragments {
        Fragments { plant: object([("torque_offset_nm", json!(c[0]))]), observer: object([("torque_offset_nm", json!(c[0]))]) }
    }
}

/// The sensor offset's drift: `+ r (t - t_m)` [Nm], `t_m` the middle of the record's time [s]
/// (a torque sensor warming up, or zeroed between repetitions of a test). A candidate of its
/// own, so that the held-out part decides it apart from the offset: a drift fitted on the
/// training part carries on into the held-out part, which an offset that steps between
/// repetitions does not (0.71, 1.00, 0.58 Nm: the line through the first two missed the third
/// by 0.6 Nm, and the offset with it was refused). Reported as part of `sensor_offset`
/// ([`fold_drift_into_offset`]). Held to its coefficient on the training part: a line in time
/// takes up any slow misfit of the other causes. Neither the observer nor the simulated plant
/// has a term in time, so it writes no fragment.
pub struct SensorOffsetDrift;

/// The internal name of [`SensorOffsetDrift`] (in the rejected and negligible lists).
pub const DRIFT_NAME: &str = "sensor_offset_drift";

impl CandidateCause for SensorOffsetDrift {
    fn name(&self) -> &str {
        DRIFT_NAME
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["drift_nm_per_s".into()]
    }
    fn columns(&self, _: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        vec![s.t_s.iter().map(|t| t - s.record_middle_s).collect()]
    }
    fn held_to_its_coefficients(&self) -> bool {
        true
    }
}

/// The drift, when named, reported as part of the sensor offset: its rate and standard error
/// join the offset's parameters, and the pair's held-out gain is `gain_of_both` (the model
/// without either against the extended one). A drift named without an offset is an offset
/// that is zero at the middle of the record's time.
///
/// ```
/// use jointctl_ident::identify::Cause;
/// use jointctl_ident::identify::causes::fold_drift_into_offset;
/// let cause = |effect: &str, key: &str, value: f64| Cause { effect: effect.into(), params: [(key.into(), value)].into(), rmse_gain: 0.1, uncertainty: Default::default(), evidence: "t = 5".into(), fragments: Default::default() };
/// let mut found = vec![cause("sensor_offset", "offset_nm", 0.5), cause("sensor_offset_drift", "drift_nm_per_s", 0.01)];
/// fold_drift_into_offset(&mut found, || Some(0.3));
/// assert_eq!(found.len(), 1);
/// assert_eq!(found[0].params["drift_nm_per_s"], 0.01);
/// assert_eq!(found[0].rmse_gain, 0.3);
/// ```
pub fn fold_drift_into_offset(found: &mut Vec<Cause>, gain_of_both: impl FnOnce() -> Option<f64>) {
    let Some(at) = found.iter().position(|c| c.effect == DRIFT_NAME) else { return };
    let mut drift = found.remove(at);
    let note = "neither the observer nor the simulated plant has a term in time: the drift is not written to them";
    match found.iter_mut().find(|c| c.effect == Effect::SensorOffset.name()) {
        Some(offset) => {
            offset.params.append(&mut drift.params);
            offset.uncertainty.append(&mut drift.uncertainty);
            offset.evidence = format!("{}; its drift: {}; offset_nm is the record's mean offset (at the middle of its time), and {note}", offset.evidence, drift.evidence);
            offset.rmse_gain = gain_of_both().unwrap_or(offset.rmse_gain + drift.rmse_gain);
        }
        None => {
            drift.effect = Effect::SensorOffset.name().into();
            drift.evidence = format!("an offset that drifts through zero at the middle of the record's time: {}; {note}", drift.evidence);
            found.push(drift);
        }
    }
}
