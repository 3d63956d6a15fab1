//! The answer/truth bookkeeping: the ground truth at the samples, and the answer's parameters of
//! each cause.

use super::Setup;
use super::request::Cause;
use super::sizing::lstsq;
use crate::model::{Physics, Spring};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Truth at the output samples, for tests and for checking answers.
#[derive(Clone, Debug, Default)]
pub struct Truth {
    /// True deflection (position) and its velocity at the samples.
    pub phi: Vec<f64>,
    pub vel: Vec<f64>,
    /// Noise-free torque the sensor would read.
    pub tau_clean: Vec<f64>,
    /// Baseline torque: k phi + baseline friction.
    pub tau_base: Vec<f64>,
    /// Baseline friction alone.
    pub friction: Vec<f64>,
    /// The noise added to the torque.
    pub noise: Vec<f64>,
    /// Repetition index of each sample.
    pub rep: Vec<usize>,
}

/// The baseline plus one cause of `ph`.
pub(super) fn only_cause(ph: &Physics, c: Cause) -> Physics {
    let mut o = ph.baseline();
    match c {
        Cause::Viscous => o.viscous_b = ph.viscous_b,
        Cause::Hysteresis => o.hysteresis = ph.hysteresis.clone(),
        Cause::DeadZone => o.dead_zone = ph.dead_zone.clone(),
        Cause::Stiffness => o.spring = ph.spring.clone(),
        Cause::Offset => o.offset = ph.offset.clone(),
        Cause::Delay => o.delay = ph.delay.clone(),
        Cause::Vibration => o.vibration = ph.vibration.clone(),
    }
    o
}

/// The answer's `params`: each cause's documented parameters, measured over the record where
/// the brief asks for it (offset mean, equivalent cubic).
pub(super) fn answer_params(setup: &Setup, tr: &Truth, offs: &[f64], total_s: f64) -> BTreeMap<String, f64> {
    let ph = &setup.physics;
    let mut m = BTreeMap::new();
    for &c in &setup.causes {
        match c {
            Cause::Viscous => {
                m.insert("b".into(), ph.viscous_b);
            }
            Cause::Hysteresis => {
                if let Some(h) = &ph.hysteresis {
                    h.params(&mut m);
                }
            }
            Cause::DeadZone => {
                if let Some(d) = &ph.dead_zone {
                    m.insert("width".into(), d.width);
                    m.insert("width_ramp".into(), d.ramp);
                }
            }
            Cause::Stiffness => {
                // Least-squares k + k3 fit of the spring shape over the excited deflections
                // (the dead-zone-filtered deflection when there is one).
                let s: Vec<f64> = tr
                    .phi
                    .iter()
                    .map(|p| ph.dead_zone.as_ref().map_or(*p, |d| d.apply(*p)))
                    .collect();
                let y: Vec<f64> = s.iter().map(|x| ph.spring.torque(ph.k, *x)).collect();
                let s3: Vec<f64> = s.iter().map(|x| x * x * x).collect();
                let fit = lstsq(&y, &[&s, &s3]);
                match ph.spring {
                    Spring::Cubic { k3 } => {
                        m.insert("k3".into(), k3);
                    }
                    Spring::TanhSoft { phi_s } | Spring::SinhHard { phi_s } => {
                        m.insert("k3".into(), fit[1]);
                        m.insert("stiff_phi_s".into(), phi_s);
                    }
                    Spring::Linear => {}
                }
                m.insert("stiff_k_equivalent".into(), fit[0]);
            }
            Cause::Offset => {
                let mean = offs.iter().sum::<f64>() / offs.len().max(1) as f64;
                m.insert("offset".into(), mean);
                if let Some(o) = &ph.offset {
                    // Offset(t) = scale (1 + rep + drift_rel (t - mid) / total): the slope [Nm/s].
                    if o.drift_rel != 0.0 {
                        m.insert(
                            "offset_drift_per_s".into(),
                            o.scale_nm * o.drift_rel / total_s.max(1e-9),
                        );
                    }
                    if !o.rep_rel.is_empty() {
                        let reps = tr.rep.iter().max().map_or(1, |r| r + 1);
                        for r in 0..reps {
                            let (s, c) = tr
                                .rep
                                .iter()
                                .zip(offs)
                                .filter(|(rr, _)| **rr == r)
                                .fold((0.0, 0usize), |(s, c), (_, o)| (s + o, c + 1));
                            m.insert(format!("offset_rep{r}"), s / c.max(1) as f64);
                        }
                    }
                }
            }
            Cause::Delay => {
                if let Some(d) = &ph.delay {
                    m.insert("delay".into(), d.equivalent_s());
                    m.insert("delay_transport".into(), d.transport_s);
                    if d.lp_tau_s > 0.0 {
                        m.insert("delay_fc_hz".into(), 1.0 / (2.0 * PI * d.lp_tau_s));
                    }
                }
            }
            Cause::Vibration => {
                if let Some(v) = &ph.vibration {
                    m.insert("frequency".into(), v.freq_hz);
                    m.insert("amplitude".into(), v.amp_nm);
                    m.insert("vibration_phase".into(), v.phase_rad);
                }
            }
        }
    }
    m
}
