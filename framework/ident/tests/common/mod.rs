//! A synthetic characterisation shared by the identification tests.

use jointctl_ident::csv::Data;

/// The thesis' baseline (linear spring, 120 Nm/rad, + eq. 3.5 friction `0.3 atan(80 v)`), a
/// 0.1 rad sine deflection, 14-bit deflection, 0.02 Nm sensor noise, 80 s at 200 Hz, plus
/// `extra(t, deflection, velocity)` [Nm].
pub fn sine_experiment(extra: impl Fn(f64, f64, f64) -> f64) -> Data {
    // Not phase-locked to the sampling (0.25 Hz would be exactly 800 samples a period): locked,
    // every period samples the same deflections and the 14-bit quantisation error becomes a
    // real ripple in torque against measured deflection.
    let (rate, n, amp, f, k) = (200.0, 16_000, 0.1, 0.2371, 120.0);
    let q = std::f64::consts::TAU / 16384.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let mut data = Data::default();
    for i in 0..n {
        let t = i as f64 / rate;
        let x = amp * (std::f64::consts::TAU * f * t).sin();
        let v = amp * std::f64::consts::TAU * f * (std::f64::consts::TAU * f * t).cos();
        // Gaussian noise of 0.02 Nm (Box-Muller).
        let noise = 0.02 * rng.normal();
        data.t.push(t);
        data.deflection.push((x / q).round() * q);
        data.torque.push(k * x + 0.3 * (80.0 * v).atan() + extra(t, x, v) + noise);
        for col in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque] {
            col.push(f64::NAN);
        }
    }
    data
}
