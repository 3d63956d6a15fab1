//! A structural mode rung by each velocity reversal: after every reversal a decaying ring
//! `e^(-zeta w tau) (a_r sin(w_d tau) + b_r cos(w_d tau))`, `tau` the time since the reversal,
//! with an amplitude and phase of its own (what a reversal starts depends on backlash and on the
//! state the last ring left). The frequency and the damping ratio carry over from ring to ring;
//! the amplitude and phase of each ring do not, so they are fitted anew on every ring, on the
//! held-out part too, and charged for (see [`CandidateCause::segments`]). The gain reported is
//! therefore how much of the held-out error a mode of this frequency and damping explains once
//! each ring's start is seen, less the Cp charge for the two coefficients of every ring: an honest
//! measure of the mode, not a prediction of the rings.

use super::{CandidateCause, Parameter, Refine, Samples, SearchContext, log_grid, reversals};
use crate::identify::spectrum;

/// Rings after velocity reversals: frequency [Hz] and damping ratio [-] shared, amplitude and
/// phase per ring. It writes no fragment yet: the simulation's mode (`sim.effects.vibration`) is
/// rung by changes of the element torque and needs a gain (mode torque per element torque) that
/// is not measured here.
pub struct ReversalRinging;

/// The largest damping ratio searched ...
const MOST_DAMPED: f64 = 0.3;

/// ... and the largest a ring is named with: its envelope falls to 28 % within a period, and
/// it is gone after two (an assumption: a joint's structural modes ring at a few hundredths). A
/// fit more damped than that is a transient after each reversal that a heavily damped ring only
/// approximates (a torque sensor's filter on the friction's step, a friction's shape error), not
/// a mode; searched up to [`MOST_DAMPED`] so that such a fit shows as one.
const RING_DAMPING: f64 = 0.2;

impl CandidateCause for ReversalRinging {
    fn name(&self) -> &str {
        "reversal_ringing"
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
            Parameter { name: "damping_ratio".into(), grid: log_grid(0.003, MOST_DAMPED, 13), refine: Refine::Between },
        ]
    }
    fn segments(&self, _: &[f64], s: &Samples) -> Option<Vec<usize>> {
        let mut starts = reversals(s.deflection_rad);
        starts.insert(0, 0);
        starts.dedup();
        Some(starts)
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let (w, zeta) = (std::f64::consts::TAU * p[0], p[1].clamp(0.0, 0.99));
        let wd = w * (1.0 - zeta * zeta).sqrt();
        let starts = self.segments(p, s).unwrap_or_default();
        let (mut sin, mut cos) = (vec![0.0; s.t_s.len()], vec![0.0; s.t_s.len()]);
        for (k, &a) in starts.iter().enumerate() {
            let b = starts.get(k + 1).copied().unwrap_or(s.t_s.len());
            for i in a..b {
                let tau = s.t_s[i] - s.t_s[a];
                let envelope = (-zeta * w * tau).exp();
                sin[i] = envelope * (wd * tau).sin();
                cos[i] = envelope * (wd * tau).cos();
            }
        }
        vec![sin, cos]
    }
    fn impossible(&self, p: &[f64], _: &[f64]) -> Option<String> {
        p.get(1).filter(|z| **z > RING_DAMPING).map(|z| format!("damping ratio {z:.2} above a ring's {RING_DAMPING}: a transient after reversals, not a mode"))
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        // `c` holds every ring's pair: the typical (RMS) ring amplitude.
        let rings = (c.len() / 2).max(1) as f64;
        let rms = (c.chunks(2).map(|ab| ab[0] * ab[0] + ab.get(1).map_or(0.0, |b| b * b)).sum::<f64>() / rings).sqrt();
        [("frequency_hz".to_string(), p[0]), ("damping_ratio".to_string(), p[1]), ("ring_amplitude_nm".to_string(), rms)].into_iter().collect()
    }
    fn look_elsewhere(&self, c: &SearchContext) -> f64 {
        2.0 * spectrum::resolvable(c.full_rate.t_s, c.excitation.frequency_hz).ln()
    }
}
