//! The observer's model offline: a joint's configured characteristic and its `model_extension`
//! along recorded deflections, as the plugins compute them online.

use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic};
use jointctl_models::extension::{ExtensionSpec, ModelExtension};
use serde_json::Value;

use super::err;
use crate::ExperimentError;

/// The observer's torque along the recorded deflections [Nm]: the joint's characteristic
/// (`params.characteristic` at the recorded pivot, or `params.stiffness_nm_per_rad`), through its
/// `model_extension` when it has one, as the elastic and shoulder plugins compute it online.
/// NaN where the deflection is unknown (and the extension's state starts again after it).
///
/// ```
/// let params = serde_json::json!({"stiffness_nm_per_rad": 100.0, "model_extension": {"torque_offset_nm": 0.5}});
/// let tau = jointctl_experiments::model_loop::observer_torque(&params, &[0.0, 0.01], &[0.0, 0.02], &[f64::NAN; 2]).unwrap();
/// assert!((tau[1] - 2.5).abs() < 1e-12);
/// ```
pub fn observer_torque(params: &Value, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Result<Vec<f64>, ExperimentError> {
    observer_torque_of(params, 0, t_s, deflection_rad, pivot_mm)
}

/// `params.characteristic`, if the joint has one.
fn characteristic(params: &Value) -> Result<Option<CharacteristicSpec>, ExperimentError> {
    params.get("characteristic").map(|spec| serde_json::from_value(spec.clone()).map_err(|e| err(format!("params.characteristic: {e}")))).transpose()
}

/// Whether `params` hold a 2-DOF (wrist) characteristic, whose curves have directions.
pub(super) fn two_dof(params: &Value) -> bool {
    characteristic(params).ok().flatten().is_some_and(|s| s.is_two_dof())
}

/// The torque [Nm] a joint's params give DOF `dof` at `(pivot [mm], deflection [rad])`: its
/// characteristic at the pivot (the wrist's for that DOF with the other undeflected, section
/// 3.5.2), or `stiffness_nm_per_rad` times the deflection; the configured model `identify --config`
/// takes as its baseline and the observer starts from.
///
/// ```
/// let params = serde_json::json!({"stiffness_nm_per_rad": 100.0});
/// let curve = jointctl_experiments::model_loop::configured_torque(&params, 0).unwrap();
/// assert!((curve(0.0, 0.01) - 1.0).abs() < 1e-12);
/// ```
pub fn configured_torque(params: &Value, dof: usize) -> Result<Box<dyn Fn(f64, f64) -> f64 + Send + Sync>, ExperimentError> {
    let table_err = |e: jointctl_models::characteristic::SpecError| err(format!("params.characteristic.{}: {}", e.field, e.message));
    match characteristic(params)? {
        Some(spec) if spec.is_two_dof() => {
            let table = jointctl_models::characteristic::WristCharacteristic::from_spec(&spec).map_err(table_err)?;
            Ok(Box::new(move |pivot, x| table.torque_of_dof(pivot, dof, x)))
        }
        Some(spec) => {
            let table = PivotCharacteristic::from_spec(&spec).map_err(table_err)?;
            Ok(Box::new(move |pivot, x| table.evaluate(pivot, x).torque_nm))
        }
        None => match params.get("stiffness_nm_per_rad").and_then(Value::as_f64) {
            Some(k) => Ok(Box::new(move |_, x| k * x)),
            None => Err(err("params: neither `characteristic` nor `stiffness_nm_per_rad`: the joint has no elastic observer model")),
        },
    }
}

/// The wrist's table from `params.characteristic`, and whether it changes with the pivot (then
/// a torque needs a pivot reading). An error for a joint that is not a 2-DOF wrist.
fn wrist_table(params: &Value) -> Result<(jointctl_models::characteristic::WristCharacteristic, bool), ExperimentError> {
    let spec = characteristic(params)?.filter(|s| s.is_two_dof()).ok_or_else(|| err("params.characteristic: not a 2-DOF (wrist) table: a deflection direction needs one"))?;
    let table = jointctl_models::characteristic::WristCharacteristic::from_spec(&spec).map_err(|e| err(format!("params.characteristic.{}: {}", e.field, e.message)))?;
    Ok((table, spec.pivot_settings_mm().len() > 1))
}

/// DOF `dof`'s `model_extension`, if the joint has one: the list's entry `dof` for a joint with
/// one entry per DOF (the wrist), the one given otherwise; the error names the field.
fn extension_of(params: &Value, dof: usize) -> Result<Option<ModelExtension>, ExperimentError> {
    let (given, field) = match params.get("model_extension") {
        Some(Value::Array(list)) => (list.get(dof).cloned(), format!("params.model_extension[{dof}]")),
        other => (other.cloned(), "params.model_extension".to_string()),
    };
    match given {
        None | Some(Value::Null) => Ok(None),
        Some(v) => {
            let spec: ExtensionSpec = serde_json::from_value(v).map_err(|e| err(format!("{field}: {e}")))?;
            Ok(Some(ModelExtension::new(spec).map_err(|e| err(format!("{field}.{}: {}", e.field, e.message)))?))
        }
    }
}

/// The torque [Nm] the wrist's table (section 3.5.2) gives along deflection direction
/// `angle_deg` (0 = q7 only, 90 = q6 only) at `(pivot [mm], deflection along the direction
/// [rad])`: q6 deflected by `deflection sin(angle)`, q7 by `deflection cos(angle)`, and their
/// torques projected back onto the direction, as `sim record --angle-deg` projects a wrist's F/T
/// torques. Along 0 and 90 deg it is [`configured_torque`] of q7 and q6. An error for a joint that is not a
/// 2-DOF wrist.
///
/// ```
/// let params: serde_json::Value = serde_json::json!({"characteristic": {"source": "assumed", "curves": [
///     {"pivot_mm": 20.0, "angle_deg": 0.0, "coefficients": [10.0], "stiffness_nm_per_rad": 10.0},
///     {"pivot_mm": 20.0, "angle_deg": 90.0, "coefficients": [30.0], "stiffness_nm_per_rad": 30.0}]}});
/// let along_q7 = jointctl_experiments::model_loop::configured_torque_along(&params, 0.0).unwrap();
/// assert!((along_q7(20.0, 0.01) - 0.1).abs() < 1e-12);
/// let diagonal = jointctl_experiments::model_loop::configured_torque_along(&params, 45.0).unwrap();
/// assert!((diagonal(20.0, 0.01) - 0.2).abs() < 1e-9);
/// ```
pub fn configured_torque_along(params: &Value, angle_deg: f64) -> Result<Box<dyn Fn(f64, f64) -> f64 + Send + Sync>, ExperimentError> {
    let (table, _) = wrist_table(params)?;
    let (sin, cos) = angle_deg.to_radians().sin_cos();
    Ok(Box::new(move |pivot, x| {
        let e = table.evaluate(pivot, x * sin, x * cos);
        e.torque_q6_nm * sin + e.torque_q7_nm * cos
    }))
}

/// The wrist observer's torque along deflection direction `angle_deg` [Nm], as the wrist plugin
/// computes it online for a deflection on that line (the record of `sim record --angle-deg`
/// holds the deflection along the line only, so a sideways deflection is not seen here): q6
/// deflected by `deflection sin(angle)`, q7 by `deflection cos(angle)`, the table at each DOF's
/// elastic deflection, each DOF's `model_extension` entry added, the two torques projected back
/// onto the direction, as the record projects the F/T sensor's. NaN where the deflection or a
/// needed pivot is unknown (the extensions' states start again after it).
///
/// ```
/// let params: serde_json::Value = serde_json::json!({
///     "characteristic": {"source": "assumed", "curves": [
///         {"pivot_mm": 20.0, "angle_deg": 0.0, "coefficients": [10.0], "stiffness_nm_per_rad": 10.0},
///         {"pivot_mm": 20.0, "angle_deg": 90.0, "coefficients": [30.0], "stiffness_nm_per_rad": 30.0}]},
///     "model_extension": [null, {"torque_offset_nm": 0.5}]});
/// let tau = jointctl_experiments::model_loop::observer_torque_along(&params, 45.0, &[0.0], &[0.01], &[20.0]).unwrap();
/// // The table's 0.2 Nm along 45 deg, and q7's offset projected: 0.5 cos(45 deg).
/// assert!((tau[0] - (0.2 + 0.5 * std::f64::consts::FRAC_1_SQRT_2)).abs() < 1e-9);
/// ```
pub fn observer_torque_along(params: &Value, angle_deg: f64, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Result<Vec<f64>, ExperimentError> {
    let (table, needs_pivot) = wrist_table(params)?;
    if params.get("model_extension").is_some_and(|v| !v.is_null() && v.as_array().is_none_or(|l| l.len() != 2)) {
        return Err(err("params.model_extension: the wrist's is a list of one entry per DOF, [q6, q7]"));
    }
    let mut extension = [extension_of(params, 0)?, extension_of(params, 1)?];
    let (sin, cos) = angle_deg.to_radians().sin_cos();
    let mut out = Vec::with_capacity(t_s.len());
    for (k, (&t, &x)) in t_s.iter().zip(deflection_rad).enumerate() {
        let pivot = pivot_mm.get(k).copied().filter(|p| p.is_finite() || needs_pivot).unwrap_or(0.0);
        if !x.is_finite() || !pivot.is_finite() {
            extension.iter_mut().flatten().for_each(ModelExtension::reset);
            out.push(f64::NAN);
            continue;
        }
        let d = [x * sin, x * cos];
        extension.iter_mut().flatten().for_each(|e| e.at_pivot(pivot));
        let elastic = |i: usize| extension[i].as_ref().map_or(d[i], |e| e.elastic_deflection(d[i]));
        let at = table.evaluate(pivot, elastic(0), elastic(1));
        let mut torque = [at.torque_q6_nm, at.torque_q7_nm];
        for (i, e) in extension.iter_mut().enumerate() {
            if let Some(e) = e {
                torque[i] = e.torque(t, d[i], torque[i]);
            }
        }
        out.push(torque[0] * sin + torque[1] * cos);
    }
    Ok(out)
}

/// [`observer_torque`] for DOF `dof` of the joint: for the wrist (section 3.5.2), that DOF's
/// table torque with the other DOF undeflected, through `model_extension[dof]`, as the wrist
/// plugin computes it online along a record that deflects that DOF alone.
///
/// ```
/// let params = serde_json::json!({"stiffness_nm_per_rad": 100.0});
/// let tau = jointctl_experiments::model_loop::observer_torque_of(&params, 0, &[0.0], &[0.01], &[f64::NAN]).unwrap();
/// assert!((tau[0] - 1.0).abs() < 1e-12);
/// ```
pub fn observer_torque_of(params: &Value, dof: usize, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Result<Vec<f64>, ExperimentError> {
    let curve = configured_torque(params, dof)?;
    let needs_pivot = characteristic(params)?.is_some_and(|s| s.pivot_settings_mm().len() > 1);
    // The wrist's extension is a list, one entry per DOF.
    let mut extension = extension_of(params, dof)?;
    let mut out = Vec::with_capacity(t_s.len());
    for (k, (&t, &phi)) in t_s.iter().zip(deflection_rad).enumerate() {
        // A model that changes with the pivot has no torque without a pivot reading (the plugins
        // leave it unknown online); one that does not reads at its one setting.
        let pivot = pivot_mm.get(k).copied().filter(|p| p.is_finite() || needs_pivot).unwrap_or(0.0);
        if !phi.is_finite() || !pivot.is_finite() {
            if let Some(e) = &mut extension {
                e.reset();
            }
            out.push(f64::NAN);
            continue;
        }
        out.push(match &mut extension {
            Some(e) => {
                e.at_pivot(pivot);
                let tau = curve(pivot, e.elastic_deflection(phi));
                e.torque(t, phi, tau)
            }
            None => curve(pivot, phi),
        });
    }
    Ok(out)
}
