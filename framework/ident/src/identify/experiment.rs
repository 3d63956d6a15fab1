//! An experiment that tells confounded causes apart (issue 32): when the record cannot tell a
//! named cause from an alternative (see [`Confound`]), the two depend on the motion in
//! different ways, and a motion that varies what one depends on and not the other separates
//! them. The experiment is a list of flow-source sines run one after the other, each from rest
//! (`jointctl sim record --experiment`, or the same references on the arm), never beyond the
//! recorded amplitude, and never beyond the recorded peak rate but for one pair: eq. 3.5's
//! arctan, nearly straight over the recorded rates, against a viscous friction in its place.
//! Those two part only where the arctan saturates, faster than the arm went, so their
//! experiment goes there ([`propose`]'s `saturates_rad_per_s`); what else the arm already did is
//! known to be safe.

use jointctl_models::effect::Effect;
use serde::{Deserialize, Serialize};

/// A named cause and a candidate that explains the training part about as well in its place:
/// the data cannot tell them apart, and the name given is one of the two.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Confound {
    /// The named cause, or `coulomb_friction` for eq. 3.5's friction in the baseline (its
    /// arctan nearly straight over the recorded rates, a viscous friction in its place).
    pub effect: String,
    /// The candidate that fits the training part about as well instead.
    pub alternative: String,
    /// Training BIC of the model with the named cause and with the alternative in its place
    /// (decimated training part, in the step the cause was named).
    pub bic: [f64; 2],
    /// One sentence: what cannot be told apart, and why.
    pub evidence: String,
}

pub use jointctl_models::effect::Dependence;

/// What `effect` (one of the vocabulary's names) depends on ([`Effect::dependence`]); `None` for
/// a name not in it (a user's own cause).
///
/// ```
/// use jointctl_ident::identify::experiment::{Dependence, dependence};
/// assert_eq!(dependence("viscous_friction"), Some(Dependence::Rate));
/// assert_eq!(dependence("dead_zone"), Some(Dependence::Deflection));
/// assert_eq!(dependence("not_a_cause"), None);
/// ```
pub fn dependence(effect: &str) -> Option<Dependence> {
    Effect::from_name(effect).map(Effect::dependence)
}

/// One sine of the flow source, run from rest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// Amplitude [rad].
    pub amplitude_rad: f64,
    /// Frequency [Hz].
    pub frequency_hz: f64,
    /// Duration [s].
    pub duration_s: f64,
}

impl Segment {
    /// The sine's peak deflection rate, `2 pi A f` [rad/s].
    ///
    /// ```
    /// use jointctl_ident::identify::experiment::Segment;
    /// let s = Segment { amplitude_rad: 0.01, frequency_hz: 0.5, duration_s: 4.0 };
    /// assert!((s.peak_rate_rad_per_s() - 0.0314159).abs() < 1e-6);
    /// ```
    pub fn peak_rate_rad_per_s(&self) -> f64 {
        std::f64::consts::TAU * self.amplitude_rad * self.frequency_hz
    }
}

/// An experiment: why, and the segments to run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Experiment {
    /// Each confounded pair and what the experiment varies to separate it (may be left out of
    /// a file written by hand).
    #[serde(default)]
    pub purpose: Vec<String>,
    /// The segments, in order.
    pub segments: Vec<Segment>,
}

/// Cycles each segment runs at least, and its shortest duration [s] (assumptions: three cycles
/// give a Dahl state and a delay two settled cycles after the start from rest; 20 s keeps a
/// fast segment long enough for the slow modes of the noise to average out).
pub const SEGMENT_CYCLES: f64 = 3.0;

/// Passes of the whole set of segments (an assumption: identify holds out the last 30 % of the
/// time range; with three passes a whole pass is held out and two are trained on, so both parts
/// see every amplitude and every rate. With one pass the held-out part held the last segments
/// only: on the elbow the small amplitudes, where a cubic is a few hundredths of a newton-metre,
/// and the cubic was refused there at t = 1.8).
pub const PASSES: usize = 3;
/// See [`SEGMENT_CYCLES`].
pub const SEGMENT_MIN_S: f64 = 20.0;

/// Rates, as fractions of the recorded peak rate, that a pair with a rate-driven cause is run at
/// (an assumption: a factor of 4 in the rate turns a viscous torque 4 times smaller, leaves a
/// Dahl loop's or a cubic's as it was, and spans eq. 3.5's arctan from its linear part to its
/// saturation when its smoothing speed lies inside the recorded rates).
const RATE_STEPS: [f64; 3] = [0.25, 0.5, 1.0];

/// Amplitudes, as fractions of the recorded one, that a pair of deflection- or stroke-driven
/// causes is run at (an assumption: a play's missing torque `k w` is the same at every amplitude
/// beyond it, so a quarter of the amplitude shows it four times larger against the spring's
/// torque, while a cubic's share falls sixteen-fold).
const AMPLITUDE_STEPS: [f64; 3] = [0.25, 0.5, 1.0];

/// Multiples of the rate where eq. 3.5's arctan saturates (`3 / k_b`, where it reaches 80 % of
/// its limit) that the pair of a nearly straight arctan and a viscous friction is run at, beside
/// the recorded frequency (an assumption: at twice that rate the arctan is at 90 % of its limit
/// and adds a tenth of it more, while a viscous torque doubles; on the simulated elbow, a
/// viscous friction of 3 Nm s/rad confounded so on a 0.05 rad, 0.25 Hz sine was named at 2.93
/// after this experiment, and a straight arctan of 0.5 Nm x 10 s/rad was left to the baseline).
pub const SATURATION_STEPS: [f64; 2] = [1.0, 2.0];

/// The highest frequency a segment may have [Hz] (`sim record`'s check of an experiment file):
/// a faster segment of the arctan's pair, for a small recorded amplitude, is left out, and the
/// purpose says so.
pub const MAX_FREQUENCY_HZ: f64 = 100.0;

/// The arctan's pair, as its purpose names it.
const SATURATION_PAIR: &str = "coulomb_friction or viscous_friction";

/// The fastest peak deflection rate of `experiment`'s segments [rad/s], when it runs eq. 3.5's
/// nearly straight arctan against a viscous friction beyond the recorded rates (`propose`'s
/// `saturates_rad_per_s`); `None` when it does not.
///
/// ```
/// use jointctl_ident::identify::experiment::{fastest_for_saturation, propose};
/// let e = propose(&[], 0.1, 0.25, Some(0.6)).unwrap();
/// assert!((fastest_for_saturation(&e).unwrap() - 1.2).abs() < 1e-9);
/// let e = propose(&[("hysteresis".into(), "viscous_friction".into())], 0.1, 0.25, None).unwrap();
/// assert_eq!(fastest_for_saturation(&e), None);
/// ```
pub fn fastest_for_saturation(experiment: &Experiment) -> Option<f64> {
    experiment.purpose.iter().any(|p| p.starts_with(SATURATION_PAIR)).then(|| experiment.segments.iter().map(Segment::peak_rate_rad_per_s).fold(0.0, f64::max))
}

/// The experiment that separates every confounded pair `(named, alternative)` of a record whose
/// excitation had amplitude `amplitude_rad` and fundamental `frequency_hz`; `None` without pairs
/// (and without a rate for the arctan's pair that a segment can reach).
/// A pair where one cause depends on the rate (or on time) is run at lower frequencies along the
/// same amplitude; any other pair at smaller amplitudes at the same frequency. With
/// `saturates_rad_per_s` (`3 / k_b` of eq. 3.5's arctan in the baseline, when the record cannot
/// tell it, nearly straight, from a viscous friction in its place), the same amplitude at the
/// recorded frequency and at the frequencies whose peak rates are [`SATURATION_STEPS`] times
/// that: the one proposal beyond the recorded peak rate, since the two part only there.
///
/// ```
/// use jointctl_ident::identify::experiment::propose;
/// let e = propose(&[("dead_zone".into(), "stiffness_nonlinearity".into())], 0.1, 0.25, None).unwrap();
/// // Smaller amplitudes at the recorded frequency: a play against a cubic.
/// assert!(e.segments.iter().all(|s| s.frequency_hz == 0.25 && s.amplitude_rad <= 0.1));
/// // Three amplitudes, the set run three times.
/// assert_eq!(e.segments.len(), 9);
/// let e = propose(&[("hysteresis".into(), "viscous_friction".into())], 0.1, 0.25, None).unwrap();
/// // Slower along the same amplitude: a viscous torque falls with the rate, a Dahl loop does not.
/// assert!(e.segments.iter().all(|s| s.amplitude_rad == 0.1 && s.frequency_hz <= 0.25));
/// assert!(propose(&[], 0.1, 0.25, None).is_none());
/// // A straight arctan against a viscous friction: faster, to where the arctan saturates
/// // (0.6 rad/s, k_b = 5 s/rad) and twice that, beside the recorded 0.157 rad/s.
/// let e = propose(&[], 0.1, 0.25, Some(0.6)).unwrap();
/// let peaks: Vec<f64> = e.segments.iter().take(3).map(|s| s.peak_rate_rad_per_s()).collect();
/// assert!((peaks[0] - 0.157).abs() < 1e-3 && (peaks[1] - 0.6).abs() < 1e-9 && (peaks[2] - 1.2).abs() < 1e-9);
/// // From 0.1 mrad, 0.6 rad/s needs 955 Hz: beyond what a segment may have, no experiment.
/// assert!(propose(&[], 1e-4, 0.25, Some(0.6)).is_none());
/// ```
pub fn propose(pairs: &[(String, String)], amplitude_rad: f64, frequency_hz: f64, saturates_rad_per_s: Option<f64>) -> Option<Experiment> {
    let (mut purpose, mut segments) = (Vec::new(), Vec::<Segment>::new());
    let add = |segments: &mut Vec<Segment>, a: f64, f: f64| {
        if !segments.iter().any(|s| s.amplitude_rad == a && s.frequency_hz == f) {
            segments.push(Segment { amplitude_rad: a, frequency_hz: f, duration_s: (SEGMENT_CYCLES / f).max(SEGMENT_MIN_S) });
        }
    };
    let recorded_peak = std::f64::consts::TAU * amplitude_rad * frequency_hz;
    if let Some(rate) = saturates_rad_per_s.filter(|r| r.is_finite() && *r > 0.0 && amplitude_rad > 0.0 && frequency_hz > 0.0) {
        // Pure sines of the recorded amplitude, each peaking at its multiple of the rate.
        let all: Vec<f64> = SATURATION_STEPS.iter().map(|m| m * rate / (std::f64::consts::TAU * amplitude_rad)).collect();
        let faster: Vec<f64> = all.iter().copied().filter(|f| *f <= MAX_FREQUENCY_HZ).collect();
        if !faster.is_empty() {
            let left_out = match all.len() - faster.len() {
                0 => String::new(),
                n => format!("; {n} of them, above {MAX_FREQUENCY_HZ} Hz (the most a segment may have), left out: the recorded amplitude is too small to reach that rate slower"),
            };
            purpose.push(format!(
                "{SATURATION_PAIR} (eq. 3.5's arctan nearly straight over the recorded rates): the same amplitude ({amplitude_rad:.4} rad) at the recorded frequency ({frequency_hz:.3} Hz) and at {} Hz, whose peak rates are {} times {} rad/s, where the arctan saturates (3 / k_b){left_out}: the two part only there, so this is the one proposal beyond the recorded excitation (its fundamental's peak rate {recorded_peak:.4} rad/s); before it runs on the arm, check that the joint may move that fast (`cmd experiment --dry-run` prints each segment's peak rate; in the position form the runtime clips a set-point faster than the joint's rate limit), and record it at more than twice its fastest frequency",
                all.iter().map(|f| format!("{f:.3}")).collect::<Vec<_>>().join(" and "),
                SATURATION_STEPS.map(|m| format!("{m}")).join(" and "),
                super::numeric::format_value(rate),
            ));
            for f in std::iter::once(frequency_hz).chain(faster) {
                add(&mut segments, amplitude_rad, f);
            }
        }
    }
    for (named, other) in pairs {
        let by_rate = [named, other].iter().any(|e| matches!(dependence(e), Some(Dependence::Rate | Dependence::Time)));
        let steps: Vec<(f64, f64)> = if by_rate {
            purpose.push(format!("{named} or {other}: the same amplitude ({amplitude_rad:.4} rad) at {} times the recorded frequency ({frequency_hz:.3} Hz): a rate-driven torque changes with the rate, a deflection- or stroke-driven one does not", list(&RATE_STEPS)));
            RATE_STEPS.iter().map(|r| (amplitude_rad, frequency_hz * r)).collect()
        } else {
            purpose.push(format!("{named} or {other}: {} times the recorded amplitude ({amplitude_rad:.4} rad) at the recorded frequency ({frequency_hz:.3} Hz): a play's missing torque stays as the amplitude falls, a curve's or a loop's share changes with it", list(&AMPLITUDE_STEPS)));
            AMPLITUDE_STEPS.iter().map(|a| (amplitude_rad * a, frequency_hz)).collect()
        };
        for (a, f) in steps {
            add(&mut segments, a, f);
        }
    }
    if segments.is_empty() {
        return None;
    }
    let segments = segments.iter().cycle().take(PASSES * segments.len()).cloned().collect();
    purpose.push(format!("the set run {PASSES} times, so that the held-out part (the last 30 % of the time) and the training part each see every setting"));
    Some(Experiment { purpose, segments })
}

fn list(steps: &[f64]) -> String {
    steps.iter().map(|s| format!("{s}")).collect::<Vec<_>>().join(", ")
}
