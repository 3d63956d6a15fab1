//! A delay between the channels: the torque channel sees the deflection `d` seconds late
//! (`d > 0`) or early (`d < 0`, the encoder side lags). A late torque may be partly a
//! first-order lag (a sensor's filter, behind a bus's transport delay): a share of `d` is then
//! the lag's time constant and the rest the transport delay, so that `d` stays the delay at low
//! frequency. A pure delay stands for a lag of time constant `tau` only well below `1 / tau`:
//! at `omega` it reads `atan(omega tau) / omega`, and one device's tests at different speeds
//! read different delays (the blind generator's device D: a transport delay and a low-pass,
//! read 1-25 ms short, its variants apart by more than their errors on 66 of 120 pairs).

use super::{CandidateCause, Inputs, Parameter, Refine, Samples, SearchContext};
use jointctl_models::effect::Effect;

/// Sample periods above which a delay is refined in fractions of a sample [s] (an assumption:
/// 20 Hz bins carry a sensor filter's delay of 15 ms, a third of a sample, and must resolve it;
/// at 200 Hz, sub-sample delays of 2 ms were named on clean records of the project's generator,
/// where no delay is hidden, so at and below this period a delay is refined in whole samples).
pub(crate) const SUB_SAMPLE_DELAYS_ABOVE_S: f64 = 0.01;

/// The step a whole-sample parameter (a delay) is refined in [s]: the full-rate sample period,
/// or, on records sampled slower than [`SUB_SAMPLE_DELAYS_ABOVE_S`], a fiftieth of it but at
/// least a millisecond (the delay's transform interpolates between samples; the refinement's
/// search halves its stride, so a finer step costs a few fits more). A tenth (5 ms at 20 Hz)
/// left a 3 ms delay at 0 or 5 ms and a viscous friction to make up the difference (blind seeds
/// 4, 6 and 8; `slow_log::a_delay_of_a_fraction_of_a_20_hz_sample_is_refined_finer_than_a_tenth_of_it`).
pub(crate) fn delay_unit(full_rate_dt: f64) -> f64 {
    if full_rate_dt <= SUB_SAMPLE_DELAYS_ABOVE_S { full_rate_dt } else { (0.02 * full_rate_dt).max(1e-3) }
}

/// The step in which delays count as told apart [s]: the full-rate sample period, or on records
/// sampled slower than [`SUB_SAMPLE_DELAYS_ABOVE_S`] a tenth of it but at least a millisecond
/// (an assumption, as before the finer [`delay_unit`]). The look-elsewhere charge counts the
/// delays in these steps, and the refinement reaches as far in them as before: a finer step of
/// refinement neither adds to how many delays the data can tell apart nor shortens the reach.
pub(crate) fn delay_resolution(full_rate_dt: f64) -> f64 {
    if full_rate_dt <= SUB_SAMPLE_DELAYS_ABOVE_S { full_rate_dt } else { (0.1 * full_rate_dt).max(1e-3) }
}

/// How many [`delay_unit`]s make `steps` of [`delay_resolution`] (the refinement's reach).
pub(crate) fn delay_units_in(steps: i64, full_rate_dt: f64) -> i64 {
    (steps as f64 * delay_resolution(full_rate_dt) / delay_unit(full_rate_dt)).round().max(1.0) as i64
}

/// The model of `phi(t - d)`: the inputs interpolated at the shifted time stamps (irregular
/// logs too); `d` is refined in whole full-rate sample periods, or milliseconds when the samples
/// are further apart.
pub struct TimeDelay;

/// `x` at the times `t - delay`, interpolated between the samples around each: cubic Hermite
/// with the rates `dx` at the two samples when they are given, linear otherwise; held at the
/// first value before the record and never interpolated across a gap of more than `max_step`
/// (the value on the sample's own side of the gap is taken, extrapolated along its rate when the
/// rates are given). A part's inputs begin with its history (`part::Lead`), so the first value
/// is held only at the record's own start. Extrapolated there along the rate instead, 3 of 1946
/// generated reports moved, none by 1 %, and four of this project's own delay tests read their
/// delays a millisecond late or named a cause beside it (not understood; not taken).
///
/// A fraction of a sample on a slow log (20 Hz bins) is where it matters: a line between samples
/// 50 ms apart misses a 1 Hz sine by a percent of its amplitude, an error of the delay's own
/// size (a 13 ms delay on a 33 Nm/rad spring); Hermite's cubic through the samples and their rates
/// misses it by 0.01 %.
fn delayed(t: &[f64], x: &[f64], dx: Option<&[f64]>, delay: f64, max_step: f64) -> Vec<f64> {
    let n = t.len();
    let mut out = Vec::with_capacity(n);
    // The sample at or before the shifted time moves forward monotonically with it.
    let mut j = 0usize;
    for &ti in t {
        let at = ti - delay;
        while j + 1 < n && t[j + 1] <= at {
            j += 1;
        }
        let value = if at <= t[0] {
            x[0]
        } else if j + 1 >= n {
            x[n - 1]
        } else {
            let step = t[j + 1] - t[j];
            let s = (at - t[j]) / step;
            if step > max_step {
                // Across a gap (a logging gap, the held-out window, a join of the searches'
                // pieces) each sample keeps to its own side: extrapolated from the sample at its
                // side's edge along its rate (held without one), over at most the delay. Taking
                // the value after the gap for every sample gave a negative delay's last samples
                // of each piece the next piece's first deflection, seconds away, and with the
                // searches in pieces such delays went unnamed; held at the edge, they came out
                // at two thirds of the truth.
                let k = if ti <= t[j] { j } else { j + 1 };
                dx.map_or(x[k], |dx| x[k] + dx[k] * (at - t[k]))
            } else if let Some(dx) = dx {
                let (s2, s3) = (s * s, s * s * s);
                (2.0 * s3 - 3.0 * s2 + 1.0) * x[j] + (s3 - 2.0 * s2 + s) * step * dx[j] + (3.0 * s2 - 2.0 * s3) * x[j + 1] + (s3 - s2) * step * dx[j + 1]
            } else {
                x[j] + (x[j + 1] - x[j]) * s
            }
        };
        out.push(value);
    }
    out
}

/// The shares of a named delay that may be a first-order lag (the rest a transport delay),
/// looked over once the delay is named (see `identify::lag`); the first, a pure delay, is the
/// simpler model. A lag behind the encoder (a negative delay) is not modelled.
const LAG_SHARES: [f64; 7] = [0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0];

/// The lag's share of a named delay as the delay term's second parameter: nested, at zero a
/// pure delay (not estimated there, not charged).
pub(crate) fn lag_share_parameter() -> Parameter {
    Parameter { name: "lag_share".into(), grid: LAG_SHARES.to_vec(), refine: Refine::Nested }
}

impl CandidateCause for TimeDelay {
    fn name(&self) -> &str {
        Effect::TimeDelay.name()
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::TimeDelay)
    }
    fn coefficient_names(&self) -> Vec<String> {
        Vec::new()
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        // Up to a tenth of the excitation period either way, every sample near zero and about
        // 20 steps further out; the search refines the best on every full-rate sample around it.
        let dt = c.excitation.sample_period_s;
        let max = ((0.1 / c.excitation.frequency_hz / dt).min(400.0)) as i64;
        let step = (max / 20).max(1);
        let mut grid: Vec<f64> = (1..=max.max(1)).filter(|k| k % step == 0 || *k <= 3).flat_map(|k| [k as f64 * dt, -(k as f64) * dt]).collect();
        // Samples far apart (a slow log, bins): fractions of a sample too, interpolated.
        if dt > SUB_SAMPLE_DELAYS_ABOVE_S {
            grid.extend([0.25 * dt, -0.25 * dt, 0.5 * dt, -0.5 * dt]);
        }
        vec![Parameter { name: "delay_s".into(), grid, refine: Refine::Samples }]
    }
    fn transforms(&self) -> bool {
        true
    }
    fn look_elsewhere(&self, c: &SearchContext) -> f64 {
        // The delay is the best of M resolvable values (the grid's span in refinement steps):
        // 2 ln M on top of BIC's count, as for a frequency scan. A small delay is, to first
        // order, a damping (`phi(t - d) = phi - d dphi/dt`): without the charge it took the
        // place of a viscous friction on a tie.
        let span = 0.2 / c.excitation.frequency_hz.max(1e-3);
        let step = delay_resolution(c.full_rate.t_s.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min).max(1e-6));
        2.0 * (span / step).max(1.0).ln()
    }
    fn transform(&self, p: &[f64], inputs: &mut Inputs) {
        let max_step = 10.0 * inputs.sample_period_s;
        // Behind a lag the inputs are shifted by the transport delay alone; the lag acts on
        // the torque (see `output_lag_s`).
        let p = [transport_s(p)];
        // The deflection through its rate; the elastic deflection too while it is the
        // deflection (no transform before this one bent it); the rate itself linearly.
        let elastic_is_deflection = inputs.elastic_rad == inputs.deflection_rad;
        let deflection = delayed(&inputs.t_s, &inputs.deflection_rad, Some(&inputs.velocity_rad_per_s), p[0], max_step);
        inputs.elastic_rad = if elastic_is_deflection { deflection.clone() } else { delayed(&inputs.t_s, &inputs.elastic_rad, None, p[0], max_step) };
        inputs.deflection_rad = deflection;
        inputs.velocity_rad_per_s = delayed(&inputs.t_s, &inputs.velocity_rad_per_s, None, p[0], max_step);
    }
    fn columns(&self, _: &[f64], _: &Samples) -> Vec<Vec<f64>> {
        Vec::new()
    }
    /// The whole delay; behind a lag also the lag's share of it and its time constant.
    fn report(&self, p: &[f64], _: &[String], _: &[f64]) -> std::collections::BTreeMap<String, f64> {
        let mut out = std::collections::BTreeMap::from([("delay_s".to_string(), p[0])]);
        if let Some(lag_s) = self.output_lag_s(p) {
            out.extend([("lag_share".to_string(), p[1]), ("lag_s".to_string(), lag_s)]);
        }
        out
    }
    fn output_lag_s(&self, p: &[f64]) -> Option<f64> {
        let share = p.get(1).copied().unwrap_or(0.0);
        (p[0] > 0.0 && share > 0.0).then(|| p[0] * share)
    }
}

/// The transport part of a delay [s]: the whole delay but the share that is a lag (a lag
/// behind the encoder, a negative delay, is not modelled: the torque cannot be read ahead).
fn transport_s(p: &[f64]) -> f64 {
    let share = p.get(1).copied().unwrap_or(0.0);
    if p[0] > 0.0 { p[0] * (1.0 - share) } else { p[0] }
}

#[cfg(test)]
mod tests {
    use super::delayed;

    #[test]
    fn a_delay_interpolates_on_irregular_time_stamps() {
        // A ramp x = t on jittered stamps: delayed by 0.0123 s it reads t - 0.0123 exactly.
        let t: Vec<f64> = (0..500).map(|i| i as f64 * 0.002 + if i % 3 == 0 { 0.0007 } else { 0.0 }).collect();
        let got = delayed(&t, &t, None, 0.0123, 0.02);
        for i in 20..500 {
            assert!((got[i] - (t[i] - 0.0123)).abs() < 1e-12, "{i}");
        }
        // Negative: early.
        let got = delayed(&t, &t, None, -0.005, 0.02);
        assert!((got[100] - (t[100] + 0.005)).abs() < 1e-12);
    }

    #[test]
    fn a_fraction_of_a_slow_logs_sample_is_read_through_the_rate() {
        // A 1 Hz sine of 0.2 rad logged at 20 Hz, delayed by 13 ms (a quarter sample): the line
        // between samples misses by about 1 % of the amplitude, Hermite's cubic with the rates
        // by 0.01 %.
        use std::f64::consts::TAU;
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
        let x: Vec<f64> = t.iter().map(|t| 0.2 * (TAU * t).sin()).collect();
        let v: Vec<f64> = t.iter().map(|t| 0.2 * TAU * (TAU * t).cos()).collect();
        let worst = |got: &[f64]| (40..200).map(|i| (got[i] - 0.2 * (TAU * (t[i] - 0.013)).sin()).abs()).fold(0.0, f64::max);
        let (line, cubic) = (worst(&delayed(&t, &x, None, 0.013, 0.5)), worst(&delayed(&t, &x, Some(&v), 0.013, 0.5)));
        assert!(line > 1e-3 && cubic < 5e-5, "line {line}, cubic {cubic}");
    }
}
