//! A steady vibration seen by the torque sensor: `a sin(2 pi f t) + b cos(2 pi f t)` (a source
//! that runs whatever the joint does: a pump, a fan, the rover's drive).

use super::{CandidateCause, Excitation, Parameter, Refine, Samples, SearchContext};
use crate::identify::spectrum;

/// `+ a sin(2 pi f t) + b cos(2 pi f t)` [Nm].
pub struct Vibration;

impl CandidateCause for Vibration {
    fn name(&self) -> &str {
        "vibration"
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["sin_nm".into(), "cos_nm".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let Some(f) = c.dominant_frequency_hz() else {
            // No mode in the band: nothing to search.
            return vec![Parameter { name: "frequency_hz".into(), grid: Vec::new(), refine: Refine::Not }];
        };
        vec![Parameter { name: "frequency_hz".into(), grid: vec![f], refine: Refine::Not }]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let w = std::f64::consts::TAU * p[0];
        vec![s.t_s.iter().map(|t| (w * t).sin()).collect(), s.t_s.iter().map(|t| (w * t).cos()).collect()]
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        [("frequency_hz".to_string(), p[0]), ("amplitude_nm".to_string(), c[0].hypot(c[1]))].into_iter().collect()
    }
    fn remark(&self, p: &[f64], e: &Excitation, duration_s: f64) -> Option<String> {
        harmonic_remark(p[0], e, duration_s)
    }
    fn look_elsewhere(&self, c: &SearchContext) -> f64 {
        // The frequency is the best of M resolvable ones: 2 ln M on top of BIC's count.
        2.0 * spectrum::resolvable(c.full_rate.t_s, c.excitation.frequency_hz).ln()
    }
}

/// A mode at a harmonic of the excitation (within the record's frequency resolution) cannot be
/// told from a periodic shape error of the model: say so.
pub(crate) fn harmonic_remark(f: f64, e: &Excitation, duration_s: f64) -> Option<String> {
    let harmonic = (f / e.frequency_hz).round();
    (harmonic >= 1.0 && (f - harmonic * e.frequency_hz).abs() < 1.0 / duration_s)
        .then(|| format!("at {harmonic:.0}x the excitation frequency: possibly a periodic model error rather than a structural mode"))
}
