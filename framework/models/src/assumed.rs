//! Stand-in VSA characteristics until measured data replaces them.
//!
//! The thesis gives the elastic joints' stiffnesses (section 3.3.2) but not the VSA polynomial
//! coefficients. These tables are generated from the lever-arm model (eq. 2.6) with a dead-zone
//! and a mild asymmetry like figures 3.14-3.16 and 3.25-3.26, then fitted exactly as the thesis
//! fitted its measurements: shoulder, separate 3rd-order branches through zero (section 3.4.2);
//! wrist, a continuous 4th-order polynomial through zero per direction (section 3.5.2); the
//! stiffness, a first-order fit per setting (section 4.2). **Every number below is an assumption.**

use crate::characteristic::{CharacteristicSpec, CurveSpec, Source};
use crate::fit::through_zero;
use crate::lever_arm::LeverArm;

/// Assumed shoulder (q2) lever arm: K from 432 Nm/rad (pivot 0 mm) down to 27 Nm/rad (45 mm).
pub const SHOULDER_LEVER: LeverArm =
    LeverArm { lever_length_m: 0.15, crank_radius_m: 0.03, spring_n_per_m: 30_000.0, pivot_offset_m: 0.03 };
/// Assumed wrist (q6/q7) lever arm: K from 46 Nm/rad (pivot 0 mm) down to 2.2 Nm/rad (50 mm).
pub const WRIST_LEVER: LeverArm =
    LeverArm { lever_length_m: 0.15, crank_radius_m: 0.012, spring_n_per_m: 20_000.0, pivot_offset_m: 0.03 };
/// Assumed dead-zone half-widths [rad] (figure 5.6 shows one; its width is not given).
pub const SHOULDER_DEAD_ZONE_RAD: f64 = 0.01;
/// Assumed wrist dead-zone half-width [rad].
pub const WRIST_DEAD_ZONE_RAD: f64 = 0.02;
/// Assumed ratio of the negative to the positive branch stiffness (mild asymmetry).
pub const NEGATIVE_BRANCH_SCALE: f64 = 0.9;
/// Assumed largest characterised torques [Nm] (the thesis stepped the shoulder to 20 Nm, fig. 5.2,
/// and the wrist to 2 Nm, fig. 5.16).
pub const SHOULDER_MAX_TORQUE_NM: f64 = 25.0;
/// See [`SHOULDER_MAX_TORQUE_NM`].
pub const WRIST_MAX_TORQUE_NM: f64 = 3.0;

/// A smooth dead-zone of half-width `d` [rad]: slope 0 at zero deflection, slope 1 beyond about
/// two half-widths (none when `d` is not positive).
///
/// ```
/// use jointctl_models::assumed::smooth_dead_zone;
/// assert_eq!(smooth_dead_zone(0.0, 0.01), 0.0);
/// assert!((smooth_dead_zone(0.1, 0.01) - (0.1 - 0.01)).abs() < 1e-9);
/// assert_eq!(smooth_dead_zone(0.3, 0.0), 0.3);
/// ```
pub fn smooth_dead_zone(x: f64, d: f64) -> f64 {
    if d > 0.0 { x - d * (x / d).tanh() } else { x }
}

/// The generating "true" characteristic of one setting/direction: stiffness `k` beyond the dead-zone.
pub fn true_torque(k: f64, dead_zone_rad: f64, x: f64) -> f64 {
    let scale = if x >= 0.0 { 1.0 } else { NEGATIVE_BRANCH_SCALE };
    scale * k * smooth_dead_zone(x, dead_zone_rad)
}

fn samples(k: f64, d: f64, max_torque: f64, negative: bool) -> (Vec<f64>, Vec<f64>) {
    let x_max = (max_torque / k + d).min(0.35);
    let x: Vec<f64> = (1..=200).map(|i| i as f64 / 200.0 * x_max * if negative { -1.0 } else { 1.0 }).collect();
    let y = x.iter().map(|x| true_torque(k, d, *x)).collect();
    (x, y)
}

fn round6(v: Vec<f64>) -> Vec<f64> {
    v.into_iter().map(|c| format!("{c:.6e}").parse().unwrap_or(c)).collect()
}

fn first_order(x: &[f64], y: &[f64]) -> f64 {
    through_zero(x, y, 1).map(|c| c[0]).unwrap_or(f64::NAN)
}

/// The assumed shoulder characteristic: pivots 0-45 mm in 5 mm steps (section 3.4.2).
pub fn shoulder_spec() -> CharacteristicSpec {
    let curves = (0..10)
        .map(|i| {
            let p = 5.0 * i as f64;
            let k = SHOULDER_LEVER.stiffness_at(p);
            let (xp, yp) = samples(k, SHOULDER_DEAD_ZONE_RAD, SHOULDER_MAX_TORQUE_NM, false);
            let (xn, yn) = samples(k, SHOULDER_DEAD_ZONE_RAD, SHOULDER_MAX_TORQUE_NM, true);
            let x_all: Vec<f64> = xp.iter().chain(&xn).copied().collect();
            let y_all: Vec<f64> = yp.iter().chain(&yn).copied().collect();
            CurveSpec {
                pivot_mm: Some(p),
                angle_deg: None,
                coefficients: None,
                positive: Some(round6(through_zero(&xp, &yp, 3).unwrap_or_default())),
                negative: Some(round6(through_zero(&xn, &yn, 3).unwrap_or_default())),
                offset_nm: None,
                stiffness_nm_per_rad: round6(vec![first_order(&x_all, &y_all)])[0],
                range_rad: Some(rounded_span(&x_all)),
            }
        })
        .collect();
    CharacteristicSpec { source: Source::Assumed, curves }
}

/// The lowest and highest of the samples a curve was fitted to [rad], rounded as the
/// coefficients are.
fn rounded_span(x: &[f64]) -> [f64; 2] {
    let r = round6(crate::characteristic::deflection_range(x).to_vec());
    [r[0], r[1]]
}

/// Assumed anisotropy of the wrist: the stiffness along direction `theta` is `K (1 + 0.1 cos 2 theta)`.
pub fn wrist_direction_stiffness(k: f64, angle_deg: f64) -> f64 {
    k * (1.0 + 0.1 * (2.0 * angle_deg.to_radians()).cos())
}

/// The assumed wrist characteristic: pivots 0-50 mm in 5 mm steps, directions 0, 45, 90, 135 deg
/// (section 3.5.2).
pub fn wrist_spec() -> CharacteristicSpec {
    let mut curves = Vec::new();
    for i in 0..11 {
        let p = 5.0 * i as f64;
        for angle in [0.0, 45.0, 90.0, 135.0] {
            let k = wrist_direction_stiffness(WRIST_LEVER.stiffness_at(p), angle);
            let (xp, yp) = samples(k, WRIST_DEAD_ZONE_RAD, WRIST_MAX_TORQUE_NM, false);
            let (xn, yn) = samples(k, WRIST_DEAD_ZONE_RAD, WRIST_MAX_TORQUE_NM, true);
            let x: Vec<f64> = xp.iter().chain(&xn).copied().collect();
            let y: Vec<f64> = yp.iter().chain(&yn).copied().collect();
            curves.push(CurveSpec {
                pivot_mm: Some(p),
                angle_deg: Some(angle),
                coefficients: Some(round6(through_zero(&x, &y, 4).unwrap_or_default())),
                positive: None,
                negative: None,
                offset_nm: None,
                stiffness_nm_per_rad: round6(vec![first_order(&x, &y)])[0],
                range_rad: Some(rounded_span(&x)),
            });
        }
    }
    CharacteristicSpec { source: Source::Assumed, curves }
}
