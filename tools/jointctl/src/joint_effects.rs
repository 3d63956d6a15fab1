//! The model effects a joint carries, for `jointctl check`: those of its simulated plant
//! (`sim.effects`, per DOF, by pivot) and of its observer (`model_extension`), both read through
//! the one typed list of effects (`jointctl_models::effect`), under the names `identify` reports.

use jointctl_config::LoadedConfig;
use jointctl_models::effect::Effect;
use jointctl_models::extension::ExtensionSpec;

/// One line for joint `joint`, or `None` when neither side carries an effect. A
/// `model_extension` is one spec or one per DOF (the wrist's list, `null` for none); the
/// plugin has checked it when the arm was built, so one that does not read is left out here.
pub fn line(loaded: &LoadedConfig, joint: &str) -> Option<String> {
    let entry = loaded.config.joints.iter().find(|j| j.name == joint)?;
    let plant = entry.sim.as_ref().map(jointctl_sim::effect_checks::joint_effects).unwrap_or_default();
    let specs: Vec<ExtensionSpec> = match entry.params.0.get("model_extension") {
        Some(serde_json::Value::Array(per_dof)) => per_dof.iter().filter_map(|v| serde_json::from_value(v.clone()).ok()).collect(),
        Some(v) => serde_json::from_value(v.clone()).into_iter().collect(),
        None => Vec::new(),
    };
    let observer = jointctl_models::effect::in_order(specs.iter().flat_map(ExtensionSpec::effects));
    if plant.is_empty() && observer.is_empty() {
        return None;
    }
    Some(format!("model effects in the simulated plant: {}; in the observer: {}", names(&plant), names(&observer)))
}

fn names(effects: &[Effect]) -> String {
    if effects.is_empty() {
        return "none".into();
    }
    effects.iter().map(|e| e.name()).collect::<Vec<_>>().join(", ")
}
