//! The model loop's last step (section 6.2's first recommendation): what `jointctl identify`
//! found in measured data, written as an extended observer (the joint's params with a
//! `model_extension`) and an extended simulation (the joint's `sim.effects`), with the gain of
//! each measured on the data's held-out part.
//!
//! - **Observer**: the recorded deflections through the joint's observer model (its
//!   characteristic and, when it has one, its `model_extension`: the functions the plugins call
//!   online), before and after, against the F/T sensor. `identify` compares the data with the
//!   characteristic alone, so the causes' observer terms together *are* the new extension; an
//!   extension already configured is replaced, never added to.
//! - **Simulation**: the simulated joint's element and effects replayed along the recorded
//!   motion ([`jointctl_sim::unit::Unit::replay`]), before and after, against the F/T sensor. The
//!   causes were named against the observer's model, which need not be the plant's (the
//!   reference arm's plant already holds the hysteresis its observer lacks): a cause's plant
//!   terms go into the simulation only when they make its replay of the *training* part
//!   significantly better (the block t-test of [`jointctl_ident::identify::significance`]); the
//!   held-out part only measures.

use std::path::{Path, PathBuf};

use jointctl_config::{EffectsConfig, LoadedConfig};
use jointctl_ident::csv::Data;
use jointctl_ident::identify::significance::block_test;
use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic};
use jointctl_models::extension::{ExtensionSpec, ModelExtension};
use serde::Serialize;
use serde_json::{Map, Value};

use crate::ExperimentError;

/// The deflection rate's window in the simulation's replay [s]: the observer extension's
/// (assumption, see [`ExtensionSpec::rate_window_s`]).
pub const REPLAY_RATE_WINDOW_S: f64 = 0.02;

/// Plant keys that add to what the simulation has (a linear term's coefficient); every other
/// key replaces.
const ADDITIVE: [&str; 3] = ["viscous_nms_per_rad", "cubic_nm_per_rad3", "torque_offset_nm"];

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

fn err(m: impl Into<String>) -> ExperimentError {
    ExperimentError(m.into())
}

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
fn two_dof(params: &Value) -> bool {
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
    let (given, field) = match params.get("model_extension") {
        Some(Value::Array(list)) => (list.get(dof).cloned(), format!("params.model_extension[{dof}]")),
        other => (other.cloned(), "params.model_extension".to_string()),
    };
    let mut extension = match given {
        None | Some(Value::Null) => None,
        Some(v) => {
            let spec: ExtensionSpec = serde_json::from_value(v).map_err(|e| err(format!("{field}: {e}")))?;
            Some(ModelExtension::new(spec).map_err(|e| err(format!("{field}.{}: {}", e.field, e.message)))?)
        }
    };
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

/// Which samples are held out: those `identify` holds out (see
/// [`jointctl_ident::identify::prepare::split_time`]), so that every gain is measured on data no
/// fit has seen.
fn held_out_mask(t_s: &[f64], train_fraction: f64) -> Vec<bool> {
    let split = jointctl_ident::identify::prepare::split_time(t_s, train_fraction);
    t_s.iter().map(|t| *t >= split).collect()
}

/// Squared errors against the measurement on the samples `mask` selects (NaNs left out).
fn squared_errors(measured: &[f64], model: &[f64], mask: &[bool], want: bool) -> Vec<f64> {
    measured.iter().zip(model).zip(mask).filter(|((m, p), k)| **k == want && m.is_finite() && p.is_finite()).map(|((m, p), _)| (m - p) * (m - p)).collect()
}

fn rmse(sq: &[f64]) -> f64 {
    if sq.is_empty() { f64::NAN } else { (sq.iter().sum::<f64>() / sq.len() as f64).sqrt() }
}

fn trace(data: &Data, mask: &[bool], before: &[f64], after: &[f64]) -> Trace {
    let mut t = Trace::default();
    for k in (0..data.t.len()).filter(|k| mask[*k]) {
        t.t_s.push(data.t[k]);
        t.measured_nm.push(data.torque[k]);
        t.before_nm.push(before[k]);
        t.after_nm.push(after[k]);
    }
    t
}

/// `fragment` merged into `effects`: linear coefficients add, everything else replaces.
fn merge_plant(effects: &Value, fragment: &Map<String, Value>) -> Value {
    let mut out = effects.as_object().cloned().unwrap_or_default();
    for (k, v) in fragment {
        let add = ADDITIVE.contains(&k.as_str()).then(|| out.get(k).and_then(Value::as_f64).unwrap_or(0.0) + v.as_f64().unwrap_or(0.0));
        out.insert(k.clone(), add.map_or_else(|| v.clone(), Value::from));
    }
    Value::Object(out)
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
pub fn extend(loaded: &LoadedConfig, dof: &str, found: &[Found], data: &Data, train_fraction: f64) -> Result<Extension, ExperimentError> {
    let (j, i, entry) = extended_joint(loaded, dof)?;
    let mut notes = Vec::new();
    // The observer: every cause's observer terms together.
    let extension = observer_terms(found, &mut notes);
    finish(loaded, dof, (j, i, entry), Value::Object(extension), found, data, (&held_out_mask(&data.t, train_fraction), &[(0..data.len()).collect()]), notes)
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
/// (its last `1 - train_fraction` of time). The simulated plant's effects are one set for every
/// setting (`sim.effects` has no per-setting form): a cause named at half the settings or more is
/// tried there with its plant terms averaged over them, and taken as [`extend`] takes a cause.
///
/// # Errors
/// As [`extend`]; also settings not in increasing order.
pub fn extend_by_pivot(loaded: &LoadedConfig, dof: &str, settings: &[SettingFound], data: &Data, train_fraction: f64) -> Result<Extension, ExperimentError> {
    let (j, i, entry) = extended_joint(loaded, dof)?;
    if let Some(w) = settings.windows(2).find(|w| !(w[1].pivot_mm > w[0].pivot_mm)) {
        return Err(err(format!("the settings must be in increasing pivot order, got {} mm after {} mm", w[1].pivot_mm, w[0].pivot_mm)));
    }
    let mut notes = Vec::new();
    let mut by_pivot = Vec::new();
    let mut held_out = vec![false; data.len()];
    for SettingFound { pivot_mm, samples, found } in settings {
        let t: Vec<f64> = samples.iter().map(|&i| data.t[i]).collect();
        let split = jointctl_ident::identify::prepare::split_time(&t, train_fraction);
        for (&i, &t) in samples.iter().zip(&t) {
            held_out[i] = t >= split;
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

/// Effects without the keys that are off (zero or none), for a readable file.
fn tidy(effects: &Value) -> Value {
    let mut out = effects.as_object().cloned().unwrap_or_default();
    out.retain(|_, v| !(v.is_null() || v.as_f64() == Some(0.0)));
    Value::Object(out)
}

/// The files [`write`] writes.
#[derive(Clone, Debug)]
pub struct Written {
    /// The joint's complete params (`params: {include: ...}` alone configures it).
    pub observer: PathBuf,
    /// The joint's `sim.effects`.
    pub plant: PathBuf,
    /// The config with both in place (and the loop's `hal.sim` values).
    pub extended: PathBuf,
    /// The loop's `hal.sim` values (`loop.yaml`), when a closed-loop recording named causes in
    /// the loop.
    pub loop_sim: Option<PathBuf>,
}

/// Paths a config writes relative to its own folder, made absolute, so that the extended config
/// in another folder names the same files.
fn absolute_paths(doc: &mut serde_yaml::Value, config: &Path) {
    let dir = std::path::absolute(config).ok().and_then(|p| p.parent().map(Path::to_path_buf)).unwrap_or_default();
    let fix = |v: &mut serde_yaml::Value| {
        if let Some(s) = v.as_str()
            && Path::new(s).is_relative()
        {
            *v = serde_yaml::Value::from(dir.join(s).display().to_string());
        }
    };
    if let Some(dirs) = doc.get_mut("plugin_dirs").and_then(|d| d.as_sequence_mut()) {
        dirs.iter_mut().for_each(fix);
    }
    if let Some(urdf) = doc.get_mut("kinematics").and_then(|k| k.get_mut("urdf")) {
        fix(urdf);
    }
    if let Some(joints) = doc.get_mut("joints").and_then(|j| j.as_sequence_mut()) {
        for joint in joints {
            if let Some(path) = joint.get_mut("plugin").and_then(|p| p.get_mut("path")) {
                fix(path);
            }
            if let Some(include) = joint.get_mut("params").and_then(|p| p.get_mut("include")) {
                fix(include);
            }
        }
    }
}

/// Writes `dir/observer.yaml`, `dir/plant.yaml` and `dir/extended.yaml` (the config with the
/// joint's params `{include: observer.yaml}`, its `sim.effects` those of `plant.yaml` and the
/// `hal.sim` keys of `loop_sim`, the causes in the loop, also written to `dir/loop.yaml` when
/// there are any), and checks that the last loads.
///
/// # Errors
/// A file cannot be read or written, or the extended config does not load (said with its error).
pub fn write(ext: &Extension, loaded: &LoadedConfig, dir: &Path, provenance: &str, loop_sim: &Map<String, Value>) -> Result<Written, ExperimentError> {
    std::fs::create_dir_all(dir).map_err(|e| err(format!("cannot create {}: {e}", dir.display())))?;
    let config = &loaded.source.file;
    let yaml = |v: &Value| serde_yaml::to_string(v).map_err(|e| err(e.to_string()));
    let written = Written {
        observer: dir.join("observer.yaml"),
        plant: dir.join("plant.yaml"),
        extended: dir.join("extended.yaml"),
        loop_sim: (!loop_sim.is_empty()).then(|| dir.join("loop.yaml")),
    };
    let put = |path: &Path, text: String| std::fs::write(path, text).map_err(|e| err(format!("cannot write {}: {e}", path.display())));
    put(
        &written.observer,
        format!("# The complete params of `{}`'s joint in {}, with the observer's model extension {provenance}.\n# Use: params: {{include: observer.yaml}}\n{}", ext.dof, config.display(), yaml(&versioned(&ext.observer_params))?),
    )?;
    put(&written.plant, format!("# `sim.effects` of `{}`'s joint in {}, extended {provenance}.\n{}", ext.dof, config.display(), yaml(&ext.plant_effects)?))?;
    let text = jointctl_files::read_to_string(config, jointctl_files::FileKind::Config).map_err(|e| err(e.to_string()))?;
    let mut doc: serde_yaml::Value = serde_yaml::from_str(&text).map_err(|e| err(format!("{}: {e}", config.display())))?;
    absolute_paths(&mut doc, config);
    // Written in this jointctl's format, whatever the original's was.
    if let Some(m) = doc.as_mapping_mut() {
        m.insert("version".into(), jointctl_config::FORMAT_VERSION.into());
    }
    let joint = doc.get_mut("joints").and_then(|j| j.get_mut(ext.joint_index)).ok_or_else(|| err(format!("{}: no joints[{}]", config.display(), ext.joint_index)))?;
    let mut params = serde_yaml::Mapping::new();
    params.insert("include".into(), "observer.yaml".into());
    joint["params"] = serde_yaml::Value::Mapping(params);
    let effects: serde_yaml::Value = serde_yaml::to_value(&ext.plant_effects).map_err(|e| err(e.to_string()))?;
    let entry = &loaded.config.joints[ext.joint_index];
    let per_dof = entry.sim.as_ref().is_some_and(|s| !s.effects_per_dof.is_empty());
    let i = entry.dof_names().iter().position(|n| *n == ext.dof).unwrap_or(0);
    match joint.get_mut("sim") {
        // A joint with a set of effects per DOF: this DOF's.
        Some(sim) if per_dof => match sim.get_mut("effects_per_dof").and_then(|l| l.get_mut(i)) {
            Some(slot) => *slot = effects,
            None => return Err(err(format!("{}: joints[{}].sim.effects_per_dof has no entry {i}", config.display(), ext.joint_index))),
        },
        Some(sim) => sim["effects"] = effects,
        None => return Err(err(format!("{}: joints[{}] has no sim section", config.display(), ext.joint_index))),
    }
    if let Some(path) = &written.loop_sim {
        let fragment: serde_yaml::Value = serde_yaml::to_value(loop_sim).map_err(|e| err(e.to_string()))?;
        put(path, format!("# `hal.sim` values of {} identified in the loop {provenance}.\n{}", config.display(), serde_yaml::to_string(&fragment).map_err(|e| err(e.to_string()))?))?;
        let hal = doc.as_mapping_mut().ok_or_else(|| err(format!("{}: not a mapping", config.display())))?.entry("hal".into()).or_insert_with(|| serde_yaml::Value::Mapping(Default::default()));
        let sim = hal.as_mapping_mut().ok_or_else(|| err(format!("{}: hal is not a mapping", config.display())))?.entry("sim".into()).or_insert_with(|| serde_yaml::Value::Mapping(Default::default()));
        merge_yaml(sim, &fragment);
    }
    put(
        &written.extended,
        format!("# {} with `{}`'s observer (observer.yaml) and simulation (plant.yaml) extended {provenance}.\n# Written, not edited: the original's comments are in the original.\n{}", config.display(), ext.dof, serde_yaml::to_string(&doc).map_err(|e| err(e.to_string()))?),
    )?;
    jointctl_config::load(&written.extended).map_err(|e| err(format!("the extended config does not load: {e}")))?;
    Ok(written)
}

/// `params` with this jointctl's file format first (`version:`), for a file a joint includes.
fn versioned(params: &Value) -> Value {
    match params {
        Value::Object(m) => {
            let mut out = Map::new();
            out.insert("version".into(), jointctl_config::FORMAT_VERSION.into());
            out.extend(m.iter().filter(|(k, _)| *k != "version").map(|(k, v)| (k.clone(), v.clone())));
            Value::Object(out)
        }
        other => other.clone(),
    }
}

/// `from`'s keys into `into`, mappings merged key by key (`elmo: {max_acceleration_rad_s2}`
/// keeps the drive's other settings).
fn merge_yaml(into: &mut serde_yaml::Value, from: &serde_yaml::Value) {
    match (into.as_mapping_mut(), from.as_mapping()) {
        (Some(a), Some(b)) => {
            for (k, v) in b {
                match a.get_mut(k) {
                    Some(existing) if existing.is_mapping() && v.is_mapping() => merge_yaml(existing, v),
                    _ => {
                        a.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        _ => *into = from.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_loops_values_merge_into_hal_sim_and_keep_the_rest() {
        let mut sim: serde_yaml::Value = serde_yaml::from_str("{seed: 1, can_latency_s: 0.03, elmo: {kp: 10.0, max_acceleration_rad_s2: 30.0}}").unwrap();
        merge_yaml(&mut sim, &serde_yaml::from_str("{can_latency_s: 0.05, elmo: {max_acceleration_rad_s2: 8.0}}").unwrap());
        assert_eq!(sim, serde_yaml::from_str::<serde_yaml::Value>("{seed: 1, can_latency_s: 0.05, elmo: {kp: 10.0, max_acceleration_rad_s2: 8.0}}").unwrap());
    }

    #[test]
    fn linear_plant_terms_add_and_the_others_replace() {
        let effects = serde_json::json!({"viscous_nms_per_rad": 0.1, "hysteresis": {"sigma_nm_per_rad": 100.0, "limit_nm": 0.2}});
        let fragment: Map<String, Value> = serde_json::from_value(serde_json::json!({"viscous_nms_per_rad": 0.5, "hysteresis": {"sigma_nm_per_rad": 300.0, "limit_nm": 1.0}, "dead_zone_rad": 0.01})).unwrap();
        let merged = merge_plant(&effects, &fragment);
        assert!((merged["viscous_nms_per_rad"].as_f64().unwrap() - 0.6).abs() < 1e-12);
        assert_eq!(merged["hysteresis"]["limit_nm"], 1.0);
        assert_eq!(merged["dead_zone_rad"], 0.01);
    }

    #[test]
    fn the_held_out_part_is_identifys_last_thirty_per_cent_of_the_time_range() {
        let t: Vec<f64> = (0..=10).map(f64::from).collect();
        let mask = held_out_mask(&t, 0.7);
        assert_eq!(mask.iter().filter(|m| **m).count(), 4);
        assert!(!mask[6] && mask[7]);
    }
}
