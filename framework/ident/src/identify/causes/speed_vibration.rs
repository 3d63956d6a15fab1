//! A vibration whose amplitude grows with speed: `|dphi/dt| (a sin(2 pi f t) + b cos(2 pi f t))`
//! (gear meshing, a rubbing cable: the faster the joint moves, the harder it shakes). Its phase
//! is fitted on each repetition apart, as the steady vibration's (see [`super::Vibration`]).

use super::{CandidateCause, InputSet, Excitation, Parameter, Refine, Samples, SearchContext, repetition_starts, rms_amplitude};
use crate::identify::spectrum;
use jointctl_models::effect::Effect;

/// `+ |dphi/dt| (a sin(2 pi f t) + b cos(2 pi f t))` [Nm].
pub struct SpeedVibration;

impl CandidateCause for SpeedVibration {
    fn name(&self) -> &str {
        Effect::SpeedVibration.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::VELOCITY
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::SpeedVibration)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["sin_nms_per_rad".into(), "cos_nms_per_rad".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        // The matched filter for an amplitude that follows the speed: the residual weighted by it.
        // On the full-rate stretch: the mode may lie above the decimated part's Nyquist frequency.
        let f = c.full_rate;
        let weighted: Vec<f64> = f.residual_nm.iter().zip(f.velocity_rad_per_s).map(|(r, v)| r * v.abs()).collect();
        let Some(f) = spectrum::dominant_frequency(f.t_s, &weighted, c.excitation.frequency_hz) else {
            // No mode in the band: nothing to search.
            return vec![Parameter { name: "frequency_hz".into(), grid: Vec::new(), refine: Refine::Not }];
        };
        vec![Parameter { name: "frequency_hz".into(), grid: vec![f], refine: Refine::Not }]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let w = std::f64::consts::TAU * p[0];
        let speed = s.velocity_rad_per_s;
        vec![
            s.t_s.iter().zip(speed).map(|(t, v)| v.abs() * (w * t).sin()).collect(),
            s.t_s.iter().zip(speed).map(|(t, v)| v.abs() * (w * t).cos()).collect(),
        ]
    }
    fn segments(&self, _: &[f64], s: &Samples) -> Option<Vec<usize>> {
        repetition_starts(s)
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        [("frequency_hz".to_string(), p[0]), ("amplitude_nms_per_rad".to_string(), rms_amplitude(c))].into_iter().collect()
    }
    fn remark(&self, p: &[f64], e: &Excitation, duration_s: f64) -> Option<String> {
        super::vibration::harmonic_remark(p[0], e, duration_s)
    }
    fn look_elsewhere(&self, c: &SearchContext) -> f64 {
        2.0 * spectrum::resolvable(c.full_rate.t_s, c.excitation.frequency_hz).ln()
    }
}
