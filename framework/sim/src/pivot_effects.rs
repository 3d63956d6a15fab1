//! Plant effects that change with a VSA's pivot setting (`sim.effects_by_pivot`): the set at the
//! current pivot, interpolated linearly between the two given settings around it, as the
//! characteristic's curves are (section 3.4's table over settings).

use jointctl_config::{EffectsConfig, PivotEffectsConfig};

/// DOF `dof`'s effects at `pivot_mm` [mm]: linear between the two settings of `settings`
/// (increasing `pivot_mm`) around it, the nearest one's beyond the first or last, none when
/// `settings` is empty. An optional effect present at one of the two settings only fades out
/// towards the other: its size (a loop's limit and rest stiffness, a friction's `k_a`, a mode's
/// gain) goes to zero there while its shape stays.
///
/// ```
/// use jointctl_config::{EffectsConfig, PivotEffectsConfig};
/// let at = |pivot_mm, viscous| PivotEffectsConfig { pivot_mm, effects: EffectsConfig { viscous_nms_per_rad: viscous, ..Default::default() }, effects_per_dof: Vec::new() };
/// let settings = [at(10.0, 2.0), at(30.0, 6.0)];
/// assert_eq!(jointctl_sim::pivot_effects::effects_at(&settings, 15.0, 0).viscous_nms_per_rad, 3.0);
/// assert_eq!(jointctl_sim::pivot_effects::effects_at(&settings, 40.0, 0).viscous_nms_per_rad, 6.0);
/// ```
pub fn effects_at(settings: &[PivotEffectsConfig], pivot_mm: f64, dof: usize) -> EffectsConfig {
    let (Some(first), Some(last)) = (settings.first(), settings.last()) else { return EffectsConfig::default() };
    if !(pivot_mm > first.pivot_mm) {
        return first.of_dof(dof);
    }
    if pivot_mm >= last.pivot_mm {
        return last.of_dof(dof);
    }
    // The first setting above the pivot, and the one before it.
    let k = settings.iter().position(|s| s.pivot_mm > pivot_mm).unwrap_or(settings.len() - 1);
    let (a, b) = (&settings[k - 1], &settings[k]);
    interpolate(&a.of_dof(dof), &b.of_dof(dof), (pivot_mm - a.pivot_mm) / (b.pivot_mm - a.pivot_mm))
}

/// `a` at `w = 0`, `b` at `w = 1`, every number linear in between.
fn interpolate(a: &EffectsConfig, b: &EffectsConfig, w: f64) -> EffectsConfig {
    let lerp = |x: f64, y: f64| x + (y - x) * w;
    // An optional effect on one side only: the other side's is the same effect scaled to zero.
    fn pair<T: Copy>(a: Option<T>, b: Option<T>, zero: impl Fn(T) -> T) -> Option<(T, T)> {
        match (a, b) {
            (Some(a), Some(b)) => Some((a, b)),
            (Some(a), None) => Some((a, zero(a))),
            (None, Some(b)) => Some((zero(b), b)),
            (None, None) => None,
        }
    }
    let mut out = EffectsConfig {
        viscous_nms_per_rad: lerp(a.viscous_nms_per_rad, b.viscous_nms_per_rad),
        dead_zone_rad: lerp(a.dead_zone_rad, b.dead_zone_rad),
        dead_zone_ramp_rad: lerp(a.dead_zone_ramp_rad, b.dead_zone_ramp_rad),
        cubic_nm_per_rad3: lerp(a.cubic_nm_per_rad3, b.cubic_nm_per_rad3),
        torque_offset_nm: lerp(a.torque_offset_nm, b.torque_offset_nm),
        torque_noise_nm: lerp(a.torque_noise_nm, b.torque_noise_nm),
        ..EffectsConfig::default()
    };
    out.arctan_friction = pair(a.arctan_friction, b.arctan_friction, |f| jointctl_config::ArctanFrictionConfig { k_a_nm: 0.0, ..f })
        .map(|(x, y)| jointctl_config::ArctanFrictionConfig { k_a_nm: lerp(x.k_a_nm, y.k_a_nm), k_b_s_per_rad: lerp(x.k_b_s_per_rad, y.k_b_s_per_rad) });
    // A Dahl loop scaled by s in both its limit and rest stiffness is the same loop's state
    // times s; at size zero it is no loop (its state is divided by the limit).
    out.hysteresis = pair(a.hysteresis, b.hysteresis, |h| jointctl_config::DahlConfig { sigma_nm_per_rad: 0.0, limit_nm: 0.0, ..h })
        .map(|(x, y)| jointctl_config::DahlConfig {
            sigma_nm_per_rad: lerp(x.sigma_nm_per_rad, y.sigma_nm_per_rad),
            limit_nm: lerp(x.limit_nm, y.limit_nm),
            shape: lerp(x.shape, y.shape),
            presliding_damping_s: lerp(x.presliding_damping_s, y.presliding_damping_s),
        })
        .filter(|h| h.limit_nm > 0.0);
    out.vibration = pair(a.vibration, b.vibration, |m| jointctl_config::VibrationConfig { gain: 0.0, ..m }).map(|(x, y)| jointctl_config::VibrationConfig {
        frequency_hz: lerp(x.frequency_hz, y.frequency_hz),
        damping_ratio: lerp(x.damping_ratio, y.damping_ratio),
        gain: lerp(x.gain, y.gain),
        reference_stiffness_nm_per_rad: match (x.reference_stiffness_nm_per_rad, y.reference_stiffness_nm_per_rad) {
            (Some(p), Some(q)) => Some(lerp(p, q)),
            (p, q) => p.or(q),
        },
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::unit::check_effects_by_pivot;
    use jointctl_config::DahlConfig;

    fn loop_at(pivot_mm: f64, limit_nm: f64) -> PivotEffectsConfig {
        PivotEffectsConfig { pivot_mm, effects: EffectsConfig { hysteresis: Some(DahlConfig { sigma_nm_per_rad: 100.0 * limit_nm, limit_nm, shape: 1.0, presliding_damping_s: 0.0 }), ..Default::default() }, effects_per_dof: Vec::new() }
    }

    #[test]
    fn a_loop_at_one_setting_only_fades_out_towards_the_next() {
        let settings = [loop_at(10.0, 0.4), PivotEffectsConfig { pivot_mm: 20.0, effects: EffectsConfig::default(), effects_per_dof: Vec::new() }];
        let h = effects_at(&settings, 12.5, 0).hysteresis.unwrap();
        assert!((h.limit_nm - 0.3).abs() < 1e-12 && (h.sigma_nm_per_rad - 30.0).abs() < 1e-12, "{h:?}");
        assert!(effects_at(&settings, 20.0, 0).hysteresis.is_none());
        assert!(effects_at(&settings, 25.0, 0).hysteresis.is_none());
        assert_eq!(effects_at(&settings, 0.0, 0).hysteresis.unwrap().limit_nm, 0.4);
    }

    #[test]
    fn settings_out_of_order_or_not_physical_are_refused_by_entry() {
        let e = check_effects_by_pivot(&[loop_at(20.0, 0.4), loop_at(10.0, 0.4)], 1).unwrap_err();
        assert_eq!(e.0, "[1].pivot_mm");
        let e = check_effects_by_pivot(&[loop_at(10.0, 0.4), loop_at(20.0, -0.1)], 1).unwrap_err();
        assert_eq!(e.0, "[1].effects.hysteresis.sigma_nm_per_rad");
        assert!(check_effects_by_pivot(&[loop_at(10.0, 0.4), loop_at(20.0, 0.1)], 1).is_ok());
    }
}
