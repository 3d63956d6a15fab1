//! Which causes' plant terms the simulation takes: each tried in turn on the training part, and
//! taken when the replay is significantly better there (the block t-test of
//! [`jointctl_ident::identify::significance`]); for one record, or at each pivot setting of a
//! record of several.

use jointctl_config::{LoadedConfig, PivotEffectsConfig};
use jointctl_ident::csv::{Data, SETTING_GAP_MM};
use jointctl_ident::identify::significance::{BlockTest, block_test};
use serde_json::Value;

use super::err;
use super::found::{Found, SettingFound};
use super::gain::squared_errors;
use super::simulation::{PlantEffects, merge_plant, simulated_torque};
use crate::ExperimentError;

/// The plant effects with the terms taken, the causes taken, and the replays before and after.
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

/// The record and the DOF the causes are tried on.
struct Trials<'a> {
    loaded: &'a LoadedConfig,
    dof: &'a str,
    data: &'a Data,
}

impl Trials<'_> {
    fn replay(&self, effects: &PlantEffects) -> Result<Vec<f64>, ExperimentError> {
        simulated_torque(self.loaded, self.dof, effects, &self.data.t, &self.data.deflection, &self.data.pivot_mm)
    }

    /// `candidate`'s replay against the `current` one on the samples of `mask`: the replay when
    /// it is significantly better there, else the test that says why not.
    fn try_candidate(&self, current: &[f64], candidate: &PlantEffects, mask: &[bool]) -> Result<Result<Vec<f64>, BlockTest>, ExperimentError> {
        let tried = self.replay(candidate)?;
        let (a, b) = (squared_errors(&self.data.torque, current, mask, true), squared_errors(&self.data.torque, &tried, mask, true));
        let test = block_test(&a.iter().zip(&b).map(|(a, b)| a - b).collect::<Vec<f64>>());
        Ok(if test.significant() { Ok(tried) } else { Err(test) })
    }
}

/// The note of a cause without plant terms.
fn no_term(effect: &str, at: &str) -> String {
    format!("`{effect}`{at} has no simulation term (the simulated plant has its own curve)")
}

/// The note of a cause left out of the simulation.
fn left_out(effect: &str, at: &str, t: &BlockTest) -> String {
    format!(
        "`{effect}`{at} left out of the simulation: its plant terms do not make the replay of the training part significantly better (block t = {:.2} < {:.2}); the simulation already has it or it is the observer's alone",
        t.t, t.critical
    )
}

/// Each cause's plant terms merged into `base` (at every setting, when it is by setting) and
/// tried in turn on the training part (the samples not `held_out`).
pub(super) fn choose_plant(loaded: &LoadedConfig, dof: &str, base: PlantEffects, found: &[Found], data: &Data, held_out: &[bool], notes: &mut Vec<String>) -> Result<PlantChoice, ExperimentError> {
    let trials = Trials { loaded, dof, data };
    let before = trials.replay(&base)?;
    let training: Vec<bool> = held_out.iter().map(|h| !h).collect();
    let (mut effects, mut replayed) = (base, before.clone());
    let mut causes = Vec::new();
    for f in found {
        if f.plant.is_empty() {
            notes.push(no_term(&f.effect, ""));
            continue;
        }
        let candidate = match &effects {
            PlantEffects::One(v) => PlantEffects::One(merge_plant(v, &f.plant)),
            PlantEffects::ByPivot(list) => PlantEffects::ByPivot(list.iter().map(|(pivot, v)| (*pivot, merge_plant(v, &f.plant))).collect()),
        };
        match trials.try_candidate(&replayed, &candidate, &training)? {
            Ok(tried) => {
                (effects, replayed) = (candidate, tried);
                causes.push(f.effect.clone());
            }
            Err(test) => notes.push(left_out(&f.effect, "", &test)),
        }
    }
    Ok(PlantChoice { effects, causes, before, after: replayed })
}

/// One set of effects per pivot setting (`sim.effects_by_pivot`): the configured settings and
/// the record's ([`with_settings`]: the same plant, so the replay starts where the configured
/// one is). At each of the record's settings (or the configured one it is), each cause
/// named there is tried in turn with its plant terms at that setting, on that setting's training
/// part. Each setting is its own experiment: blocks of different settings differ in gain, and
/// one block test over all of them reads that spread as noise (three settings whose replays each
/// fell 0.33-0.81 -> 0.05-0.06 Nm gave t = 1.99). With no cause taken, or a simulated joint
/// without a pivot (its effects cannot follow a setting: said in `notes`), the configured
/// effects stay.
pub(super) fn choose_plant_by_pivot(loaded: &LoadedConfig, dof: &str, base: PlantEffects, settings: &[SettingFound], data: &Data, held_out: &[bool], notes: &mut Vec<String>) -> Result<PlantChoice, ExperimentError> {
    let trials = Trials { loaded, dof, data };
    let before = trials.replay(&base)?;
    let (j, _) = crate::locate(loaded, dof)?;
    if loaded.config.joints[j].sim.as_ref().is_none_or(|s| s.pivot.is_none()) {
        notes.push("the simulated joint has no `pivot`: its effects cannot follow a setting, and the simulation stays as configured".into());
        return Ok(PlantChoice { effects: base, causes: Vec::new(), after: before.clone(), before });
    }
    let mut list = with_settings(&base, &settings.iter().map(|s| s.pivot_mm).collect::<Vec<_>>())?;
    let mut replayed = trials.replay(&PlantEffects::ByPivot(list.clone()))?;
    let mut causes = Vec::new();
    for s in settings {
        let mut training = vec![false; data.len()];
        s.samples.iter().for_each(|&i| training[i] = !held_out[i]);
        let at = format!(" at {:.1} mm", s.pivot_mm);
        for f in &s.found {
            if f.plant.is_empty() {
                notes.push(no_term(&f.effect, &at));
                continue;
            }
            let mut candidate = list.clone();
            if let Some(entry) = candidate.iter_mut().filter(|(p, _)| same_setting(*p, s.pivot_mm)).min_by(|a, b| (a.0 - s.pivot_mm).abs().total_cmp(&(b.0 - s.pivot_mm).abs())) {
                entry.1 = merge_plant(&entry.1, &f.plant);
            }
            match trials.try_candidate(&replayed, &PlantEffects::ByPivot(candidate.clone()), &training)? {
                Ok(tried) => {
                    (list, replayed) = (candidate, tried);
                    causes.push(format!("{}{at}", f.effect));
                }
                Err(test) => notes.push(left_out(&f.effect, &at, &test)),
            }
        }
    }
    if causes.is_empty() {
        return Ok(PlantChoice { effects: base, causes, after: before.clone(), before });
    }
    Ok(PlantChoice { effects: PlantEffects::ByPivot(list), causes, before, after: replayed })
}

/// Two pivot settings [mm] within [`SETTING_GAP_MM`] of each other are one (as the record's
/// holds are): a record identified again on an extended config finds its settings a hair off.
fn same_setting(a: f64, b: f64) -> bool {
    (a - b).abs() <= SETTING_GAP_MM
}

/// `base` by setting: its own settings (none for one set) and those of `pivots` [mm] that are
/// not one of them, each with `base`'s effects there, in increasing order: the same plant as
/// `base`.
pub(super) fn with_settings(base: &PlantEffects, pivots: &[f64]) -> Result<Vec<(f64, Value)>, ExperimentError> {
    let mut list = match base {
        PlantEffects::One(_) => Vec::new(),
        PlantEffects::ByPivot(list) => list.clone(),
    };
    for &pivot_mm in pivots {
        if !list.iter().any(|(p, _)| same_setting(*p, pivot_mm)) {
            let there = match base {
                PlantEffects::One(v) => v.clone(),
                PlantEffects::ByPivot(configured) => at_setting(configured, pivot_mm)?,
            };
            list.push((pivot_mm, there));
        }
    }
    list.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(list)
}

/// The effects of a DOF's list by setting at `pivot_mm`, interpolated as the simulation does.
fn at_setting(list: &[(f64, Value)], pivot_mm: f64) -> Result<Value, ExperimentError> {
    let parsed = list
        .iter()
        .enumerate()
        .map(|(k, (p, v))| Ok(PivotEffectsConfig { pivot_mm: *p, effects: serde_json::from_value(v.clone()).map_err(|e| err(format!("effects_by_pivot[{k}]: {e}")))?, effects_per_dof: Vec::new() }))
        .collect::<Result<Vec<_>, ExperimentError>>()?;
    serde_json::to_value(jointctl_sim::pivot_effects::effects_at(&parsed, pivot_mm, 0)).map_err(|e| err(e.to_string()))
}

