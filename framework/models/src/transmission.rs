//! The SHERPA transmissions, one function per thesis equation.

/// Eq. 3.1/3.2, elbow q4: `theta_out = theta_motor + theta_RC`; ideally `theta_RC =
/// theta_motor`, so the deflection of the tendon stage (the RC element) is
/// `theta_out - 2 * theta_motor`.
///
/// ```
/// assert!((jointctl_models::transmission::eq_3_2_elbow_deflection(0.25, 0.1) - 0.05).abs() < 1e-15);
/// ```
pub fn eq_3_2_elbow_deflection(theta_out_rad: f64, theta_motor_rad: f64) -> f64 {
    theta_out_rad - 2.0 * theta_motor_rad
}

/// Eq. 3.3, shoulder tendon differential between actuators `a2`, `a3` and joints `q2`, `q3`.
///
/// The printed matrix has two identical rows (`q2 = q3 = (a2 - a3)/2`), which is not invertible
/// and cannot be meant. **Assumption**: the intended differential is the usual one, sum and
/// difference: `q2 = (a2 + a3)/2`, `q3 = (a2 - a3)/2`, inverse `a2 = q2 + q3`, `a3 = q2 - q3`.
///
/// ```
/// use jointctl_models::transmission::{eq_3_3_shoulder_joints, eq_3_3_shoulder_actuators};
/// let (q2, q3) = eq_3_3_shoulder_joints(0.3, 0.1);
/// assert!((q2 - 0.2).abs() < 1e-15 && (q3 - 0.1).abs() < 1e-15);
/// let (a2, a3) = eq_3_3_shoulder_actuators(q2, q3);
/// assert!((a2 - 0.3).abs() < 1e-15 && (a3 - 0.1).abs() < 1e-15);
/// ```
pub fn eq_3_3_shoulder_joints(a2_rad: f64, a3_rad: f64) -> (f64, f64) {
    (0.5 * (a2_rad + a3_rad), 0.5 * (a2_rad - a3_rad))
}

/// Inverse of [`eq_3_3_shoulder_joints`]: actuator angles for joint angles.
pub fn eq_3_3_shoulder_actuators(q2_rad: f64, q3_rad: f64) -> (f64, f64) {
    (q2_rad + q3_rad, q2_rad - q3_rad)
}

/// Eq. 3.4, planetary differential: carrier speed from ring and sun speeds,
/// `omega_c = omega_r / (1 + Ns/Nr) + omega_s / (1 + Nr/Ns)`.
///
/// ```
/// use jointctl_models::transmission::eq_3_4_planet_carrier;
/// // Ring fixed, Ns = 20, Nr = 60: carrier = sun * 20/80.
/// assert!((eq_3_4_planet_carrier(0.0, 1.0, 20.0, 60.0) - 0.25).abs() < 1e-15);
/// // Sun fixed: carrier = ring * 60/80.
/// assert!((eq_3_4_planet_carrier(1.0, 0.0, 20.0, 60.0) - 0.75).abs() < 1e-15);
/// ```
pub fn eq_3_4_planet_carrier(omega_ring: f64, omega_sun: f64, teeth_sun: f64, teeth_ring: f64) -> f64 {
    omega_ring / (1.0 + teeth_sun / teeth_ring) + omega_sun / (1.0 + teeth_ring / teeth_sun)
}

/// Eq. 3.5, gear friction: `F = k_a * atan(k_b * d_omega)` [Nm].
///
/// ```
/// let f = jointctl_models::transmission::eq_3_5_friction(0.2, 50.0, 1.0);
/// assert!((f - 0.2 * 50f64.atan()).abs() < 1e-15);
/// ```
pub fn eq_3_5_friction(k_a: f64, k_b: f64, d_omega: f64) -> f64 {
    k_a * (k_b * d_omega).atan()
}

/// Eq. 3.6, bevel differential with gear diameters `d1`, `d2`:
/// `theta_x = (phi1 + phi2)/2`, `theta_y = d1/d2 * (phi1 - phi2)/2`.
pub fn eq_3_6_bevel(phi1: f64, phi2: f64, d1: f64, d2: f64) -> (f64, f64) {
    (0.5 * (phi1 + phi2), 0.5 * d1 / d2 * (phi1 - phi2))
}

/// Eq. 3.7 (eq. 3.6 with `d1 = d2`): `theta_x = (phi1 + phi2)/2`, `theta_y = (phi1 - phi2)/2`.
///
/// ```
/// use jointctl_models::transmission::{eq_3_7_bevel, eq_3_7_bevel_inverse};
/// let (x, y) = eq_3_7_bevel(0.3, 0.1);
/// assert!((x - 0.2).abs() < 1e-15 && (y - 0.1).abs() < 1e-15);
/// let (p1, p2) = eq_3_7_bevel_inverse(0.2, 0.1);
/// assert!((p1 - 0.3).abs() < 1e-15 && (p2 - 0.1).abs() < 1e-15);
/// ```
pub fn eq_3_7_bevel(phi1: f64, phi2: f64) -> (f64, f64) {
    eq_3_6_bevel(phi1, phi2, 1.0, 1.0)
}

/// Inverse of eq. 3.7: bevel inputs for the Cartesian angles, `phi1 = x + y`, `phi2 = x - y`.
pub fn eq_3_7_bevel_inverse(theta_x: f64, theta_y: f64) -> (f64, f64) {
    (theta_x + theta_y, theta_x - theta_y)
}

/// Eq. 3.8, wrist: the bevel-input angle the planet-carrier input encoder predicts with the
/// ring (elastic element) undeflected, `theta_a~ = Ns/(Ns + Nr) * Dp/Db * theta_pc`.
///
/// ```
/// // Ns = 20, Nr = 60, belt 30:40 (Dp/Db = 0.75): 0.25 * 0.75 * 2.0 = 0.375
/// let t = jointctl_models::transmission::eq_3_8_expected_bevel_input(2.0, 20.0, 60.0, 0.75);
/// assert!((t - 0.375).abs() < 1e-15);
/// ```
pub fn eq_3_8_expected_bevel_input(theta_pc: f64, teeth_sun: f64, teeth_ring: f64, belt_ratio: f64) -> f64 {
    teeth_sun / (teeth_sun + teeth_ring) * belt_ratio * theta_pc
}

/// Eq. 3.8: `deflection = theta_a~ - theta_a`, the expected minus the measured bevel input.
pub fn eq_3_8_deflection(expected_bevel_input: f64, measured_bevel_input: f64) -> f64 {
    expected_bevel_input - measured_bevel_input
}
