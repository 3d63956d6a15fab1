//! Pivot blending: the terms weighted between two characterised pivot settings, and the
//! settings that bracket a pivot.

use super::spec::{DahlSpec, FrictionSpec, PivotTerms, Terms};

impl Terms {
    /// Each parameter weighted linearly between `self` (weight `1 - w`) and `other` (`w`). A
    /// friction or hysteresis that one side lacks weighs in with its torque scale (`k_a`, `F_c`)
    /// at zero and the other side's shape (`k_b`, `sigma`), so that it fades in over the span
    /// (none where its weight is zero).
    ///
    /// ```
    /// use jointctl_models::extension::{DahlSpec, Terms};
    /// let a = Terms { cubic_nm_per_rad3: 100.0, ..Default::default() };
    /// let b = Terms { cubic_nm_per_rad3: 300.0, hysteresis: Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.4, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }), ..Default::default() };
    /// let mid = a.blend(&b, 0.5);
    /// assert_eq!(mid.cubic_nm_per_rad3, 200.0);
    /// assert_eq!(mid.hysteresis, Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.2, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }));
    /// ```
    pub fn blend(&self, other: &Terms, w: f64) -> Terms {
        let mix = |a: f64, b: f64| a + (b - a) * w;
        let friction = match (self.friction, other.friction) {
            (None, None) => None,
            (a, b) => {
                let (a, b) = (a.unwrap_or(FrictionSpec { ka_nm: 0.0, ..b.unwrap_or(FrictionSpec { ka_nm: 0.0, kb_s_per_rad: 1.0 }) }), b.unwrap_or(FrictionSpec { ka_nm: 0.0, ..a.unwrap_or(FrictionSpec { ka_nm: 0.0, kb_s_per_rad: 1.0 }) }));
                Some(FrictionSpec { ka_nm: mix(a.ka_nm, b.ka_nm), kb_s_per_rad: mix(a.kb_s_per_rad, b.kb_s_per_rad) }).filter(|f| f.ka_nm != 0.0)
            }
        };
        let hysteresis = match (self.hysteresis, other.hysteresis) {
            (None, None) => None,
            (a, b) => {
                let (a, b) = (a.unwrap_or(DahlSpec { limit_nm: 0.0, ..b.unwrap_or(DahlSpec { limit_nm: 0.0, sigma_nm_per_rad: 1.0, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }) }), b.unwrap_or(DahlSpec { limit_nm: 0.0, ..a.unwrap_or(DahlSpec { limit_nm: 0.0, sigma_nm_per_rad: 1.0, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }) }));
                Some(DahlSpec { sigma_nm_per_rad: mix(a.sigma_nm_per_rad, b.sigma_nm_per_rad), limit_nm: mix(a.limit_nm, b.limit_nm), input_dead_band_rad: mix(a.input_dead_band_rad, b.input_dead_band_rad), shape: mix(a.shape, b.shape), presliding_damping_s: mix(a.presliding_damping_s, b.presliding_damping_s) }).filter(|h| h.limit_nm != 0.0 && h.limit_nm / h.sigma_nm_per_rad > 0.0)
            }
        };
        Terms {
            torque_scale: mix(self.torque_scale, other.torque_scale),
            cubic_nm_per_rad3: mix(self.cubic_nm_per_rad3, other.cubic_nm_per_rad3),
            dead_zone_rad: mix(self.dead_zone_rad, other.dead_zone_rad),
            dead_zone_ramp_rad: mix(self.dead_zone_ramp_rad, other.dead_zone_ramp_rad),
            viscous_nms_per_rad: mix(self.viscous_nms_per_rad, other.viscous_nms_per_rad),
            friction,
            hysteresis,
            torque_offset_nm: mix(self.torque_offset_nm, other.torque_offset_nm),
        }
    }
}

/// The setting below `pivot_mm` (or the first) and the weight of the one above, clamped to
/// the settings' range (at least two settings, pivots increasing), as
/// [`crate::characteristic::pivot_bracket`] brackets the curves; no allocation.
pub(super) fn bracket(settings: &[PivotTerms], pivot_mm: f64) -> (usize, f64) {
    let n = settings.len();
    if pivot_mm.is_nan() || pivot_mm <= settings[0].pivot_mm {
        return (0, 0.0);
    }
    if pivot_mm >= settings[n - 1].pivot_mm {
        return (n - 2, 1.0);
    }
    let i = settings.partition_point(|s| s.pivot_mm <= pivot_mm) - 1;
    (i, (pivot_mm - settings[i].pivot_mm) / (settings[i + 1].pivot_mm - settings[i].pivot_mm))
}
