//! Writing the extension: the observer's params, the plant's effects and the extended config
//! that includes both (checked to load).

use std::path::{Path, PathBuf};

use jointctl_config::LoadedConfig;
use serde_json::{Map, Value};

use super::err;
use super::extension::Extension;
use crate::ExperimentError;

/// The files [`write`] writes.
#[derive(Clone, Debug)]
pub struct Written {
    /// The joint's complete params (`params: {include: ...}` alone configures it).
    pub observer: PathBuf,
    /// The joint's `sim.effects`, `sim.effects_per_dof` or `sim.effects_by_pivot`.
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
/// joint's params `{include: observer.yaml}`, its `sim.effects`, `effects_per_dof` or `effects_by_pivot` those of `plant.yaml` and the
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
    let entry = &loaded.config.joints[ext.joint_index];
    let i = entry.dof_names().iter().position(|n| *n == ext.dof).unwrap_or(0);
    let (key, effects) = match entry.sim.as_ref() {
        Some(sim) => super::simulation::with_other_dofs(sim, ext.other_dofs.iter().map(|o| (o.index, &o.effects))).and_then(|sim| ext.plant_effects.joint_effects(&sim, i))?.yaml_entry()?,
        None => return Err(err(format!("{}: joints[{}] has no sim section", config.display(), ext.joint_index))),
    };
    put(&written.plant, format!("# `sim.{key}` of `{}`'s joint in {}, extended {provenance}.\n{}", ext.dof, config.display(), yaml(&effects)?))?;
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
    let effects: serde_yaml::Value = serde_yaml::to_value(&effects).map_err(|e| err(e.to_string()))?;
    match joint.get_mut("sim").and_then(|sim| sim.as_mapping_mut()) {
        // The DOF's effects in the form they take (one set, one per DOF, or by setting), the
        // other forms gone.
        Some(sim) => {
            for other in ["effects", "effects_per_dof", "effects_by_pivot"].into_iter().filter(|k| *k != key) {
                sim.remove(other);
            }
            sim.insert(key.into(), effects);
        }
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
        format!("# {} with `{}`'s observer (observer.yaml) and simulation (plant.yaml) extended {provenance}.\n# Written, not edited: the original's comments are in the original.\n{}", config.display(), extended_dofs(ext), serde_yaml::to_string(&doc).map_err(|e| err(e.to_string()))?),
    )?;
    jointctl_config::load(&written.extended).map_err(|e| err(format!("the extended config does not load: {e}")))?;
    Ok(written)
}

/// The DOFs an extension changes, for the files' headers: its own, and its joint's others whose
/// effects change too.
fn extended_dofs(ext: &Extension) -> String {
    std::iter::once(ext.dof.as_str()).chain(ext.other_dofs.iter().map(|o| o.dof.as_str())).collect::<Vec<_>>().join("` and `")
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
pub(super) fn merge_yaml(into: &mut serde_yaml::Value, from: &serde_yaml::Value) {
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
