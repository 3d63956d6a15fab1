//! Blind synthetic characterisation records of a compliant joint (elastic element between a
//! held motor and a hand-moved output; F/T sensor torque, encoder deflection), each with a
//! known hidden effect on top of the baseline `tau = k phi + k_a atan(k_b dphi/dt)`.
//!
//! Written from physics and a short description only, without reading the identification code
//! it is meant to test, so that it does not share that code's assumptions: hysteresis comes
//! from Bouc-Wen and LuGre as well as Dahl, the baseline friction is sometimes a Stribeck
//! curve, the sensor lag is sometimes a low-pass, and so on. See README.md.

pub mod excitation;
pub mod model;
pub mod rng;
pub mod synth;

use rng::{Rng, derive_seed};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use synth::{ALL_CAUSES, Cause, Flags, Meta, Request};

/// One record and its answer.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: String,
    /// Time stamps [s] as a logger would write them (epoch, restarting, binned...).
    pub t: Vec<f64>,
    /// Measured deflection [rad] (a joint position for `friction_position`).
    pub deflection: Vec<f64>,
    /// Measured torque [Nm].
    pub torque: Vec<f64>,
    pub answer: Answer,
}

/// What an identification tool should find in a record.
#[derive(Clone, Debug, PartialEq)]
pub struct Answer {
    /// Hidden cause names joined by '+' in the fixed order viscous_friction, hysteresis,
    /// dead_zone, stiffness_nonlinearity, sensor_offset, time_delay, vibration; or "none".
    pub effect: String,
    /// The causes' parameters (SI units): `b`, `force`, `width`, `k3`, `offset`, `delay`,
    /// `frequency`, `amplitude`, plus model details with a cause prefix (`hyst_*`, ...).
    pub params: BTreeMap<String, f64>,
    /// Std of the noise actually added to the torque column [Nm] (after binning).
    pub noise: f64,
    /// Sampling rate of the output [Hz] (1 / median step for irregular time stamps).
    pub fs: f64,
    /// Small-signal stiffness [Nm/rad] (0 for `friction_position`).
    pub k: f64,
    /// Largest noise-free |torque| in the record [Nm].
    pub tau_max: f64,
    pub variant: String,
    pub device: Option<String>,
    /// Difficulty: 1 plain record with one or no effect and the exact atan baseline; 2 one
    /// complication (a variant flag or a non-atan baseline); 3 two causes or more complications.
    pub level: u8,
    /// RMS of the hidden effects' torque left after a least-squares fit of the baseline's own
    /// regressors (deflection and the true baseline friction), over the noise std.
    pub effect_rms_over_noise: f64,
    /// RMS of the hidden effects' torque (before any refit of the baseline), over the noise std.
    pub effect_rms_raw_over_noise: f64,
    /// `effect_rms_over_noise` of each cause alone.
    pub effect_rms_each: BTreeMap<String, f64>,
    /// The model used for each cause (e.g. hysteresis -> bouc_wen).
    pub models: BTreeMap<String, String>,
    /// The baseline friction's model ("atan", "stribeck", "lugre") and its parameters.
    pub friction_model: String,
    pub friction: BTreeMap<String, f64>,
    /// Encoder count [rad].
    pub encoder_step: f64,
    /// Whether the deflection column is on the encoder grid (false once bin-averaged).
    pub quantised: bool,
    /// The torque span effects and noise were scaled to [Nm].
    pub torque_span: f64,
    /// Physical duration [s] and number of rows.
    pub duration: f64,
    pub n_samples: usize,
    /// Number of runs in the record (all levels' repetitions for `amplitudes<N>`).
    pub repetitions: usize,
    /// The drive amplitudes of a test at several levels (`amplitudes<N>`), else None.
    pub drive: Option<Drive>,
    /// White noise std per raw sample before any binning [Nm].
    pub noise_white_raw: f64,
    pub seed: u64,
}

/// A test at one or several drive amplitudes, each repeated: the runs of level `l` are runs
/// `l * runs_per_level ..` of the record, levels in increasing amplitude.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    /// Each level's drive amplitude relative to the device's usual amplitude (the one of its
    /// other variants).
    pub scales: Vec<f64>,
    /// Each level's drive amplitude [rad]: the test program's nominal peak deflection.
    pub amplitudes_rad: Vec<f64>,
    pub runs_per_level: usize,
    /// `effect_rms_each` of each level's samples alone.
    pub effect_rms_each: Vec<BTreeMap<String, f64>>,
}

/// Ground truth at the samples (for tests; not part of what a tool sees).
pub use synth::Truth;

/// One case: `effect` is "none" or causes joined by '+', each optionally `cause:model`
/// (e.g. "hysteresis:lugre+time_delay"); `variant` is "plain" or flags joined by '+'
/// (irregular, rig550, epoch, repetitions, restart, encoder17, linear2e-6, bin20, long,
/// friction_position, amplitudes<N>). Panics on an impossible request; see `try_case`.
pub fn case(seed: u64, effect: &str, variant: &str) -> Case {
    try_case(seed, effect, variant).unwrap_or_else(|e| panic!("{e}"))
}

/// Like `case`, with an error for impossible requests.
pub fn try_case(seed: u64, effect: &str, variant: &str) -> Result<Case, String> {
    let spec = Spec {
        name: format!("case_{}_{}", short_effect(effect), short_variant(variant)),
        effect: effect.to_string(),
        variant: variant.to_string(),
        baseline: None,
        duration_s: None,
        seed,
    };
    spec.generate().map(|(c, _)| c)
}

/// A planned case: everything needed to generate it.
#[derive(Clone, Debug)]
pub struct Spec {
    pub name: String,
    pub effect: String,
    pub variant: String,
    pub baseline: Option<String>,
    pub duration_s: Option<f64>,
    pub seed: u64,
}

impl Spec {
    /// Generates the case together with its ground truth.
    pub fn generate(&self) -> Result<(Case, Truth), String> {
        let mut rng = Rng::new(self.seed);
        let causes = synth::parse_effects(&self.effect)?;
        let flags = Flags::parse(&self.variant, &mut rng)?;
        let req = Request {
            causes: causes.clone(),
            flags: flags.clone(),
            baseline: self.baseline.clone(),
            duration_s: self.duration_s,
            ratio: None,
            for_device: false,
        };
        let setup = synth::draw_setup_retrying(&mut rng, &req)?;
        let meta = Meta {
            name: self.name.clone(),
            device: None,
            effect: effect_name(&causes),
            seed: self.seed,
        };
        Ok(synth::record(&setup, &flags, &mut rng.fork("record"), meta))
    }
}

fn effect_name(causes: &[(Cause, Option<String>)]) -> String {
    if causes.is_empty() {
        "none".into()
    } else {
        causes
            .iter()
            .map(|(c, _)| c.name())
            .collect::<Vec<_>>()
            .join("+")
    }
}

fn short_cause(c: &str) -> &str {
    match c.split(':').next().unwrap_or(c) {
        "viscous_friction" => "viscous",
        "hysteresis" => "hyst",
        "dead_zone" => "deadzone",
        "stiffness_nonlinearity" => "stiff",
        "sensor_offset" => "offset",
        "time_delay" => "delay",
        "vibration" => "vib",
        other => other,
    }
}

fn short_effect(e: &str) -> String {
    e.split('+').map(short_cause).collect::<Vec<_>>().join("-")
}

fn short_variant(v: &str) -> String {
    v.replace('+', "-")
}

/// Real-data-like variants the suite rotates through.
const REAL_VARIANTS: [&str; 11] = [
    "irregular",
    "epoch",
    "repetitions",
    "restart",
    "encoder17",
    "linear2e-6",
    "bin20",
    "irregular+epoch",
    "restart+epoch",
    "bin20+irregular",
    "encoder17+repetitions",
];

/// Model rotation for the single-effect cases (hysteresis: Dahl, the tool's own model, is the
/// rarest on purpose).
fn model_cycle(c: Cause) -> &'static [&'static str] {
    match c {
        Cause::Hysteresis => &["bouc_wen", "lugre", "bouc_wen", "lugre", "dahl"],
        Cause::Offset => &["constant", "drift"],
        other => other.models(),
    }
}

/// The plan of `suite(seed)`: cheap to list (tests check its coverage without generating).
pub fn suite_plan(seed: u64) -> Vec<Spec> {
    let mut plan: Vec<(String, String, Option<String>, Option<f64>)> = Vec::new();
    // Single effects: 7 causes x 9 (4 plain, 5 real-data-like).
    for (ci, &c) in ALL_CAUSES.iter().enumerate() {
        let mut variants: Vec<String> = vec!["plain".into(); 4];
        let mut j = ci * 5;
        while variants.len() < 9 {
            let v = REAL_VARIANTS[j % REAL_VARIANTS.len()];
            j += 1;
            if c == Cause::Vibration && v.contains("bin20") {
                continue;
            }
            variants.push(v.to_string());
        }
        if c == Cause::Hysteresis {
            variants[8] = "long".into();
        }
        let cyc = model_cycle(c);
        for (j, v) in variants.iter().enumerate() {
            let reps = v.contains("repetitions") || v.contains("restart");
            let model = if c == Cause::Offset && reps {
                "per_repetition"
            } else {
                cyc[j % cyc.len()]
            };
            let baseline = Some(if j % 4 == 2 { "stribeck" } else { "atan" }.to_string());
            let dur = v.contains("long").then_some(200.0);
            plan.push((format!("{}:{model}", c.name()), v.clone(), baseline, dur));
        }
    }
    // Friction-only records (position, no spring).
    for (e, v) in [
        ("viscous_friction", "friction_position"),
        ("viscous_friction", "friction_position+irregular"),
        ("sensor_offset:constant", "friction_position"),
        ("sensor_offset:drift", "friction_position+epoch"),
        ("none", "friction_position"),
    ] {
        plan.push((e.into(), v.into(), None, None));
    }
    // Clean records: 10 plain (3 with a Stribeck baseline), 10 real-data-like.
    for j in 0..10 {
        let baseline = Some(if j % 3 == 1 { "stribeck" } else { "atan" }.to_string());
        plan.push(("none".into(), "plain".into(), baseline, None));
    }
    for v in [
        "irregular",
        "epoch",
        "repetitions",
        "restart",
        "encoder17",
        "linear2e-6",
        "bin20",
        "long",
        "irregular+epoch",
        "bin20+irregular",
    ] {
        let dur = (v == "long").then_some(200.0);
        let baseline = if v == "epoch" { "stribeck" } else { "atan" };
        plan.push(("none".into(), v.into(), Some(baseline.into()), dur));
    }
    // Pairs: all 21 combinations, every other one on a real-data-like variant.
    let mut p = 0;
    for (a, &ca) in ALL_CAUSES.iter().enumerate() {
        for &cb in &ALL_CAUSES[a + 1..] {
            let mut v = "plain".to_string();
            if p % 2 == 1 {
                let mut j = p / 2;
                loop {
                    let cand = REAL_VARIANTS[j % REAL_VARIANTS.len()];
                    j += 1;
                    let vib = ca == Cause::Vibration || cb == Cause::Vibration;
                    if !(vib && cand.contains("bin20")) {
                        v = cand.to_string();
                        break;
                    }
                }
            }
            let baseline = if p % 4 == 3 { "stribeck" } else { "atan" };
            plan.push((
                format!("{}+{}", ca.name(), cb.name()),
                v,
                Some(baseline.into()),
                None,
            ));
            p += 1;
        }
    }
    plan.into_iter()
        .enumerate()
        .map(|(i, (e, v, baseline, duration_s))| Spec {
            name: format!("{i:03}_{}_{}", short_effect(&e), short_variant(&v)),
            seed: derive_seed(seed, &format!("suite/{i}")),
            effect: e,
            variant: v,
            baseline,
            duration_s,
        })
        .collect()
}

/// The deterministic test suite: 63 single-effect cases (9 per cause), 5 friction-only
/// records, 20 clean records and all 21 pairs; about half on real-data-like variants.
pub fn suite(seed: u64) -> Vec<Case> {
    try_suite(seed).unwrap_or_else(|e| panic!("{e}"))
}

/// [`suite`], or which case could not be generated and why.
pub fn try_suite(seed: u64) -> Result<Vec<Case>, String> {
    suite_plan(seed)
        .iter()
        .map(|s| s.generate().map(|(c, _)| c).map_err(|e| format!("{}: {e}", s.name)))
        .collect()
}

/// The devices of `device_variants`: hidden causes of each.
pub const DEVICES: [(&str, &str); 5] = [
    ("devA", "hysteresis:bouc_wen"),
    ("devB", "none"),
    ("devC", "dead_zone:ramp"),
    ("devD", "time_delay:lowpass"),
    ("devE", "viscous_friction+sensor_offset:constant"),
];

/// Number of drive amplitudes of a device's `6_amp5` variant.
pub const DRIVE_LEVELS: usize = 5;

/// The variants each device is logged in: (file tag, variant flags).
///
/// - `1_irregular`: the full rate with irregular time stamps;
/// - `2_bin20`: 50 ms bin averages (20 Hz);
/// - `3_rep1`: one run, uniform rate;
/// - `4_rep3`: three runs;
/// - `5_amp1` and `6_amp5`: as a series-elastic-actuator test rig logs a stiffness test, the
///   test at one drive amplitude (the middle of the five), or at five (`DRIVE_LEVELS`), each
///   run three times, the runs in one file with time jumps between them; ~550 Hz irregular
///   epoch time stamps (`rig550`) and a 2e-6 rad linear encoder.
pub const DEVICE_VARIANTS: [(&str, &str); 6] = [
    ("1_irregular", "irregular"),
    ("2_bin20", "bin20"),
    ("3_rep1", "plain"),
    ("4_rep3", "repetitions3"),
    ("5_amp1", "linear2e-6+repetitions3+amplitudes1+rig550+epoch"),
    ("6_amp5", "linear2e-6+repetitions3+amplitudes5+rig550+epoch"),
];

/// Several records of each of a few devices, identical physics and test program per device,
/// logged differently (`DEVICE_VARIANTS`: full-rate irregular, binned to 20 Hz, one run, three
/// runs, and as a test rig logs a stiffness test at one or five drive amplitudes, three runs
/// each): a tool's answers for one device should agree across its variants.
pub fn device_variants(seed: u64) -> Vec<Case> {
    try_device_variants(seed).unwrap_or_else(|e| panic!("{e}"))
}

/// [`device_variants`], or which device could not be generated and why.
pub fn try_device_variants(seed: u64) -> Result<Vec<Case>, String> {
    Ok(try_device_variants_with_truth(seed)?
        .into_iter()
        .map(|(c, _)| c)
        .collect())
}

#[doc(hidden)]
pub fn device_variants_with_truth(seed: u64) -> Vec<(Case, Truth)> {
    try_device_variants_with_truth(seed).unwrap_or_else(|e| panic!("{e}"))
}

#[doc(hidden)]
pub fn try_device_variants_with_truth(seed: u64) -> Result<Vec<(Case, Truth)>, String> {
    let mut out = Vec::new();
    for (dev, effect) in DEVICES {
        let dev_seed = derive_seed(seed, &format!("device/{dev}"));
        let mut rng = Rng::new(dev_seed);
        let causes = synth::parse_effects(effect).map_err(|e| format!("{dev}: effect {effect}: {e}"))?;
        let req = Request {
            causes: causes.clone(),
            flags: Flags::default(),
            baseline: Some("atan".into()),
            duration_s: Some(rng.range(25.0, 45.0)),
            ratio: None,
            for_device: true,
        };
        let setup = synth::draw_setup_retrying(&mut rng, &req).map_err(|e| format!("{dev}: set-up: {e}"))?;
        let levels = synth::drive_levels(&setup, DRIVE_LEVELS);
        for (tag, variant) in DEVICE_VARIANTS {
            let mut vr = Rng::new(derive_seed(dev_seed, tag));
            let mut flags = Flags::parse(variant, &mut vr)
                .map_err(|e| format!("{dev}: variant {variant}: {e}"))?;
            // Drive amplitudes are the device's: its levels, or the middle one alone.
            flags.amplitudes = match flags.amplitudes.len() {
                0 => Vec::new(),
                1 => vec![levels[levels.len() / 2]],
                n if n == levels.len() => levels.clone(),
                n => {
                    return Err(format!(
                        "{dev}: {n} drive amplitudes; devices have 1 or {}",
                        levels.len()
                    ));
                }
            };
            let setup = setup.relogged(&flags, &mut vr);
            let meta = Meta {
                name: format!("{dev}_{tag}"),
                device: Some(dev.to_string()),
                effect: effect_name(&causes),
                seed: dev_seed,
            };
            out.push(synth::record(&setup, &flags, &mut vr, meta));
        }
    }
    Ok(out)
}

/// The answer as a JSON object (the keys of answers.json).
pub fn answer_json(a: &Answer) -> serde_json::Value {
    use serde_json::{Map, Value, json};
    let num = |m: &BTreeMap<String, f64>| -> Value {
        Value::Object(
            m.iter()
                .map(|(k, v)| (k.clone(), json!(v)))
                .collect::<Map<_, _>>(),
        )
    };
    let mut v = json!({
        "effect": a.effect,
        "params": num(&a.params),
        "noise": a.noise,
        "fs": a.fs,
        "k": a.k,
        "tau_max": a.tau_max,
        "variant": a.variant,
        "device": a.device,
        "level": a.level,
        "effect_rms_over_noise": a.effect_rms_over_noise,
        "effect_rms_raw_over_noise": a.effect_rms_raw_over_noise,
        "effect_rms_each": num(&a.effect_rms_each),
        "models": a.models,
        "friction_model": a.friction_model,
        "friction": num(&a.friction),
        "encoder_step": a.encoder_step,
        "quantised": a.quantised,
        "torque_span": a.torque_span,
        "duration": a.duration,
        "n_samples": a.n_samples,
        "repetitions": a.repetitions,
        "noise_white_raw": a.noise_white_raw,
        "seed": a.seed,
    });
    // Only records of a test at several drive amplitudes have these keys.
    if let (Some(d), Some(o)) = (&a.drive, v.as_object_mut()) {
        o.insert("amplitude_scales".into(), json!(d.scales));
        o.insert("amplitudes".into(), json!(d.amplitudes_rad));
        o.insert("runs_per_amplitude".into(), json!(d.runs_per_level));
        o.insert(
            "effect_rms_each_amplitude".into(),
            Value::Array(d.effect_rms_each.iter().map(num).collect()),
        );
    }
    v
}

/// Writes `t,deflection,torque` with enough digits: microseconds for time (epoch stamps too),
/// 13 significant digits for the deflection (encoder steps stay exact), micro-newton-metres
/// for the torque.
pub fn write_csv(case: &Case, path: &Path) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "t,deflection,torque")?;
    for i in 0..case.t.len() {
        writeln!(
            w,
            "{:.6},{:.12e},{:.6}",
            case.t[i], case.deflection[i], case.torque[i]
        )?;
    }
    w.flush()
}

/// Writes every case as DIR/<name>.csv and DIR/answers.json (name.csv -> answer).
pub fn write_set(cases: &[Case], dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut answers = serde_json::Map::new();
    for c in cases {
        let file = format!("{}.csv", c.name);
        write_csv(c, &dir.join(&file))?;
        answers.insert(file, answer_json(&c.answer));
    }
    let text = serde_json::to_string_pretty(&serde_json::Value::Object(answers))
        .map_err(std::io::Error::other)?;
    std::fs::write(dir.join("answers.json"), text + "\n")
}
