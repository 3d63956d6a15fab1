//! The lever-arm stiffness adjustment of the SHERPA VSAs (thesis section 2.4, Barrett et al. 2016).
//!
//! A crank of length `R` turns the output deflection `phi` into a lever deflection
//! `x = sin(phi) R`; the lever, pivoting at `q` along its length `l`, stretches the internal
//! spring (stiffness `k_s`) by `s = (l - q)/q * x`. All lengths in metres here; pivot positions
//! in the configuration are in mm, as the thesis gives them.

use serde::Deserialize;

/// Geometry and spring of one lever-arm VSA.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeverArm {
    /// Lever length `l` [m].
    pub lever_length_m: f64,
    /// Crank length `R` [m].
    pub crank_radius_m: f64,
    /// Internal spring constant `k_s` [N/m].
    pub spring_n_per_m: f64,
    /// Pivot position `q` [m] at the pivot setting 0 mm; a setting of `p` mm puts the pivot at
    /// `q = pivot_offset_m + p / 1000`.
    pub pivot_offset_m: f64,
}

/// Eq. 2.1: spring elongation `s = (l - q)/q * sin(phi) * R` [m].
///
/// ```
/// let s = jointctl_models::lever_arm::eq_2_1_spring_elongation(0.1, 0.02, 0.03, 0.1);
/// assert!((s - 4.0 * 0.1f64.sin() * 0.03).abs() < 1e-15);
/// ```
pub fn eq_2_1_spring_elongation(l: f64, q: f64, r: f64, phi: f64) -> f64 {
    (l - q) / q * phi.sin() * r
}

/// Eq. 2.5 (small deflections): output torque `tau = ((l - q)/q * R)^2 * k_s * phi` [Nm].
pub fn eq_2_5_torque(l: f64, q: f64, r: f64, k_s: f64, phi: f64) -> f64 {
    eq_2_6_stiffness(l, q, r, k_s) * phi
}

/// Eq. 2.6: output stiffness `K = ((l - q)/q * R)^2 * k_s` [Nm/rad].
///
/// ```
/// // l = 0.1 m, q = 0.02 m, R = 0.03 m, k_s = 30 kN/m: ((0.08/0.02) * 0.03)^2 * 30000 = 432
/// let k = jointctl_models::lever_arm::eq_2_6_stiffness(0.1, 0.02, 0.03, 30_000.0);
/// assert!((k - 432.0).abs() < 1e-9);
/// ```
pub fn eq_2_6_stiffness(l: f64, q: f64, r: f64, k_s: f64) -> f64 {
    let ratio = (l - q) / q * r;
    ratio * ratio * k_s
}

/// Eq. 2.1-2.4 without eq. 2.5's small-deflection step: the crank's moment arm shrinks as it
/// turns (`x = R sin(phi)`, so `dx/dphi = R cos(phi)`), and the output torque is
/// `tau = F_o R cos(phi) = ((l - q)/q R)^2 k_s sin(phi) cos(phi)` [Nm]: eq. 2.5 near zero, softer
/// beyond (about `K (phi - 2 phi^3 / 3)`). The simulated VSAs' "true" element.
///
/// ```
/// use jointctl_models::lever_arm::{eq_2_1_to_2_4_torque, eq_2_5_torque};
/// let (l, q, r, k_s) = (0.15, 0.03, 0.03, 30_000.0);
/// // Near zero, eq. 2.5; at 0.2 rad, 2.6 % softer (sin(2 phi) / (2 phi) = 0.974).
/// assert!((eq_2_1_to_2_4_torque(l, q, r, k_s, 1e-4) / eq_2_5_torque(l, q, r, k_s, 1e-4) - 1.0).abs() < 1e-7);
/// let ratio = eq_2_1_to_2_4_torque(l, q, r, k_s, 0.2) / eq_2_5_torque(l, q, r, k_s, 0.2);
/// assert!((ratio - 0.4f64.sin() / 0.4).abs() < 1e-12);
/// ```
pub fn eq_2_1_to_2_4_torque(l: f64, q: f64, r: f64, k_s: f64, phi: f64) -> f64 {
    let (s, c) = phi.sin_cos();
    eq_2_6_stiffness(l, q, r, k_s) * s * c
}

impl LeverArm {
    /// Stiffness [Nm/rad] at a pivot setting [mm], eq. 2.6.
    ///
    /// ```
    /// let k = jointctl_models::assumed::SHOULDER_LEVER.stiffness_at(0.0);
    /// assert!((k - 432.0).abs() < 1e-9);
    /// ```
    pub fn stiffness_at(&self, pivot_mm: f64) -> f64 {
        eq_2_6_stiffness(self.lever_length_m, self.pivot_m(pivot_mm), self.crank_radius_m, self.spring_n_per_m)
    }

    /// Output torque [Nm] at a pivot setting [mm] and deflection [rad], without the
    /// small-deflection approximation ([`eq_2_1_to_2_4_torque`]).
    ///
    /// ```
    /// let lever = jointctl_models::assumed::SHOULDER_LEVER;
    /// let (k, phi) = (lever.stiffness_at(20.0), 0.05);
    /// assert!((lever.torque_at(20.0, phi) - k * phi.sin() * phi.cos()).abs() < 1e-12);
    /// ```
    pub fn torque_at(&self, pivot_mm: f64, phi_rad: f64) -> f64 {
        eq_2_1_to_2_4_torque(self.lever_length_m, self.pivot_m(pivot_mm), self.crank_radius_m, self.spring_n_per_m, phi_rad)
    }

    /// The pivot position `q` [m] of a setting [mm].
    fn pivot_m(&self, pivot_mm: f64) -> f64 {
        self.pivot_offset_m + pivot_mm / 1000.0
    }
}
