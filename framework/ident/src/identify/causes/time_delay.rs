//! A delay between the channels: the torque channel sees the deflection `d` seconds late
//! (`d > 0`) or early (`d < 0`, the encoder side lags).

use super::{CandidateCause, Inputs, Parameter, Refine, Samples, SearchContext};

/// The model of `phi(t - d)`, `d` a whole number of sample periods.
pub struct TimeDelay;

impl CandidateCause for TimeDelay {
    fn name(&self) -> &str {
        "time_delay"
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
        let grid = (1..=max.max(1)).filter(|k| k % step == 0 || *k <= 3).flat_map(|k| [k as f64 * dt, -(k as f64) * dt]).collect();
        vec![Parameter { name: "delay_s".into(), grid, refine: Refine::Samples }]
    }
    fn transforms(&self) -> bool {
        true
    }
    fn transform(&self, p: &[f64], inputs: &mut Inputs) {
        let k = (p[0] / inputs.sample_period_s).round() as i64;
        for x in [&mut inputs.deflection_rad, &mut inputs.velocity_rad_per_s, &mut inputs.elastic_rad] {
            let n = x.len() as i64;
            let src = x.clone();
            for (i, v) in x.iter_mut().enumerate() {
                *v = src[(i as i64 - k).clamp(0, n - 1) as usize];
            }
        }
    }
    fn columns(&self, _: &[f64], _: &Samples) -> Vec<Vec<f64>> {
        Vec::new()
    }
}
