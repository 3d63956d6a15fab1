//! A DOF's extension from the causes `identify` named (in one record, or at each pivot setting):
//! the extended observer, the causes whose plant terms improve the simulation, and both gains.

use jointctl_config::LoadedConfig;
use jointctl_ident::csv::Data;
use serde_json::{Map, Value};

use super::err;
use super::found::{Found, SettingFound};
use super::gain::{Gain, Split, Trace, held_out_mask, rmse, squared_errors, trace};
use super::observer::{observer_torque_of, two_dof};
use super::plant_choice::{PlantChoice, choose_plant, choose_plant_by_pivot};
use super::simulation::{PlantEffects, configured_plant};
use crate::ExperimentError;

/// The extension of one DOF, and its gains.
#[derive(Clone, Debug)]
pub struct Extension {
    /// The DOF.
    pub dof: String,
    /// Index of its joint in the config.
    pub joint_index: usize,
    /// The joint's complete params with the extended observer model.
    pub observer_params: Value,
    /// The DOF's plant effects with the extended simulation.
    pub plant_effects: PlantEffects,
    /// The joint's other DOFs whose plant effects change too, by DOF index (the wrist's torque
    /// offsets split from its diagonals, [`super::extend_wrist_offsets`]); empty when the
    /// extension is one DOF's.
    pub other_dofs: Vec<DofEffects>,
    /// Causes whose plant terms went into the simulation (with their setting, by pivot).
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
    /// For a record of several pivot settings, both gains at each (empty for one record).
    pub by_setting: Vec<SettingGain>,
}

/// Another DOF's plant effects, changed beside the extension's own DOF's.
#[derive(Clone, Debug)]
pub struct DofEffects {
    /// The DOF.
    pub dof: String,
    /// Its index in its joint.
    pub index: usize,
    /// Its effects.
    pub effects: PlantEffects,
}

/// Both gains on what one pivot setting's identification held out.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SettingGain {
    /// The setting [mm].
    pub pivot_mm: f64,
    /// The simulation's gain there.
    pub simulation: Gain,
    /// The observer's gain there.
    pub observer: Gain,
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

/// The extension of `dof` from the causes `identify` named on `data`, and its gains. On a
/// joint whose simulated effects are by pivot setting, a record at one setting has the causes'
/// plant terms tried at that setting alone.
///
/// # Errors
/// The DOF is not in the config or not simulated, or its joint has no single-DOF elastic
/// observer model (the 2-DOF wrist), or a cause's terms are out of range.
pub fn extend(loaded: &LoadedConfig, dof: &str, found: &[Found], data: &Data, split: Split) -> Result<Extension, ExperimentError> {
    let (j, i, entry) = extended_joint(loaded, dof)?;
    let mut notes = Vec::new();
    // The observer: every cause's observer terms together.
    let extension = observer_terms(found, &mut notes);
    let held_out = held_out_mask(&data.t, &data.deflection, split);
    let base = configured_plant(entry, i)?;
    // A joint whose effects are by setting, and a record at one setting (a hold, as `identify`
    // finds the settings of a record): the causes' terms go to that setting alone (the record
    // says nothing of the others).
    let settings = if matches!(base, PlantEffects::ByPivot(_)) { data.pivot_settings(1) } else { Vec::new() };
    let plant = match settings.as_slice() {
        [(pivot_mm, samples)] => {
            let setting = SettingFound { pivot_mm: *pivot_mm, samples: samples.clone(), found: found.to_vec() };
            choose_plant_by_pivot(loaded, dof, base, std::slice::from_ref(&setting), data, &held_out, &mut notes)?
        }
        _ => choose_plant(loaded, dof, base, found, data, &held_out, &mut notes)?,
    };
    finish(dof, (j, i, entry), Value::Object(extension), plant, data, (&held_out, &[], &[]), notes)
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
/// [`jointctl_ident::identify::prepare::held_out_window`]). The simulated plant's effects are
/// given by setting (`sim.effects_by_pivot`, the configured settings and the record's): a
/// cause's plant terms are tried at each setting that named it, on that setting's training
/// part, and taken there as [`extend`] takes a cause.
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
    let plant = choose_plant_by_pivot(loaded, dof, configured_plant(entry, i)?, settings, data, &held_out, &mut notes)?;
    let groups: Vec<Vec<usize>> = settings.iter().map(|s| s.samples.clone()).collect();
    let pivots: Vec<f64> = settings.iter().map(|s| s.pivot_mm).collect();
    finish(dof, (j, i, entry), extension, plant, data, (&held_out, &groups, &pivots), notes)
}

/// The observer with `extension` (an empty object: none), the plant `chosen`, and both gains on
/// the `held_out` samples (and on those of each of `groups`, sample indices at the pivot
/// settings `pivots`, when given).
fn finish(dof: &str, (j, i, entry): (usize, usize, &jointctl_config::JointConfig), extension: Value, chosen: PlantChoice, data: &Data, (held_out, groups, pivots): (&[bool], &[Vec<usize>], &[f64]), notes: Vec<String>) -> Result<Extension, ExperimentError> {
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

    let PlantChoice { effects, causes: plant_causes, before: sim_before, after: current } = chosen;
    let gain_on = |mask: &[bool], before: &[f64], after: &[f64]| Gain {
        rmse_before: rmse(&squared_errors(&data.torque, before, mask, true)),
        rmse_after: rmse(&squared_errors(&data.torque, after, mask, true)),
    };
    let gain = |before: &[f64], after: &[f64]| gain_on(held_out, before, after);
    let by_setting = pivots
        .iter()
        .zip(groups)
        .map(|(&pivot_mm, g)| {
            let mut mask = vec![false; data.len()];
            g.iter().for_each(|&i| mask[i] = held_out[i]);
            SettingGain { pivot_mm, simulation: gain_on(&mask, &sim_before, &current), observer: gain_on(&mask, &obs_before, &obs_after) }
        })
        .collect();
    Ok(Extension {
        dof: dof.into(),
        joint_index: j,
        observer_params: params_after,
        plant_effects: effects,
        other_dofs: Vec::new(),
        plant_causes,
        notes,
        simulation: gain(&sim_before, &current),
        observer: gain(&obs_before, &obs_after),
        simulation_trace: trace(data, held_out, &sim_before, &current),
        observer_trace: trace(data, held_out, &obs_before, &obs_after),
        by_setting,
    })
}
