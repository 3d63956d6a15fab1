//! An experiment that tells confounded causes apart (issue 32): when the record cannot tell a
//! named cause from an alternative (see [`Confound`]), the two depend on the motion in
//! different ways, and a motion that varies what one depends on and not the other separates
//! them. The experiment is a list of flow-source sines run one after the other, each from rest
//! (`jointctl sim record --experiment`, or the same references on the arm), never beyond the
//! recorded amplitude or peak rate: what the arm already did is known to be safe.

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

/// The experiment that separates every confounded pair `(named, alternative)` of a record whose
/// excitation had amplitude `amplitude_rad` and fundamental `frequency_hz`; `None` without pairs.
/// A pair where one cause depends on the rate (or on time) is run at lower frequencies along the
/// same amplitude; any other pair at smaller amplitudes at the same frequency.
///
/// ```
/// use jointctl_ident::identify::experiment::propose;
/// let e = propose(&[("dead_zone".into(), "stiffness_nonlinearity".into())], 0.1, 0.25).unwrap();
/// // Smaller amplitudes at the recorded frequency: a play against a cubic.
/// assert!(e.segments.iter().all(|s| s.frequency_hz == 0.25 && s.amplitude_rad <= 0.1));
/// // Three amplitudes, the set run three times.
/// assert_eq!(e.segments.len(), 9);
/// let e = propose(&[("hysteresis".into(), "viscous_friction".into())], 0.1, 0.25).unwrap();
/// // Slower along the same amplitude: a viscous torque falls with the rate, a Dahl loop does not.
/// assert!(e.segments.iter().all(|s| s.amplitude_rad == 0.1 && s.frequency_hz <= 0.25));
/// assert!(propose(&[], 0.1, 0.25).is_none());
/// ```
pub fn propose(pairs: &[(String, String)], amplitude_rad: f64, frequency_hz: f64) -> Option<Experiment> {
    let (mut purpose, mut segments) = (Vec::new(), Vec::<Segment>::new());
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
            if !segments.iter().any(|s| s.amplitude_rad == a && s.frequency_hz == f) {
                segments.push(Segment { amplitude_rad: a, frequency_hz: f, duration_s: (SEGMENT_CYCLES / f).max(SEGMENT_MIN_S) });
            }
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
