//! The joint's physics: the elastic element with its baseline friction, the hidden effects, and
//! the torque sensor channel. Stateful parts (hysteresis, LuGre bristles, sensor low-pass) are
//! integrated on a fine time grid; memoryless parts are evaluated wherever they are needed.
//!
//! Sign convention: `tau` is the torque the sensor reads; friction and hysteresis add torque in
//! the direction of the deflection velocity (they oppose the hand, which pushes harder).

use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Velocity [rad/s] below which the sign function of the Stribeck curve is smoothed (tanh);
/// keeps the truth finite and deterministic at velocity reversals.
pub const STRIBECK_V_EPS: f64 = 1e-3;

/// The baseline friction of the element (always present, not a hidden effect).
#[derive(Clone, Debug)]
pub enum Friction {
    /// tau_f = ka * atan(kb * v): the structure the identification tool is told (eq. 3.5).
    Atan { ka: f64, kb: f64 },
    /// Static Stribeck curve: (fc + (fs - fc) exp(-(v/vs)^2)) sign(v).
    Stribeck { fc: f64, fs: f64, vs: f64 },
    /// LuGre (Canudas de Wit et al. 1995) with stiff bristles: dz/dt = v - sigma0 |v| z / g(v),
    /// tau_f = sigma0 z + sigma1 dz/dt, g(v) the Stribeck curve. Used for friction-only records.
    LuGre {
        fc: f64,
        fs: f64,
        vs: f64,
        sigma0: f64,
        sigma1: f64,
    },
}

fn stribeck_g(v: f64, fc: f64, fs: f64, vs: f64) -> f64 {
    fc + (fs - fc) * (-(v / vs) * (v / vs)).exp()
}

impl Friction {
    pub fn name(&self) -> &'static str {
        match self {
            Friction::Atan { .. } => "atan",
            Friction::Stribeck { .. } => "stribeck",
            Friction::LuGre { .. } => "lugre",
        }
    }

    pub fn params(&self) -> BTreeMap<String, f64> {
        let mut m = BTreeMap::new();
        match *self {
            Friction::Atan { ka, kb } => {
                m.insert("k_a".into(), ka);
                m.insert("k_b".into(), kb);
            }
            Friction::Stribeck { fc, fs, vs } => {
                m.insert("fc".into(), fc);
                m.insert("fs".into(), fs);
                m.insert("vs".into(), vs);
                m.insert("v_eps".into(), STRIBECK_V_EPS);
            }
            Friction::LuGre {
                fc,
                fs,
                vs,
                sigma0,
                sigma1,
            } => {
                m.insert("fc".into(), fc);
                m.insert("fs".into(), fs);
                m.insert("vs".into(), vs);
                m.insert("sigma0".into(), sigma0);
                m.insert("sigma1".into(), sigma1);
            }
        }
        m
    }

    /// The memoryless friction torque (zero for LuGre, whose torque comes from its state).
    pub fn memoryless(&self, v: f64) -> f64 {
        match *self {
            Friction::Atan { ka, kb } => ka * (kb * v).atan(),
            Friction::Stribeck { fc, fs, vs } => {
                stribeck_g(v, fc, fs, vs) * (v / STRIBECK_V_EPS).tanh()
            }
            Friction::LuGre { .. } => 0.0,
        }
    }
}

/// Hysteresis models. All are written with a unit "force" (saturation torque) so the torque is
/// `force * unit_state`, and shaped by `x_h` [rad], the deflection over which the memory
/// saturates (the loop's width), which is what makes it a loop rather than Coulomb friction.
#[derive(Clone, Debug)]
pub enum HystModel {
    /// Dahl (1968), exponent 1: dh/dphi = sigma (1 - h/F sign(dphi)), sigma = F / x_h.
    Dahl { x_h: f64 },
    /// Bouc-Wen (Wen 1976): dh = A dphi - beta |dphi| |h|^(n-1) h - gamma dphi |h|^n,
    /// A = F / x_h, beta + gamma = A / F^n, beta = beta_frac (beta + gamma); max |h| = F.
    BoucWen { x_h: f64, n: f64, beta_frac: f64 },
    /// LuGre bristle state (Canudas de Wit et al. 1995) with Stribeck g:
    /// dz/dt = v - sigma0 |v| z / g(v), g = F (1 + (fs_ratio - 1) exp(-(v/vs)^2)),
    /// torque = sigma0 z + sigma1 dz/dt, sigma0 = F / x_h, sigma1 = F * c1.
    LuGre {
        x_h: f64,
        fs_ratio: f64,
        vs: f64,
        c1: f64,
    },
}

#[derive(Clone, Debug)]
pub struct Hysteresis {
    /// Saturation torque [Nm] (Dahl Fc, LuGre Coulomb level, Bouc-Wen max |h|).
    pub force: f64,
    pub model: HystModel,
}

impl Hysteresis {
    pub fn model_name(&self) -> &'static str {
        match self.model {
            HystModel::Dahl { .. } => "dahl",
            HystModel::BoucWen { .. } => "bouc_wen",
            HystModel::LuGre { .. } => "lugre",
        }
    }

    /// Parameters for the answer, in SI units, prefixed `hyst_`.
    pub fn params(&self, m: &mut BTreeMap<String, f64>) {
        let f = self.force;
        m.insert("force".into(), f);
        match self.model {
            HystModel::Dahl { x_h } => {
                m.insert("hyst_x_h".into(), x_h);
                m.insert("hyst_sigma".into(), f / x_h);
            }
            HystModel::BoucWen { x_h, n, beta_frac } => {
                let a = f / x_h;
                let bg = a / f.powf(n);
                m.insert("hyst_x_h".into(), x_h);
                m.insert("hyst_n".into(), n);
                m.insert("hyst_A".into(), a);
                m.insert("hyst_beta".into(), beta_frac * bg);
                m.insert("hyst_gamma".into(), (1.0 - beta_frac) * bg);
            }
            HystModel::LuGre {
                x_h,
                fs_ratio,
                vs,
                c1,
            } => {
                m.insert("hyst_x_h".into(), x_h);
                m.insert("hyst_sigma0".into(), f / x_h);
                m.insert("hyst_sigma1".into(), f * c1);
                m.insert("hyst_fs".into(), f * fs_ratio);
                m.insert("hyst_vs".into(), vs);
            }
        }
    }
}

/// Exact update of dy/dx = 1 - y / y_sat_signed... written generally: over an increment dx
/// of frozen sign, dy = dx - |dx| y / w  =>  y -> y_ss + (y - y_ss) exp(-|dx| / w),
/// y_ss = w sign(dx). Used by Dahl (w = x_h) and LuGre (w = x_h g(v)/F).
fn exp_relax(y: f64, dx: f64, w: f64) -> f64 {
    if dx == 0.0 {
        return y;
    }
    let y_ss = w * dx.signum();
    y_ss + (y - y_ss) * (-dx.abs() / w).exp()
}

/// Simulates a hysteresis model with unit force on the grid `phi` (step `dt_s`).
/// Returns the torque per unit force at each node.
pub fn simulate_hysteresis_unit(model: &HystModel, phi: &[f64], dt_s: f64) -> Vec<f64> {
    let n = phi.len();
    let mut out = vec![0.0; n];
    match *model {
        HystModel::Dahl { x_h } => {
            // unit state u = h / F obeys du/dphi = (1 - u sign(dphi)) / x_h.
            // In "z = u x_h" form: dz = dphi - |dphi| z / x_h, exactly integrable per step.
            let mut z = 0.0;
            for i in 1..n {
                z = exp_relax(z, phi[i] - phi[i - 1], x_h);
                out[i] = z / x_h;
            }
        }
        HystModel::BoucWen {
            x_h,
            n: p,
            beta_frac,
        } => {
            // du = (dphi - beta_frac |dphi| |u|^(p-1) u - (1-beta_frac) dphi |u|^p) / x_h.
            // Rate independent: integrate in phi with RK4 sub-steps of at most x_h / 40.
            let f = |u: f64, dx: f64| -> f64 {
                let au = u.abs();
                (dx - beta_frac * dx.abs() * au.powf(p - 1.0) * u
                    - (1.0 - beta_frac) * dx * au.powf(p))
                    / x_h
            };
            let mut u = 0.0;
            for i in 1..n {
                let dx = phi[i] - phi[i - 1];
                if dx != 0.0 {
                    let subs = ((dx.abs() / (x_h / 40.0)).ceil() as usize).max(1);
                    let h = dx / subs as f64;
                    for _ in 0..subs {
                        let k1 = f(u, h);
                        let k2 = f(u + 0.5 * k1, h);
                        let k3 = f(u + 0.5 * k2, h);
                        let k4 = f(u + k3, h);
                        u += (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0;
                    }
                }
                out[i] = u;
            }
            let _ = dt_s;
        }
        HystModel::LuGre {
            x_h,
            fs_ratio,
            vs,
            c1,
        } => {
            // z in rad; with sigma0 = F/x_h and g = F g'(v): dz = dphi - |dphi| z / (x_h g'(v)),
            // torque/F = z / x_h + c1 dz/dt.
            let mut z = 0.0;
            for i in 1..n {
                let dx = phi[i] - phi[i - 1];
                let v = dx / dt_s;
                let g = 1.0 + (fs_ratio - 1.0) * (-(v / vs) * (v / vs)).exp();
                let z_new = exp_relax(z, dx, x_h * g);
                let zdot = (z_new - z) / dt_s;
                z = z_new;
                out[i] = z / x_h + c1 * zdot;
            }
        }
    }
    out
}

/// Time at rest after which the hand lets go in a friction-only record [s].
pub const LUGRE_LET_GO_S: f64 = 0.3;
/// Time constant of the stuck bristle torque's decay once let go [s].
pub const LUGRE_RELAX_TAU_S: f64 = 0.1;

/// LuGre friction torque (absolute, not per unit) on the grid, for friction-only records.
pub fn simulate_lugre_friction(f: &Friction, phi: &[f64], dt_s: f64) -> Vec<f64> {
    let Friction::LuGre {
        fc,
        fs,
        vs,
        sigma0,
        sigma1,
    } = *f
    else {
        return vec![0.0; phi.len()];
    };
    let n = phi.len();
    let mut out = vec![0.0; n];
    let mut z = 0.0;
    let mut still_s = 0.0;
    for i in 1..n {
        let dx = phi[i] - phi[i - 1];
        let v = dx / dt_s;
        let g = stribeck_g(v, fc, fs, vs);
        let mut z_new = exp_relax(z, dx, g / sigma0);
        // At rest the hand lets go: the joint settles by the (sub-count) presliding
        // displacement and the stuck bristle torque decays, instead of reading as an offset.
        still_s = if v.abs() < 1e-6 { still_s + dt_s } else { 0.0 };
        if still_s > LUGRE_LET_GO_S {
            z_new *= (-dt_s / LUGRE_RELAX_TAU_S).exp();
        }
        let zdot = (z_new - z) / dt_s;
        z = z_new;
        out[i] = sigma0 * z + sigma1 * zdot;
    }
    out
}

/// Play: no torque for |phi| < width.
#[derive(Clone, Debug)]
pub struct DeadZone {
    /// Half width w [rad].
    pub width: f64,
    /// Half width of the contact stiffness ramp [rad] around |phi| = w (0 = ideal dead zone).
    /// The element's deflection is then (|phi| - (w - r))^2 / (4 r) inside the ramp.
    pub ramp: f64,
}

impl DeadZone {
    /// The effective (transmitted) deflection of the spring.
    pub fn apply(&self, phi: f64) -> f64 {
        let a = phi.abs();
        let (w, r) = (self.width, self.ramp);
        let s = if r <= 0.0 {
            (a - w).max(0.0)
        } else if a <= w - r {
            0.0
        } else if a >= w + r {
            a - w
        } else {
            let d = a - (w - r);
            d * d / (4.0 * r)
        };
        s * phi.signum()
    }
}

/// The spring's shape applied to the (dead-zone filtered) deflection s.
#[derive(Clone, Debug)]
pub enum Spring {
    Linear,
    /// k s + k3 s^3.
    Cubic {
        k3: f64,
    },
    /// k phi_s tanh(s / phi_s): softening, saturating.
    TanhSoft {
        phi_s: f64,
    },
    /// k phi_s sinh(s / phi_s): progressive hardening.
    SinhHard {
        phi_s: f64,
    },
}

impl Spring {
    pub fn torque(&self, k: f64, s: f64) -> f64 {
        match *self {
            Spring::Linear => k * s,
            Spring::Cubic { k3 } => k * s + k3 * s * s * s,
            Spring::TanhSoft { phi_s } => k * phi_s * (s / phi_s).tanh(),
            Spring::SinhHard { phi_s } => k * phi_s * (s / phi_s).sinh(),
        }
    }

    pub fn model_name(&self) -> &'static str {
        match self {
            Spring::Linear => "linear",
            Spring::Cubic { k3 } if *k3 >= 0.0 => "cubic_hardening",
            Spring::Cubic { .. } => "cubic_softening",
            Spring::TanhSoft { .. } => "tanh_softening",
            Spring::SinhHard { .. } => "sinh_hardening",
        }
    }
}

/// Torque channel lag: first-order low-pass (optional) then a transport delay.
#[derive(Clone, Debug)]
pub struct Delay {
    pub transport_s: f64,
    /// Low-pass time constant 1/(2 pi fc) [s]; 0 = none.
    pub lp_tau_s: f64,
}

impl Delay {
    pub fn equivalent_s(&self) -> f64 {
        self.transport_s + self.lp_tau_s
    }
}

/// A steady sinusoid on the torque (pump, fan), independent of the motion.
#[derive(Clone, Debug)]
pub struct Vibration {
    pub freq_hz: f64,
    pub amp_nm: f64,
    pub phase_rad: f64,
}

/// Torque sensor offset: `scale * (1 + rep_rel[rep] + drift_rel * (t - t_mid) / t_len)`.
/// Written with one scale so that sizing it is linear.
#[derive(Clone, Debug)]
pub struct Offset {
    pub scale_nm: f64,
    /// Relative per-repetition deviation (empty: none).
    pub rep_rel: Vec<f64>,
    /// Relative drift over the whole record (0: constant).
    pub drift_rel: f64,
}

impl Offset {
    pub fn at(&self, t_s: f64, rep: usize, t_mid_s: f64, t_len_s: f64) -> f64 {
        let r = self.rep_rel.get(rep).copied().unwrap_or(0.0);
        self.scale_nm * (1.0 + r + self.drift_rel * (t_s - t_mid_s) / t_len_s.max(1e-9))
    }
}

/// Everything physical about one joint (a "device").
#[derive(Clone, Debug)]
pub struct Physics {
    /// Small-signal spring stiffness [Nm/rad] (0 for friction-only records).
    pub k: f64,
    pub friction: Friction,
    /// Viscous friction b [Nm s/rad] (a hidden effect when > 0).
    pub viscous_b: f64,
    pub hysteresis: Option<Hysteresis>,
    pub dead_zone: Option<DeadZone>,
    pub spring: Spring,
    pub delay: Option<Delay>,
    pub vibration: Option<Vibration>,
    pub offset: Option<Offset>,
}

impl Physics {
    /// Baseline only: same k and friction, no hidden effect.
    pub fn baseline(&self) -> Physics {
        Physics {
            k: self.k,
            friction: self.friction.clone(),
            viscous_b: 0.0,
            hysteresis: None,
            dead_zone: None,
            spring: Spring::Linear,
            delay: None,
            vibration: None,
            offset: None,
        }
    }

    /// Spring torque of the element at true deflection phi.
    pub fn spring_torque(&self, phi: f64) -> f64 {
        let s = match &self.dead_zone {
            Some(dz) => dz.apply(phi),
            None => phi,
        };
        self.spring.torque(self.k, s)
    }

    /// Memoryless part of the element torque: spring + static friction + viscous.
    pub fn memoryless(&self, phi: f64, v: f64) -> f64 {
        self.spring_torque(phi) + self.friction.memoryless(v) + self.viscous_b * v
    }

    /// Sensor-level additive terms at physical time t (offset and vibration).
    pub fn additive(&self, t_s: f64, rep: usize, t_mid_s: f64, t_len_s: f64) -> f64 {
        let mut a = 0.0;
        if let Some(o) = &self.offset {
            a += o.at(t_s, rep, t_mid_s, t_len_s);
        }
        if let Some(vb) = &self.vibration {
            a += vb.amp_nm * (2.0 * PI * vb.freq_hz * t_s + vb.phase_rad).sin();
        }
        a
    }
}

/// First-order low-pass on a uniform grid, exact for a piecewise-linear input (so the grid step
/// does not bias the lag).
pub fn lowpass(u: &[f64], dt_s: f64, tau_s: f64) -> Vec<f64> {
    if tau_s <= 0.0 || u.is_empty() {
        return u.to_vec();
    }
    let a = (-dt_s / tau_s).exp();
    let c = tau_s / dt_s * (1.0 - a);
    let mut y = Vec::with_capacity(u.len());
    let mut yi = u[0];
    y.push(yi);
    for i in 1..u.len() {
        yi = u[i] + (yi - u[i - 1]) * a - (u[i] - u[i - 1]) * c;
        y.push(yi);
    }
    y
}

/// Linear interpolation of a uniform grid series at time t (clamped to the ends).
pub fn interp(x: &[f64], dt_s: f64, t_s: f64) -> f64 {
    let n = x.len();
    if n == 0 {
        return 0.0;
    }
    let p = t_s / dt_s;
    if p <= 0.0 {
        return x[0];
    }
    let i = p.floor() as usize;
    if i + 1 >= n {
        return x[n - 1];
    }
    let f = p - i as f64;
    x[i] * (1.0 - f) + x[i + 1] * f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine_grid(amp: f64, f: f64, dur: f64, dt: f64) -> Vec<f64> {
        (0..(dur / dt) as usize)
            .map(|i| amp * (2.0 * PI * f * i as f64 * dt).sin())
            .collect()
    }

    #[test]
    fn hysteresis_models_saturate_at_unit_force() {
        let dt = 1e-3;
        let phi = sine_grid(0.2, 0.5, 8.0, dt);
        for m in [
            HystModel::Dahl { x_h: 0.02 },
            HystModel::BoucWen {
                x_h: 0.02,
                n: 2.0,
                beta_frac: 0.7,
            },
            HystModel::LuGre {
                x_h: 0.02,
                fs_ratio: 1.0,
                vs: 0.1,
                c1: 0.0,
            },
        ] {
            let h = simulate_hysteresis_unit(&m, &phi, dt);
            let mx = h.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
            assert!(mx > 0.95 && mx <= 1.0 + 1e-6, "{m:?}: {mx}");
            // Memory: on the rising and falling branch at phi = 0 the sign differs.
            let i_up = (4.0 / dt) as usize; // phi = 0 rising (t = 4 s, 2 periods)
            let i_dn = (5.0 / dt) as usize; // phi = 0 falling
            assert!(h[i_up] > 0.5 && h[i_dn] < -0.5, "{m:?}");
        }
    }

    #[test]
    fn lowpass_lags_a_ramp_by_tau() {
        let dt = 1e-3;
        let u: Vec<f64> = (0..2000).map(|i| i as f64 * dt).collect();
        let y = lowpass(&u, dt, 0.01);
        assert!((u[1999] - y[1999] - 0.01).abs() < 1e-9);
    }

    #[test]
    fn dead_zone_ramp_is_continuous() {
        let dz = DeadZone {
            width: 0.01,
            ramp: 0.004,
        };
        let mut prev = dz.apply(0.0);
        for i in 1..4000 {
            let p = i as f64 * 1e-5;
            let s = dz.apply(p);
            assert!((s - prev).abs() <= 1.01e-5 && s >= prev);
            prev = s;
        }
        assert!((dz.apply(0.03) - 0.02).abs() < 1e-12);
        assert_eq!(dz.apply(0.005), 0.0);
    }
}
