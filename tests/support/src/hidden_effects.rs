//! The hidden-effect suite of `identify` (issue 13): synthetic characterisations with hidden
//! effects (one, two, or none), scored the same way by the test
//! (`framework/ident/tests/hidden_effects.rs`) and the benchmark (which prints the confusion
//! matrix). The cases cover every effect of the vocabulary, both vibration kinds (a mode whose
//! amplitude grows with speed; a mode rung by each reversal with a random phase), a delay on the
//! encoder side, pairs of effects with the known confounds, a lower signal-to-noise ratio (noise
//! 1.5-3 % of the peak torque) and 20 clean controls.

use std::collections::BTreeMap;
use std::f64::consts::TAU;

use crate::XorShift64 as Rng;

pub const SINGLE: [&str; 11] = [
    "viscous_friction",
    "hysteresis",
    "dead_zone",
    "stiffness_nonlinearity",
    "time_delay",
    "encoder_delay",
    "dropout",
    "sensor_offset",
    "vibration",
    "speed_vibration",
    "reversal_ringing",
];

/// Pairs, including the confounds the issue names (delay vs viscous friction, hysteresis vs
/// eq. 3.5 friction is in every case's baseline, dead zone vs offset, cubic stiffness vs delay).
pub const PAIRS: [(&str, &str); 8] = [
    ("time_delay", "viscous_friction"),
    ("dead_zone", "sensor_offset"),
    ("stiffness_nonlinearity", "time_delay"),
    ("hysteresis", "vibration"),
    ("hysteresis", "sensor_offset"),
    ("viscous_friction", "stiffness_nonlinearity"),
    ("dead_zone", "reversal_ringing"),
    ("hysteresis", "speed_vibration"),
];

/// The effect's name as identify reports it (an encoder-side delay is a negative time delay).
pub fn reported(effect: &str) -> &str {
    if effect == "encoder_delay" { "time_delay" } else { effect }
}

/// One synthetic experiment: columns as a CSV would hold them, and the truth.
pub struct Case {
    /// The hidden effects.
    pub effects: Vec<&'static str>,
    /// Time [s].
    pub t: Vec<f64>,
    /// Deflection [rad], 14-bit quantised (zeros where readings dropped out).
    pub deflection: Vec<f64>,
    /// Torque-sensor reading [Nm].
    pub torque: Vec<f64>,
    /// (effect, parameter, true value).
    pub truths: Vec<(&'static str, &'static str, f64)>,
}

/// One synthetic characterisation: a sine deflection, the thesis' baseline (linear spring +
/// eq. 3.5 arctan friction) plus `effects`, 14-bit deflection, noisy torque sensor.
pub fn generate(effects: &[&'static str], seed: u64, low_snr: bool) -> Case {
    generate_samples(effects, seed, low_snr, SHORT_SAMPLES)
}

/// Samples of the suite's records (60 s at 200 Hz).
pub const SHORT_SAMPLES: usize = 12_000;

/// [`generate`] with `n` samples at 200 Hz instead of [`SHORT_SAMPLES`].
pub fn generate_samples(effects: &[&'static str], seed: u64, low_snr: bool, n: usize) -> Case {
    let mut r = Rng::new(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let rate = 200.0;
    let amp = r.range(0.05, 0.15);
    let f = r.range(0.1, 0.4);
    let k = r.range(30.0, 200.0);
    let ka = r.range(0.1, 0.6);
    let kb = r.range(20.0, 200.0);
    let noise = if low_snr { r.range(0.015, 0.03) * k * amp } else { r.range(0.01, 0.04) };
    let q = TAU / 16384.0;
    let has = |e: &str| effects.contains(&e);
    let mut truths = Vec::new();
    let mut pick = |e: &'static str, p: &'static str, v: f64, on: bool| {
        if on {
            truths.push((e, p, v));
            v
        } else {
            0.0
        }
    };
    let b = pick("viscous_friction", "damping_nms_per_rad", r.range(0.1, 0.4) * k / (TAU * f) * 0.1, has("viscous_friction"));
    let fc = pick("hysteresis", "limit_nm", r.range(0.5, 2.0), has("hysteresis"));
    let lambda = amp * r.range(0.03, 0.15);
    let w = pick("dead_zone", "half_width_rad", amp * r.range(0.1, 0.25), has("dead_zone"));
    let k3 = pick("stiffness_nonlinearity", "k3_nm_per_rad3", r.range(0.1, 0.3) * k / (amp * amp) * if r.uniform() < 0.5 { -1.0 } else { 1.0 }, has("stiffness_nonlinearity"));
    let torque_delay = pick("time_delay", "delay_s", (r.range(0.02, 0.1) * rate).round() / rate, has("time_delay"));
    let encoder_delay = (r.range(0.02, 0.1) * rate).round() / rate;
    pick("encoder_delay", "delay_s", -encoder_delay, has("encoder_delay"));
    let offset = pick("sensor_offset", "offset_nm", r.range(0.3, 1.0) * if r.uniform() < 0.5 { -1.0 } else { 1.0 }, has("sensor_offset"));
    let vib = (r.range(0.3, 1.0), pick("vibration", "frequency_hz", r.range(5.0, 20.0), has("vibration")));
    let peak_speed = amp * TAU * f;
    let speed_vib = (r.range(0.3, 1.0) / peak_speed, pick("speed_vibration", "frequency_hz", r.range(5.0, 20.0), has("speed_vibration")), r.range(0.0, TAU));
    let ring_f = pick("reversal_ringing", "frequency_hz", r.range(5.0, 20.0), has("reversal_ringing"));
    let ring_zeta = pick("reversal_ringing", "damping_ratio", r.range(0.02, 0.1), has("reversal_ringing"));
    // Rings: every reversal of the sine (cos = 0) starts one with its own amplitude and phase.
    let reversals: Vec<(f64, f64, f64)> = (0..((n as f64 / rate) * 2.0 * f) as usize + 2)
        .map(|i| ((i as f64 + 0.5) / (2.0 * f), r.range(0.3, 1.0), r.range(0.0, TAU)))
        .collect();
    // A delay on the encoder side is, on one sine, exactly a stiffness change plus viscous
    // friction (`x(t + d) = cos(w d) x + sin(w d) / w x'`): only a second, faster component of the
    // excitation tells them apart. Those cases get one (a fifth of the amplitude at 7x the
    // frequency), as a characterisation with a fast segment would.
    let fast = if has("encoder_delay") || (has("time_delay") && has("viscous_friction")) { 0.2 } else { 0.0 };
    let phi = |t: f64| amp * ((TAU * f * t).sin() + fast * (TAU * 7.0 * f * t).sin());
    let dphi = |t: f64| amp * TAU * f * ((TAU * f * t).cos() + 7.0 * fast * (TAU * 7.0 * f * t).cos());
    let mut z = 0.0;
    let mut prev = phi(0.0);
    let (mut deflection, mut torque, mut t_all) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let ti = i as f64 / rate;
        let x = phi(ti);
        let step = x - prev;
        if step != 0.0 {
            let s = step.signum();
            z = s + (z - s) * (-step.abs() / lambda).exp();
        }
        prev = x;
        // The torque channel may lag the deflection (torque_delay) or lead it (the encoder lags).
        let xd = phi(ti - torque_delay);
        let xe = xd.signum() * (xd.abs() - w).max(0.0);
        let v = dphi(ti - torque_delay);
        let mut tau = k * xe + k3 * xe.powi(3) + ka * (kb * v).atan() + b * v + fc * z + offset + noise * r.normal();
        if vib.1 > 0.0 {
            tau += vib.0 * (TAU * vib.1 * ti).sin();
        }
        if speed_vib.1 > 0.0 {
            tau += speed_vib.0 * v.abs() * (TAU * speed_vib.1 * ti + speed_vib.2).sin();
        }
        if ring_f > 0.0 {
            let wn = TAU * ring_f;
            let wd = wn * (1.0 - ring_zeta * ring_zeta).sqrt();
            if let Some((t0, a, ph)) = reversals.iter().rev().find(|(t0, ..)| *t0 <= ti) {
                let tau_s = ti - t0;
                tau += a * (-ring_zeta * wn * tau_s).exp() * (wd * tau_s + ph).sin();
            }
        }
        let measured = if has("encoder_delay") { phi(ti - encoder_delay) } else { x };
        deflection.push((measured / q).round() * q);
        torque.push(tau);
        t_all.push(ti);
    }
    if has("dropout") {
        let count = (n as f64 * r.range(0.005, 0.02)) as usize;
        for _ in 0..count {
            let i = 1 + (r.uniform() * (n - 2) as f64) as usize;
            if deflection[i].abs() > 0.01 {
                deflection[i] = 0.0;
            }
        }
        truths.push(("dropout", "fraction", count as f64 / n as f64));
    }
    Case { effects: effects.to_vec(), truths, t: t_all, deflection, torque }
}

/// The relative tolerance on a parameter.
pub fn tolerance(param: &str) -> f64 {
    match param {
        // Issue 13: a mode's frequency within 5 %.
        "frequency_hz" => 0.05,
        "damping_ratio" => 0.5,
        // The Dahl limit and the arctan friction of eq. 3.5 overlap away from reversals.
        "limit_nm" => 0.5,
        "delay_s" => 0.2,
        "fraction" => 0.5,
        _ => 0.3,
    }
}

/// What identify reported for a case: (effect, parameters) of each cause, and the rejected
/// candidates (for the misses' explanations).
pub type Found = (Vec<(String, BTreeMap<String, f64>)>, Vec<String>);

/// The suite's outcome.
#[derive(Debug, Default)]
pub struct Score {
    /// (hidden, named) -> cases.
    pub confusion: BTreeMap<(String, String), usize>,
    /// Cases with hidden effects.
    pub with_effects: usize,
    /// Of those, the ones where every hidden effect was named.
    pub named: usize,
    /// Clean controls that got a cause.
    pub control_hits: usize,
    /// Cases with hidden effects that also got a cause not hidden in them.
    pub extra: usize,
    /// Clean controls.
    pub controls: usize,
    /// Parameters compared with the truth.
    pub params_checked: usize,
    /// Of those, within tolerance.
    pub params_ok: usize,
    /// What went wrong, case by case.
    pub misses: Vec<String>,
}

impl Score {
    /// The confusion matrix and the rates, for a report.
    pub fn report(&self) -> String {
        let mut out = String::new();
        for ((truth, found), count) in &self.confusion {
            out += &format!("  {truth:>40} -> {found:<40} {count}\n");
        }
        out += &format!(
            "named: {} of {}; false causes in {} clean controls: {}; parameters within tolerance: {} of {}; cases with a cause besides the hidden ones: {} of {}\n",
            self.named, self.with_effects, self.controls, self.control_hits, self.params_ok, self.params_checked, self.extra, self.with_effects
        );
        out
    }
}

/// Samples of a long record (500 s at 200 Hz): identify's searches decimate it (see
/// `jointctl_ident::identify::prepare::SEARCH_SAMPLES`), unlike the suite's 60 s records.
pub const LONG_SAMPLES: usize = 100_000;

/// The long-record suite: every single effect once and four clean controls, each
/// [`LONG_SAMPLES`] long, scored as [`run`] scores.
pub fn run_long(identify: impl FnMut(&Case) -> Found) -> Score {
    let mut cases: Vec<(String, Vec<&'static str>, bool)> = SINGLE.iter().map(|e| (format!("{e} (long)"), vec![*e], false)).collect();
    for rep in 0..4 {
        cases.push((format!("clean #{rep} (long)"), vec![], rep == 3));
    }
    score(&cases, LONG_SAMPLES, identify)
}

/// Runs the suite: `identify` turns one case into what it found.
pub fn run(identify: impl FnMut(&Case) -> Found) -> Score {
    let mut cases: Vec<(String, Vec<&'static str>, bool)> = Vec::new();
    for effect in SINGLE {
        for rep in 0..4 {
            cases.push((format!("{effect} #{rep}"), vec![effect], false));
        }
        // One more at the lower signal-to-noise ratio.
        cases.push((format!("{effect} low-SNR"), vec![effect], true));
    }
    for (a, b) in PAIRS {
        for rep in 0..2 {
            cases.push((format!("{a}+{b} #{rep}"), vec![a, b], false));
        }
    }
    for rep in 0..20 {
        cases.push((format!("clean #{rep}"), vec![], rep % 4 == 3));
    }
    score(&cases, SHORT_SAMPLES, identify)
}

/// Scores `identify` on the cases (label, effects, low SNR) of `n` samples each.
fn score(cases: &[(String, Vec<&'static str>, bool)], n: usize, mut identify: impl FnMut(&Case) -> Found) -> Score {
    let mut score = Score::default();
    for (i, (label, effects, low_snr)) in cases.iter().enumerate() {
        let case = generate_samples(effects, i as u64 * 7919 + 13, *low_snr, n);
        let (causes, rejected) = identify(&case);
        let found: Vec<&str> = causes.iter().map(|c| c.0.as_str()).collect();
        let truth = if effects.is_empty() { "none".to_string() } else { effects.join("+") };
        let mut sorted = found.clone();
        sorted.sort();
        *score.confusion.entry((truth, if found.is_empty() { "none".into() } else { sorted.join("+") })).or_default() += 1;
        if case.effects.is_empty() {
            score.controls += 1;
            if !found.is_empty() {
                score.control_hits += 1;
                score.misses.push(format!("{label}: found {found:?}"));
            }
            continue;
        }
        score.with_effects += 1;
        let extra: Vec<&&str> = found.iter().filter(|f| !case.effects.iter().any(|e| reported(e) == **f)).collect();
        if !extra.is_empty() {
            score.extra += 1;
            score.misses.push(format!("{label}: also named {extra:?}"));
        }
        if case.effects.iter().all(|e| found.contains(&reported(e))) {
            score.named += 1;
        } else {
            score.misses.push(format!("{label}: found {found:?}; rejected {rejected:?}"));
        }
        for (effect, param, value) in &case.truths {
            let Some(cause) = causes.iter().find(|c| c.0 == reported(effect)) else { continue };
            score.params_checked += 1;
            let got = cause.1.get(*param).copied().unwrap_or(f64::NAN);
            if (got - value).abs() <= tolerance(param) * value.abs() {
                score.params_ok += 1;
            } else {
                score.misses.push(format!("{label}: {effect}.{param} {got:.4} vs {value:.4}"));
            }
        }
    }
    score
}
