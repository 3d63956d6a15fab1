//! What to generate: the hidden causes (the vocabulary and its models), the record variant
//! flags, the request, and parsing the `effect` string.

use crate::rng::Rng;

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
    /// Time stamps of a series-elastic-actuator test rig's logger (implies `irregular`): median
    /// step 1.75-1.85 ms (about 550 Hz), 2.5 % of steps 3-23 ms (99th percentile about 15 ms),
    /// a gap of 0.05-0.26 s in about half of the runs.
    pub rig_logger: bool,
    pub epoch: bool,
    pub bin20: bool,
    /// Drive amplitudes of a test at several levels, relative to the set-up's amplitude, in the
    /// order they are run (increasing for `amplitudes<N>` and devices); each level is run
    /// `reps` times, one after the other (empty: one level, the set-up's).
    pub amplitudes: Vec<f64>,
}

/// Evenly spread relative drive amplitudes from 0.4 to 1.0 (1.0 alone for one level): the
/// levels of `amplitudes<N>` unless the caller sets its own (devices do).
pub fn default_amplitudes(n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![1.0];
    }
    (0..n)
        .map(|i| 0.4 + 0.6 * i as f64 / (n - 1) as f64)
        .collect()
}

impl Flags {
    pub fn parse(s: &str, rng: &mut Rng) -> Result<Flags, String> {
        let mut f = Flags::default();
        for tok in s.split('+').map(str::trim).filter(|t| !t.is_empty()) {
            match tok {
                "plain" => {}
                "irregular" => f.irregular = true,
                "rig550" => {
                    f.irregular = true;
                    f.rig_logger = true;
                }
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
                other => match other.strip_prefix("amplitudes").map(str::parse::<usize>) {
                    Some(Ok(n)) if (1..=9).contains(&n) => f.amplitudes = default_amplitudes(n),
                    _ => return Err(format!("unknown variant token `{other}`")),
                },
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
        let levels = format!("amplitudes{}", self.amplitudes.len());
        if !self.amplitudes.is_empty() {
            t.push(&levels);
        }
        if self.rig_logger {
            t.push("rig550");
        } else if self.irregular {
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
            self.amplitudes.len() > 1,
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
