//! The gain of an extension: torque errors against the F/T sensor on the held-out part, and
//! that part's torques for plots.

use jointctl_ident::csv::Data;
use jointctl_ident::identify::prepare::HeldOut;
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

/// How `identify` split the record: the fraction of the time range fitted and which part was
/// held out; the gains are measured on what it held out.
///
/// ```
/// use jointctl_experiments::model_loop::Split;
/// use jointctl_ident::identify::IdentifyOptions;
/// assert_eq!(Split::of(&IdentifyOptions::default()).train_fraction, 0.7);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    /// Fraction of the time range fitted.
    pub train_fraction: f64,
    /// Which part was held out.
    pub held_out: HeldOut,
}

impl Split {
    /// The split of `opts`.
    pub fn of(opts: &jointctl_ident::identify::IdentifyOptions) -> Split {
        Split { train_fraction: opts.train_fraction, held_out: opts.held_out }
    }
}

/// Which samples are held out: those `identify` holds out (see
/// [`jointctl_ident::identify::prepare::held_out_window`]: the last part of the time range, or a
/// window whose motion is more like the rest's), so that every gain is measured on data no fit
/// has seen.
pub(super) fn held_out_mask(t_s: &[f64], deflection_rad: &[f64], split: Split) -> Vec<bool> {
    let window = jointctl_ident::identify::prepare::held_out_window(t_s, deflection_rad, split.train_fraction, split.held_out);
    t_s.iter().map(|t| window.holds(t_s, *t)).collect()
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

/// The wrist observer's held-out gain along a diagonal deflection direction `angle_deg`
/// (section 3.5.2): the table alone against the table with the joint's per-DOF
/// `model_extension` (see [`super::observer_torque_along`]), both scored on the same held-out
/// samples (those `identify` holds out, where the measurement and both models are known). How an
/// extension identified along the DOFs' axes explains a record along a diagonal. `None` when the
/// params have no extension entry, or no held-out sample has both models.
///
/// ```
/// use jointctl_ident::csv::Data;
/// let params: serde_json::Value = serde_json::json!({
///     "characteristic": {"source": "assumed", "curves": [
///         {"pivot_mm": 20.0, "angle_deg": 0.0, "coefficients": [10.0], "stiffness_nm_per_rad": 10.0},
///         {"pivot_mm": 20.0, "angle_deg": 90.0, "coefficients": [30.0], "stiffness_nm_per_rad": 30.0}]},
///     "model_extension": [null, {"torque_offset_nm": 0.5}]});
/// // Measured: the table along 45 deg plus q7's offset projected onto the direction.
/// let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.01).collect();
/// let x: Vec<f64> = t.iter().map(|t| 0.01 * (6.0 * t).sin()).collect();
/// let tau = x.iter().map(|x| 20.0 * x + 0.5 * std::f64::consts::FRAC_1_SQRT_2).collect();
/// let data = Data::from_columns(t, x, tau);
/// let gain = jointctl_experiments::model_loop::observer_gain_along(&params, 45.0, &data, jointctl_experiments::model_loop::Split::of(&Default::default())).unwrap().unwrap();
/// assert!(gain.rmse_after < 1e-9 && (gain.rmse_before - 0.5 * std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9);
/// ```
pub fn observer_gain_along(params: &serde_json::Value, angle_deg: f64, data: &Data, split: Split) -> Result<Option<Gain>, crate::ExperimentError> {
    if params.get("model_extension").is_none_or(|e| e.is_null()) {
        return Ok(None);
    }
    let mut table_alone = params.clone();
    if let Some(p) = table_alone.as_object_mut() {
        p.remove("model_extension");
    }
    let after = super::observer_torque_along(params, angle_deg, &data.t, &data.deflection, &data.pivot_mm)?;
    let before = super::observer_torque_along(&table_alone, angle_deg, &data.t, &data.deflection, &data.pivot_mm)?;
    // One set of samples for both: where the measurement and both models are known.
    let mask: Vec<bool> = held_out_mask(&data.t, &data.deflection, split).iter().zip(before.iter().zip(&after)).map(|(k, (b, a))| *k && b.is_finite() && a.is_finite()).collect();
    let (rmse_before, rmse_after) = (rmse(&squared_errors(&data.torque, &before, &mask, true)), rmse(&squared_errors(&data.torque, &after, &mask, true)));
    Ok((rmse_before.is_finite() && rmse_after.is_finite()).then_some(Gain { rmse_before, rmse_after }))
}
