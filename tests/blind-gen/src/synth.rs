//! From a request (which hidden causes, which record variant) to a record: draw the joint's
//! physics and the test program, size the hidden effects against the noise, simulate on a fine
//! grid, sample like a data logger (uniform or irregular time stamps, repetitions, binning),
//! add noise, quantise the deflection, and write down the answer.

use crate::excitation::{self, Program};
use crate::model::{
    self, DeadZone, Delay, Friction, HystModel, Hysteresis, Offset, Physics, Spring, Vibration,
};
use crate::rng::Rng;
use crate::{Answer, Case};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Internal simulation step [s] (4 kHz): at least twice the fastest sampling rate, and fine
/// enough that linear interpolation of the smooth motion is far below one encoder count.
pub const FINE_DT_S: f64 = 2.5e-4;
/// Step of the grid the effect sizes are computed on [s].
const SIZING_DT_S: f64 = 2.0e-3;
/// 14-bit absolute encoder count [rad].
pub const ENC14_STEP: f64 = 2.0 * PI / 16384.0;
/// 17-bit absolute encoder count [rad].
pub const ENC17_STEP: f64 = 2.0 * PI / 131072.0;
/// Linear encoder count [rad].
pub const LINEAR_STEP: f64 = 2.0e-6;
/// Uniform logger rates [Hz]: all have a whole number of microseconds per step.
const RATES_HZ: [f64; 8] = [200.0, 250.0, 400.0, 500.0, 800.0, 1000.0, 1250.0, 2000.0];
const EPOCH_BASE_US: i64 = 1_700_000_000_000_000;

/// The hidden causes (the vocabulary the identification tool answers in).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Cause {
    Viscous,
    Hysteresis,
    DeadZone,
    Stiffness,
    Offset,
    Delay,
    Vibration,
}

pub const ALL_CAUSES: [Cause; 7] = [
    Cause::Viscous,
    Cause::Hysteresis,
    Cause::DeadZone,
    Cause::Stiffness,
    Cause::Offset,
    Cause::Delay,
    Cause::Vibration,
];

impl Cause {
    pub fn name(self) -> &'static str {
        match self {
            Cause::Viscous => "viscous_friction",
            Cause::Hysteresis => "hysteresis",
            Cause::DeadZone => "dead_zone",
            Cause::Stiffness => "stiffness_nonlinearity",
            Cause::Offset => "sensor_offset",
            Cause::Delay => "time_delay",
            Cause::Vibration => "vibration",
        }
    }

    pub fn parse(s: &str) -> Result<Cause, String> {
        ALL_CAUSES
            .iter()
            .copied()
            .find(|c| c.name() == s)
            .ok_or_else(|| format!("unknown cause `{s}`"))
    }

    /// The model variants this generator has for the cause (the first is drawn most often).
    pub fn models(self) -> &'static [&'static str] {
        match self {
            Cause::Viscous => &["viscous"],
            Cause::Hysteresis => &["bouc_wen", "lugre", "dahl"],
            Cause::DeadZone => &["ideal", "ramp"],
            Cause::Stiffness => &[
                "cubic_hardening",
                "cubic_softening",
                "tanh_softening",
                "sinh_hardening",
            ],
            Cause::Offset => &["constant", "drift", "per_repetition"],
            Cause::Delay => &["transport", "lowpass"],
            Cause::Vibration => &["sine"],
        }
    }
}

/// Record variant flags (the `variant` field is these joined by '+', or "plain").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Flags {
    pub friction_position: bool,
    pub linear: bool,
    pub encoder17: bool,
    pub long: bool,
    /// Number of repetitions (0 or 1: a single run).
    pub reps: usize,
    /// Time restarts at 0 for each repetition (implies repetitions).
    pub restart: bool,
    pub irregular: bool,
    pub epoch: bool,
    pub bin20: bool,
}

impl Flags {
    pub fn parse(s: &str, rng: &mut Rng) -> Result<Flags, String> {
        let mut f = Flags::default();
        for tok in s.split('+').map(str::trim).filter(|t| !t.is_empty()) {
            match tok {
                "plain" => {}
                "irregular" => f.irregular = true,
                "epoch" => f.epoch = true,
                "repetitions" => f.reps = f.reps.max(rng.int(2, 3)),
                "repetitions2" => f.reps = 2,
                "repetitions3" => f.reps = 3,
                "restart" => {
                    f.restart = true;
                    f.reps = f.reps.max(rng.int(2, 3));
                }
                "encoder17" => f.encoder17 = true,
                "linear2e-6" => f.linear = true,
                "bin20" => f.bin20 = true,
                "long" => f.long = true,
                "friction_position" => f.friction_position = true,
                other => return Err(format!("unknown variant token `{other}`")),
            }
        }
        if f.linear && f.encoder17 {
            return Err("linear2e-6 and encoder17 exclude each other".into());
        }
        if f.linear && f.friction_position {
            return Err("linear2e-6 needs a stiff spring; friction_position has none".into());
        }
        Ok(f)
    }

    /// Canonical name: tokens in a fixed order, "plain" when none.
    pub fn name(&self) -> String {
        let mut t: Vec<&str> = Vec::new();
        if self.friction_position {
            t.push("friction_position");
        }
        if self.linear {
            t.push("linear2e-6");
        }
        if self.encoder17 {
            t.push("encoder17");
        }
        if self.long {
            t.push("long");
        }
        if self.restart {
            t.push("restart");
        } else if self.reps > 1 {
            t.push("repetitions");
        }
        if self.irregular {
            t.push("irregular");
        }
        if self.epoch {
            t.push("epoch");
        }
        if self.bin20 {
            t.push("bin20");
        }
        if t.is_empty() {
            "plain".into()
        } else {
            t.join("+")
        }
    }

    /// How many "real-data" complications the record has (for the difficulty level).
    pub fn complications(&self) -> usize {
        [
            self.friction_position,
            self.linear,
            self.encoder17,
            self.long,
            self.reps > 1,
            self.irregular,
            self.epoch,
            self.bin20,
        ]
        .iter()
        .filter(|b| **b)
        .count()
    }
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct Request {
    /// Hidden causes with an optional forced model variant.
    pub causes: Vec<(Cause, Option<String>)>,
    pub flags: Flags,
    /// Forced baseline friction: "atan", "stribeck" (deflection records) or "lugre",
    /// "stribeck" (friction_position). None: drawn.
    pub baseline: Option<String>,
    /// Forced program duration [s] (per repetition).
    pub duration_s: Option<f64>,
    /// Forced target ratio of each effect's unexplained RMS to the noise std.
    pub ratio: Option<f64>,
    /// The set-up of a device logged in several variants: a raw rate that can be binned.
    pub for_device: bool,
}

/// Parses "none" or "cause[:model]+cause[:model]".
pub fn parse_effects(s: &str) -> Result<Vec<(Cause, Option<String>)>, String> {
    let s = s.trim();
    if s.is_empty() || s == "none" {
        return Ok(Vec::new());
    }
    let mut out: Vec<(Cause, Option<String>)> = Vec::new();
    for part in s.split('+') {
        let (c, m) = match part.split_once(':') {
            Some((c, m)) => (c, Some(m.to_string())),
            None => (part, None),
        };
        let cause = Cause::parse(c.trim())?;
        if let Some(m) = &m
            && !cause.models().contains(&m.as_str())
        {
            return Err(format!("unknown model `{m}` for {}", cause.name()));
        }
        if out.iter().any(|(o, _)| *o == cause) {
            return Err(format!("cause {} given twice", cause.name()));
        }
        out.push((cause, m));
    }
    out.sort_by_key(|(c, _)| *c);
    Ok(out)
}

/// The physical set-up of one device and one test program: everything but the logging.
#[derive(Clone, Debug)]
pub struct Setup {
    pub physics: Physics,
    pub program: Program,
    /// Motion amplitude [rad] and rest position [rad] (non-zero only for friction_position).
    pub amp_rad: f64,
    pub centre_rad: f64,
    pub v_max: f64,
    /// Uniform logger rate [Hz] (raw rate before binning).
    pub fs_hz: f64,
    /// Median step of irregular time stamps [s].
    pub irregular_dt_s: f64,
    /// Torque noise per raw sample: white std, coloured (Ornstein-Uhlenbeck) std and its
    /// time constant [Nm, Nm, s].
    pub noise_white: f64,
    pub noise_col: f64,
    pub noise_tau_s: f64,
    pub encoder_step: f64,
    /// Std of the sub-count dither before rounding, in counts (linear encoder flicker).
    pub flicker_counts: f64,
    pub causes: Vec<Cause>,
    pub models: BTreeMap<String, String>,
    /// Torque span [Nm] the noise and effects are scaled to (spring or friction span).
    pub span_nm: f64,
    pub friction_position: bool,
}

/// Truth at the output samples, for tests and for checking answers.
#[derive(Clone, Debug, Default)]
pub struct Truth {
    /// True deflection (position) and its velocity at the samples.
    pub phi: Vec<f64>,
    pub vel: Vec<f64>,
    /// Noise-free torque the sensor would read.
    pub tau_clean: Vec<f64>,
    /// Baseline torque: k phi + baseline friction.
    pub tau_base: Vec<f64>,
    /// Baseline friction alone.
    pub friction: Vec<f64>,
    /// The noise added to the torque.
    pub noise: Vec<f64>,
    /// Repetition index of each sample.
    pub rep: Vec<usize>,
}

// ---------------------------------------------------------------------------------------------
// Timeline: the continuous motion of a whole record (all repetitions and the pauses between).

pub struct Timeline {
    pub dt_s: f64,
    pub phi: Vec<f64>,
    pub vel: Vec<f64>,
    /// [start, end) of each repetition [s].
    pub reps: Vec<(f64, f64)>,
}

impl Timeline {
    /// `gaps_s[i]` is the pause after repetition i; `scales[i]` the amplitude factor of rep i
    /// (a person never repeats a test exactly).
    pub fn build(setup: &Setup, scales: &[f64], gaps_s: &[f64]) -> Timeline {
        let dt = FINE_DT_S;
        let one = excitation::render(&setup.program, dt, setup.amp_rad, setup.v_max);
        let mut phi = Vec::new();
        let mut reps = Vec::new();
        for (i, s) in scales.iter().enumerate() {
            let start = phi.len() as f64 * dt;
            phi.extend(one.iter().map(|x| x * s));
            reps.push((start, phi.len() as f64 * dt));
            if let Some(g) = gaps_s.get(i) {
                let n = (g / dt).round() as usize;
                phi.extend(std::iter::repeat_n(0.0, n));
            }
        }
        let mut phi = excitation::smooth(&phi, dt, 0.02);
        phi.iter_mut().for_each(|x| *x += setup.centre_rad);
        let vel = excitation::velocity(&phi, dt);
        Timeline {
            dt_s: dt,
            phi,
            vel,
            reps,
        }
    }

    pub fn total_s(&self) -> f64 {
        self.phi.len() as f64 * self.dt_s
    }
}

/// Fine-grid states of a physics on a timeline.
struct States {
    /// Stateful torque: hysteresis + LuGre friction [Nm].
    state: Vec<f64>,
    /// LuGre baseline friction alone (zeros otherwise).
    fric_state: Vec<f64>,
    /// Low-pass filtered element torque, when the sensor has a low-pass.
    lp: Option<Vec<f64>>,
}

fn states(ph: &Physics, tl: &Timeline) -> States {
    let fric_state = model::simulate_lugre_friction(&ph.friction, &tl.phi, tl.dt_s);
    let mut state = fric_state.clone();
    if let Some(h) = &ph.hysteresis {
        let u = model::simulate_hysteresis_unit(&h.model, &tl.phi, tl.dt_s);
        state
            .iter_mut()
            .zip(&u)
            .for_each(|(s, u)| *s += h.force * u);
    }
    let lp = match &ph.delay {
        Some(d) if d.lp_tau_s > 0.0 => {
            let elem: Vec<f64> = (0..tl.phi.len())
                .map(|i| ph.memoryless(tl.phi[i], tl.vel[i]) + state[i])
                .collect();
            Some(model::lowpass(&elem, tl.dt_s, d.lp_tau_s))
        }
        _ => None,
    };
    States {
        state,
        fric_state,
        lp,
    }
}

/// Noise-free sensor torque at physical time t (repetition rep).
fn sensor_at(ph: &Physics, tl: &Timeline, st: &States, t: f64, rep: usize) -> f64 {
    let transport = ph.delay.as_ref().map_or(0.0, |d| d.transport_s);
    let td = t - transport;
    let elem = match &st.lp {
        Some(lp) => model::interp(lp, tl.dt_s, td),
        None => {
            let phi = model::interp(&tl.phi, tl.dt_s, td);
            let v = model::interp(&tl.vel, tl.dt_s, td);
            ph.memoryless(phi, v) + model::interp(&st.state, tl.dt_s, td)
        }
    };
    let total = tl.total_s();
    elem + ph.additive(t, rep, 0.5 * total, total)
}

// ---------------------------------------------------------------------------------------------
// Sizing: the part of an effect the baseline cannot explain.

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

fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

fn std_dev(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return 0.0;
    }
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

/// A decimated copy of a single-run timeline with precomputed baseline arrays.
struct Grid {
    t: Vec<f64>,
    /// Index into the fine timeline of each grid point.
    idx: Vec<usize>,
    phi: Vec<f64>,
    /// Baseline friction (memoryless + LuGre state) and the LuGre state alone.
    fric: Vec<f64>,
    fric_state: Vec<f64>,
    base: Vec<f64>,
}

impl Grid {
    fn new(base_ph: &Physics, tl: &Timeline) -> Grid {
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
    fn contribution(&self, ph: &Physics, tl: &Timeline, hyst_unit: Option<&[f64]>) -> Vec<f64> {
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

    fn unexplained(&self, c: &[f64]) -> f64 {
        unexplained_rms(c, &[&self.phi, &self.fric])
    }
}

/// Finds the scale s in [0, s_max] at which `f(s)` first reaches `target`: a coarse scan (the
/// unexplained part of some effects is not monotone, e.g. a dead zone as wide as the motion is
/// explained by a smaller k), then bisection. Returns (s, f(s)); the best scanned point if the
/// target is out of reach.
fn solve_scale(mut f: impl FnMut(f64) -> f64, target: f64, s_max: f64) -> (f64, f64) {
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
fn output_noise_factor(setup_fs: f64, col_rel: f64, tau: f64, bin20: bool) -> f64 {
    if bin20 {
        let n = (0.05 * setup_fs).max(1.0);
        (1.0 / n + col_rel * col_rel * ou_mean_var_factor(tau, 0.05)).sqrt()
    } else {
        (1.0 + col_rel * col_rel).sqrt()
    }
}

// ---------------------------------------------------------------------------------------------
// Drawing a set-up.

fn pick_model(rng: &mut Rng, cause: Cause, forced: &Option<String>, flags: &Flags) -> String {
    if let Some(m) = forced {
        return m.clone();
    }
    let m = match cause {
        Cause::Hysteresis => {
            let u = rng.uniform();
            if u < 0.4 {
                "bouc_wen"
            } else if u < 0.8 {
                "lugre"
            } else {
                "dahl"
            }
        }
        Cause::Offset if flags.reps > 1 => {
            if rng.chance(0.7) {
                "per_repetition"
            } else {
                "drift"
            }
        }
        Cause::Offset => {
            if rng.chance(0.5) {
                "constant"
            } else {
                "drift"
            }
        }
        other => rng.pick(other.models()),
    };
    m.to_string()
}

/// Why a set-up could not be drawn.
#[derive(Debug)]
pub enum SetupError {
    /// The request is impossible (e.g. vibration with bin20).
    Invalid(String),
    /// This draw cannot show the effect clearly; another draw (other motion) may.
    Unreachable(String),
}

/// Draws a set-up, redrawing (other motion, other physics) while an effect cannot be made
/// clearly present.
pub fn draw_setup_retrying(rng: &mut Rng, req: &Request) -> Result<Setup, String> {
    let mut last = String::new();
    for attempt in 0..20 {
        match draw_setup(&mut rng.fork(&format!("setup{attempt}")), req) {
            Ok(s) => return Ok(s),
            Err(SetupError::Invalid(e)) => return Err(e),
            Err(SetupError::Unreachable(e)) => last = e,
        }
    }
    Err(format!(
        "no set-up shows the effects clearly after 20 draws: {last}"
    ))
}

/// Draws the physics and program for a request, with each hidden effect sized so its
/// unexplained RMS is a drawn multiple (1.5-8) of the output noise std.
pub fn draw_setup(rng: &mut Rng, req: &Request) -> Result<Setup, SetupError> {
    let f = &req.flags;
    let causes: Vec<Cause> = req.causes.iter().map(|(c, _)| *c).collect();
    if f.friction_position
        && causes
            .iter()
            .any(|c| !matches!(c, Cause::Viscous | Cause::Offset))
    {
        return Err(SetupError::Invalid(
            "friction_position records only take viscous_friction or sensor_offset".into(),
        ));
    }
    if f.bin20 && causes.contains(&Cause::Vibration) {
        return Err(SetupError::Invalid(
            "vibration (8-60 Hz) cannot be seen below 0.4 x 20 Hz: not with bin20".into(),
        ));
    }

    // Logging rates.
    let fs_hz = if f.bin20 || f.long || req.for_device {
        *rng.pick(&RATES_HZ[3..])
    } else {
        *rng.pick(&RATES_HZ)
    };
    let irregular_dt_s = rng.range(1.0e-3, 2.0e-3);
    let fs_eff = if f.irregular {
        1.0 / irregular_dt_s
    } else {
        fs_hz
    };

    // Program duration (per repetition).
    let reps = f.reps.max(1);
    let program_s = if let Some(d) = req.duration_s {
        d
    } else if f.long {
        let n = rng.log_range(1.0e5, 1.0e6);
        (n / fs_eff / reps as f64).clamp(60.0, 600.0)
    } else if reps > 1 {
        rng.range(15.0, 35.0)
    } else {
        rng.range(20.0, 60.0)
    };
    let program = excitation::random_program(rng, program_s);

    // Encoder.
    let encoder_step = if f.linear {
        LINEAR_STEP
    } else if f.encoder17 {
        ENC17_STEP
    } else {
        ENC14_STEP
    };
    let flicker_counts = if f.linear { rng.range(0.35, 0.7) } else { 0.0 };

    // Stiffness and amplitude.
    // `span_target`: the spring torque span [Nm] the motion should produce (3-30 Nm).
    let (k, amp_rad, centre_rad, v_max, span_target) = if f.friction_position {
        let centre = rng.sign() * rng.range(0.2, 0.8);
        (0.0, rng.range(0.3, 1.0), centre, 2.0, 0.0)
    } else if f.linear {
        // A stiff spring and a span of a few mrad (hundreds to thousands of counts).
        let k = rng.log_range(1000.0, 3000.0);
        let amp = rng.range(1.2e-3, 4.0e-3);
        let span = (2.0 * k * amp).clamp(3.0, 30.0);
        (k, span / (2.0 * k), 0.0, 3.0, span)
    } else {
        let span = rng.log_range(3.0, 30.0);
        // At least 40 counts of half span, so the deflection is not a few quantisation levels.
        let amp_min = 40.0 * encoder_step;
        let k_max = (span / (2.0 * amp_min)).clamp(30.0, 3000.0);
        let k = rng.log_range(30.0, k_max.max(30.0 + 1e-9));
        let amp = (span / (2.0 * k)).min(0.6);
        (k, amp, 0.0, 3.0, span)
    };

    // A provisional set-up to render the motion.
    let mut setup = Setup {
        physics: Physics {
            k,
            friction: Friction::Atan { ka: 0.0, kb: 1.0 },
            viscous_b: 0.0,
            hysteresis: None,
            dead_zone: None,
            spring: Spring::Linear,
            delay: None,
            vibration: None,
            offset: None,
        },
        program,
        amp_rad,
        centre_rad,
        v_max,
        fs_hz,
        irregular_dt_s,
        noise_white: 0.0,
        noise_col: 0.0,
        noise_tau_s: 0.1,
        encoder_step,
        flicker_counts,
        causes: causes.clone(),
        models: BTreeMap::new(),
        span_nm: 0.0,
        friction_position: f.friction_position,
    };
    let mut tl = Timeline::build(&setup, &[1.0], &[]);
    // Segments use 45-100 % of the amplitude and fast ones are velocity-limited: scale the
    // amplitude until the spring torque really spans the target.
    if span_target > 0.0 {
        for _ in 0..4 {
            let (lo, hi) = tl
                .phi
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
            let actual = k * (hi - lo);
            if actual <= 0.0 || (actual / span_target - 1.0).abs() < 0.03 {
                break;
            }
            let amp_new = (setup.amp_rad * span_target / actual).min(0.6);
            if (amp_new / setup.amp_rad - 1.0).abs() < 1e-3 {
                break;
            }
            setup.amp_rad = amp_new;
            tl = Timeline::build(&setup, &[1.0], &[]);
        }
    }
    let phi_max = tl
        .phi
        .iter()
        .fold(0.0_f64, |m, p| m.max((p - centre_rad).abs()));
    let (pmin, pmax) = tl
        .phi
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
    let v_rms = rms(&tl.vel).max(1e-6);
    let v_peak = tl.vel.iter().fold(0.0_f64, |m, v| m.max(v.abs())).max(1e-6);

    // Baseline friction.
    let spring_span = k * (pmax - pmin);
    let baseline = req.baseline.clone().unwrap_or_else(|| {
        if f.friction_position {
            if rng.chance(0.5) { "lugre" } else { "stribeck" }.to_string()
        } else if rng.chance(0.25) {
            "stribeck".to_string()
        } else {
            "atan".to_string()
        }
    });
    let friction = if f.friction_position {
        let fc = rng.range(0.5, 5.0);
        let fs = fc * rng.range(1.1, 1.7);
        let vs = rng.log_range(0.01, 0.1);
        match baseline.as_str() {
            "lugre" => {
                // Stiff bristles: presliding well below one encoder count's worth of motion
                // matters little; this is friction, not a hidden hysteresis.
                let x_p = rng.log_range(1e-4, 5e-4);
                let sigma0 = fs / x_p;
                let sigma1 = rng.range(0.02, 0.1) * fc / v_rms;
                Friction::LuGre {
                    fc,
                    fs,
                    vs,
                    sigma0,
                    sigma1,
                }
            }
            "stribeck" => Friction::Stribeck { fc, fs, vs },
            other => {
                return Err(SetupError::Invalid(format!(
                    "baseline `{other}` not for friction_position"
                )));
            }
        }
    } else {
        let ka = rng.range(0.01, 0.05) * spring_span;
        let kb = rng.log_range(20.0, 200.0);
        match baseline.as_str() {
            "atan" => Friction::Atan { ka, kb },
            "stribeck" => {
                let fc = ka * PI / 2.0 * rng.range(0.8, 1.2);
                Friction::Stribeck {
                    fc,
                    fs: fc * rng.range(1.1, 1.8),
                    vs: rng.log_range(0.005, 0.05).min(0.3 * v_rms),
                }
            }
            other => {
                return Err(SetupError::Invalid(format!(
                    "baseline `{other}` not for deflection records"
                )));
            }
        }
    };
    setup.physics.friction = friction;
    let base_ph = setup.physics.clone();
    let grid = Grid::new(&base_ph, &tl);
    let span = if f.friction_position {
        let (a, b) = grid
            .fric
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
        b - a
    } else {
        spring_span
    };
    setup.span_nm = span;

    // Noise: white, sometimes plus a little coloured noise.
    let noise_frac = rng.log_range(0.005, 0.05);
    let (col_rel, noise_tau) = if rng.chance(0.3) {
        (rng.range(0.2, 0.5), rng.log_range(0.02, 0.2))
    } else {
        (0.0, 0.1)
    };
    let out_factor = output_noise_factor(fs_hz, col_rel, noise_tau, f.bin20);
    let mut noise_out = noise_frac * span * out_factor;

    // Model shapes (everything but the size).
    let models: Vec<String> = req
        .causes
        .iter()
        .map(|(c, m)| pick_model(rng, *c, m, f))
        .collect();
    for ((c, _), m) in req.causes.iter().zip(&models) {
        setup.models.insert(c.name().to_string(), m.clone());
    }
    let f_max = setup.program.max_freq_hz();
    let steady = setup.program.steady_freqs_hz();
    let mut hyst_shape: Option<HystModel> = None;
    let mut dz_ramp_rel = 0.0;
    let mut delay_lp_share = 0.0;
    let mut offset_shape = Offset {
        scale_nm: 0.0,
        rep_rel: Vec::new(),
        drift_rel: 0.0,
    };
    let mut offset_sign = 1.0_f64;
    let mut vib = Vibration {
        freq_hz: 0.0,
        amp_nm: 0.0,
        phase_rad: 0.0,
    };
    for ((c, _), m) in req.causes.iter().zip(&models) {
        match c {
            Cause::Hysteresis => {
                let x_h = rng.range(0.08, 0.4) * phi_max;
                hyst_shape = Some(match m.as_str() {
                    "dahl" => HystModel::Dahl { x_h },
                    "bouc_wen" => HystModel::BoucWen {
                        x_h,
                        n: rng.range(1.0, 2.5),
                        beta_frac: rng.range(0.55, 0.9),
                    },
                    _ => HystModel::LuGre {
                        x_h,
                        fs_ratio: rng.range(1.1, 1.6),
                        vs: rng.range(0.05, 0.3) * v_rms,
                        c1: rng.range(0.02, 0.15) / v_rms,
                    },
                });
            }
            Cause::DeadZone => {
                dz_ramp_rel = if m == "ramp" {
                    rng.range(0.3, 1.0)
                } else {
                    0.0
                };
            }
            Cause::Delay => {
                delay_lp_share = if m == "lowpass" {
                    rng.range(0.4, 1.0)
                } else {
                    0.0
                };
            }
            Cause::Offset => {
                offset_sign = rng.sign();
                if m == "drift" {
                    offset_shape.drift_rel = rng.sign() * rng.range(0.2, 0.8);
                }
                if m == "per_repetition" {
                    offset_shape.rep_rel = (0..reps.max(2)).map(|_| rng.range(-0.4, 0.4)).collect();
                    offset_shape.rep_rel[0] = 0.0;
                }
            }
            Cause::Vibration => {
                let fs_out = fs_eff;
                let lo = 8.0_f64.max(2.5 * f_max);
                let hi = 60.0_f64.min(0.4 * fs_out);
                if hi <= lo + 1.0 {
                    return Err(SetupError::Unreachable(format!(
                        "no room for a vibration between {lo:.1} and {hi:.1} Hz"
                    )));
                }
                let mut fv = rng.range(lo, hi);
                for _ in 0..200 {
                    let near = steady.iter().any(|&fm| {
                        (1..=20).any(|n| (fv - n as f64 * fm).abs() < (0.3_f64).max(0.02 * fv))
                    });
                    if !near {
                        break;
                    }
                    fv = rng.range(lo, hi);
                }
                vib = Vibration {
                    freq_hz: fv,
                    amp_nm: 0.0,
                    phase_rad: rng.range(0.0, 2.0 * PI),
                };
            }
            _ => {}
        }
    }
    let hyst_unit_grid: Option<Vec<f64>> = hyst_shape.as_ref().map(|m| {
        let u = model::simulate_hysteresis_unit(m, &tl.phi, tl.dt_s);
        grid.idx.iter().map(|&i| u[i]).collect()
    });

    // Each cause as "physics with this cause at scale s" and its largest sensible scale.
    let lp_tau_max = 1.0 / (2.0 * PI * 4.0 * f_max);
    let delay_cap = 0.1_f64.min(0.25 / f_max);
    let stiff_cap = |m: &str| -> f64 {
        match m {
            "cubic_softening" => 0.9 * k / (3.0 * phi_max * phi_max),
            "cubic_hardening" => 2.0 * k / (phi_max * phi_max),
            "tanh_softening" => 1.32 / phi_max,
            _ => 1.76 / phi_max,
        }
    };
    let apply = |ph: &mut Physics, c: Cause, m: &str, s: f64| match c {
        Cause::Viscous => ph.viscous_b = s,
        Cause::Hysteresis => {
            ph.hysteresis = Some(Hysteresis {
                force: s,
                model: hyst_shape.clone().expect("hysteresis shape"),
            })
        }
        Cause::DeadZone => {
            ph.dead_zone = Some(DeadZone {
                width: s,
                ramp: dz_ramp_rel * s,
            })
        }
        Cause::Stiffness => {
            ph.spring = match m {
                "cubic_softening" => Spring::Cubic { k3: -s },
                "cubic_hardening" => Spring::Cubic { k3: s },
                "tanh_softening" => Spring::TanhSoft {
                    phi_s: 1.0 / s.max(1e-300),
                },
                _ => Spring::SinhHard {
                    phi_s: 1.0 / s.max(1e-300),
                },
            }
        }
        Cause::Offset => {
            let mut o = offset_shape.clone();
            o.scale_nm = offset_sign * s;
            ph.offset = Some(o);
        }
        Cause::Delay => {
            let lp = (delay_lp_share * s).min(lp_tau_max);
            ph.delay = Some(Delay {
                transport_s: s - lp,
                lp_tau_s: lp,
            });
        }
        Cause::Vibration => {
            let mut v = vib.clone();
            v.amp_nm = s;
            ph.vibration = Some(v);
        }
    };
    let cap = |c: Cause, m: &str| -> f64 {
        match c {
            Cause::Viscous => {
                if f.friction_position {
                    2.0 * span / v_peak
                } else {
                    0.5 * span / v_peak
                }
            }
            Cause::Hysteresis => 0.25 * span,
            Cause::DeadZone => 0.45 * phi_max,
            Cause::Stiffness => stiff_cap(m),
            Cause::Offset => 0.5 * span,
            Cause::Delay => delay_cap,
            Cause::Vibration => 0.3 * span,
        }
    };
    let single_rms = |c: Cause, m: &str, s: f64| -> f64 {
        let mut ph = base_ph.clone();
        apply(&mut ph, c, m, s);
        let u = if c == Cause::Hysteresis {
            hyst_unit_grid.as_deref()
        } else {
            None
        };
        grid.unexplained(&grid.contribution(&ph, &tl, u))
    };

    // Noise low enough that every effect can reach its target within its cap, but not below
    // 0.5 % of the span.
    // Pairs a little smaller each, so that together they stay within about 10 x noise.
    let ratio_hi = if causes.len() > 1 { 6.0 } else { 8.0 };
    let mut targets: Vec<f64> = causes
        .iter()
        .map(|_| req.ratio.unwrap_or_else(|| rng.log_range(1.5, ratio_hi)))
        .collect();
    let cap_rms: Vec<f64> = causes
        .iter()
        .zip(&models)
        .map(|(c, m)| single_rms(*c, m, cap(*c, m)))
        .collect();
    for (t, r) in targets.iter().zip(&cap_rms) {
        noise_out = noise_out.min(0.85 * r / t);
    }
    noise_out = noise_out.max(0.005 * span * out_factor);
    for ((t, r), c) in targets.iter_mut().zip(&cap_rms).zip(&causes) {
        *t = t.min(0.9 * r / noise_out);
        // Not clearly present even at its largest sensible size over the lowest noise: this
        // motion does not show the effect (e.g. a delay on slow motion looks like friction).
        if *t < 1.2 {
            return Err(SetupError::Unreachable(format!(
                "{} reaches only {:.2} x noise",
                c.name(),
                t
            )));
        }
    }

    // Size each cause alone; for pairs, check they do not cancel (e.g. a delay acts like a
    // negative viscous term) and redraw the targets if they do.
    let mut ph = base_ph.clone();
    for attempt in 0..8 {
        ph = base_ph.clone();
        let mut each = Vec::new();
        for ((c, m), t) in causes.iter().zip(&models).zip(&targets) {
            let (s, r) = solve_scale(|s| single_rms(*c, m, s), t * noise_out, cap(*c, m));
            apply(&mut ph, *c, m, s);
            each.push(r);
        }
        if causes.len() < 2 {
            break;
        }
        let both = grid.unexplained(&grid.contribution(&ph, &tl, hyst_unit_grid.as_deref()));
        let max_each = each.iter().cloned().fold(0.0, f64::max);
        if both >= 0.6 * max_each || attempt == 7 {
            break;
        }
        for (t, r) in targets.iter_mut().zip(&cap_rms) {
            *t = rng.log_range(1.5, ratio_hi).min(0.9 * r / noise_out);
        }
    }
    setup.physics = ph;
    setup.noise_white = noise_out / out_factor;
    setup.noise_col = col_rel * setup.noise_white;
    setup.noise_tau_s = noise_tau;
    Ok(setup)
}

// ---------------------------------------------------------------------------------------------
// Logging.

/// Physical sample times [µs] of one repetition window.
fn sample_times_us(
    rng: &mut Rng,
    setup: &Setup,
    irregular: bool,
    start_us: i64,
    end_us: i64,
) -> Vec<i64> {
    let mut out = Vec::new();
    if !irregular {
        let step = (1e6 / setup.fs_hz).round() as i64;
        let mut t = start_us;
        while t < end_us {
            out.push(t);
            t += step;
        }
        return out;
    }
    // Irregular: jittered median step, occasional long steps (99th percentile ~10 ms) and a
    // few gaps of 0.1-0.3 s (a logger that stalled).
    let d0 = setup.irregular_dt_s * 1e6;
    let n_gaps = rng.int(1, 3);
    let mut gaps: Vec<i64> = (0..n_gaps)
        .map(|_| start_us + ((end_us - start_us) as f64 * rng.range(0.1, 0.9)) as i64)
        .collect();
    gaps.sort();
    let mut gi = 0;
    let mut t = start_us;
    while t < end_us {
        out.push(t);
        let mut step = if rng.chance(0.025) {
            rng.range(3.0e3, 15.0e3)
        } else {
            d0 * (1.0 + rng.range(-0.25, 0.25))
        };
        if gi < gaps.len() && t >= gaps[gi] {
            step += rng.range(0.1e6, 0.3e6);
            gi += 1;
        }
        t += step.round().max(50.0) as i64;
    }
    out
}

fn median(mut x: Vec<f64>) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.sort_by(|a, b| a.total_cmp(b));
    x[x.len() / 2]
}

/// Everything needed to describe the output besides the data.
pub struct Meta {
    pub name: String,
    pub device: Option<String>,
    pub effect: String,
    pub seed: u64,
}

/// Logs one record of a set-up with the given flags.
pub fn record(setup: &Setup, flags: &Flags, rng: &mut Rng, meta: Meta) -> (Case, Truth) {
    let ph = &setup.physics;
    let reps = flags.reps.max(1);
    let scales: Vec<f64> = (0..reps)
        .map(|r| if r == 0 { 1.0 } else { rng.range(0.96, 1.04) })
        .collect();
    let gaps: Vec<f64> = (1..reps)
        .map(|_| (rng.range(3.0, 10.0) * 1e3).round() / 1e3)
        .collect();
    let tl = Timeline::build(setup, &scales, &gaps);
    let st = states(ph, &tl);
    let base_ph = ph.baseline();
    let base_st = states(&base_ph, &tl);

    // Sample times, repetition by repetition.
    let mut t_us: Vec<i64> = Vec::new();
    let mut rep_of: Vec<usize> = Vec::new();
    for (r, &(a, b)) in tl.reps.iter().enumerate() {
        let ts = sample_times_us(
            rng,
            setup,
            flags.irregular,
            (a * 1e6).round() as i64,
            (b * 1e6).round() as i64,
        );
        rep_of.extend(std::iter::repeat_n(r, ts.len()));
        t_us.extend(ts);
    }
    let n = t_us.len();
    let t_phys: Vec<f64> = t_us.iter().map(|&u| u as f64 * 1e-6).collect();

    // Truth at the samples.
    let mut tr = Truth {
        rep: rep_of.clone(),
        ..Default::default()
    };
    for i in 0..n {
        let t = t_phys[i];
        let phi = model::interp(&tl.phi, tl.dt_s, t);
        let v = model::interp(&tl.vel, tl.dt_s, t);
        let fr = ph.friction.memoryless(v) + model::interp(&base_st.fric_state, tl.dt_s, t);
        tr.phi.push(phi);
        tr.vel.push(v);
        tr.friction.push(fr);
        tr.tau_base.push(ph.k * phi + fr);
        tr.tau_clean.push(sensor_at(ph, &tl, &st, t, rep_of[i]));
    }

    // Noise: white plus Ornstein-Uhlenbeck (exact update for any time step).
    let mut col = 0.0;
    let mut t_prev = t_phys.first().copied().unwrap_or(0.0);
    if setup.noise_col > 0.0 {
        col = setup.noise_col * rng.normal();
    }
    for &t in &t_phys {
        if setup.noise_col > 0.0 {
            let a = (-(t - t_prev) / setup.noise_tau_s).exp();
            col = col * a + setup.noise_col * (1.0 - a * a).sqrt() * rng.normal();
        }
        t_prev = t;
        tr.noise.push(setup.noise_white * rng.normal() + col);
    }

    // Measurements: quantised deflection (with flicker for the linear encoder), noisy torque.
    let q = setup.encoder_step;
    let mut defl: Vec<f64> = tr
        .phi
        .iter()
        .map(|p| {
            let d = if setup.flicker_counts > 0.0 {
                setup.flicker_counts * rng.normal()
            } else {
                0.0
            };
            (p / q + d).round() * q
        })
        .collect();
    let mut torque: Vec<f64> = tr
        .tau_clean
        .iter()
        .zip(&tr.noise)
        .map(|(a, b)| a + b)
        .collect();

    // Output time column.
    let epoch_us = if flags.epoch {
        EPOCH_BASE_US + (rng.range(0.0, 5.0e7) * 1e6) as i64
    } else {
        0
    };
    let rep_start_us: Vec<i64> = tl
        .reps
        .iter()
        .map(|(a, _)| (a * 1e6).round() as i64)
        .collect();
    let mut t_out: Vec<f64> = (0..n)
        .map(|i| {
            let rel = if flags.restart {
                t_us[i] - rep_start_us[rep_of[i]]
            } else {
                t_us[i]
            };
            (epoch_us + rel) as f64 / 1e6
        })
        .collect();

    // Per-sample sensor offset truth (for the reported mean).
    let total = tl.total_s();
    let mut offs: Vec<f64> = (0..n)
        .map(|i| {
            ph.offset
                .as_ref()
                .map_or(0.0, |o| o.at(t_phys[i], rep_of[i], 0.5 * total, total))
        })
        .collect();

    // Per-cause clean torque (for the per-cause ratio), evaluated at the samples.
    let mut each_clean: Vec<(Cause, Vec<f64>)> = Vec::new();
    if setup.causes.len() > 1 {
        for &c in &setup.causes {
            let only = only_cause(ph, c);
            let st1 = states(&only, &tl);
            let v: Vec<f64> = (0..n)
                .map(|i| sensor_at(&only, &tl, &st1, t_phys[i], rep_of[i]))
                .collect();
            each_clean.push((c, v));
        }
    }

    // Bin-average to 20 Hz (per repetition, 50 ms bins of physical time).
    let mut fs_out = if flags.irregular {
        let d: Vec<f64> = (1..n)
            .filter(|&i| rep_of[i] == rep_of[i - 1])
            .map(|i| t_phys[i] - t_phys[i - 1])
            .collect();
        1.0 / median(d)
    } else {
        setup.fs_hz
    };
    if flags.bin20 {
        let key = |i: usize| -> (usize, i64) {
            (rep_of[i], (t_us[i] - rep_start_us[rep_of[i]]) / 50_000)
        };
        let mut groups: Vec<(usize, usize)> = Vec::new(); // [start, end) of each bin
        let mut s = 0;
        for i in 1..=n {
            if i == n || key(i) != key(s) {
                groups.push((s, i));
                s = i;
            }
        }
        let avg = |x: &[f64]| -> Vec<f64> {
            groups
                .iter()
                .map(|&(a, b)| x[a..b].iter().sum::<f64>() / (b - a) as f64)
                .collect()
        };
        t_out = avg(&t_out);
        defl = avg(&defl);
        torque = avg(&torque);
        offs = avg(&offs);
        tr.phi = avg(&tr.phi);
        tr.vel = avg(&tr.vel);
        tr.tau_clean = avg(&tr.tau_clean);
        tr.tau_base = avg(&tr.tau_base);
        tr.friction = avg(&tr.friction);
        tr.noise = avg(&tr.noise);
        tr.rep = groups.iter().map(|&(a, _)| rep_of[a]).collect();
        for (_, v) in each_clean.iter_mut() {
            *v = avg(v);
        }
        fs_out = 20.0;
    }
    if flags.epoch {
        // Printed with microseconds; make the truth match what a reader will see.
        t_out.iter_mut().for_each(|t| *t = (*t * 1e6).round() / 1e6);
    }

    // The answer.
    let noise = std_dev(&tr.noise);
    let contrib: Vec<f64> = tr
        .tau_clean
        .iter()
        .zip(&tr.tau_base)
        .map(|(a, b)| a - b)
        .collect();
    let regs: [&[f64]; 2] = [&tr.phi, &tr.friction];
    let unexpl = unexplained_rms(&contrib, &regs);
    let mut each = BTreeMap::new();
    if setup.causes.len() == 1 {
        each.insert(setup.causes[0].name().to_string(), unexpl / noise);
    }
    for (c, v) in &each_clean {
        let cc: Vec<f64> = v.iter().zip(&tr.tau_base).map(|(a, b)| a - b).collect();
        each.insert(c.name().to_string(), unexplained_rms(&cc, &regs) / noise);
    }
    let params = answer_params(setup, &tr, &offs, total);
    let tau_max = tr.tau_clean.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let level = {
        let comp = flags.complications() + usize::from(ph.friction.name() != "atan");
        if setup.causes.len() >= 2 || comp >= 2 {
            3
        } else if comp == 1 {
            2
        } else {
            1
        }
    };
    let answer = Answer {
        effect: meta.effect,
        params,
        noise,
        fs: fs_out,
        k: ph.k,
        tau_max,
        variant: flags.name(),
        device: meta.device,
        level,
        effect_rms_over_noise: unexpl / noise,
        effect_rms_raw_over_noise: rms(&contrib) / noise,
        effect_rms_each: each,
        models: setup.models.clone(),
        friction_model: ph.friction.name().to_string(),
        friction: ph.friction.params(),
        encoder_step: q,
        quantised: !flags.bin20,
        torque_span: setup.span_nm,
        duration: t_phys.last().copied().unwrap_or(0.0) - t_phys.first().copied().unwrap_or(0.0),
        n_samples: t_out.len(),
        repetitions: reps,
        noise_white_raw: setup.noise_white,
        seed: meta.seed,
    };
    (
        Case {
            name: meta.name,
            t: t_out,
            deflection: defl,
            torque,
            answer,
        },
        tr,
    )
}

/// The baseline plus one cause of `ph`.
fn only_cause(ph: &Physics, c: Cause) -> Physics {
    let mut o = ph.baseline();
    match c {
        Cause::Viscous => o.viscous_b = ph.viscous_b,
        Cause::Hysteresis => o.hysteresis = ph.hysteresis.clone(),
        Cause::DeadZone => o.dead_zone = ph.dead_zone.clone(),
        Cause::Stiffness => o.spring = ph.spring.clone(),
        Cause::Offset => o.offset = ph.offset.clone(),
        Cause::Delay => o.delay = ph.delay.clone(),
        Cause::Vibration => o.vibration = ph.vibration.clone(),
    }
    o
}

/// The answer's `params`: each cause's documented parameters, measured over the record where
/// the brief asks for it (offset mean, equivalent cubic).
fn answer_params(setup: &Setup, tr: &Truth, offs: &[f64], total_s: f64) -> BTreeMap<String, f64> {
    let ph = &setup.physics;
    let mut m = BTreeMap::new();
    for &c in &setup.causes {
        match c {
            Cause::Viscous => {
                m.insert("b".into(), ph.viscous_b);
            }
            Cause::Hysteresis => {
                if let Some(h) = &ph.hysteresis {
                    h.params(&mut m);
                }
            }
            Cause::DeadZone => {
                if let Some(d) = &ph.dead_zone {
                    m.insert("width".into(), d.width);
                    m.insert("width_ramp".into(), d.ramp);
                }
            }
            Cause::Stiffness => {
                // Least-squares k + k3 fit of the spring shape over the excited deflections
                // (the dead-zone-filtered deflection when there is one).
                let s: Vec<f64> = tr
                    .phi
                    .iter()
                    .map(|p| ph.dead_zone.as_ref().map_or(*p, |d| d.apply(*p)))
                    .collect();
                let y: Vec<f64> = s.iter().map(|x| ph.spring.torque(ph.k, *x)).collect();
                let s3: Vec<f64> = s.iter().map(|x| x * x * x).collect();
                let fit = lstsq(&y, &[&s, &s3]);
                match ph.spring {
                    Spring::Cubic { k3 } => {
                        m.insert("k3".into(), k3);
                    }
                    Spring::TanhSoft { phi_s } | Spring::SinhHard { phi_s } => {
                        m.insert("k3".into(), fit[1]);
                        m.insert("stiff_phi_s".into(), phi_s);
                    }
                    Spring::Linear => {}
                }
                m.insert("stiff_k_equivalent".into(), fit[0]);
            }
            Cause::Offset => {
                let mean = offs.iter().sum::<f64>() / offs.len().max(1) as f64;
                m.insert("offset".into(), mean);
                if let Some(o) = &ph.offset {
                    // Offset(t) = scale (1 + rep + drift_rel (t - mid) / total): the slope [Nm/s].
                    if o.drift_rel != 0.0 {
                        m.insert(
                            "offset_drift_per_s".into(),
                            o.scale_nm * o.drift_rel / total_s.max(1e-9),
                        );
                    }
                    if !o.rep_rel.is_empty() {
                        let reps = tr.rep.iter().max().map_or(1, |r| r + 1);
                        for r in 0..reps {
                            let (s, c) = tr
                                .rep
                                .iter()
                                .zip(offs)
                                .filter(|(rr, _)| **rr == r)
                                .fold((0.0, 0usize), |(s, c), (_, o)| (s + o, c + 1));
                            m.insert(format!("offset_rep{r}"), s / c.max(1) as f64);
                        }
                    }
                }
            }
            Cause::Delay => {
                if let Some(d) = &ph.delay {
                    m.insert("delay".into(), d.equivalent_s());
                    m.insert("delay_transport".into(), d.transport_s);
                    if d.lp_tau_s > 0.0 {
                        m.insert("delay_fc_hz".into(), 1.0 / (2.0 * PI * d.lp_tau_s));
                    }
                }
            }
            Cause::Vibration => {
                if let Some(v) = &ph.vibration {
                    m.insert("frequency".into(), v.freq_hz);
                    m.insert("amplitude".into(), v.amp_nm);
                    m.insert("vibration_phase".into(), v.phase_rad);
                }
            }
        }
    }
    m
}
