//! The simulated plant: the joint's element and effects replayed along a recorded motion, a
//! cause's plant terms merged into its effects, and the causes whose terms the simulation takes.

use jointctl_config::{EffectsConfig, JointConfig, JointSimConfig, LoadedConfig, PivotEffectsConfig};
use jointctl_ident::csv::Data;
use jointctl_ident::identify::significance::{BlockTest, block_test};
use serde_json::{Map, Value};

use super::err;
use super::found::{Found, SettingFound};
use super::gain::squared_errors;
use crate::ExperimentError;

/// The deflection rate's window in the simulation's replay [s]: the observer extension's
/// (assumption, see [`ExtensionSpec::rate_window_s`](jointctl_models::extension::ExtensionSpec::rate_window_s)).
pub const REPLAY_RATE_WINDOW_S: f64 = 0.02;

/// Plant keys that add to what the simulation has (a linear term's coefficient); every other
/// key replaces.
const ADDITIVE: [&str; 3] = ["viscous_nms_per_rad", "cubic_nm_per_rad3", "torque_offset_nm"];

/// A simulated DOF's plant effects: one set (`sim.effects`, or the DOF's `sim.effects_per_dof`
/// entry), or one set per pivot setting (`sim.effects_by_pivot`), as `sim.effects` JSON objects.
#[derive(Clone, Debug, PartialEq)]
pub enum PlantEffects {
    /// One set at every pivot setting.
    One(Value),
    /// `(setting [mm], effects there)` in increasing pivot order.
    ByPivot(Vec<(f64, Value)>),
}

impl PlantEffects {
    /// As in the config: the effects' object, or `{"by_pivot": [{pivot_mm, effects}, ...]}`
    /// (the observer extension's form), keys that are off left out.
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
            PlantEffects::ByPivot(list) => serde_json::json!({"by_pivot": Self::list(list)}),
        }
    }

    /// The `sim.effects_by_pivot` list of `(setting, effects)`.
    fn list(list: &[(f64, Value)]) -> Value {
        Value::Array(list.iter().map(|(p, v)| serde_json::json!({"pivot_mm": p, "effects": tidy(v)})).collect())
    }

    /// The key of the joint's `sim` section DOF `i`'s effects go to (`effects`, or
    /// `effects_by_pivot`: the other DOFs' own sets there as configured) and its value.
    ///
    /// # Errors
    /// An effects object that is not `sim.effects`.
    pub(super) fn config_entry(&self, sim: &JointSimConfig, i: usize) -> Result<(&'static str, Value), ExperimentError> {
        let to_json = |fx: &EffectsConfig| serde_json::to_value(fx).map(|v| tidy(&v)).map_err(|e| err(e.to_string()));
        Ok(match self {
            PlantEffects::One(v) => ("effects", tidy(v)),
            PlantEffects::ByPivot(list) => {
                let entries = joint_by_pivot(sim, i, list)?
                    .iter()
                    .map(|e| {
                        Ok(if e.effects_per_dof.is_empty() {
                            serde_json::json!({"pivot_mm": e.pivot_mm, "effects": to_json(&e.effects)?})
                        } else {
                            serde_json::json!({"pivot_mm": e.pivot_mm, "effects_per_dof": e.effects_per_dof.iter().map(to_json).collect::<Result<Vec<_>, ExperimentError>>()?})
                        })
                    })
                    .collect::<Result<Vec<_>, ExperimentError>>()?;
                ("effects_by_pivot", Value::Array(entries))
            }
        })
    }
}

/// The joint's `sim.effects_by_pivot` with DOF `i`'s set at each setting of `list` taken from
/// it: one set for every DOF, or, when the joint's DOFs have their own (the wrist), the other
/// DOFs' sets at those settings as configured.
fn joint_by_pivot(sim: &JointSimConfig, i: usize, list: &[(f64, Value)]) -> Result<Vec<PivotEffectsConfig>, ExperimentError> {
    let per_dof = !sim.effects_per_dof.is_empty() || sim.effects_by_pivot.iter().any(|e| !e.effects_per_dof.is_empty());
    let configured = |d: usize, pivot_mm: f64| match sim.effects_by_pivot.is_empty() {
        true => sim.effects_per_dof.get(d).copied().unwrap_or(sim.effects),
        false => jointctl_sim::pivot_effects::effects_at(&sim.effects_by_pivot, pivot_mm, d),
    };
    list.iter()
        .enumerate()
        .map(|(k, (pivot_mm, v))| {
            let own: EffectsConfig = serde_json::from_value(v.clone()).map_err(|e| err(format!("effects_by_pivot[{k}].effects: {e}")))?;
            Ok(match per_dof {
                false => PivotEffectsConfig { pivot_mm: *pivot_mm, effects: own, effects_per_dof: Vec::new() },
                true => PivotEffectsConfig { pivot_mm: *pivot_mm, effects: EffectsConfig::default(), effects_per_dof: (0..sim.matrix.len()).map(|d| if d == i { own } else { configured(d, *pivot_mm) }).collect() },
            })
        })
        .collect()
}

/// DOF `i`'s plant effects as the config gives them.
pub(super) fn configured_plant(entry: &JointConfig, i: usize) -> Result<PlantEffects, ExperimentError> {
    let to_value = |fx: &EffectsConfig| serde_json::to_value(fx).map_err(|e| err(e.to_string()));
    let Some(sim) = entry.sim.as_ref() else { return Ok(PlantEffects::One(Value::Object(Map::new()))) };
    if !sim.effects_by_pivot.is_empty() {
        return Ok(PlantEffects::ByPivot(sim.effects_by_pivot.iter().map(|s| Ok((s.pivot_mm, to_value(&s.of_dof(i))?))).collect::<Result<_, ExperimentError>>()?));
    }
    Ok(PlantEffects::One(to_value(sim.effects_per_dof.get(i).unwrap_or(&sim.effects))?))
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
    let parse = |v: &Value, field: &str| serde_json::from_value::<EffectsConfig>(v.clone()).map_err(|e| err(format!("joints[{j}].sim.{field}: {e}")));
    let mut cfg = loaded.config.clone();
    if let Some(sim) = cfg.joints[j].sim.as_mut() {
        match effects {
            PlantEffects::One(v) => {
                let fx = parse(v, "effects")?;
                sim.effects_by_pivot.clear();
                match sim.effects_per_dof.get_mut(i) {
                    Some(own) => *own = fx,
                    None => sim.effects = fx,
                }
            }
            PlantEffects::ByPivot(list) => {
                sim.effects_by_pivot = joint_by_pivot(sim, i, list).map_err(|e| err(format!("joints[{j}].sim.{e}")))?;
                sim.effects = EffectsConfig::default();
                sim.effects_per_dof.clear();
            }
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
fn tidy(effects: &Value) -> Value {
    let mut out = effects.as_object().cloned().unwrap_or_default();
    out.retain(|_, v| !(v.is_null() || v.as_f64() == Some(0.0)));
    Value::Object(out)
}

/// The plant effects with each of `found`'s plant terms that make the replay of the training
/// part (the samples not `held_out`) significantly better (the block t-test), the causes taken,
/// and the replays before and after.
pub(super) struct PlantChoice {
    /// The effects with the terms taken.
    pub effects: PlantEffects,
    /// The causes taken (with their setting, by pivot).
    pub causes: Vec<String>,
    /// The replay with the configured effects [Nm].
    pub before: Vec<f64>,
    /// The replay with `effects` [Nm].
    pub after: Vec<f64>,
}

/// The block test of `tried` against `current` on the samples of `mask`.
fn better(data: &Data, current: &[f64], tried: &[f64], mask: &[bool]) -> BlockTest {
    let (a, b) = (squared_errors(&data.torque, current, mask, true), squared_errors(&data.torque, tried, mask, true));
    block_test(&a.iter().zip(&b).map(|(a, b)| a - b).collect::<Vec<f64>>())
}

/// The note of a cause left out of the simulation.
fn left_out(effect: &str, at: &str, t: &BlockTest) -> String {
    format!(
        "`{effect}`{at} left out of the simulation: its plant terms do not make the replay of the training part significantly better (block t = {:.2} < {:.2}); the simulation already has it or it is the observer's alone",
        t.t, t.critical
    )
}

/// One set of effects for the record: each cause's plant terms tried in turn on the training part.
pub(super) fn choose_plant(loaded: &LoadedConfig, dof: &str, base: PlantEffects, found: &[Found], data: &Data, held_out: &[bool], notes: &mut Vec<String>) -> Result<PlantChoice, ExperimentError> {
    let (t, d, p) = (&data.t, &data.deflection, &data.pivot_mm);
    let before = simulated_torque(loaded, dof, &base, t, d, p)?;
    let training: Vec<bool> = held_out.iter().map(|h| !h).collect();
    let (mut effects, mut current, mut causes) = (base, before.clone(), Vec::new());
    for f in found {
        if f.plant.is_empty() {
            notes.push(format!("`{}` has no simulation term (the simulated plant has its own curve)", f.effect));
            continue;
        }
        let candidate = match &effects {
            PlantEffects::One(v) => PlantEffects::One(merge_plant(v, &f.plant)),
            PlantEffects::ByPivot(list) => PlantEffects::ByPivot(list.iter().map(|(pivot, v)| (*pivot, merge_plant(v, &f.plant))).collect()),
        };
        let tried = simulated_torque(loaded, dof, &candidate, t, d, p)?;
        let test = better(data, &current, &tried, &training);
        if test.significant() {
            causes.push(f.effect.clone());
            (effects, current) = (candidate, tried);
        } else {
            notes.push(left_out(&f.effect, "", &test));
        }
    }
    Ok(PlantChoice { effects, causes, before, after: current })
}

/// One set of effects per pivot setting (`sim.effects_by_pivot` at the record's settings, from
/// the configured effects there): at each setting, each cause named there tried in turn with its
/// plant terms at that setting, on that setting's training part. Each setting is its own
/// experiment: blocks of different settings differ in gain, and one block test over all of them
/// reads that spread as noise (three settings whose replays each fell 0.33-0.81 -> 0.05-0.06 Nm
/// gave t = 1.99). With no cause taken, the configured effects stay as they were.
pub(super) fn choose_plant_by_pivot(loaded: &LoadedConfig, dof: &str, base: PlantEffects, settings: &[SettingFound], data: &Data, held_out: &[bool], notes: &mut Vec<String>) -> Result<PlantChoice, ExperimentError> {
    let (t, d, p) = (&data.t, &data.deflection, &data.pivot_mm);
    let before = simulated_torque(loaded, dof, &base, t, d, p)?;
    let at = |pivot_mm: f64| -> Result<Value, ExperimentError> {
        match &base {
            PlantEffects::One(v) => Ok(v.clone()),
            PlantEffects::ByPivot(list) => {
                let parsed = list.iter().map(|(p, v)| Ok(PivotEffectsConfig { pivot_mm: *p, effects: serde_json::from_value(v.clone()).map_err(|e| err(e.to_string()))?, effects_per_dof: Vec::new() })).collect::<Result<Vec<_>, ExperimentError>>()?;
                serde_json::to_value(jointctl_sim::pivot_effects::effects_at(&parsed, pivot_mm, 0)).map_err(|e| err(e.to_string()))
            }
        }
    };
    let mut list = settings.iter().map(|s| Ok((s.pivot_mm, at(s.pivot_mm)?))).collect::<Result<Vec<_>, ExperimentError>>()?;
    let mut current = simulated_torque(loaded, dof, &PlantEffects::ByPivot(list.clone()), t, d, p)?;
    let mut causes = Vec::new();
    for (k, s) in settings.iter().enumerate() {
        let training: Vec<bool> = {
            let mut m = vec![false; data.len()];
            s.samples.iter().for_each(|&i| m[i] = !held_out[i]);
            m
        };
        let at_setting = format!(" at {:.1} mm", s.pivot_mm);
        for f in &s.found {
            if f.plant.is_empty() {
                notes.push(format!("`{}`{at_setting} has no simulation term (the simulated plant has its own curve)", f.effect));
                continue;
            }
            let mut candidate = list.clone();
            candidate[k].1 = merge_plant(&candidate[k].1, &f.plant);
            let tried = simulated_torque(loaded, dof, &PlantEffects::ByPivot(candidate.clone()), t, d, p)?;
            let test = better(data, &current, &tried, &training);
            if test.significant() {
                causes.push(format!("{}{at_setting}", f.effect));
                (list, current) = (candidate, tried);
            } else {
                notes.push(left_out(&f.effect, &at_setting, &test));
            }
        }
    }
    if causes.is_empty() {
        return Ok(PlantChoice { effects: base, causes, after: before.clone(), before });
    }
    Ok(PlantChoice { effects: PlantEffects::ByPivot(list), causes, before, after: current })
}
