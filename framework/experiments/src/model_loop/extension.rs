//! A DOF's extension from the causes `identify` named (in one record, or at each pivot setting):
//! the extended observer, the causes whose plant terms improve the simulation, and both gains.

use jointctl_config::LoadedConfig;
use jointctl_ident::csv::Data;
use jointctl_ident::identify::significance::block_test;
use serde_json::{Map, Value};

use super::err;
use super::gain::{Gain, Split, Trace, held_out_mask, rmse, squared_errors, trace};
use super::observer::{observer_torque_of, two_dof};
use super::simulation::{merge_plant, simulated_torque, tidy};
use crate::ExperimentError;

/// A cause `identify` named, with what it adds to each side.
#[derive(Clone, Debug, PartialEq)]
pub struct Found {
    /// The cause's name.
    pub effect: String,
    /// Its keys of the joint's `sim.effects`.
    pub plant: Map<String, Value>,
    /// Its keys of the joint's `model_extension`.
    pub observer: Map<String, Value>,
}

/// The extension of one DOF, and its gains.
#[derive(Clone, Debug)]
pub struct Extension {
    /// The DOF.
    pub dof: String,
    /// Index of its joint in the config.
    pub joint_index: usize,
    /// The joint's complete params with the extended observer model.
    pub observer_params: Value,
    /// The joint's `sim.effects` with the extended simulation.
    pub plant_effects: Value,
    /// Causes whose plant terms went into the simulation.
    pub plant_causes: Vec<String>,
    /// Why other causes did not change one side or the other.
    pub notes: Vec<String>,
    /// The simulation's gain.
    pub simulation: Gain,
    /// The observer's gain.
    pub observer: Gain,
    /// The simulation's held-out torques.
    pub simulation_trace: Trace,
    /// The observer's held-out torques.
    pub observer_trace: Trace,
}

/// `dof`'s joint entry (index, the DOF's index in it, the entry): a joint's observer extends its
/// first DOF, or each DOF of the wrist.
fn extended_joint<'a>(loaded: &'a LoadedConfig, dof: &str) -> Result<(usize, usize, &'a jointctl_config::JointConfig), ExperimentError> {
    let (j, i) = crate::locate(loaded, dof)?;
    let entry = &loaded.config.joints[j];
    if i != 0 && !two_dof(&entry.params.0) {
        return Err(err(format!("`{dof}` is DOF {i} of joint `{}`: its observer's model extension is the joint's first DOF's", entry.name)));
    }
    Ok((j, i, entry))
}

/// The extension of `dof` from the causes `identify` named on `data`, and its gains.
///
/// # Errors
/// The DOF is not in the config or not simulated, or its joint has no single-DOF elastic
/// observer model (the 2-DOF wrist), or a cause's terms are out of range.
pub fn extend(loaded: &LoadedConfig, dof: &str, found: &[Found], data: &Data, split: Split) -> Result<Extension, ExperimentError> {
    let (j, i, entry) = extended_joint(loaded, dof)?;
    let mut notes = Vec::new();
    // The observer: every cause's observer terms together.
    let extension = observer_terms(found, &mut notes);
    finish(loaded, dof, (j, i, entry), Value::Object(extension), found, data, (&held_out_mask(&data.t, &data.deflection, split), &[(0..data.len()).collect()]), notes)
}

/// The causes `identify` named at one pivot setting of a record.
#[derive(Clone, Debug)]
pub struct SettingFound {
    /// The setting [mm].
    pub pivot_mm: f64,
    /// Its samples in the record, in time order.
    pub samples: Vec<usize>,
    /// The causes named on them.
    pub found: Vec<Found>,
}

/// Every cause's observer terms together (a note for each cause without one).
fn observer_terms(found: &[Found], notes: &mut Vec<String>) -> Map<String, Value> {
    let mut extension = Map::new();
    for f in found {
        if f.observer.is_empty() {
            notes.push(format!("`{}` has no observer term (the observer models the element, not the sensor's structure or the loop)", f.effect));
        }
        extension.extend(f.observer.clone());
    }
    extension
}

/// The extension of a DOF with pivot settings (the shoulder q2) from the causes `identify` named
/// at each setting, in increasing pivot order: the observer's terms `by_pivot`, weighted at the
/// joint's pivot online (issue 32), and its gain on what each setting's identification held out
/// (its last `1 - train_fraction` of time, or the window `identify` held out instead; see
/// [`jointctl_ident::identify::prepare::held_out_window`]). The simulated plant's effects are one set for every
/// setting (`sim.effects` has no per-setting form): a cause named at half the settings or more is
/// tried there with its plant terms averaged over them, and taken as [`extend`] takes a cause.
///
/// # Errors
/// As [`extend`]; also settings not in increasing order.
pub fn extend_by_pivot(loaded: &LoadedConfig, dof: &str, settings: &[SettingFound], data: &Data, split: Split) -> Result<Extension, ExperimentError> {
    let (j, i, entry) = extended_joint(loaded, dof)?;
    if let Some(w) = settings.windows(2).find(|w| !(w[1].pivot_mm > w[0].pivot_mm)) {
        return Err(err(format!("the settings must be in increasing pivot order, got {} mm after {} mm", w[1].pivot_mm, w[0].pivot_mm)));
    }
    let mut notes = Vec::new();
    let mut by_pivot = Vec::new();
    let mut held_out = vec![false; data.len()];
    for SettingFound { pivot_mm, samples, found } in settings {
        let t: Vec<f64> = samples.iter().map(|&i| data.t[i]).collect();
        let d: Vec<f64> = samples.iter().map(|&i| data.deflection[i]).collect();
        for (&i, held) in samples.iter().zip(held_out_mask(&t, &d, split)) {
            held_out[i] = held;
        }
        let mut setting_notes = Vec::new();
        let terms = observer_terms(found, &mut setting_notes);
        notes.extend(setting_notes.into_iter().map(|n| format!("at {pivot_mm:.1} mm: {n}")));
        by_pivot.push(serde_json::json!({"pivot_mm": pivot_mm, "terms": terms}));
    }
    let any = settings.iter().any(|s| s.found.iter().any(|f| !f.observer.is_empty()));
    let extension = if any { serde_json::json!({"by_pivot": by_pivot}) } else { Value::Object(Map::new()) };
    let plant = plant_over_settings(settings);
    notes.push(format!(
        "the simulated plant's effects are one set for every pivot setting: a cause named at half the settings or more is tried in the simulation with its plant terms averaged over them ({})",
        if plant.is_empty() { "none".to_string() } else { plant.iter().map(|f| format!("`{}`", f.effect)).collect::<Vec<_>>().join(", ") }
    ));
    let groups: Vec<Vec<usize>> = settings.iter().map(|s| s.samples.clone()).collect();
    finish(loaded, dof, (j, i, entry), extension, &plant, data, (&held_out, &groups), notes)
}

/// The causes named at half the settings or more, each with its plant terms averaged over the
/// settings that named it (numbers averaged, objects key by key): `sim.effects` has one set for
/// every pivot setting, so a cause of the element alike at every setting goes there once.
fn plant_over_settings(settings: &[SettingFound]) -> Vec<Found> {
    let mut effects: Vec<&str> = settings.iter().flat_map(|s| s.found.iter().map(|f| f.effect.as_str())).collect();
    effects.sort_unstable();
    effects.dedup();
    effects
        .into_iter()
        .filter_map(|effect| {
            let fragments: Vec<&Map<String, Value>> = settings.iter().filter_map(|s| s.found.iter().find(|f| f.effect == effect)).map(|f| &f.plant).collect();
            (2 * fragments.len() >= settings.len() && fragments.iter().all(|f| !f.is_empty())).then(|| Found {
                effect: effect.to_string(),
                plant: mean_object(&fragments),
                observer: Map::new(),
            })
        })
        .collect()
}

/// Key by key, the mean of the numbers (and of nested objects) the objects hold; other values
/// from the first.
fn mean_object(objects: &[&Map<String, Value>]) -> Map<String, Value> {
    let mut out = objects[0].clone();
    for (key, value) in out.iter_mut() {
        let same: Vec<&Value> = objects.iter().filter_map(|o| o.get(key)).collect();
        if value.is_number() {
            let numbers: Vec<f64> = same.iter().filter_map(|v| v.as_f64()).collect();
            *value = Value::from(numbers.iter().sum::<f64>() / numbers.len() as f64);
        } else if value.is_object() {
            let nested: Vec<&Map<String, Value>> = same.iter().filter_map(|v| v.as_object()).collect();
            *value = Value::Object(mean_object(&nested));
        }
    }
    out
}

/// The observer with `extension` (an empty object: none), the plant with each of `found`'s
/// terms that make the replay of the training part better in more than half of `groups` (sample
/// indices: the pivot settings, or one group of every sample), and both gains on the `held_out`
/// samples.
#[allow(clippy::too_many_arguments)]
fn finish(loaded: &LoadedConfig, dof: &str, (j, i, entry): (usize, usize, &jointctl_config::JointConfig), extension: Value, found: &[Found], data: &Data, (held_out, groups): (&[bool], &[Vec<usize>]), mut notes: Vec<String>) -> Result<Extension, ExperimentError> {
    let (t, d, p) = (&data.t, &data.deflection, &data.pivot_mm);
    let params_before = entry.params.0.clone();
    let empty = extension.as_object().is_some_and(Map::is_empty);
    let mut params_after = params_before.clone();
    let wrist = two_dof(&params_before);
    if let Some(obj) = params_after.as_object_mut() {
        if wrist {
            // One entry per DOF ([q6, q7]): this DOF's, the other's as it was.
            let mut list = match obj.get("model_extension") {
                Some(Value::Array(l)) if l.len() == entry.dof_names().len() => l.clone(),
                _ => vec![Value::Null; entry.dof_names().len()],
            };
            list[i] = if empty { Value::Null } else { extension };
            if list.iter().all(Value::is_null) {
                obj.remove("model_extension");
            } else {
                obj.insert("model_extension".into(), Value::Array(list));
            }
        } else if empty {
            obj.remove("model_extension");
        } else {
            obj.insert("model_extension".into(), extension);
        }
    }
    let obs_before = observer_torque_of(&params_before, i, t, d, p)?;
    let obs_after = observer_torque_of(&params_after, i, t, d, p)?;

    // The simulation: a cause's plant terms only when they make the training part's replay
    // significantly better.
    // The DOF's own set when the joint has one per DOF.
    let base_effects = entry.sim.as_ref().map(|s| serde_json::to_value(s.effects_per_dof.get(i).copied().unwrap_or(s.effects))).transpose().map_err(|e| err(e.to_string()))?.unwrap_or_default();
    let replay = |effects: &Value| simulated_torque(loaded, dof, effects, t, d, p);
    let sim_before = replay(&base_effects)?;
    let (mut effects, mut current) = (base_effects.clone(), sim_before.clone());
    let mut plant_causes = Vec::new();
    for f in found {
        if f.plant.is_empty() {
            notes.push(format!("`{}` has no simulation term (the simulated plant has its own curve)", f.effect));
            continue;
        }
        let candidate = merge_plant(&effects, &f.plant);
        let tried = replay(&candidate)?;
        // Each group (a pivot setting) is its own experiment and is tested apart: blocks of
        // different settings differ in gain, and one block test over all of them reads that
        // spread as noise (three settings whose replays each fell 0.33-0.81 -> 0.05-0.06 Nm gave
        // t = 1.99).
        let tests: Vec<_> = groups
            .iter()
            .map(|g| {
                let in_group: Vec<bool> = { let mut m = vec![false; data.len()]; g.iter().for_each(|&i| m[i] = !held_out[i]); m };
                let (a, b) = (squared_errors(&data.torque, &current, &in_group, true), squared_errors(&data.torque, &tried, &in_group, true));
                block_test(&a.iter().zip(&b).map(|(a, b)| a - b).collect::<Vec<f64>>())
            })
            .collect();
        let passed = tests.iter().filter(|t| t.significant()).count();
        if 2 * passed > tests.len() {
            plant_causes.push(f.effect.clone());
            (effects, current) = (candidate, tried);
        } else {
            notes.push(format!(
                "`{}` left out of the simulation: its plant terms do not make the replay of the training part significantly better ({}{}); the simulation already has it or it is the observer's alone",
                f.effect,
                tests.iter().map(|t| format!("block t = {:.2} < {:.2}", t.t, t.critical)).collect::<Vec<_>>().join(", "),
                if tests.len() > 1 { " in more than half of the settings" } else { "" }
            ));
        }
    }
    let gain = |before: &[f64], after: &[f64]| Gain {
        rmse_before: rmse(&squared_errors(&data.torque, before, held_out, true)),
        rmse_after: rmse(&squared_errors(&data.torque, after, held_out, true)),
    };
    Ok(Extension {
        dof: dof.into(),
        joint_index: j,
        observer_params: params_after,
        plant_effects: tidy(&effects),
        plant_causes,
        notes,
        simulation: gain(&sim_before, &current),
        observer: gain(&obs_before, &obs_after),
        simulation_trace: trace(data, held_out, &sim_before, &current),
        observer_trace: trace(data, held_out, &obs_before, &obs_after),
    })
}
