//! A structural mode rung by each velocity reversal: after every reversal a decaying ring
//! `e^(-zeta w tau) (a_r sin(w_d tau) + b_r cos(w_d tau))`, `tau` the time since the reversal,
//! with an amplitude and phase of its own (what a reversal starts depends on backlash and on the
//! state the last ring left). The frequency and the damping ratio carry over from ring to ring;
//! the amplitude and phase of each ring do not, so they are fitted anew on every ring, on the
//! held-out part too, and charged for (see [`CandidateCause::segments`]). The gain reported is
//! therefore how much of the held-out error a mode of this frequency and damping explains once
//! each ring's start is seen, less the Cp charge for the two coefficients of every ring: an honest
//! measure of the mode, not a prediction of the rings.

use super::{CandidateCause, InputSet, Parameter, Refine, Samples, SearchContext, log_grid, reversals};
use jointctl_models::effect::Effect;
use crate::identify::numeric::segment_ranges;

/// Rings after velocity reversals: frequency [Hz] and damping ratio [-] shared, amplitude and
/// phase per ring. It writes no fragment yet: the simulation's mode (`sim.effects.vibration`) is
/// rung by changes of the element torque and needs a gain (mode torque per element torque) that
/// is not measured here.
pub struct ReversalRinging;

/// The largest damping ratio searched: past critical damping (1), where a "ring" is two
/// decaying exponentials that do not oscillate. A transient after each reversal that is no mode
/// (a Stribeck friction's breakaway peak that eq. 3.5's arctan lacks, a torque sensor's filter
/// on the friction's step) then finds its own shape among the rival fits, at a damping that
/// [`RING_DAMPING`] rejects, instead of the most damped ring (an assumption: at three times
/// critical the two time constants are a thirty-seventh of the ring's period and nearly a whole
/// one, at critical damping both a sixth; measured on the blind generator's Stribeck records,
/// whose rings came out at 0.06-0.2 when the grid stopped at 0.3 and at 0.5-3 now).
const MOST_DAMPED: f64 = 3.0;

/// ... and the largest a ring is named with: its envelope falls to 28 % within a period, and
/// it is gone after two (an assumption: a joint's structural modes ring at a few hundredths). A
/// fit more damped than that is a transient after each reversal that a heavily damped ring only
/// approximates (a torque sensor's filter on the friction's step, a friction's shape error), not
/// a mode; searched up to [`MOST_DAMPED`] so that such a fit shows as one.
const RING_DAMPING: f64 = 0.2;

impl CandidateCause for ReversalRinging {
    fn name(&self) -> &str {
        Effect::ReversalRinging.name()
    }
    fn reads(&self) -> InputSet {
        InputSet::DEFLECTION
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::ReversalRinging)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["sin_nm".into(), "cos_nm".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let Some(f) = c.dominant_frequency_hz() else {
            // No mode in the band: nothing to search.
            return vec![Parameter { name: "frequency_hz".into(), grid: Vec::new(), refine: Refine::Not }];
        };
        vec![
            // The periodogram's peak of rings of random phase sits at the damped frequency.
            Parameter { name: "frequency_hz".into(), grid: vec![f], refine: Refine::Not },
            // 0.003-0.3 as before, on to MOST_DAMPED at about the same spacing.
            Parameter { name: "damping_ratio".into(), grid: log_grid(0.003, MOST_DAMPED, 17), refine: Refine::Between },
        ]
    }
    fn segments(&self, _: &[f64], s: &Samples) -> Option<Vec<usize>> {
        // A ring starts again at each reversal, and where a piece of the part begins that does
        // not follow on from the samples before it (its time since the last reversal unknown).
        let mut starts = reversals(s.deflection_rad);
        starts.push(0);
        starts.extend(s.restarts.iter().map(|r| r.at).filter(|a| *a < s.deflection_rad.len()));
        starts.sort_unstable();
        starts.dedup();
        Some(starts)
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let (w, zeta) = (std::f64::consts::TAU * p[0], p[1].max(0.0));
        let starts = self.segments(p, s).unwrap_or_default();
        let (mut sin, mut cos) = (vec![0.0; s.t_s.len()], vec![0.0; s.t_s.len()]);
        for std::ops::Range { start: a, end: b } in segment_ranges(&starts, s.t_s.len()) {
            for i in a..b {
                (sin[i], cos[i]) = ring(w, zeta, s.t_s[i] - s.t_s[a]);
            }
        }
        vec![sin, cos]
    }
    fn impossible(&self, p: &[f64], _: &[f64]) -> Option<String> {
        p.get(1).filter(|z| **z > RING_DAMPING).map(|z| format!("damping ratio {z:.2} above a ring's {RING_DAMPING}: a transient after reversals, not a mode"))
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        // `c` holds every ring's pair: the typical (RMS) ring amplitude.
        [("frequency_hz".to_string(), p[0]), ("damping_ratio".to_string(), p[1]), ("ring_amplitude_nm".to_string(), super::rms_amplitude(c))].into_iter().collect()
    }
    fn look_elsewhere(&self, c: &SearchContext) -> f64 {
        2.0 * c.frequencies_scanned().ln()
    }
}

/// The two free responses of a second-order mode (natural frequency `w` [rad/s], damping ratio
/// `zeta`) at `tau` [s] after its start: `e^(-zeta w tau)` times (sin, cos) of the damped
/// frequency below critical damping, and above it the non-oscillating pair (`w/s sinh(s tau)`,
/// `cosh(s tau)`, `s = w sqrt(zeta^2 - 1)`), which tends to (`w tau`, 1) at critical damping,
/// so the pair is continuous in `zeta` from 1 on.
fn ring(w: f64, zeta: f64, tau: f64) -> (f64, f64) {
    let envelope = (-zeta * w * tau).exp();
    if zeta < 1.0 {
        let wd = w * (1.0 - zeta * zeta).sqrt();
        return (envelope * (wd * tau).sin(), envelope * (wd * tau).cos());
    }
    let s = w * (zeta * zeta - 1.0).sqrt();
    let x = s * tau;
    if x < 1e-6 {
        // sinh(x)/x -> 1 (at critical damping, and at the ring's start).
        return (envelope * w * tau, envelope);
    }
    // As two exponentials: the envelope times cosh(x) overflows far from the start.
    let (slow, fast) = ((-(zeta * w - s) * tau).exp(), (-(zeta * w + s) * tau).exp());
    (w / s * 0.5 * (slow - fast), 0.5 * (slow + fast))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The columns of one ring of `seconds` at 1 kHz after a reversal, for `damping`.
    fn one_ring(frequency_hz: f64, damping: f64, seconds: f64) -> Vec<Vec<f64>> {
        let n = (seconds * 1000.0) as usize;
        let t: Vec<f64> = (0..n).map(|i| i as f64 / 1000.0).collect();
        // One stroke: no reversal inside, so the whole of it is one ring.
        let d: Vec<f64> = t.iter().map(|x| 0.01 * x).collect();
        let (v, zeros) = (vec![0.01; n], vec![0.0; n]);
        let s = Samples { t_s: &t, deflection_rad: &d, velocity_rad_per_s: &v, elastic_rad: &d, pivot_mm: &zeros, repetition: &[], history_rad: &[], restarts: &[], model_nm: &zeros, rate_edges_rad_per_s: &[], bin_width_s: 0.0, record_middle_s: 0.0 };
        ReversalRinging.columns(&[frequency_hz, damping], &s)
    }

    /// Finding (issue 31): the damping search stopped at 0.3 (the columns clamped the ratio
    /// below 1), so a transient after reversals that does not oscillate had no shape of its own
    /// and the most damped ring fitted in its place (the blind generator's Stribeck records named
    /// rings of 0.07-0.16). Past critical damping the pair neither oscillates nor overflows.
    #[test]
    fn past_critical_damping_a_ring_is_a_transient_that_does_not_oscillate() {
        for damping in [1.0, 1.5, 3.0] {
            let cols = one_ring(4.0, damping, 5.0);
            for (k, col) in cols.iter().enumerate() {
                assert!(col.iter().all(|x| x.is_finite() && *x >= 0.0), "damping {damping}, column {k}: a sign change or a non-finite value");
            }
            // It decays: the slow exponential's time constant is 1 / (w (zeta - sqrt(zeta^2 - 1))).
            assert!(cols[1][4999] < 0.05 * cols[1][0], "damping {damping}: {}", cols[1][4999]);
        }
        // Continuous through critical damping: the pair from above; from below the cosine (the
        // sine tends to zero there, the pair's span to the same two functions).
        let (below, at, above) = (one_ring(4.0, 0.9999, 1.0), one_ring(4.0, 1.0, 1.0), one_ring(4.0, 1.0001, 1.0));
        for i in [10, 100, 500] {
            assert!((below[1][i] - at[1][i]).abs() < 1e-3, "cosine at sample {i}");
            for k in 0..2 {
                assert!((above[k][i] - at[k][i]).abs() < 1e-3, "column {k} at sample {i}");
            }
        }
    }
}
