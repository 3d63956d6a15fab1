//! The simulated plant: the joint's element and effects replayed along a recorded motion, and a
//! cause's plant terms merged into its effects.

use jointctl_config::{EffectsConfig, LoadedConfig};
use serde_json::{Map, Value};

use super::err;
use crate::ExperimentError;

/// The deflection rate's window in the simulation's replay [s]: the observer extension's
/// (assumption, see [`ExtensionSpec::rate_window_s`](jointctl_models::extension::ExtensionSpec::rate_window_s)).
pub const REPLAY_RATE_WINDOW_S: f64 = 0.02;

/// Plant keys that add to what the simulation has (a linear term's coefficient); every other
/// key replaces.
const ADDITIVE: [&str; 3] = ["viscous_nms_per_rad", "cubic_nm_per_rad3", "torque_offset_nm"];

/// The simulated torque sensor's reading of `dof` replayed along the recorded motion, with the
/// joint's `sim.effects` (or the DOF's `sim.effects_per_dof` entry) replaced by `effects` [Nm].
///
/// ```
/// let loaded = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
/// let effects = serde_json::json!({"torque_offset_nm": 0.5});
/// let tau = jointctl_experiments::model_loop::simulated_torque(&loaded, "q4", &effects, &[0.0, 0.01], &[0.0, 0.0], &[f64::NAN; 2]).unwrap();
/// assert_eq!(tau, vec![0.5, 0.5]);
/// ```
pub fn simulated_torque(loaded: &LoadedConfig, dof: &str, effects: &Value, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Result<Vec<f64>, ExperimentError> {
    let (j, i) = crate::locate(loaded, dof)?;
    let effects: EffectsConfig = serde_json::from_value(effects.clone()).map_err(|e| err(format!("joints[{j}].sim.effects: {e}")))?;
    let mut cfg = loaded.config.clone();
    if let Some(sim) = cfg.joints[j].sim.as_mut() {
        match sim.effects_per_dof.get_mut(i) {
            Some(own) => *own = effects,
            None => sim.effects = effects,
        }
    }
    let hal = jointctl_sim::SimHal::with_chain(&cfg, loaded.chain.as_ref()).map_err(|e| err(e.to_string()))?;
    let unit = hal.units().iter().find(|u| u.dof_names.iter().any(|n| n == dof)).ok_or_else(|| err(format!("`{dof}` is not simulated")))?;
    let mut unit = unit.clone();
    // A NaN deflection (unknown) is replayed as the last known one: the element did not stop
    // existing; the comparison leaves that sample out.
    let mut last = 0.0;
    let held: Vec<f64> = deflection_rad.iter().map(|d| if d.is_finite() { last = *d; *d } else { last }).collect();
    let mut out = unit.replay(i, t_s, &held, pivot_mm, REPLAY_RATE_WINDOW_S);
    for (o, d) in out.iter_mut().zip(deflection_rad) {
        if !d.is_finite() {
            *o = f64::NAN;
        }
    }
    Ok(out)
}

/// `fragment` merged into `effects`: linear coefficients add, everything else replaces.
pub(super) fn merge_plant(effects: &Value, fragment: &Map<String, Value>) -> Value {
    let mut out = effects.as_object().cloned().unwrap_or_default();
    for (k, v) in fragment {
        let add = ADDITIVE.contains(&k.as_str()).then(|| out.get(k).and_then(Value::as_f64).unwrap_or(0.0) + v.as_f64().unwrap_or(0.0));
        out.insert(k.clone(), add.map_or_else(|| v.clone(), Value::from));
    }
    Value::Object(out)
}

/// Effects without the keys that are off (zero or none), for a readable file.
pub(super) fn tidy(effects: &Value) -> Value {
    let mut out = effects.as_object().cloned().unwrap_or_default();
    out.retain(|_, v| !(v.is_null() || v.as_f64() == Some(0.0)));
    Value::Object(out)
}
