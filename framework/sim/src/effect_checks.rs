//! Plant effects refused before they run: not numbers, not physical, or by pivot setting out of
//! order, each error naming its field (`(field, message)`, as [`crate::unit::UnitError`]).

use jointctl_config::{EffectsConfig, PivotEffectsConfig};

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
        values.extend([("hysteresis.sigma_nm_per_rad", h.sigma_nm_per_rad, true), ("hysteresis.limit_nm", h.limit_nm, true)]);
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
