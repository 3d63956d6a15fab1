//! Sizing: the part of an effect the baseline cannot explain (least squares on the baseline's
//! regressors), the scale that reaches a target, and the output noise of a logging.

use super::SIZING_DT_S;
use super::timeline::{Timeline, states};
use crate::model::{self, Physics};

/// RMS of `c` after removing its least-squares projection on the regressors (the baseline's
/// own structure: the deflection and the baseline friction). This is the part of an effect a
/// tool fitting the baseline must leave in its residual.
pub fn unexplained_rms(c: &[f64], regs: &[&[f64]]) -> f64 {
    let n = c.len();
    if n == 0 {
        return 0.0;
    }
    let m = regs.len();
    // Normal equations with a tiny ridge (regressors can be near-collinear or zero).
    let mut a = vec![vec![0.0; m]; m];
    let mut b = vec![0.0; m];
    for i in 0..n {
        for p in 0..m {
            b[p] += regs[p][i] * c[i];
            for q in 0..m {
                a[p][q] += regs[p][i] * regs[q][i];
            }
        }
    }
    for (p, row) in a.iter_mut().enumerate() {
        row[p] += 1e-12 * row[p].abs() + 1e-300;
    }
    let x = solve(a, b);
    let mut ss = 0.0;
    for i in 0..n {
        let fit: f64 = (0..m).map(|p| x[p] * regs[p][i]).sum();
        ss += (c[i] - fit).powi(2);
    }
    (ss / n as f64).sqrt()
}

/// Least-squares coefficients of y on the regressors.
pub fn lstsq(y: &[f64], regs: &[&[f64]]) -> Vec<f64> {
    let m = regs.len();
    let mut a = vec![vec![0.0; m]; m];
    let mut b = vec![0.0; m];
    for i in 0..y.len() {
        for p in 0..m {
            b[p] += regs[p][i] * y[i];
            for q in 0..m {
                a[p][q] += regs[p][i] * regs[q][i];
            }
        }
    }
    solve(a, b)
}

/// Gaussian elimination with partial pivoting (tiny systems).
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let m = b.len();
    for col in 0..m {
        let piv = (col..m)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, piv);
        b.swap(col, piv);
        let d = a[col][col];
        if d.abs() < 1e-300 {
            continue;
        }
        let pivot_row = a[col].clone();
        for r in 0..m {
            if r != col {
                let f = a[r][col] / d;
                for (x, p) in a[r][col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= f * p;
                }
                b[r] -= f * b[col];
            }
        }
    }
    (0..m)
        .map(|i| {
            if a[i][i].abs() < 1e-300 {
                0.0
            } else {
                b[i] / a[i][i]
            }
        })
        .collect()
}

pub(super) fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

pub(super) fn std_dev(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return 0.0;
    }
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

/// A decimated copy of a single-run timeline with precomputed baseline arrays.
pub(super) struct Grid {
    t: Vec<f64>,
    /// Index into the fine timeline of each grid point.
    pub(super) idx: Vec<usize>,
    phi: Vec<f64>,
    /// Baseline friction (memoryless + LuGre state) and the LuGre state alone.
    pub(super) fric: Vec<f64>,
    fric_state: Vec<f64>,
    base: Vec<f64>,
}

impl Grid {
    pub(super) fn new(base_ph: &Physics, tl: &Timeline) -> Grid {
        let st = states(base_ph, tl);
        let m = (SIZING_DT_S / tl.dt_s).round().max(1.0) as usize;
        let idx: Vec<usize> = (0..tl.phi.len()).step_by(m).collect();
        let t = idx.iter().map(|&i| i as f64 * tl.dt_s).collect();
        let phi: Vec<f64> = idx.iter().map(|&i| tl.phi[i]).collect();
        let fric: Vec<f64> = idx
            .iter()
            .map(|&i| base_ph.friction.memoryless(tl.vel[i]) + st.fric_state[i])
            .collect();
        let fric_state = idx.iter().map(|&i| st.fric_state[i]).collect();
        let base = phi
            .iter()
            .zip(&fric)
            .map(|(p, f)| base_ph.k * p + f)
            .collect();
        Grid {
            t,
            idx,
            phi,
            fric,
            fric_state,
            base,
        }
    }

    /// Contribution of everything beyond the baseline, on the grid.
    pub(super) fn contribution(&self, ph: &Physics, tl: &Timeline, hyst_unit: Option<&[f64]>) -> Vec<f64> {
        // States without re-simulating: the baseline friction state does not depend on the
        // hidden effects, and the hysteresis unit response is passed in (the models are linear
        // in their force).
        let transport = ph.delay.as_ref().map_or(0.0, |d| d.transport_s);
        let lp_tau = ph.delay.as_ref().map_or(0.0, |d| d.lp_tau_s);
        let dt = tl.dt_s * (self.idx.get(1).copied().unwrap_or(1) as f64);
        let elem: Vec<f64> = self
            .idx
            .iter()
            .enumerate()
            .map(|(g, &i)| {
                let mut e = ph.memoryless(tl.phi[i], tl.vel[i]) + self.fric_state[g];
                if let (Some(h), Some(u)) = (&ph.hysteresis, hyst_unit) {
                    e += h.force * u[g];
                }
                e
            })
            .collect();
        let elem = model::lowpass(&elem, dt, lp_tau);
        let total = tl.total_s();
        (0..self.t.len())
            .map(|g| {
                let t = self.t[g];
                let e = if transport > 0.0 {
                    model::interp(&elem, dt, t - transport)
                } else {
                    elem[g]
                };
                e + ph.additive(t, 0, 0.5 * total, total) - self.base[g]
            })
            .collect()
    }

    pub(super) fn unexplained(&self, c: &[f64]) -> f64 {
        unexplained_rms(c, &[&self.phi, &self.fric])
    }
}

/// Finds the scale s in [0, s_max] at which `f(s)` first reaches `target`: a coarse scan (the
/// unexplained part of some effects is not monotone, e.g. a dead zone as wide as the motion is
/// explained by a smaller k), then bisection. Returns (s, f(s)); the best scanned point if the
/// target is out of reach.
pub(super) fn solve_scale(mut f: impl FnMut(f64) -> f64, target: f64, s_max: f64) -> (f64, f64) {
    let n_scan = 24;
    let mut prev = 0.0;
    let mut best = (0.0, 0.0);
    for j in 1..=n_scan {
        let s = s_max * j as f64 / n_scan as f64;
        let r = f(s);
        if r > best.1 {
            best = (s, r);
        }
        if r >= target {
            let (mut lo, mut hi) = (prev, s);
            let mut r_hi = r;
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                let rm = f(mid);
                if rm >= target {
                    hi = mid;
                    r_hi = rm;
                } else {
                    lo = mid;
                }
                if (hi - lo) <= 1e-4 * hi {
                    break;
                }
            }
            return (hi, r_hi);
        }
        prev = s;
    }
    best
}

/// Variance factor of the mean of an Ornstein-Uhlenbeck process over a window (bin averaging).
fn ou_mean_var_factor(tau_s: f64, w_s: f64) -> f64 {
    let x = w_s / tau_s;
    (2.0 / x) * (1.0 - (1.0 - (-x).exp()) / x)
}

/// Ratio of the output noise std to the raw white noise std, for the given logging.
pub(super) fn output_noise_factor(setup_fs: f64, col_rel: f64, tau: f64, bin20: bool) -> f64 {
    if bin20 {
        let n = (0.05 * setup_fs).max(1.0);
        (1.0 / n + col_rel * col_rel * ou_mean_var_factor(tau, 0.05)).sqrt()
    } else {
        (1.0 + col_rel * col_rel).sqrt()
    }
}
