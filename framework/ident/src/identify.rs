//! `jointctl identify`: given measured data, what the joint model gets wrong and why.
//!
//! 1. Data quality: readings that jump to exactly zero (thesis appendix A's lost CAN frames)
//!    are excluded and reported.
//! 2. The baseline: the joint's model from the config when given, else the thesis' structure
//!    fitted on the data: a characteristic through zero (first order unless asked otherwise)
//!    plus the arctan friction of eq. 3.5, `k_a atan(k_b d(phi)/dt)`. It is fitted on the first
//!    70 % of the time range; the last 30 % is held out for scoring.
//! 3. Candidate causes, each a physical extension of the model: `viscous_friction`,
//!    `hysteresis` (Dahl), `dead_zone`, `stiffness_nonlinearity`, `time_delay`, `sensor_offset`,
//!    `vibration`; `dropout` comes from step 1. More can be registered through the
//!    [`CandidateCause`] trait ([`IdentifyOptions::extra_candidates`]).
//! 4. Forward selection on the training part by the Bayesian information criterion: a cause
//!    is kept when it lowers BIC by more than 10 (Kass and Raftery's "very strong" evidence),
//!    the same criterion for every cause and every data set. A fit that is physically
//!    impossible (negative damping, negative hysteresis) is rejected: that is evidence for
//!    another cause.
//! 5. The extended model is fitted on the training part, and 6. its gain measured on the
//!    held-out part only. A selected cause without a held-out gain is dropped as not confirmed
//!    (it fitted the training part only).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::csv::Data;

/// A cause found in the data.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Cause {
    /// One of the vocabulary's names.
    pub effect: String,
    /// Estimated parameters (SI units in the names).
    pub params: BTreeMap<String, f64>,
    /// How much the held-out torque RMSE drops because of this cause [Nm].
    pub rmse_gain: f64,
    /// Why it was selected.
    pub evidence: String,
}

/// The result, in the documented JSON shape (plus traces for plots, not serialised).
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Samples read.
    pub samples: usize,
    /// Samples excluded as dropouts.
    pub dropped_samples: usize,
    /// Held-out torque RMSE of the baseline [Nm].
    pub rmse_before: f64,
    /// Held-out torque RMSE of the extended model [Nm].
    pub rmse_after: f64,
    /// Causes, most important first; empty when the baseline explains the data.
    pub causes: Vec<Cause>,
    /// Held-out part: (t, deflection, velocity, measured, baseline, extended) for plots.
    #[serde(skip)]
    pub held_out: Vec<[f64; 6]>,
    /// Candidates rejected: fits that are physically impossible (evidence for another cause) and
    /// causes not confirmed on the held-out part.
    #[serde(skip)]
    pub rejected: Vec<String>,
}

/// The model the baseline starts from.
pub enum BaselineModel {
    /// A polynomial through zero of this order, fitted on the data (the thesis' structure).
    Polynomial(usize),
    /// A given characteristic `torque(deflection, pivot_mm)` (a joint from a config), not refitted.
    Given(Box<dyn Fn(f64, f64) -> f64 + Send + Sync>),
}

/// How to identify.
pub struct IdentifyOptions {
    /// The baseline's elastic model.
    pub baseline: BaselineModel,
    /// Fraction of the time range used for fitting (the rest is held out).
    pub train_fraction: f64,
    /// Most causes reported.
    pub max_causes: usize,
    /// Causes beyond the built-in vocabulary, tested with the same criterion.
    pub extra_candidates: Vec<Box<dyn CandidateCause>>,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions { baseline: BaselineModel::Polynomial(1), train_fraction: 0.7, max_causes: 3, extra_candidates: Vec::new() }
    }
}

/// What a candidate sees of one part of the data (training or held out). The deflection and
/// velocity are as the torque channel sees them (shifted when a time delay is in the model).
pub struct Samples<'a> {
    /// Time [s].
    pub t_s: &'a [f64],
    /// Deflection [rad].
    pub deflection_rad: &'a [f64],
    /// Deflection rate [rad/s].
    pub velocity_rad_per_s: &'a [f64],
    /// Stiffness setting [mm] (0 when the data has none).
    pub pivot_mm: &'a [f64],
    /// Deflections before this part, oldest first: the history a stateful effect starts from.
    pub history_rad: &'a [f64],
}

/// Scales of the experiment, for a candidate's parameter grid.
#[derive(Clone, Copy, Debug)]
pub struct Excitation {
    /// Largest |deflection| [rad].
    pub amplitude_rad: f64,
    /// Fundamental frequency of the deflection (zero crossings per second) [Hz].
    pub frequency_hz: f64,
    /// Sample period [s].
    pub sample_period_s: f64,
}

/// A user-defined cause: a model extension linear in its coefficients, with at most one
/// non-linear parameter searched on a grid (refined between grid points when the grid is
/// positive). It competes with the built-in causes under the same BIC criterion, on the same
/// training part, and its gain is measured on the same held-out part.
///
/// ```
/// use jointctl_ident::identify::{CandidateCause, Excitation, Samples};
///
/// /// Cogging: a torque ripple periodic in deflection, `a sin(w phi) + b cos(w phi)`.
/// struct Cogging;
///
/// impl CandidateCause for Cogging {
///     fn name(&self) -> &str { "cogging" }
///     fn coefficient_names(&self) -> Vec<String> { vec!["sin_nm".into(), "cos_nm".into()] }
///     fn parameter_name(&self) -> Option<&str> { Some("ripples_per_rad") }
///     fn grid(&self, e: &Excitation) -> Vec<f64> {
///         (1..=40).map(|k| k as f64 * 4.0 / e.amplitude_rad).collect()
///     }
///     fn columns(&self, w: f64, s: &Samples) -> Vec<Vec<f64>> {
///         vec![
///             s.deflection_rad.iter().map(|x| (w * x).sin()).collect(),
///             s.deflection_rad.iter().map(|x| (w * x).cos()).collect(),
///         ]
///     }
/// }
/// let e = Excitation { amplitude_rad: 0.1, frequency_hz: 0.2, sample_period_s: 0.005 };
/// assert_eq!(Cogging.grid(&e).len(), 40);
/// ```
pub trait CandidateCause: Send + Sync {
    /// The name reported in the `effect` field.
    fn name(&self) -> &str;
    /// Names of the linear coefficients, SI units in the names; reported as parameters.
    fn coefficient_names(&self) -> Vec<String>;
    /// Name of the non-linear parameter, if there is one (reported with its value).
    fn parameter_name(&self) -> Option<&str> {
        None
    }
    /// Values of the non-linear parameter to try (ignored without a parameter).
    fn grid(&self, excitation: &Excitation) -> Vec<f64> {
        let _ = excitation;
        vec![0.0]
    }
    /// One column per coefficient, one value per sample, for a parameter value.
    fn columns(&self, parameter: f64, samples: &Samples) -> Vec<Vec<f64>>;
    /// Why a fit is physically impossible (it is then rejected, not reported), or `None`.
    fn impossible(&self, parameter: f64, coefficients: &[f64]) -> Option<String> {
        let _ = (parameter, coefficients);
        None
    }
}

/// BIC improvement that counts as evidence (Kass and Raftery 1995: "very strong").
pub const BIC_THRESHOLD: f64 = 10.0;

/// A candidate cause: a model extension with a name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Candidate {
    /// `+ b * dphi/dt`.
    ViscousFriction,
    /// `+ c`.
    SensorOffset,
    /// `+ k3 * phi^3`.
    StiffnessNonlinearity,
    /// `+ Fc * u(phi; lambda)`, Dahl with deflection scale lambda = Fc / sigma.
    Hysteresis,
    /// The elastic model of `dz(phi, w)`, no torque within the play.
    DeadZone,
    /// The elastic model of `phi(t - d)`.
    TimeDelay,
    /// `+ a sin(2 pi f t) + b cos(2 pi f t)`.
    Vibration,
    /// The registered [`CandidateCause`] at this index of [`IdentifyOptions::extra_candidates`].
    Registered(usize),
}

impl Candidate {
    /// All built-in candidates.
    pub const ALL: [Candidate; 7] = [
        Candidate::ViscousFriction,
        Candidate::SensorOffset,
        Candidate::StiffnessNonlinearity,
        Candidate::Hysteresis,
        Candidate::DeadZone,
        Candidate::TimeDelay,
        Candidate::Vibration,
    ];

    /// The vocabulary name.
    pub fn name(self) -> &'static str {
        match self {
            Candidate::ViscousFriction => "viscous_friction",
            Candidate::SensorOffset => "sensor_offset",
            Candidate::StiffnessNonlinearity => "stiffness_nonlinearity",
            Candidate::Hysteresis => "hysteresis",
            Candidate::DeadZone => "dead_zone",
            Candidate::TimeDelay => "time_delay",
            Candidate::Vibration => "vibration",
            Candidate::Registered(_) => "registered",
        }
    }
}

/// One model: which extensions with which grid parameters.
#[derive(Clone, Debug, Default, PartialEq)]
struct Spec {
    /// Eq. 3.5's k_b (refitted with every model).
    kb: f64,
    viscous: bool,
    offset: bool,
    cubic: bool,
    hysteresis: Option<f64>,
    dead_zone: Option<f64>,
    /// Delay of the torque channel [s].
    delay: Option<f64>,
    vibration: Option<f64>,
    /// Parameter of each selected registered candidate (index into the options' list).
    registered: Vec<(usize, f64)>,
}

/// Prepared samples of one part.
struct Part {
    /// Deflections before this part (the hysteresis state carries over).
    warm: Vec<f64>,
    t: Vec<f64>,
    d: Vec<f64>,
    v: Vec<f64>,
    tau: Vec<f64>,
    pivot: Vec<f64>,
}

impl Part {
    fn len(&self) -> usize {
        self.t.len()
    }

    fn every(&self, k: usize) -> Part {
        let pick = |v: &Vec<f64>| v.iter().step_by(k.max(1)).copied().collect();
        Part { warm: pick(&self.warm), t: pick(&self.t), d: pick(&self.d), v: pick(&self.v), tau: pick(&self.tau), pivot: pick(&self.pivot) }
    }
}

fn dead_zone(x: f64, w: f64) -> f64 {
    x.signum() * (x.abs() - w).max(0.0)
}

/// The unit Dahl response (limit 1) to a deflection history with scale `lambda`, exact per step.
fn dahl_unit(d: &[f64], lambda: f64) -> Vec<f64> {
    let mut u = 0.0;
    let mut out = Vec::with_capacity(d.len());
    let mut prev = d.first().copied().unwrap_or(0.0);
    for &x in d {
        let step = x - prev;
        if step != 0.0 {
            let target = step.signum();
            u = target + (u - target) * (-step.abs() / lambda).exp();
        }
        out.push(u);
        prev = x;
    }
    out
}

struct Model<'a> {
    baseline: &'a BaselineModel,
    registered: &'a [Box<dyn CandidateCause>],
}

impl Model<'_> {
    /// Columns of the linear part and the fixed part (a given characteristic), for a spec.
    fn design(&self, spec: &Spec, p: &Part) -> (Vec<Vec<f64>>, Vec<f64>, Vec<String>) {
        let n = p.len();
        // A delay shifts the whole torque channel: what it sees of deflection and velocity.
        let spacing = if n > 1 { (p.t[n - 1] - p.t[0]) / (n - 1) as f64 } else { 1.0 };
        let shift = |x: &Vec<f64>| -> Vec<f64> {
            match spec.delay {
                Some(delay) => {
                    let k = (delay / spacing).round() as i64;
                    (0..n).map(|i| x[(i as i64 - k).clamp(0, n as i64 - 1) as usize]).collect()
                }
                None => x.clone(),
            }
        };
        let shifted = shift(&p.d);
        let velocity = shift(&p.v);
        let mut cols: Vec<Vec<f64>> = Vec::new();
        let mut names: Vec<String> = Vec::new();
        for &(i, value) in &spec.registered {
            let Some(candidate) = self.registered.get(i) else { continue };
            let samples = Samples { t_s: &p.t, deflection_rad: &shifted, velocity_rad_per_s: &velocity, pivot_mm: &p.pivot, history_rad: &p.warm };
            let coefficient_names = candidate.coefficient_names();
            let columns = candidate.columns(value, &samples);
            // Shapes are checked up front (check_registered); a column that still has the wrong
            // length would misalign the fit, so it is left out.
            for (name, col) in coefficient_names.into_iter().zip(columns).filter(|(_, c)| c.len() == n) {
                cols.push(col);
                names.push(name);
            }
        }
        let elastic: Vec<f64> = match spec.dead_zone {
            Some(w) => shifted.iter().map(|x| dead_zone(*x, w)).collect(),
            None => shifted,
        };
        let mut fixed = vec![0.0; n];
        match self.baseline {
            BaselineModel::Polynomial(order) => {
                for k in 1..=*order {
                    cols.push(elastic.iter().map(|x| x.powi(k as i32)).collect());
                    names.push(format!("k{k}"));
                }
            }
            BaselineModel::Given(f) => {
                for i in 0..n {
                    fixed[i] = f(elastic[i], p.pivot[i]);
                }
            }
        }
        cols.push(velocity.iter().map(|v| (spec.kb * v).atan()).collect());
        names.push("friction_ka_nm".into());
        if spec.viscous {
            cols.push(velocity.clone());
            names.push("damping_nms_per_rad".into());
        }
        if spec.offset {
            cols.push(vec![1.0; n]);
            names.push("offset_nm".into());
        }
        if spec.cubic {
            cols.push(elastic.iter().map(|x| x.powi(3)).collect());
            names.push("k3_nm_per_rad3".into());
        }
        if let Some(l) = spec.hysteresis {
            let mut history = p.warm.clone();
            history.extend_from_slice(&p.d);
            cols.push(dahl_unit(&history, l)[p.warm.len()..].to_vec());
            names.push("limit_nm".into());
        }
        if let Some(f) = spec.vibration {
            let w = std::f64::consts::TAU * f;
            cols.push(p.t.iter().map(|t| (w * t).sin()).collect());
            cols.push(p.t.iter().map(|t| (w * t).cos()).collect());
            names.push("vibration_sin_nm".into());
            names.push("vibration_cos_nm".into());
        }
        (cols, fixed, names)
    }

    /// Least squares on a part: coefficients and residual sum of squares.
    fn fit(&self, spec: &Spec, p: &Part) -> Option<(Vec<f64>, f64, Vec<String>)> {
        let (cols, fixed, names) = self.design(spec, p);
        let m = cols.len();
        let mut ata = DMatrix::<f64>::zeros(m, m);
        let mut aty = DVector::<f64>::zeros(m);
        for i in 0..p.len() {
            let y = p.tau[i] - fixed[i];
            for a in 0..m {
                let ca = cols[a][i];
                aty[a] += ca * y;
                for b in a..m {
                    ata[(a, b)] += ca * cols[b][i];
                }
            }
        }
        for a in 0..m {
            for b in 0..a {
                ata[(a, b)] = ata[(b, a)];
            }
        }
        let solve = |ata: &DMatrix<f64>, aty: &DVector<f64>| ata.clone().cholesky().map(|c| c.solve(aty)).or_else(|| ata.clone().lu().solve(aty));
        let mut coefs: Vec<f64> = solve(&ata, &aty)?.iter().copied().collect();
        // Coulomb friction cannot be negative: if the unconstrained optimum says so, the
        // constrained one has it at zero (least squares with one bound: drop the column).
        if let Some(f) = names.iter().position(|n| n == "friction_ka_nm")
            && coefs[f] < 0.0
        {
            let keep: Vec<usize> = (0..m).filter(|i| *i != f).collect();
            let sub_ata = DMatrix::from_fn(keep.len(), keep.len(), |r, c| ata[(keep[r], keep[c])]);
            let sub_aty = DVector::from_fn(keep.len(), |r, _| aty[keep[r]]);
            let sub = solve(&sub_ata, &sub_aty)?;
            coefs = vec![0.0; m];
            for (r, i) in keep.iter().enumerate() {
                coefs[*i] = sub[r];
            }
        }
        let rss = self.rss(&cols, &fixed, &coefs, p);
        Some((coefs, rss, names))
    }

    fn rss(&self, cols: &[Vec<f64>], fixed: &[f64], coefs: &[f64], p: &Part) -> f64 {
        (0..p.len())
            .map(|i| {
                let pred = fixed[i] + cols.iter().zip(coefs).map(|(c, k)| c[i] * k).sum::<f64>();
                (p.tau[i] - pred).powi(2)
            })
            .sum()
    }

    fn predict(&self, spec: &Spec, coefs: &[f64], p: &Part) -> Vec<f64> {
        let (cols, fixed, _) = self.design(spec, p);
        (0..p.len()).map(|i| fixed[i] + cols.iter().zip(coefs).map(|(c, k)| c[i] * k).sum::<f64>()).collect()
    }
}

fn bic(rss: f64, n: usize, params: usize) -> f64 {
    n as f64 * (rss / n as f64).max(1e-300).ln() + params as f64 * (n as f64).ln()
}

fn params_of(spec: &Spec, registered: &[Box<dyn CandidateCause>]) -> usize {
    spec.registered
        .iter()
        .filter_map(|(i, _)| registered.get(*i))
        .map(|c| c.coefficient_names().len() + c.parameter_name().is_some() as usize)
        .sum::<usize>()
        + spec.viscous as usize
        + spec.offset as usize
        + spec.cubic as usize
        + 2 * spec.hysteresis.is_some() as usize
        + spec.dead_zone.is_some() as usize
        + spec.delay.is_some() as usize
        + 3 * spec.vibration.is_some() as usize
}

fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64)).collect()
}

/// `(sum r sin(w t), sum r cos(w t))`. On uniformly spaced samples the phasor is rotated by a
/// constant step (two multiplications a sample instead of a sine and a cosine), re-anchored
/// every 1024 samples so that rounding cannot accumulate.
fn projection(t: &[f64], r: &[f64], w: f64) -> (f64, f64) {
    let n = t.len();
    let uniform = n > 2 && {
        let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
        t.windows(2).all(|p| ((p[1] - p[0]) - dt).abs() <= 1e-9 * dt.abs().max(1e-12))
    };
    let (mut s, mut c) = (0.0, 0.0);
    if !uniform {
        for (ti, ri) in t.iter().zip(r) {
            let (si, ci) = (w * ti).sin_cos();
            s += ri * si;
            c += ri * ci;
        }
        return (s, c);
    }
    let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
    let (ds, dc) = (w * dt).sin_cos();
    let (mut zs, mut zc) = (0.0, 0.0);
    for (i, ri) in r.iter().enumerate() {
        if i % 1024 == 0 {
            (zs, zc) = (w * (t[0] + i as f64 * dt)).sin_cos();
        }
        s += ri * zs;
        c += ri * zc;
        (zs, zc) = (zs * dc + zc * ds, zc * dc - zs * ds);
    }
    (s, c)
}

/// The dominant frequency of a residual above `min_hz` (a periodogram on a grid) [Hz].
fn dominant_frequency(t: &[f64], r: &[f64], min_hz: f64, max_hz: f64) -> f64 {
    let mut best = (0.0, min_hz);
    for f in log_grid(min_hz, max_hz, 240) {
        let (s, c) = projection(t, r, std::f64::consts::TAU * f);
        let power = s * s + c * c;
        if power > best.0 {
            best = (power, f);
        }
    }
    best.1
}

/// Golden-section minimum of `f` over [lo, hi] on a log scale (both > 0).
fn refine_log(f: impl Fn(f64) -> f64, lo: f64, hi: f64, iterations: usize) -> f64 {
    let (mut a, mut b) = (lo.ln(), hi.ln());
    let g = 0.618_033_988_749_895;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c.exp()), f(d.exp()));
    for _ in 0..iterations {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c.exp());
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d.exp());
        }
    }
    (0.5 * (a + b)).exp()
}

/// Refines a grid minimum between its neighbours.
fn refine_around(f: impl Fn(f64) -> f64, grid: &[f64], best: f64, iterations: usize) -> f64 {
    let i = grid.iter().position(|g| *g == best).unwrap_or(0);
    let lo = grid[i.saturating_sub(1)];
    let hi = grid[(i + 1).min(grid.len() - 1)];
    if lo > 0.0 && hi > lo { refine_log(f, lo, hi, iterations) } else { best }
}

fn with(spec: &Spec, c: Candidate, value: f64) -> Spec {
    let mut s = spec.clone();
    match c {
        Candidate::ViscousFriction => s.viscous = true,
        Candidate::SensorOffset => s.offset = true,
        Candidate::StiffnessNonlinearity => s.cubic = true,
        Candidate::Hysteresis => s.hysteresis = Some(value),
        Candidate::DeadZone => s.dead_zone = Some(value),
        Candidate::TimeDelay => s.delay = Some(value),
        Candidate::Vibration => s.vibration = Some(value),
        Candidate::Registered(i) => s.registered.push((i, value)),
    }
    s
}

fn without(spec: &Spec, c: Candidate) -> Spec {
    let mut s = spec.clone();
    match c {
        Candidate::ViscousFriction => s.viscous = false,
        Candidate::SensorOffset => s.offset = false,
        Candidate::StiffnessNonlinearity => s.cubic = false,
        Candidate::Hysteresis => s.hysteresis = None,
        Candidate::DeadZone => s.dead_zone = None,
        Candidate::TimeDelay => s.delay = None,
        Candidate::Vibration => s.vibration = None,
        Candidate::Registered(i) => s.registered.retain(|(k, _)| *k != i),
    }
    s
}

fn coef(names: &[String], coefs: &[f64], name: &str) -> Option<f64> {
    names.iter().position(|n| n == name).map(|i| coefs[i])
}

/// Is a fitted model physically possible? Returns why not.
fn impossible(spec: &Spec, names: &[String], coefs: &[f64], registered: &[Box<dyn CandidateCause>]) -> Option<String> {
    for &(i, value) in &spec.registered {
        let Some(c) = registered.get(i) else { continue };
        let own: Vec<f64> = c.coefficient_names().iter().map(|n| coef(names, coefs, n).unwrap_or(f64::NAN)).collect();
        if let Some(why) = c.impossible(value, &own) {
            return Some(why);
        }
    }
    if spec.viscous && coef(names, coefs, "damping_nms_per_rad").is_some_and(|b| b < 0.0) {
        return Some("negative viscous damping".into());
    }
    if spec.hysteresis.is_some() && coef(names, coefs, "limit_nm").is_some_and(|f| f <= 0.0) {
        return Some("negative hysteresis width".into());
    }
    if coef(names, coefs, "k1").is_some_and(|k| k <= 0.0) {
        return Some("non-positive stiffness".into());
    }
    None
}

/// Why [`identify`] failed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum IdentifyError {
    /// Too few samples to identify anything.
    #[error("{samples} samples are too few to identify anything (at least {needed})")]
    TooFewSamples {
        /// Samples given.
        samples: usize,
        /// Samples needed.
        needed: usize,
    },
    /// One side of the 70/30 fit/held-out split has too few samples.
    #[error("too few samples on one side of the 70/30 split")]
    UnevenSplit,
    /// A model's least-squares problem is singular (degenerate data).
    #[error("the {model} model cannot be fitted (degenerate data)")]
    Degenerate {
        /// "baseline" or "extended".
        model: &'static str,
    },
    /// A registered cause reuses a built-in or an earlier registered cause's name.
    #[error("registered cause `{name}`: the name is already taken")]
    CauseNameTaken {
        /// The cause's name.
        name: String,
    },
    /// A registered cause's `columns()` do not match its coefficient names or the samples.
    #[error("registered cause `{name}`: columns() gave {} column(s) of {lengths:?} values; expected {expected_columns} (one per coefficient name) of {samples} values (one per sample)", lengths.len())]
    CauseColumns {
        /// The cause's name.
        name: String,
        /// Length of each column returned.
        lengths: Vec<usize>,
        /// Columns expected.
        expected_columns: usize,
        /// Samples (values per column) expected.
        samples: usize,
    },
}

/// A registered cause must not reuse a name and must give one column per coefficient, one value
/// per sample: checked once, up front, so that a mistake is an error rather than a cause that
/// silently contributes nothing.
fn check_registered(registered: &[Box<dyn CandidateCause>], p: &Part) -> Result<(), IdentifyError> {
    let builtin: Vec<&str> = Candidate::ALL.iter().map(|c| c.name()).chain(["dropout"]).collect();
    for (i, c) in registered.iter().enumerate() {
        let name = c.name();
        if builtin.contains(&name) || registered[..i].iter().any(|o| o.name() == name) {
            return Err(IdentifyError::CauseNameTaken { name: name.into() });
        }
        let value = c.grid(&Excitation { amplitude_rad: 1.0, frequency_hz: 1.0, sample_period_s: 1.0 }).first().copied().unwrap_or(0.0);
        let samples = Samples { t_s: &p.t, deflection_rad: &p.d, velocity_rad_per_s: &p.v, pivot_mm: &p.pivot, history_rad: &p.warm };
        let columns = c.columns(value, &samples);
        let expected = c.coefficient_names().len();
        if columns.len() != expected || columns.iter().any(|col| col.len() != p.len()) {
            let lengths: Vec<usize> = columns.iter().map(Vec::len).collect();
            return Err(IdentifyError::CauseColumns { name: name.into(), lengths, expected_columns: expected, samples: p.len() });
        }
    }
    Ok(())
}

fn name_of(c: Candidate, opts: &IdentifyOptions) -> String {
    match c {
        Candidate::Registered(i) => opts.extra_candidates.get(i).map_or("registered".into(), |c| c.name().to_string()),
        _ => c.name().into(),
    }
}

/// Identifies what `data`'s model misses.
///
/// ```
/// use jointctl_ident::identify::{identify, IdentifyOptions};
///
/// // A linear spring with a 0.5 Nm torque-sensor offset, sine excitation (not phase-locked to
/// // the 100 Hz sampling).
/// let mut data = jointctl_ident::csv::Data::default();
/// for i in 0..3000 {
///     let t = i as f64 * 0.01;
///     let phi = 0.1 * (std::f64::consts::TAU * 0.237 * t).sin();
///     let noise = 0.01 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5);
///     data.t.push(t);
///     data.deflection.push(phi);
///     data.torque.push(80.0 * phi + 0.5 + noise);
///     for c in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque] {
///         c.push(f64::NAN);
///     }
/// }
/// let report = identify(&data, &IdentifyOptions::default()).unwrap();
/// assert_eq!(report.causes[0].effect, "sensor_offset");
/// assert!((report.causes[0].params["offset_nm"] - 0.5).abs() < 0.01);
/// assert!(report.rmse_after < 0.01 && report.rmse_before > 0.4);
/// ```
pub fn identify(data: &Data, opts: &IdentifyOptions) -> Result<Report, IdentifyError> {
    let n_all = data.len();
    if n_all < 50 {
        return Err(IdentifyError::TooFewSamples { samples: n_all, needed: 50 });
    }
    // 1. Dropouts: an exact zero between readings clearly away from zero.
    let steps: Vec<f64> = data.deflection.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|s| *s > 0.0).collect();
    let mut sorted = steps.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let typical = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let mut dropped = vec![false; n_all];
    for (series, scale) in [(&data.deflection, typical), (&data.torque, 0.0)] {
        let away = |x: f64| x.abs() > 5.0 * scale.max(1e-9);
        let mut i = 1;
        while i + 1 < n_all {
            if series[i] != 0.0 {
                i += 1;
                continue;
            }
            // A run of exact zeros between two readings clearly away from zero.
            let mut j = i;
            while j < n_all && series[j] == 0.0 {
                j += 1;
            }
            if j < n_all && away(series[i - 1]) && away(series[j]) {
                dropped[i..j].iter_mut().for_each(|d| *d = true);
            }
            i = j;
        }
    }
    let keep: Vec<usize> = (0..n_all).filter(|i| !dropped[*i]).collect();
    let n_dropped = n_all - keep.len();
    let d: Vec<f64> = keep.iter().map(|i| data.deflection[*i]).collect();
    let t: Vec<f64> = keep.iter().map(|i| data.t[*i]).collect();
    // Velocity: the slope of a local least-squares line (a Savitzky-Golay derivative) over about
    // a fiftieth of the excitation period: no lag, and it averages out the encoder quantisation.
    let period_samples = {
        let crossings = d.windows(2).filter(|w| w[0] < 0.0 && w[1] >= 0.0).count().max(1) as f64;
        d.len() as f64 / crossings
    };
    let half = ((period_samples / 50.0).round() as usize).clamp(2, 25);
    let v: Vec<f64> = (0..d.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half).min(d.len() - 1));
            let n = (b - a + 1) as f64;
            let (tm, dm) = (t[a..=b].iter().sum::<f64>() / n, d[a..=b].iter().sum::<f64>() / n);
            let (mut num, mut den) = (0.0, 0.0);
            for k in a..=b {
                num += (t[k] - tm) * (d[k] - dm);
                den += (t[k] - tm) * (t[k] - tm);
            }
            if den > 0.0 { num / den } else { 0.0 }
        })
        .collect();
    let tau: Vec<f64> = keep.iter().map(|i| data.torque[*i]).collect();
    let pivot: Vec<f64> = keep.iter().map(|i| if data.pivot_mm[*i].is_finite() { data.pivot_mm[*i] } else { 0.0 }).collect();
    let t_split = t[0] + opts.train_fraction * (t[t.len() - 1] - t[0]);
    let split = t.partition_point(|x| *x < t_split);
    let part = |r: std::ops::Range<usize>| Part { warm: d[..r.start].to_vec(), t: t[r.clone()].to_vec(), d: d[r.clone()].to_vec(), v: v[r.clone()].to_vec(), tau: tau[r.clone()].to_vec(), pivot: pivot[r].to_vec() };
    let train = part(0..split);
    let test = part(split..t.len());
    if train.len() < 30 || test.len() < 10 {
        return Err(IdentifyError::UnevenSplit);
    }
    // Grid searches on at most ~8000 training samples; final fits on all of them.
    let coarse = train.every(train.len().div_ceil(8000));
    check_registered(&opts.extra_candidates, &coarse)?;
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;

    // 2. Baseline: k_b of eq. 3.5 on a grid, then refined.
    let model = Model { baseline: &opts.baseline, registered: &opts.extra_candidates };
    let kb_grid = log_grid(0.3, 3000.0, 12);
    let rss_kb = |spec: &Spec, kb: f64| model.fit(&Spec { kb, ..spec.clone() }, &coarse).map_or(f64::INFINITY, |f| f.1);
    let best_kb = kb_grid.iter().copied().min_by(|a, b| rss_kb(&Spec::default(), *a).total_cmp(&rss_kb(&Spec::default(), *b))).unwrap_or(1.0);
    let kb = refine_around(|k| rss_kb(&Spec::default(), k), &kb_grid, best_kb, 25);
    // Every model refits k_b near the current value (a candidate may take part of the friction).
    let refit_kb = |spec: Spec| -> Spec { Spec { kb: refine_log(|k| rss_kb(&spec, k), spec.kb / 20.0, spec.kb * 20.0, 22), ..spec } };
    let base_params = match &opts.baseline {
        BaselineModel::Polynomial(k) => k + 2,
        BaselineModel::Given(_) => 2,
    };
    let base_spec = Spec { kb, ..Spec::default() };
    let (base_coefs, _, _) = model.fit(&base_spec, &train).ok_or(IdentifyError::Degenerate { model: "baseline" })?;
    let rmse = |spec: &Spec, coefs: &[f64]| {
        let pred = model.predict(spec, coefs, &test);
        (pred.iter().zip(&test.tau).map(|(p, y)| (p - y).powi(2)).sum::<f64>() / test.len() as f64).sqrt()
    };
    let rmse_before = rmse(&base_spec, &base_coefs);

    // 3-4. Forward selection by BIC on the (coarse) training part.
    let amplitude_d = d.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-6);
    let excitation_hz = {
        let crossings = d.windows(2).filter(|w| w[0] < 0.0 && w[1] >= 0.0).count() as f64;
        (crossings / (t[t.len() - 1] - t[0])).max(0.01)
    };
    let mut spec = base_spec.clone();
    let mut chosen: Vec<(Candidate, String)> = Vec::new();
    let mut current_bic = model.fit(&spec, &coarse).map(|(_, rss, _)| bic(rss, coarse.len(), base_params)).unwrap_or(f64::INFINITY);
    let mut rejected: Vec<String> = Vec::new();
    for _ in 0..opts.max_causes {
        let mut best: Option<(f64, Spec, Candidate, String)> = None;
        let registered = (0..opts.extra_candidates.len()).map(Candidate::Registered);
        for c in Candidate::ALL.into_iter().chain(registered).filter(|c| !chosen.iter().any(|(k, _)| k == c)) {
            if c == Candidate::StiffnessNonlinearity && matches!(opts.baseline, BaselineModel::Polynomial(k) if k >= 3) {
                continue;
            }
            let rss_at = |g: f64| model.fit(&with(&spec, c, g), &coarse).map_or(f64::INFINITY, |f| f.1);
            let grid: Vec<f64> = match c {
                Candidate::Hysteresis => log_grid(amplitude_d * 1e-3, amplitude_d, 16),
                Candidate::DeadZone => log_grid(amplitude_d * 2e-3, amplitude_d * 0.5, 16),
                Candidate::TimeDelay => {
                    // Delays [s] up to a tenth of the excitation period in steps of the coarse
                    // spacing; the best is refined on the full-rate data below.
                    let coarse_dt = dt * train.len().div_ceil(8000) as f64;
                    let max = ((0.1 / excitation_hz / coarse_dt).min(400.0)) as i64;
                    let step = (max / 40).max(1);
                    (1..=max.max(1)).filter(|k| k % step == 0 || *k <= 3).flat_map(|k| [k as f64 * coarse_dt, -(k as f64) * coarse_dt]).collect()
                }
                Candidate::Vibration => {
                    let (coefs, _, _) = match model.fit(&spec, &coarse) {
                        Some(f) => f,
                        None => continue,
                    };
                    let pred = model.predict(&spec, &coefs, &coarse);
                    let resid: Vec<f64> = coarse.tau.iter().zip(&pred).map(|(y, p)| y - p).collect();
                    let nyquist = 0.5 / (dt * train.len().div_ceil(8000) as f64);
                    let f0 = dominant_frequency(&coarse.t, &resid, (8.0 * excitation_hz).max(0.5), nyquist.min(200.0) * 0.9);
                    // The grid is 1.3 % coarse; over tens of seconds the phase needs far better.
                    let power = |f: f64| {
                        let (a, b) = projection(&coarse.t, &resid, std::f64::consts::TAU * f);
                        -(a * a + b * b)
                    };
                    vec![refine_log(power, f0 * 0.985, f0 * 1.015, 40)]
                }
                Candidate::Registered(i) => {
                    let candidate = &opts.extra_candidates[i];
                    let grid = candidate.grid(&Excitation { amplitude_rad: amplitude_d, frequency_hz: excitation_hz, sample_period_s: dt });
                    if candidate.parameter_name().is_none() || grid.is_empty() { vec![0.0] } else { grid }
                }
                _ => vec![0.0],
            };
            // The grid's best value, refined between its neighbours for continuous parameters.
            let mut values = grid.clone();
            let refinable = match c {
                Candidate::Hysteresis | Candidate::DeadZone => true,
                Candidate::Registered(i) => opts.extra_candidates[i].parameter_name().is_some() && grid.len() > 1 && grid.iter().all(|g| *g > 0.0),
                _ => false,
            };
            if refinable {
                let best_g = grid.iter().copied().min_by(|a, b| rss_at(*a).total_cmp(&rss_at(*b))).unwrap_or(grid[0]);
                values.push(refine_around(rss_at, &grid, best_g, 25));
            }
            // The grid's best for this candidate, with k_b refitted.
            let mut best_g = values.iter().copied().min_by(|a, b| rss_at(*a).total_cmp(&rss_at(*b))).unwrap_or(values[0]);
            if c == Candidate::TimeDelay {
                // Every full-rate sample within two coarse steps, each with k_b refitted.
                let coarse_dt = dt * train.len().div_ceil(8000) as f64;
                let span = (2.0 * coarse_dt * ((values.len() / 2) as f64 / 40.0).max(1.0) / dt).ceil() as i64;
                let centre = (best_g / dt).round() as i64;
                // k_b (a costly search) is refitted once, at the coarse optimum, for the scan;
                // the three best samples of the scan are then compared with k_b refitted each.
                let kb_here = refit_kb(with(&spec, c, best_g)).kb;
                let rss_with = |s: &Spec| model.fit(s, &train).map_or(f64::INFINITY, |f| f.1);
                let mut scan: Vec<(f64, i64)> = ((centre - span)..=(centre + span))
                    .filter(|k| *k != 0)
                    .map(|k| (rss_with(&Spec { kb: kb_here, ..with(&spec, c, k as f64 * dt) }), k))
                    .collect();
                scan.sort_by(|a, b| a.0.total_cmp(&b.0));
                let full_rss = |k: i64| rss_with(&refit_kb(with(&spec, c, k as f64 * dt)));
                best_g = scan.iter().take(3).map(|(_, k)| *k).min_by(|a, b| full_rss(*a).total_cmp(&full_rss(*b))).unwrap_or(centre) as f64 * dt;
            }
            for g in [best_g] {
                let s = refit_kb(with(&spec, c, g));
                let Some((coefs, rss, names)) = model.fit(&s, &coarse) else { continue };
                if let Some(why) = impossible(&s, &names, &coefs, &opts.extra_candidates) {
                    rejected.push(format!("{} ({why})", name_of(c, opts)));
                    continue;
                }
                let mut b = bic(rss, coarse.len(), base_params + params_of(&s, &opts.extra_candidates));
                if c == Candidate::Vibration {
                    // The frequency is the best of M resolvable ones (band x duration): a
                    // look-elsewhere search, charged 2 ln M on top of BIC's parameter count.
                    let duration = coarse.t[coarse.len() - 1] - coarse.t[0];
                    let band = 0.5 / (dt * train.len().div_ceil(8000) as f64);
                    b += 2.0 * (band * duration).max(1.0).ln();
                }
                if best.as_ref().is_none_or(|(bb, ..)| b < *bb) {
                    best = Some((b, s, c, format!("BIC {:.0} -> {:.0}", current_bic, b)));
                }
            }
        }
        match best {
            Some((b, s, c, why)) if current_bic - b > BIC_THRESHOLD => {
                spec = s;
                current_bic = b;
                chosen.push((c, why));
            }
            _ => break,
        }
    }

    // 5. The extended model on the whole training part; 6. gains on the held-out part. A cause
    // whose removal makes the held-out error smaller fitted the training part only: it is not
    // confirmed, dropped (the weakest first) and the rest refitted.
    let gain_of = |spec: &Spec, c: Candidate, rmse_after: f64| {
        let reduced = refit_kb(without(spec, c));
        model.fit(&reduced, &train).map(|(k, _, _)| rmse(&reduced, &k) - rmse_after).unwrap_or(0.0)
    };
    let mut spec = refit_kb(spec);
    let (coefs, names, rmse_after, gains) = loop {
        let (coefs, _, names) = model.fit(&spec, &train).ok_or(IdentifyError::Degenerate { model: "extended" })?;
        let rmse_after = rmse(&spec, &coefs);
        let gains: Vec<f64> = chosen.iter().map(|(c, _)| gain_of(&spec, *c, rmse_after)).collect();
        let weakest = (0..gains.len()).min_by(|a, b| gains[*a].total_cmp(&gains[*b]));
        match weakest {
            Some(i) if gains[i] <= 0.0 => {
                let (c, _) = chosen.remove(i);
                rejected.push(format!("{} (not confirmed on the held-out part: gain {:.4} Nm)", name_of(c, opts), gains[i]));
                spec = refit_kb(without(&spec, c));
            }
            _ => break (coefs, names, rmse_after, gains),
        }
    };
    let mut causes = Vec::new();
    for ((c, why), gain) in chosen.iter().zip(gains) {
        let mut params = BTreeMap::new();
        match c {
            Candidate::ViscousFriction => {
                params.insert("damping_nms_per_rad".into(), coef(&names, &coefs, "damping_nms_per_rad").unwrap_or(f64::NAN));
            }
            Candidate::SensorOffset => {
                params.insert("offset_nm".into(), coef(&names, &coefs, "offset_nm").unwrap_or(f64::NAN));
            }
            Candidate::StiffnessNonlinearity => {
                params.insert("k3_nm_per_rad3".into(), coef(&names, &coefs, "k3_nm_per_rad3").unwrap_or(f64::NAN));
            }
            Candidate::Hysteresis => {
                let fc = coef(&names, &coefs, "limit_nm").unwrap_or(f64::NAN);
                let lambda = spec.hysteresis.unwrap_or(f64::NAN);
                params.insert("limit_nm".into(), fc);
                params.insert("sigma_nm_per_rad".into(), fc / lambda);
            }
            Candidate::DeadZone => {
                params.insert("half_width_rad".into(), spec.dead_zone.unwrap_or(f64::NAN));
            }
            Candidate::TimeDelay => {
                params.insert("delay_s".into(), spec.delay.unwrap_or(0.0));
            }
            Candidate::Vibration => {
                let (a, b) = (coef(&names, &coefs, "vibration_sin_nm").unwrap_or(0.0), coef(&names, &coefs, "vibration_cos_nm").unwrap_or(0.0));
                params.insert("frequency_hz".into(), spec.vibration.unwrap_or(f64::NAN));
                params.insert("amplitude_nm".into(), a.hypot(b));
            }
            Candidate::Registered(i) => {
                let candidate = &opts.extra_candidates[*i];
                for name in candidate.coefficient_names() {
                    params.insert(name.clone(), coef(&names, &coefs, &name).unwrap_or(f64::NAN));
                }
                if let (Some(name), Some((_, value))) = (candidate.parameter_name(), spec.registered.iter().find(|(k, _)| k == i)) {
                    params.insert(name.into(), *value);
                }
            }
        }
        let mut evidence = format!("{why} on the training part (threshold {BIC_THRESHOLD})");
        if let (Candidate::Vibration, Some(f)) = (c, spec.vibration) {
            // A mode at a harmonic of the excitation (within the frequency resolution of the
            // record) cannot be told from a periodic shape error of the model: say so.
            let harmonic = (f / excitation_hz).round();
            let resolution_hz = 1.0 / (t[t.len() - 1] - t[0]);
            if harmonic >= 1.0 && (f - harmonic * excitation_hz).abs() < resolution_hz {
                evidence += &format!("; at {harmonic:.0}x the excitation frequency: possibly a periodic model error rather than a structural mode");
            }
        }
        causes.push(Cause { effect: name_of(*c, opts), params, rmse_gain: gain, evidence });
    }
    if n_dropped > 0 {
        let mut params = BTreeMap::new();
        params.insert("count".into(), n_dropped as f64);
        params.insert("fraction".into(), n_dropped as f64 / n_all as f64);
        causes.push(Cause {
            effect: "dropout".into(),
            params,
            rmse_gain: 0.0,
            evidence: format!("{n_dropped} readings jumped to exactly zero (appendix A's lost frames); excluded before fitting"),
        });
    }
    causes.sort_by(|a, b| b.rmse_gain.total_cmp(&a.rmse_gain));
    let base_pred = model.predict(&base_spec, &base_coefs, &test);
    let ext_pred = model.predict(&spec, &coefs, &test);
    let held_out = (0..test.len()).map(|i| [test.t[i], test.d[i], test.v[i], test.tau[i], base_pred[i], ext_pred[i]]).collect();
    rejected.sort();
    rejected.dedup();
    Ok(Report { samples: n_all, dropped_samples: n_dropped, rmse_before, rmse_after, causes, held_out, rejected })
}

#[cfg(test)]
mod tests {
    use super::projection;

    #[test]
    fn the_rotated_phasor_projection_equals_the_direct_one() {
        let t: Vec<f64> = (0..20_000).map(|i| 3.0 + i as f64 * 0.005).collect();
        let r: Vec<f64> = t.iter().map(|t| (7.3 * t).sin() + 0.2 * (1.1 * t).cos()).collect();
        for w in [0.7, 45.9, 300.0] {
            let fast = projection(&t, &r, w);
            let direct = t.iter().zip(&r).fold((0.0, 0.0), |(s, c), (t, r)| (s + r * (w * t).sin(), c + r * (w * t).cos()));
            assert!((fast.0 - direct.0).abs() < 1e-6 * (1.0 + direct.0.abs()), "{w}: {fast:?} vs {direct:?}");
            assert!((fast.1 - direct.1).abs() < 1e-6 * (1.0 + direct.1.abs()), "{w}: {fast:?} vs {direct:?}");
        }
        // A gap (a dropout) takes the direct path, which is exact by construction.
        let mut gappy = t.clone();
        gappy.remove(100);
        let rg: Vec<f64> = r[..gappy.len()].to_vec();
        let direct = gappy.iter().zip(&rg).fold((0.0, 0.0), |(s, c), (t, r)| (s + r * (2.0 * t).sin(), c + r * (2.0 * t).cos()));
        assert_eq!(projection(&gappy, &rg, 2.0), direct);
    }
}
