//! A vibration seen by the torque sensor at one frequency: `g(v) (a sin(2 pi f t) + b cos(2 pi f t))`.
//! Steady (`g = 1`: a source that runs whatever the joint does: a pump, a fan, the rover's drive),
//! or running while the joint moves (`g = tanh(|v| / v_on)`: a motor's or a gear's vibration, on
//! as soon as the joint moves a little, at full amplitude beyond the onset speed `v_on`).
//! In a record of repetitions whose time restarted (logged apart, concatenated), the time
//! between them is not known, so neither is the phase at each one's start: the amplitude and
//! phase are fitted on each repetition apart (see [`CandidateCause::segments`]).

use super::{CandidateCause, InputSet, Excitation, Parameter, Refine, Samples, SearchContext, repetition_starts, rms_amplitude};
use jointctl_models::effect::Effect;

/// `+ g(v) (a sin(2 pi f t) + b cos(2 pi f t))` [Nm], `g = 1` (steady, `onset_speed_rad_per_s` 0)
/// or `tanh(|v| / onset_speed_rad_per_s)`.
pub struct Vibration;

/// Onset speeds searched, as shares of the peak speed (and 0: steady). From a fiftieth (on at
/// the first motion) to a half (beyond, `tanh` is a straight line in the speed over most of the
/// record: the `speed_vibration` cause's envelope). An assumption of this project: a vibration
/// that runs with motion was seen in an independent generator's records (amplitude 0.7-0.9 Nm
/// while the joint moved, 0.06-0.2 Nm in its holds, one phase throughout).
const ONSET_SHARES: (f64, f64, usize) = (0.02, 0.5, 8);

/// The envelope `g(v)` for an onset speed (0: steady).
fn envelope(onset_rad_per_s: f64, v: f64) -> f64 {
    if onset_rad_per_s > 0.0 { (v.abs() / onset_rad_per_s).tanh() } else { 1.0 }
}

impl CandidateCause for Vibration {
    fn name(&self) -> &str {
        Effect::Vibration.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::VELOCITY
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::Vibration)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["sin_nm".into(), "cos_nm".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let Some(f) = c.dominant_frequency_hz() else {
            // No mode in the band: nothing to search.
            return vec![Parameter { name: "frequency_hz".into(), grid: Vec::new(), refine: Refine::Not }];
        };
        let peak = c.peak_speed_rad_per_s();
        let (lo, hi, n) = ONSET_SHARES;
        let mut onsets = vec![0.0];
        if peak > 0.0 {
            onsets.extend(super::log_grid(lo * peak, hi * peak, n));
        }
        vec![
            Parameter { name: "frequency_hz".into(), grid: around(f, c), refine: Refine::Between },
            Parameter { name: "onset_speed_rad_per_s".into(), grid: onsets, refine: Refine::Between },
        ]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let w = std::f64::consts::TAU * p[0];
        let on = p.get(1).copied().unwrap_or(0.0);
        let column = |f: fn(f64) -> f64| s.t_s.iter().zip(s.velocity_rad_per_s).map(|(t, v)| envelope(on, *v) * f(w * t)).collect();
        vec![column(f64::sin), column(f64::cos)]
    }
    fn segments(&self, _: &[f64], s: &Samples) -> Option<Vec<usize>> {
        repetition_starts(s)
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        // One pair per repetition when they are fitted apart: the RMS amplitude.
        [("frequency_hz".to_string(), p[0]), ("onset_speed_rad_per_s".to_string(), p.get(1).copied().unwrap_or(0.0)), ("amplitude_nm".to_string(), rms_amplitude(c))].into_iter().collect()
    }
    fn remark(&self, p: &[f64], e: &Excitation, duration_s: f64) -> Option<String> {
        harmonic_remark(p[0], e, duration_s)
    }
    fn look_elsewhere(&self, c: &SearchContext) -> f64 {
        // The frequency is the best of M resolvable ones: 2 ln M on top of BIC's count.
        2.0 * c.frequencies_scanned().ln()
    }
}

/// Frequencies around the periodogram's peak `f` [Hz], half the full-rate stretch's resolution
/// apart, one resolution either side, refined between them on the training part. The peak
/// alone was off by a fifth of a resolution on records of repetitions whose time restarted (the
/// phase jumps at each restart smear it): over a 24 s repetition a 24.6 Hz vibration drifted
/// through a third of a cycle, and a ring after every reversal took the drift up.
fn around(frequency_hz: f64, c: &SearchContext) -> Vec<f64> {
    let t = c.full_rate.t_s;
    let duration_s = t.last().zip(t.first()).map_or(0.0, |(b, a)| b - a);
    if duration_s <= 0.0 {
        return vec![frequency_hz];
    }
    let step_hz = 0.5 / duration_s;
    (-2..=2).map(|k| frequency_hz + k as f64 * step_hz).filter(|x| *x > 0.0).collect()
}

/// A mode at a harmonic of the excitation (within the record's frequency resolution) cannot be
/// told from a periodic shape error of the model: say so.
pub(crate) fn harmonic_remark(f: f64, e: &Excitation, duration_s: f64) -> Option<String> {
    let harmonic = (f / e.frequency_hz).round();
    (harmonic >= 1.0 && (f - harmonic * e.frequency_hz).abs() < 1.0 / duration_s)
        .then(|| format!("at {harmonic:.0}x the excitation frequency: possibly a periodic model error rather than a structural mode"))
}
