//! The gain of an extension: torque errors against the F/T sensor on the held-out part, and
//! that part's torques for plots.

use jointctl_ident::csv::Data;
use serde::Serialize;

/// Held-out torque RMSE before and after [Nm].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Gain {
    /// With the configured model.
    pub rmse_before: f64,
    /// With the extended model.
    pub rmse_after: f64,
}

impl Gain {
    /// The relative drop of the error (0.6: 60 % smaller).
    pub fn relative(&self) -> f64 {
        1.0 - self.rmse_after / self.rmse_before
    }
}

/// The held-out part's torques, for plots.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// Time [s].
    pub t_s: Vec<f64>,
    /// The F/T sensor [Nm].
    pub measured_nm: Vec<f64>,
    /// The configured model [Nm].
    pub before_nm: Vec<f64>,
    /// The extended model [Nm].
    pub after_nm: Vec<f64>,
}

/// Which samples are held out: those `identify` holds out (see
/// [`jointctl_ident::identify::prepare::split_time`]), so that every gain is measured on data no
/// fit has seen.
pub(super) fn held_out_mask(t_s: &[f64], train_fraction: f64) -> Vec<bool> {
    let split = jointctl_ident::identify::prepare::split_time(t_s, train_fraction);
    t_s.iter().map(|t| *t >= split).collect()
}

/// Squared errors against the measurement on the samples `mask` selects (NaNs left out).
pub(super) fn squared_errors(measured: &[f64], model: &[f64], mask: &[bool], want: bool) -> Vec<f64> {
    measured.iter().zip(model).zip(mask).filter(|((m, p), k)| **k == want && m.is_finite() && p.is_finite()).map(|((m, p), _)| (m - p) * (m - p)).collect()
}

pub(super) fn rmse(sq: &[f64]) -> f64 {
    if sq.is_empty() { f64::NAN } else { (sq.iter().sum::<f64>() / sq.len() as f64).sqrt() }
}

pub(super) fn trace(data: &Data, mask: &[bool], before: &[f64], after: &[f64]) -> Trace {
    let mut t = Trace::default();
    for k in (0..data.t.len()).filter(|k| mask[*k]) {
        t.t_s.push(data.t[k]);
        t.measured_nm.push(data.torque[k]);
        t.before_nm.push(before[k]);
        t.after_nm.push(after[k]);
    }
    t
}
