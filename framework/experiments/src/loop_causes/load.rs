//! The torque of a DOF without an F/T sensor, from its drives' torque readings (their current),
//! so that the drives' load is known where the joint's transmission couples that DOF to measured
//! ones (the shoulder's differential: its drives move q2, which has an F/T sensor, and q3, which
//! has none; eq. 3.3). A drive's motor torque is its load, plus what accelerates the motor and
//! gearbox, plus the gear's friction (eq. 3.5): its load is `M^T tau` (the transmission's
//! columns), so each cycle the unmeasured torques are the least-squares solution of
//! `sum_u M[u][i] tau_u = torque_i - J a_i - f(v_i) - sum_m M[m][i] tau_m` over the drives `i`.
//!
//! Only the unmeasured part is estimated: the measured torques stay as the F/T sensors read them.
//! The drive's acceleration comes from positions one cycle apart (the mean over two cycles),
//! the torque reading is instantaneous; where the acceleration switches, a cycle's estimate is off
//! by the inertia times the switch, so the estimate is averaged over a few cycles. Where the
//! drives move the unmeasured DOF alike (a pure q2 motion moves both shoulder drives alike), their
//! accelerations cancel in it.

use jointctl_models::transmission::eq_3_5_friction;

use super::{DriveTrace, at};

/// The unmeasured torques are averaged over this long [s]. Assumption: three cycles of the
/// thesis' 40 Hz loop (section 2.3), long enough to average a switch of the drive's acceleration
/// out, short against the 0.1-1 Hz of the tracking runs.
pub(super) const AVERAGE_S: f64 = 0.075;

/// A drive's readings taken `age_s` later (its state at each cycle's time), and the acceleration
/// and friction terms of its motor torque there; NaN where unknown.
fn motor_terms(t_s: &[f64], d: &DriveTrace, age_s: f64) -> Vec<f64> {
    let n = t_s.len();
    let p: Vec<f64> = t_s.iter().map(|&q| at(t_s, &d.position_rad, q + age_s)).collect();
    (0..n)
        .map(|i| {
            if i == 0 || i + 1 == n {
                return f64::NAN;
            }
            let (h0, h1) = (t_s[i] - t_s[i - 1], t_s[i + 1] - t_s[i]);
            if h0 <= 0.0 || h1 <= 0.0 {
                return f64::NAN;
            }
            let accel = 2.0 * ((p[i + 1] - p[i]) / h1 - (p[i] - p[i - 1]) / h0) / (h0 + h1);
            let velocity = (p[i + 1] - p[i - 1]) / (h0 + h1);
            d.elmo.inertia_kgm2 * accel + eq_3_5_friction(d.elmo.friction_ka_nm, d.elmo.friction_kb_s_per_rad, velocity)
        })
        .collect()
}

/// The drives' loads with the unmeasured DOFs' torques added: `drives[i].load_nm` holds the
/// measured DOFs' share (`sum_m M[m][i] tau_m`), `unmeasured_rows[u][i]` is `M[u][i]`. The
/// readings are `age_s` old. Unknown (NaN) where a reading is.
pub(super) fn with_unmeasured(t_s: &[f64], drives: &[DriveTrace], unmeasured_rows: &[Vec<f64>], age_s: f64) -> Vec<Vec<f64>> {
    let n = t_s.len();
    let terms: Vec<Vec<f64>> = drives.iter().map(|d| motor_terms(t_s, d, age_s)).collect();
    let torque: Vec<Vec<f64>> = drives.iter().map(|d| t_s.iter().map(|&q| at(t_s, &d.torque_nm, q + age_s)).collect()).collect();
    let used: Vec<usize> = (0..drives.len()).filter(|&i| unmeasured_rows.iter().any(|r| r.get(i).is_some_and(|m| *m != 0.0))).collect();
    let a = nalgebra::DMatrix::from_fn(used.len(), unmeasured_rows.len(), |r, u| unmeasured_rows[u].get(used[r]).copied().unwrap_or(0.0));
    let svd = a.clone().svd(true, true);
    // Each cycle's unmeasured torques.
    let raw: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let b = nalgebra::DVector::from_iterator(used.len(), used.iter().map(|&i| torque[i][k] - terms[i][k] - drives[i].load_nm[k]));
            if b.iter().any(|x| !x.is_finite()) {
                return vec![f64::NAN; unmeasured_rows.len()];
            }
            svd.solve(&b, 1e-12).map_or(vec![f64::NAN; unmeasured_rows.len()], |x| x.iter().copied().collect())
        })
        .collect();
    // Averaged over AVERAGE_S, centred; unknown where a cycle in the window is.
    let half = AVERAGE_S / 2.0;
    let tau: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let (lo, hi) = (t_s.partition_point(|s| *s < t_s[k] - half - 1e-9), t_s.partition_point(|s| *s <= t_s[k] + half + 1e-9));
            (0..unmeasured_rows.len())
                .map(|u| {
                    let w: Vec<f64> = raw[lo..hi].iter().map(|x| x[u]).collect();
                    if w.iter().any(|x| !x.is_finite()) { f64::NAN } else { w.iter().sum::<f64>() / w.len() as f64 }
                })
                .collect()
        })
        .collect();
    drives
        .iter()
        .enumerate()
        .map(|(i, d)| (0..n).map(|k| d.load_nm[k] + unmeasured_rows.iter().zip(&tau[k]).map(|(row, t)| row.get(i).copied().unwrap_or(0.0) * t).sum::<f64>()).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_unmeasured_dofs_torque_comes_back_from_the_drives_torques() {
        // The shoulder's differential (q2 = (a + b) / 2, q3 = (a - b) / 2 for the loads): q2's
        // 4 Nm is measured, q3 holds a slowly changing 6 sin(t) Nm that no sensor reads; the
        // drives move q2 (alike) at 0.5 Hz.
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.025).collect();
        let w = std::f64::consts::PI;
        let mut drives = vec![DriveTrace::default(), DriveTrace::default()];
        for &s in &t {
            let (p, v, acc) = (0.1 * (w * s).sin(), 0.1 * w * (w * s).cos(), -0.1 * w * w * (w * s).sin());
            let (tau2, tau3) = (4.0, 6.0 * s.sin());
            for (d, sign) in drives.iter_mut().zip([1.0, -1.0]) {
                let load = 0.5 * tau2 + sign * 0.5 * tau3;
                d.position_rad.push(p);
                d.torque_nm.push(load + d.elmo.inertia_kgm2 * acc + eq_3_5_friction(d.elmo.friction_ka_nm, d.elmo.friction_kb_s_per_rad, v));
                d.load_nm.push(0.5 * tau2);
            }
        }
        let loads = with_unmeasured(&t, &drives, &[vec![0.5, -0.5]], 0.0);
        let worst = (5..395).map(|k| (loads[0][k] - (2.0 + 3.0 * t[k].sin())).abs().max((loads[1][k] - (2.0 - 3.0 * t[k].sin())).abs())).fold(0.0, f64::max);
        // The accelerations cancel (both drives alike); what is left is the 75 ms average of
        // 3 sin(t): 3 * (1 - cos 0.0375 ...) below 0.01 Nm, and the second difference's error.
        assert!(worst < 0.02, "load off by {worst} Nm");
        assert!(loads[0][0].is_nan(), "no rate at the ends");
    }
}
