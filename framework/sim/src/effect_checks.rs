//! Plant effects refused before they run: not numbers, not physical, or by pivot setting out of
//! order, each error naming its field (`(field, message)`, as [`crate::unit::UnitError`]); and
//! which model effects a simulated joint carries ([`effects_in`], [`joint_effects`]).

use jointctl_config::{EffectsConfig, ElementSimConfig, JointSimConfig, PivotEffectsConfig};
use jointctl_models::effect::Effect;

/// The model effects `fx` carries, in [`Effect::ALL`]'s order: those with one of their
/// [`Effect::plant_keys`] set ([`jointctl_models::effect::effects_set`]: a table, or a finite
/// number other than zero). The keys are looked up by name in `sim.effects` as it is written,
/// so an effect added to the typed list on existing keys needs no code here.
///
/// ```
/// use jointctl_config::EffectsConfig;
/// use jointctl_models::effect::Effect;
/// let fx = EffectsConfig { viscous_nms_per_rad: 0.2, torque_noise_nm: 0.01, ..Default::default() };
/// assert_eq!(jointctl_sim::effect_checks::effects_in(&fx), [Effect::ViscousFriction]);
/// ```
pub fn effects_in(fx: &EffectsConfig) -> Vec<Effect> {
    let (Ok(these), Ok(defaults)) = (serde_json::to_value(fx), serde_json::to_value(EffectsConfig::default())) else { return Vec::new() };
    jointctl_models::effect::effects_set(Effect::plant_keys, &these, &defaults)
}

/// The model effects a simulated joint carries anywhere: its `effects`, each DOF's, each pivot
/// setting's, and its element's own play (`dead_zone_rad` of a lever-arm element), in
/// [`Effect::ALL`]'s order, each once.
pub fn joint_effects(sim: &JointSimConfig) -> Vec<Effect> {
    let by_pivot = sim.effects_by_pivot.iter().flat_map(|s| std::iter::once(&s.effects).chain(&s.effects_per_dof));
    let element_play = |e: &ElementSimConfig| matches!(e, ElementSimConfig::LeverArm { dead_zone_rad, .. } | ElementSimConfig::WristLeverArm { dead_zone_rad, .. } if *dead_zone_rad > 0.0);
    let play = sim.element.iter().chain(&sim.elements).any(element_play).then_some(Effect::DeadZone);
    jointctl_models::effect::in_order(std::iter::once(&sim.effects).chain(&sim.effects_per_dof).chain(by_pivot).flat_map(effects_in).chain(play))
}

/// Refuses plant effects that are not numbers or not physical (a negative friction, a noise of
/// negative spread), naming the field: a NaN here would run as a plant that is silently wrong.
pub fn check_effects(fx: &EffectsConfig) -> Result<(), (String, String)> {
    let mut values = vec![
        ("viscous_nms_per_rad", fx.viscous_nms_per_rad, true),
        ("dead_zone_rad", fx.dead_zone_rad, true),
        ("dead_zone_ramp_rad", fx.dead_zone_ramp_rad, true),
        ("cubic_nm_per_rad3", fx.cubic_nm_per_rad3, false),
        ("torque_offset_nm", fx.torque_offset_nm, false),
        ("torque_noise_nm", fx.torque_noise_nm, true),
    ];
    if let Some(f) = fx.arctan_friction {
        values.extend([("arctan_friction.k_a_nm", f.k_a_nm, true), ("arctan_friction.k_b_s_per_rad", f.k_b_s_per_rad, true)]);
    }
    if let Some(h) = fx.hysteresis {
        values.extend([("hysteresis.sigma_nm_per_rad", h.sigma_nm_per_rad, true), ("hysteresis.limit_nm", h.limit_nm, true), ("hysteresis.presliding_damping_s", h.presliding_damping_s, true)]);
        if !(h.shape >= 1.0 && h.shape <= jointctl_models::extension::MAX_LOOP_SHAPE) {
            return Err(("hysteresis.shape".into(), format!("must be between 1 and {}, got {}", jointctl_models::extension::MAX_LOOP_SHAPE, h.shape)));
        }
    }
    if let Some(m) = fx.vibration {
        values.extend([("vibration.frequency_hz", m.frequency_hz, true), ("vibration.damping_ratio", m.damping_ratio, true), ("vibration.gain", m.gain, false)]);
        if let Some(k) = m.reference_stiffness_nm_per_rad
            && !(k.is_finite() && k > 0.0)
        {
            return Err(("vibration.reference_stiffness_nm_per_rad".into(), format!("must be a finite number > 0, got {k}")));
        }
    }
    for (name, v, non_negative) in values {
        if !v.is_finite() || (non_negative && v < 0.0) {
            return Err((name.into(), format!("must be a finite number{}, got {v}", if non_negative { " >= 0" } else { "" })));
        }
    }
    if fx.dead_zone_ramp_rad > fx.dead_zone_rad {
        return Err(("dead_zone_ramp_rad".into(), format!("must be at most dead_zone_rad ({}), got {}", fx.dead_zone_rad, fx.dead_zone_ramp_rad)));
    }
    if fx.hysteresis.is_some_and(|h| h.limit_nm == 0.0) {
        return Err(("hysteresis.limit_nm".into(), "must be > 0 (the Dahl state is scaled by it)".into()));
    }
    Ok(())
}

/// Refuses a list of settings out of increasing `pivot_mm` order, one whose effects
/// [`check_effects`] refuses, or one with both forms or a set per DOF for other than `dofs`
/// DOFs, naming the entry (`[2].pivot_mm`, `[0].effects.viscous_nms_per_rad`).
pub fn check_effects_by_pivot(settings: &[PivotEffectsConfig], dofs: usize) -> Result<(), (String, String)> {
    for (k, s) in settings.iter().enumerate() {
        if !s.pivot_mm.is_finite() {
            return Err((format!("[{k}].pivot_mm"), format!("must be a finite number, got {}", s.pivot_mm)));
        }
        if k > 0 && !(s.pivot_mm > settings[k - 1].pivot_mm) {
            return Err((format!("[{k}].pivot_mm"), format!("must be above the setting before ({} mm): give the settings in increasing pivot order, got {} mm", settings[k - 1].pivot_mm, s.pivot_mm)));
        }
        check_effects(&s.effects).map_err(|(f, m)| (format!("[{k}].effects.{f}"), m))?;
        if !s.effects_per_dof.is_empty() && s.effects != EffectsConfig::default() {
            return Err((format!("[{k}].effects"), "give `effects` (every DOF) or `effects_per_dof`, not both".into()));
        }
        if !s.effects_per_dof.is_empty() && s.effects_per_dof.len() != dofs {
            return Err((format!("[{k}].effects_per_dof"), format!("give one set per DOF ({dofs}), got {}", s.effects_per_dof.len())));
        }
        for (i, fx) in s.effects_per_dof.iter().enumerate() {
            check_effects(fx).map_err(|(f, m)| (format!("[{k}].effects_per_dof[{i}].{f}"), m))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every plant key of the typed list is a field of `sim.effects`: a key it does not have
    /// would be refused when the model loop writes what `identify` found into the plant.
    #[test]
    fn every_plant_key_is_a_field_of_sim_effects() {
        let serde_json::Value::Object(fields) = serde_json::to_value(EffectsConfig::default()).unwrap() else { panic!("sim.effects is a table") };
        for e in Effect::ALL {
            for key in e.plant_keys() {
                assert!(fields.contains_key(*key), "{e}: `{key}` is not a field of sim.effects");
            }
        }
    }

    #[test]
    fn a_joints_effects_are_gathered_from_every_form() {
        let fx = |yaml: &str| -> EffectsConfig { serde_yaml::from_str(yaml).unwrap() };
        let sim: JointSimConfig = serde_yaml::from_str("drives: [a]\nmatrix: [[1.0]]\neffects: {dead_zone_rad: 0.01}\neffects_by_pivot: [{pivot_mm: 10, effects: {hysteresis: {sigma_nm_per_rad: 100, limit_nm: 0.5}}}]").unwrap();
        assert_eq!(joint_effects(&sim), [Effect::Hysteresis, Effect::DeadZone]);
        // The element's own play, and a structural mode.
        let sim: JointSimConfig = serde_yaml::from_str("drives: [a]\nmatrix: [[1.0]]\nelement: {kind: lever_arm, lever_length_m: 0.1, crank_radius_m: 0.02, spring_n_per_m: 5000, pivot_offset_m: 0.01, dead_zone_rad: 0.02}\neffects: {vibration: {frequency_hz: 18, damping_ratio: 0.05, gain: 0.1}}").unwrap();
        assert_eq!(joint_effects(&sim), [Effect::DeadZone, Effect::Vibration]);
        // A number that is not finite sets nothing (the checks refuse it).
        assert!(effects_in(&EffectsConfig { viscous_nms_per_rad: f64::NAN, ..Default::default() }).is_empty());
        assert_eq!(effects_in(&fx("{arctan_friction: {k_a_nm: 0.1, k_b_s_per_rad: 20}, torque_offset_nm: -0.3}")), [Effect::CoulombFriction, Effect::SensorOffset]);
        assert!(effects_in(&fx("{torque_noise_nm: 0.01}")).is_empty());
    }
}
