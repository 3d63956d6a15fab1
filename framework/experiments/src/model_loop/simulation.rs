//! The simulated plant: the joint's element and effects replayed along a recorded motion, a
//! cause's plant terms merged into a DOF's effects, and those effects put back into the joint's
//! `sim` section (one set for every DOF, one per DOF, or either per pivot setting).

use jointctl_config::{EffectsConfig, JointConfig, JointSimConfig, LoadedConfig, PivotEffectsConfig};
use serde_json::{Map, Value};

use super::err;
use crate::ExperimentError;

/// The deflection rate's window in the simulation's replay [s]: the observer extension's
/// (assumption, see [`ExtensionSpec::rate_window_s`](jointctl_models::extension::ExtensionSpec::rate_window_s)).
pub const REPLAY_RATE_WINDOW_S: f64 = 0.02;

/// Plant keys that add to what the simulation has (a linear term's coefficient); every other
/// key replaces.
const ADDITIVE: [&str; 3] = ["viscous_nms_per_rad", "cubic_nm_per_rad3", "torque_offset_nm"];

/// One DOF's plant effects, as `sim.effects` JSON objects: one set, or one per pivot setting.
#[derive(Clone, Debug, PartialEq)]
pub enum PlantEffects {
    /// One set at every pivot setting.
    One(Value),
    /// `(setting [mm], effects there)` in increasing pivot order.
    ByPivot(Vec<(f64, Value)>),
}

impl PlantEffects {
    /// The DOF's effects, keys that are off left out: the object, or `{"by_pivot": [{pivot_mm,
    /// effects}, ...]}` (the observer extension's form; the config's key is `effects_by_pivot`).
    ///
    /// ```
    /// use jointctl_experiments::model_loop::PlantEffects;
    /// use serde_json::json;
    /// let plant = PlantEffects::ByPivot(vec![(10.0, json!({"viscous_nms_per_rad": 2.0, "cubic_nm_per_rad3": 0.0}))]);
    /// assert_eq!(plant.to_json(), json!({"by_pivot": [{"pivot_mm": 10.0, "effects": {"viscous_nms_per_rad": 2.0}}]}));
    /// ```
    pub fn to_json(&self) -> Value {
        match self {
            PlantEffects::One(v) => tidy(v),
            PlantEffects::ByPivot(list) => serde_json::json!({"by_pivot": list.iter().map(|(p, v)| serde_json::json!({"pivot_mm": p, "effects": tidy(v)})).collect::<Vec<_>>()}),
        }
    }

    /// The joint's effects with DOF `i`'s these: one set for a joint of one DOF, else one set
    /// per DOF, the other DOFs' as configured (at each setting, when these are by setting).
    ///
    /// # Errors
    /// An object that is not `sim.effects` (said with its setting), or one set for a DOF of a
    /// joint whose effects are by setting.
    pub(super) fn joint_effects(&self, sim: &JointSimConfig, i: usize) -> Result<JointEffects, ExperimentError> {
        let parse = |v: &Value, at: &str| serde_json::from_value::<EffectsConfig>(v.clone()).map_err(|e| err(format!("{at}: {e}")));
        let n = sim.matrix.len();
        let sets = |own: EffectsConfig, pivot_mm: Option<f64>| (0..n).map(|d| if d == i { Ok(own) } else { configured(sim, d, pivot_mm) }).collect::<Result<Vec<_>, ExperimentError>>();
        Ok(match self {
            PlantEffects::One(_) if !sim.effects_by_pivot.is_empty() => return Err(err("one set of effects for a DOF of a joint whose effects are by pivot setting")),
            PlantEffects::One(v) if n <= 1 => JointEffects::Every(parse(v, "effects")?),
            PlantEffects::One(v) => JointEffects::PerDof(sets(parse(v, &format!("effects_per_dof[{i}]"))?, None)?),
            PlantEffects::ByPivot(list) => JointEffects::ByPivot(
                list.iter()
                    .enumerate()
                    .map(|(k, (pivot_mm, v))| {
                        let own = parse(v, &format!("effects_by_pivot[{k}]"))?;
                        Ok(match n <= 1 {
                            true => PivotEffectsConfig { pivot_mm: *pivot_mm, effects: own, effects_per_dof: Vec::new() },
                            false => PivotEffectsConfig { pivot_mm: *pivot_mm, effects: EffectsConfig::default(), effects_per_dof: sets(own, Some(*pivot_mm))? },
                        })
                    })
                    .collect::<Result<_, ExperimentError>>()?,
            ),
        })
    }
}

/// A joint's plant effects in one of the three forms of its `sim` section.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum JointEffects {
    /// `effects`: one set for every DOF.
    Every(EffectsConfig),
    /// `effects_per_dof`.
    PerDof(Vec<EffectsConfig>),
    /// `effects_by_pivot`.
    ByPivot(Vec<PivotEffectsConfig>),
}

impl JointEffects {
    /// Into `sim`, the other forms cleared.
    pub(super) fn apply(self, sim: &mut JointSimConfig) {
        sim.effects = EffectsConfig::default();
        sim.effects_per_dof.clear();
        sim.effects_by_pivot.clear();
        match self {
            JointEffects::Every(fx) => sim.effects = fx,
            JointEffects::PerDof(list) => sim.effects_per_dof = list,
            JointEffects::ByPivot(list) => sim.effects_by_pivot = list,
        }
    }

    /// The key of the `sim` section and its value, keys that are off left out.
    pub(super) fn yaml_entry(&self) -> Result<(&'static str, Value), ExperimentError> {
        let set = |fx: &EffectsConfig| serde_json::to_value(fx).map(|v| tidy(&v)).map_err(|e| err(e.to_string()));
        let sets = |list: &[EffectsConfig]| list.iter().map(set).collect::<Result<Vec<_>, ExperimentError>>();
        Ok(match self {
            JointEffects::Every(fx) => ("effects", set(fx)?),
            JointEffects::PerDof(list) => ("effects_per_dof", Value::Array(sets(list)?)),
            JointEffects::ByPivot(list) => (
                "effects_by_pivot",
                Value::Array(
                    list.iter()
                        .map(|e| {
                            Ok(match e.effects_per_dof.is_empty() {
                                true => serde_json::json!({"pivot_mm": e.pivot_mm, "effects": set(&e.effects)?}),
                                false => serde_json::json!({"pivot_mm": e.pivot_mm, "effects_per_dof": sets(&e.effects_per_dof)?}),
                            })
                        })
                        .collect::<Result<_, ExperimentError>>()?,
                ),
            ),
        })
    }
}

/// `sim` with each of `other_dofs`' effects in its DOF's place (each in the form it takes, the
/// DOFs not listed as configured): what an extension of several DOFs starts its own DOF from.
///
/// # Errors
/// As [`PlantEffects::joint_effects`].
pub(super) fn with_other_dofs<'a>(sim: &JointSimConfig, other_dofs: impl IntoIterator<Item = (usize, &'a PlantEffects)>) -> Result<JointSimConfig, ExperimentError> {
    let mut sim = sim.clone();
    for (d, effects) in other_dofs {
        effects.joint_effects(&sim, d)?.apply(&mut sim);
    }
    Ok(sim)
}

/// DOF `d`'s configured effects (at `pivot_mm` when they are by setting).
///
/// # Errors
/// Effects by setting and no setting to take them at.
fn configured(sim: &JointSimConfig, d: usize, pivot_mm: Option<f64>) -> Result<EffectsConfig, ExperimentError> {
    match (sim.effects_by_pivot.is_empty(), pivot_mm) {
        (true, _) => Ok(sim.effects_per_dof.get(d).copied().unwrap_or(sim.effects)),
        (false, Some(p)) => Ok(jointctl_sim::pivot_effects::effects_at(&sim.effects_by_pivot, p, d)),
        (false, None) => Err(err("the joint's effects are by pivot setting: give the setting")),
    }
}

/// DOF `i`'s plant effects as the config gives them.
pub(super) fn configured_plant(entry: &JointConfig, i: usize) -> Result<PlantEffects, ExperimentError> {
    let to_value = |fx: &EffectsConfig| serde_json::to_value(fx).map_err(|e| err(e.to_string()));
    let Some(sim) = entry.sim.as_ref() else { return Ok(PlantEffects::One(Value::Object(Map::new()))) };
    if !sim.effects_by_pivot.is_empty() {
        return Ok(PlantEffects::ByPivot(sim.effects_by_pivot.iter().map(|s| Ok((s.pivot_mm, to_value(&s.of_dof(i))?))).collect::<Result<_, ExperimentError>>()?));
    }
    Ok(PlantEffects::One(to_value(&configured(sim, i, None)?)?))
}

/// The simulated torque sensor's reading of `dof` replayed along the recorded motion, with the
/// joint's plant effects (`sim.effects`, the DOF's `sim.effects_per_dof` entry, or
/// `sim.effects_by_pivot`) replaced by `effects` [Nm].
///
/// ```
/// use jointctl_experiments::model_loop::{PlantEffects, simulated_torque};
/// let loaded = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
/// let effects = PlantEffects::One(serde_json::json!({"torque_offset_nm": 0.5}));
/// let tau = simulated_torque(&loaded, "q4", &effects, &[0.0, 0.01], &[0.0, 0.0], &[f64::NAN; 2]).unwrap();
/// assert_eq!(tau, vec![0.5, 0.5]);
/// ```
pub fn simulated_torque(loaded: &LoadedConfig, dof: &str, effects: &PlantEffects, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Result<Vec<f64>, ExperimentError> {
    let (j, i) = crate::locate(loaded, dof)?;
    let mut cfg = loaded.config.clone();
    if let Some(sim) = cfg.joints[j].sim.as_mut() {
        effects.joint_effects(sim, i).map_err(|e| err(format!("joints[{j}].sim: {e}")))?.apply(sim);
    }
    let hal = jointctl_sim::SimHal::with_chain(&cfg, loaded.chain.as_ref()).map_err(|e| err(e.to_string()))?;
    let unit = hal.units().iter().find(|u| u.dof_names.iter().any(|n| n == dof)).ok_or_else(|| err(format!("`{dof}` is not simulated")))?;
    let mut along = vec![0.0; i + 1];
    along[i] = 1.0;
    Ok(replay_known(&mut unit.clone(), &along, t_s, deflection_rad, pivot_mm))
}

/// `unit` replayed along `direction` (see [`jointctl_sim::unit::Unit::replay_along`]), NaN where
/// the deflection is unknown: such a sample is replayed as the last known deflection (the element
/// did not stop existing) and the comparison leaves it out.
fn replay_known(unit: &mut jointctl_sim::unit::Unit, direction: &[f64], t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Vec<f64> {
    let mut last = 0.0;
    let held: Vec<f64> = deflection_rad.iter().map(|d| if d.is_finite() { last = *d; *d } else { last }).collect();
    let mut out = unit.replay_along(direction, t_s, &held, pivot_mm, REPLAY_RATE_WINDOW_S);
    for (o, d) in out.iter_mut().zip(deflection_rad) {
        if !d.is_finite() {
            *o = f64::NAN;
        }
    }
    out
}

/// The simulated torque sensors of joint `j` (the wrist) replayed along deflection direction
/// `angle_deg` (section 3.5.2: its first DOF deflected by `sin`, its second by `cos` of the
/// deflection) and projected back onto it, with the joint's `sim` section `sim` [Nm]; NaN where
/// the deflection is unknown.
///
/// # Errors
/// The joint is not simulated, or does not have two DOFs.
pub(super) fn simulated_torque_along(loaded: &LoadedConfig, j: usize, sim: &JointSimConfig, angle_deg: f64, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64]) -> Result<Vec<f64>, ExperimentError> {
    let mut cfg = loaded.config.clone();
    let entry = cfg.joints.get_mut(j).ok_or_else(|| err(format!("no joints[{j}]")))?;
    entry.sim = Some(sim.clone());
    let names: Vec<String> = entry.dof_names().iter().map(|n| n.to_string()).collect();
    if names.len() != 2 {
        return Err(err(format!("joints[{j}] has {} DOFs: a direction is of a 2-DOF joint's", names.len())));
    }
    let hal = jointctl_sim::SimHal::with_chain(&cfg, loaded.chain.as_ref()).map_err(|e| err(e.to_string()))?;
    let mut unit = hal.units().iter().find(|u| u.dof_names == names).ok_or_else(|| err(format!("joints[{j}] ({}) is not simulated as one unit", names.join(", "))))?.clone();
    let (sin, cos) = angle_deg.to_radians().sin_cos();
    Ok(replay_known(&mut unit, &[sin, cos], t_s, deflection_rad, pivot_mm))
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
fn tidy(effects: &Value) -> Value {
    let mut out = effects.as_object().cloned().unwrap_or_default();
    out.retain(|_, v| !(v.is_null() || v.as_f64() == Some(0.0)));
    Value::Object(out)
}
