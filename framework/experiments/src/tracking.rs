//! Torque tracking (thesis chapter 5, figures 5.2-5.26): the joint's output clamped (figures 5.1,
//! 5.14), torque control following step, sine and cosine references at several stiffness
//! settings, and a frequency sweep; observed and sensor torque compared with the reference.

use jointctl_config::{EnvironmentConfig, LoadedConfig};
use jointctl_modes::{Mode, Reference, Waveform};
use jointctl_runtime::{Arm, PluginLoader};
use jointctl_runtime::commands::ArmCommand;
use jointctl_sim::{SharedSim, SimHal};
use serde::Serialize;

use crate::{ExperimentError, arm_dof, locate, set_environment};

/// The loop and bus of an experiment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// The thesis' set-up: a 40 Hz loop, SPI 15 ms and CAN 30 ms latency (section 2.3).
    Thesis,
    /// The same hardware with a 1 kHz loop and the 1 ms latencies of a direct bus (assumption).
    Modern,
}

impl Scenario {
    /// Parses `thesis` or `modern`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "thesis" => Some(Scenario::Thesis),
            "modern" => Some(Scenario::Modern),
            _ => None,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Thesis => "thesis",
            Scenario::Modern => "modern",
        }
    }

    /// (loop rate [Hz], SPI latency [s], CAN latency [s]).
    pub fn timing(self) -> (f64, f64, f64) {
        match self {
            Scenario::Thesis => (40.0, 0.015, 0.030),
            Scenario::Modern => (1000.0, 0.001, 0.001),
        }
    }
}

/// One run's result, in the documented JSON row shape.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// DOF.
    pub joint: String,
    /// Scenario name.
    pub scenario: String,
    /// `step`, `sine` or `cosine`.
    pub reference: String,
    /// Frequency [Hz] (0 for a step).
    pub frequency_hz: f64,
    /// Pivot setting [mm], if the joint has one.
    pub pivot_mm: Option<f64>,
    /// The reference's amplitude [Nm] (the step's height).
    pub amplitude_nm: f64,
    /// RMSE(observed - reference) / amplitude.
    pub nrmse_observed: f64,
    /// RMSE(sensor - reference) / amplitude.
    pub nrmse_sensor: f64,
    /// RMSE(observed - sensor) / amplitude: how far the observer is from the F/T sensor, the
    /// offset the thesis reports (sections 5.1, 5.2).
    pub nrmse_observer_vs_sensor: f64,
    /// Mean(observed - sensor) [Nm]: the offset's constant part.
    pub offset_nm: f64,
    /// Vibration the F/T sensor sees [Nm]: the RMS of its torque, less the sine fitted at the
    /// reference frequency, less the rest's centred 0.2 s moving average (what is left lies above
    /// about 5 Hz: structural modes, a ringing loop, noise); sine and cosine references of at
    /// most 1 Hz, from 2.5 s after the reference starts. Sections 5.1 and 5.2 saw the shoulder vibrate at low stiffness and the wrist
    /// at high stiffness.
    pub ripple_nm: Option<f64>,
    /// Phase lag of the sensor torque behind the reference [deg] (sine and cosine).
    pub phase_lag_deg: Option<f64>,
    /// Sensor amplitude / reference amplitude at the reference frequency (sine and cosine).
    #[serde(skip)]
    pub gain: Option<f64>,
    /// Samples for plotting: (t, reference, observed, sensor).
    #[serde(skip)]
    pub trace: Vec<(f64, f64, f64, f64)>,
    /// The other DOFs' references in the same run (the wrist's pairs), e.g. `q7 cosine 0.1 Hz`;
    /// empty when this DOF ran alone.
    #[serde(skip)]
    pub together: String,
}

/// Which runs to make.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    /// Requested stiffness settings [Nm/rad] (variable stiffness joints); empty: as configured.
    pub stiffness_nm_per_rad: Vec<f64>,
    /// Reference amplitude [Nm] per stiffness setting (`None`, or none given: 0.05 rad of
    /// deflection at the setting's stiffness, within half the torque limit; an assumption).
    pub amplitudes_nm: Vec<Option<f64>>,
    /// (waveform, frequency [Hz]) pairs, one DOF driven at a time.
    pub references: Vec<(Waveform, f64)>,
    /// Runs of a multi-DOF joint (the wrist): in each, these DOFs (index within the joint) follow
    /// these references together; the joint's other DOFs hold zero torque.
    pub together: Vec<Vec<(usize, Waveform, f64)>>,
    /// Periods per sine/cosine run (at least 10 s for a step).
    pub periods: f64,
}

impl Plan {
    /// Chapter 5 references (step; sine and cosine at 0.1 and 0.2 Hz) and a sweep to 8 Hz.
    ///
    /// ```
    /// let plan = jointctl_experiments::tracking::Plan::thesis(vec![27.0, 89.4, 320.0]);
    /// assert_eq!(plan.references.len(), 10);
    /// ```
    pub fn thesis(stiffness_nm_per_rad: Vec<f64>) -> Self {
        let mut references = vec![(Waveform::Step, 0.0)];
        for f in [0.1, 0.2] {
            references.push((Waveform::Sine, f));
            references.push((Waveform::Cosine, f));
        }
        for f in [0.5, 1.0, 2.0, 4.0, 8.0] {
            references.push((Waveform::Sine, f));
        }
        Plan { stiffness_nm_per_rad, references, periods: 2.0, ..Plan::default() }
    }

    /// Section 5.2's wrist runs (figures 5.15-5.26), q6 and q7 together: two cosines, two
    /// sines, a sine on q6 with a cosine on q7 (all 0.1 Hz), a step on q6, a step on q7, and a
    /// sine on q7 alone at 0.1 and 0.2 Hz; plus the sweep on q7 to find the bandwidth.
    ///
    /// ```
    /// let plan = jointctl_experiments::tracking::Plan::wrist(vec![2.0, 8.0, 28.0]);
    /// assert_eq!(plan.together[0].len(), 2);
    /// ```
    pub fn wrist(stiffness_nm_per_rad: Vec<f64>) -> Self {
        let (sine, cosine, step) = (Waveform::Sine, Waveform::Cosine, Waveform::Step);
        let mut together = vec![
            vec![(0, cosine, 0.1), (1, cosine, 0.1)],
            vec![(0, sine, 0.1), (1, sine, 0.1)],
            vec![(0, sine, 0.1), (1, cosine, 0.1)],
            vec![(0, step, 0.0)],
            vec![(1, step, 0.0)],
            vec![(1, sine, 0.1)],
            vec![(1, sine, 0.2)],
        ];
        together.extend([0.5, 1.0, 2.0, 4.0].map(|f| vec![(1, sine, f)]));
        Plan { stiffness_nm_per_rad, together, periods: 2.0, ..Plan::default() }
    }

    /// How many runs the plan makes.
    pub fn runs(&self) -> usize {
        self.stiffness_nm_per_rad.len().max(1) * if self.together.is_empty() { self.references.len() } else { self.together.len() }
    }
}

fn sine_fit(t: &[f64], y: &[f64], f: f64) -> (f64, f64) {
    // Least squares y ~ a sin(wt) + b cos(wt): amplitude and phase.
    let w = std::f64::consts::TAU * f;
    let (mut ss, mut cc, mut sc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (ti, yi) in t.iter().zip(y) {
        let (s, c) = (w * ti).sin_cos();
        ss += s * s;
        cc += c * c;
        sc += s * c;
        ys += yi * s;
        yc += yi * c;
    }
    let det = ss * cc - sc * sc;
    let a = (ys * cc - yc * sc) / det;
    let b = (yc * ss - ys * sc) / det;
    (a.hypot(b), b.atan2(a))
}

/// One run: `drives` (arm DOF names with their references) at one stiffness setting (asked of
/// the joint's first DOF, whichever DOFs are driven: the wrist's pivot is shared); the other
/// DOFs in `hold` stay in torque control at zero. One row per driven DOF.
#[allow(clippy::too_many_arguments)]
fn run_one(
    cfg: &LoadedConfig,
    loader: &PluginLoader,
    scenario: Scenario,
    stiffness: Option<(&str, f64)>,
    amplitude_nm: Option<f64>,
    drives: &[(String, Waveform, f64)],
    hold: &[String],
    periods: f64,
) -> Result<Vec<Row>, ExperimentError> {
    let sim = SharedSim::new(SimHal::load(cfg).map_err(|e| ExperimentError(e.to_string()))?);
    let mut arm = Arm::build(cfg, loader, Box::new(sim.clone()))?;
    arm.run_in_simulated_time();
    arm.activate().map_err(|e| ExperimentError(e.to_string()))?;
    let dofs: Vec<usize> = drives.iter().map(|(name, ..)| arm_dof(&arm, name)).collect();
    let dt = 1.0 / arm.rate_hz;
    let mut t = 0.0;
    arm.observe(t);
    if let Some((name, k)) = stiffness {
        arm.apply(ArmCommand::Stiffness { dof: arm_dof(&arm, name), stiffness_nm_per_rad: k });
    }
    // Let the pivot settle with the joint held.
    for _ in 0..(3.0 / dt) as usize {
        arm.control();
        t += dt;
        arm.observe(t);
    }
    let mut references = Vec::new();
    for (&dof, (_, waveform, frequency_hz)) in dofs.iter().zip(drives) {
        let k = arm.states[dof].stiffness().unwrap_or(100.0);
        let limit = arm.controllers[dof].limits().torque_nm;
        let amplitude = amplitude_nm.unwrap_or_else(|| (0.05 * k).min(0.5 * if limit.is_finite() { limit } else { f64::INFINITY }));
        let reference = Reference { waveform: *waveform, amplitude, frequency_hz: *frequency_hz, offset: 0.0, start_s: 0.5 };
        arm.apply(ArmCommand::Mode { dof, mode: Mode::Torque { reference }, streamed: false });
        references.push(reference);
    }
    for name in hold {
        let zero = Reference { waveform: Waveform::Step, amplitude: 0.0, frequency_hz: 0.0, offset: 0.0, start_s: 0.0 };
        arm.apply(ArmCommand::Mode { dof: arm_dof(&arm, name), mode: Mode::Torque { reference: zero }, streamed: false });
    }
    let duration = references.iter().map(|r| if r.waveform == Waveform::Step { 10.0 } else { (periods / r.frequency_hz).max(4.0) }).fold(0.0, f64::max);
    let start = t;
    let mut traces: Vec<Vec<(f64, f64, f64, f64)>> = vec![Vec::new(); dofs.len()];
    for _ in 0..(duration / dt) as usize {
        arm.control();
        t += dt;
        arm.observe(t);
        for (k, &dof) in dofs.iter().enumerate() {
            let sensor = sim.with(|s| s.joint_torque(&drives[k].0).map_or(f64::NAN, |x| x.1));
            let r = arm.torque_references[dof];
            traces[k].push((t - start, if r.is_finite() { r } else { references[k].value(t) }, arm.states[dof].torque().unwrap_or(f64::NAN), sensor));
        }
    }
    let mut rows = Vec::new();
    for (k, trace) in traces.into_iter().enumerate() {
        let (dof, reference) = (dofs[k], references[k]);
        let mut row = score(&drives[k].0, scenario, reference, arm.states[dof].pivot(), trace);
        row.together = drives.iter().enumerate().filter(|(o, _)| *o != k).map(|(_, (name, w, f))| format!("{name} {} {f} Hz", waveform_name(*w))).collect::<Vec<_>>().join(", ");
        rows.push(row);
    }
    Ok(rows)
}

/// A run's row from its trace (t, reference, observed, sensor), scored from the reference's
/// start (0.5 s after the mode switch).
fn score(joint: &str, scenario: Scenario, reference: Reference, pivot_mm: Option<f64>, trace: Vec<(f64, f64, f64, f64)>) -> Row {
    let (waveform, frequency_hz, amplitude) = (reference.waveform, reference.frequency_hz, reference.amplitude);
    let scored: Vec<(f64, f64, f64, f64)> = trace.iter().copied().filter(|p| p.0 >= 0.5).collect();
    let rmse = |sel: fn(&(f64, f64, f64, f64)) -> f64| {
        let v: Vec<f64> = scored.iter().map(|p| sel(p) - p.1).filter(|e| e.is_finite()).collect();
        (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    let gap: Vec<f64> = scored.iter().map(|p| p.2 - p.3).filter(|e| e.is_finite()).collect();
    let gap_n = gap.len().max(1) as f64;
    let nrmse_observer_vs_sensor = (gap.iter().map(|e| e * e).sum::<f64>() / gap_n).sqrt() / amplitude;
    let offset_nm = gap.iter().sum::<f64>() / gap_n;
    let (phase_lag_deg, gain) = if waveform == Waveform::Step {
        (None, None)
    } else {
        let ts: Vec<f64> = scored.iter().map(|p| p.0).collect();
        let (ar, pr) = sine_fit(&ts, &scored.iter().map(|p| p.1).collect::<Vec<_>>(), frequency_hz);
        let (asn, ps) = sine_fit(&ts, &scored.iter().map(|p| if p.3.is_finite() { p.3 } else { 0.0 }).collect::<Vec<_>>(), frequency_hz);
        let lag = (pr - ps).to_degrees().rem_euclid(360.0);
        (Some(if lag > 180.0 { lag - 360.0 } else { lag }), Some(asn / ar))
    };
    // The ripple from 2.5 s after the reference starts: a cosine starts with a jump, and the
    // loop's answer to it is not a vibration.
    let settled: Vec<&(f64, f64, f64, f64)> = scored.iter().filter(|p| p.0 >= 3.0).collect();
    let ripple_nm = (waveform != Waveform::Step && frequency_hz <= 1.0)
        .then(|| ripple(&settled.iter().map(|p| p.3).collect::<Vec<_>>(), &settled.iter().map(|p| p.0).collect::<Vec<_>>(), frequency_hz))
        .flatten();
    Row {
        joint: joint.to_string(),
        scenario: scenario.name().to_string(),
        reference: waveform_name(waveform).to_string(),
        frequency_hz,
        pivot_mm,
        amplitude_nm: amplitude,
        nrmse_observed: rmse(|p| p.2) / amplitude,
        nrmse_sensor: rmse(|p| p.3) / amplitude,
        nrmse_observer_vs_sensor,
        offset_nm,
        ripple_nm,
        phase_lag_deg,
        gain,
        trace,
        together: String::new(),
    }
}

/// RMS of `x` less its sine at `frequency_hz` less the rest's centred moving average over 0.2 s
/// [x's unit]: the sine goes first, since the average would let 6 % of a 1 Hz sine through.
/// `None` when a reading is missing or the record is shorter than two windows.
fn ripple(x: &[f64], t: &[f64], frequency_hz: f64) -> Option<f64> {
    let dt = (t.last()? - t.first()?) / (t.len().max(2) - 1) as f64;
    let half = ((0.1 / dt).round() as usize).max(1);
    if x.len() < 4 * half + 1 || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let (amplitude, phase) = sine_fit(t, x, frequency_hz);
    let w = std::f64::consts::TAU * frequency_hz;
    let x: Vec<f64> = x.iter().zip(t).map(|(v, ti)| v - amplitude * (w * ti + phase).sin()).collect();
    let mut prefix = vec![0.0; x.len() + 1];
    for (i, v) in x.iter().enumerate() {
        prefix[i + 1] = prefix[i] + v;
    }
    let inner = half..x.len() - half;
    let count = inner.len() as f64;
    let sum: f64 = inner.map(|i| (x[i] - (prefix[i + half + 1] - prefix[i - half]) / (2 * half + 1) as f64).powi(2)).sum();
    Some((sum / count).sqrt())
}

fn waveform_name(w: Waveform) -> &'static str {
    match w {
        Waveform::Step => "step",
        Waveform::Sine => "sine",
        Waveform::Cosine => "cosine",
    }
}

/// Runs a plan; `progress(done, total)` after each run.
pub fn run(
    loaded: &LoadedConfig,
    loader: &PluginLoader,
    joint: &str,
    scenario: Scenario,
    plan: &Plan,
    progress: impl FnMut(usize, usize),
) -> Result<Vec<Row>, ExperimentError> {
    let mut cfg = loaded.clone();
    scenario.apply(&mut cfg);
    run_as_configured(&cfg, loader, joint, scenario, plan, progress)
}

impl Scenario {
    /// Sets the scenario's loop rate and bus latencies in `cfg`.
    ///
    /// ```
    /// use jointctl_experiments::tracking::Scenario;
    /// let yaml = "arm: a\nhal: {backend: sim}\njoints: [{name: q, plugin: p}]\n";
    /// let mut cfg = jointctl_config::parse_str(yaml, std::path::Path::new("a.yaml")).unwrap();
    /// Scenario::Thesis.apply(&mut cfg);
    /// assert_eq!((cfg.config.rate_hz, cfg.config.hal.sim.can_latency_s), (40.0, 0.030));
    /// ```
    pub fn apply(self, cfg: &mut LoadedConfig) {
        let (rate, spi, can) = self.timing();
        cfg.config.rate_hz = rate;
        cfg.config.hal.sim.spi_latency_s = spi;
        cfg.config.hal.sim.can_latency_s = can;
    }
}

/// Runs a plan on `loaded` as it is (its loop rate and latencies; `scenario` only names the rows),
/// the joint's output clamped.
pub fn run_as_configured(
    loaded: &LoadedConfig,
    loader: &PluginLoader,
    joint: &str,
    scenario: Scenario,
    plan: &Plan,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<Row>, ExperimentError> {
    let mut cfg = loaded.clone();
    // A joint entry of several DOFs (`wrist`) runs its DOFs together; anything else is a DOF.
    let entry = cfg.config.joints.iter().position(|e| e.name == joint && e.dof_names().len() > 1);
    let (j, i, names) = match entry {
        Some(j) => (j, 0, cfg.config.joints[j].dof_names().iter().map(|n| n.to_string()).collect::<Vec<_>>()),
        None => {
            let (j, i) = locate(&cfg, joint)?;
            (j, i, vec![joint.to_string()])
        }
    };
    // Chapter 5's set-ups clamp the joint's output (figures 5.1, 5.14).
    let clamp = EnvironmentConfig::Fixed { position_rad: 0.0 };
    set_environment(&mut cfg, j, i, clamp.clone(), clamp);
    let runs: Vec<Vec<(usize, Waveform, f64)>> = if names.len() > 1 {
        if plan.together.is_empty() {
            return Err(ExperimentError(format!("`{joint}` has {} DOFs: its plan needs runs of them together (Plan::wrist)", names.len())));
        }
        plan.together.clone()
    } else {
        plan.references.iter().map(|(w, f)| vec![(0, *w, *f)]).collect()
    };
    if let Some(bad) = runs.iter().flatten().find(|(d, ..)| *d >= names.len()) {
        return Err(ExperimentError(format!("`{joint}` has no DOF {} (it has {})", bad.0, names.len())));
    }
    let settings: Vec<Option<f64>> = if plan.stiffness_nm_per_rad.is_empty() { vec![None] } else { plan.stiffness_nm_per_rad.iter().map(|k| Some(*k)).collect() };
    let total = settings.len() * runs.len();
    let (mut rows, mut done) = (Vec::new(), 0);
    for (s, k) in settings.iter().enumerate() {
        let amplitude = plan.amplitudes_nm.get(s).copied().flatten();
        for run in &runs {
            let drives: Vec<(String, Waveform, f64)> = run.iter().map(|(d, w, f)| (names[*d].clone(), *w, *f)).collect();
            let hold: Vec<String> = (0..names.len()).filter(|d| !run.iter().any(|r| r.0 == *d)).map(|d| names[d].clone()).collect();
            rows.extend(run_one(&cfg, loader, scenario, k.map(|k| (names[0].as_str(), k)), amplitude, &drives, &hold, plan.periods)?);
            done += 1;
            progress(done, total);
        }
    }
    Ok(rows)
}

/// The highest swept frequency at which the sensor torque keeps at least -3 dB of the
/// reference's amplitude and lags less than 90 degrees [Hz], per stiffness setting (the smallest).
pub fn bandwidth_hz(rows: &[Row]) -> Option<f64> {
    let mut by_pivot: std::collections::BTreeMap<i64, Vec<&Row>> = Default::default();
    for r in rows.iter().filter(|r| r.reference == "sine") {
        by_pivot.entry(r.pivot_mm.map_or(0, |p| (p * 1000.0) as i64)).or_default().push(r);
    }
    by_pivot
        .values()
        .map(|rs| {
            rs.iter()
                .filter(|r| r.gain.is_some_and(|g| g >= 0.707) && r.phase_lag_deg.is_some_and(|p| p.abs() < 90.0))
                .map(|r| r.frequency_hz)
                .fold(0.0, f64::max)
        })
        .reduce(f64::min)
}

#[cfg(test)]
mod tests {
    use super::ripple;

    fn signal(f: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..800).map(|i| 3.0 + i as f64 / 40.0).collect();
        (t.iter().map(|&t| f(t)).collect(), t)
    }

    #[test]
    fn the_ripple_is_what_rings_above_the_reference_not_the_reference() {
        let w = std::f64::consts::TAU;
        // A 1 Hz sine of 20 Nm alone: the moving average alone would let 6 % through.
        let (x, t) = signal(|t| 20.0 * (w * t).sin());
        assert!(ripple(&x, &t, 1.0).unwrap() < 1e-9);
        // Plus a 0.1 Nm ring at 13 Hz (below the 40 Hz loop's Nyquist rate): its RMS, 0.0707 Nm,
        // less what the 0.2 s average keeps of it (a few per cent).
        let (x, t) = signal(|t| 20.0 * (w * t).sin() + 0.1 * (w * 13.0 * t).sin());
        let r = ripple(&x, &t, 1.0).unwrap();
        assert!((r - 0.1 / 2f64.sqrt()).abs() < 0.005, "{r}");
        // A missing reading is not a value.
        let (mut x, t) = signal(|t| (w * t).sin());
        x[100] = f64::NAN;
        assert_eq!(ripple(&x, &t, 1.0), None);
    }
}
