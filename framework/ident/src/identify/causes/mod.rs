//! The vocabulary of causes: one module per physical effect, each implementing
//! [`CandidateCause`] for one [`Effect`]. Adding a cause means a variant of [`Effect`] (its name,
//! keys and dependence), one file here and one arm in [`cause_of`].

use std::collections::BTreeMap;

use jointctl_models::effect::Effect;
use serde_json::{Map, Value};

pub use super::numeric::log_grid;

mod coulomb_friction;
mod reversals;
mod dead_zone;
mod gravity_error;
mod hysteresis;
mod reversal_ringing;
mod sensor_offset;
mod speed_vibration;
mod stribeck_friction;
mod stiffness_error;
mod stiffness_nonlinearity;
mod time_delay;
mod vibration;
mod viscous_friction;
mod input_set;
mod loop_scales;
mod refine;

pub use coulomb_friction::CoulombFriction;
pub use reversals::reversals;
pub use dead_zone::DeadZone;
pub use gravity_error::GravityError;
pub use hysteresis::{Hysteresis, dahl_unit, dead_band, loop_unit};
pub use reversal_ringing::ReversalRinging;
pub use sensor_offset::SensorOffset;
pub(crate) use sensor_offset::{DRIFT_NAME, SensorOffsetDrift, fold_drift_into_offset};
pub use speed_vibration::SpeedVibration;
pub use stribeck_friction::StribeckFriction;
pub use stiffness_error::StiffnessError;
pub use stiffness_nonlinearity::StiffnessNonlinearity;
pub use time_delay::TimeDelay;
pub(crate) use time_delay::lag_share_parameter;
pub(crate) use time_delay::{delay_unit, delay_units_in};
pub use vibration::Vibration;
pub use viscous_friction::ViscousFriction;
pub use input_set::InputSet;
pub use refine::Refine;
pub use reversals::turn_step_rad;
pub(crate) use hysteresis::{PRESLIDING_DAMPING_AT, STRIBECK_AT, STRIBECK_RATIOS, presliding_damping_parameter, stribeck_parameters};

/// The built-in vocabulary: a cause for each model effect, in [`Effect::ALL`]'s order (the order
/// candidates are tried; ties go to the earlier one), and last the sensor offset's drift, which
/// is reported as part of the offset (`sensor_offset.rs`).
pub fn builtin() -> Vec<Box<dyn CandidateCause>> {
    Effect::ALL.into_iter().map(cause_of).chain([Box::new(SensorOffsetDrift) as Box<dyn CandidateCause>]).collect()
}

/// The built-in cause of `effect`: where a new effect's cause is registered (the compiler asks
/// for an arm for every variant of [`Effect`]).
///
/// ```
/// use jointctl_ident::identify::causes::cause_of;
/// use jointctl_models::effect::Effect;
/// assert_eq!(cause_of(Effect::DeadZone).effect(), Some(Effect::DeadZone));
/// ```
pub fn cause_of(effect: Effect) -> Box<dyn CandidateCause> {
    match effect {
        Effect::ViscousFriction => Box::new(ViscousFriction),
        Effect::CoulombFriction => Box::new(CoulombFriction),
        Effect::StribeckFriction => Box::new(StribeckFriction),
        Effect::SensorOffset => Box::new(SensorOffset),
        Effect::StiffnessError => Box::new(StiffnessError),
        Effect::StiffnessNonlinearity => Box::new(StiffnessNonlinearity),
        Effect::Hysteresis => Box::new(Hysteresis),
        Effect::DeadZone => Box::new(DeadZone),
        Effect::TimeDelay => Box::new(TimeDelay),
        Effect::Vibration => Box::new(Vibration),
        Effect::SpeedVibration => Box::new(SpeedVibration),
        Effect::ReversalRinging => Box::new(ReversalRinging),
        Effect::GravityError => Box::new(GravityError),
    }
}

/// Scales of the experiment, for a candidate's parameter grid.
#[derive(Clone, Copy, Debug)]
pub struct Excitation {
    /// Largest |deflection| [rad].
    pub amplitude_rad: f64,
    /// Fundamental frequency of the deflection (zero crossings per second) [Hz].
    pub frequency_hz: f64,
    /// Sample period of the data the search runs on [s].
    pub sample_period_s: f64,
    /// The deflection reading's scatter from sample to sample beyond its quantisation [rad]
    /// (an encoder that flickers between counts), as the data shows it.
    pub deflection_scatter_rad: f64,
    /// The deflection reading's resolution [rad]: its smallest common step.
    pub resolution_rad: f64,
    /// The step of the reading's coarsest quantiser [rad] (`prepare`'s `coarsest_tick_rad` or
    /// the lattice its steps lie on, `prepare::lattice`, the coarser; at least `resolution_rad`):
    /// a deflection that is a coarse output encoder less a fine motor encoder through a ratio
    /// steps by the motor's count and is off by half the output's.
    pub quantum_rad: f64,
    /// How finely the log shows the motion where it turns [rad] ([`turn_step_rad`]).
    pub turn_step_rad: f64,
    /// For a record read as bin averages, the interval each sample averages over [s] (a cause
    /// may then be averaged over it); 0 for point samples.
    pub bin_width_s: f64,
}

/// What a candidate sees when it chooses its parameter grid: the experiment's scales and the
/// current model's residual on the (decimated) training part, and on a stretch of it at the full
/// rate.
pub struct SearchContext<'a> {
    /// The experiment's scales.
    pub excitation: Excitation,
    /// Time [s].
    pub t_s: &'a [f64],
    /// Deflection rate [rad/s].
    pub velocity_rad_per_s: &'a [f64],
    /// The current model's residual, measured minus predicted torque [Nm].
    pub residual_nm: &'a [f64],
    /// The same on a contiguous stretch of the training part at the full sample rate: what
    /// lies above the decimated part's Nyquist frequency (a structural mode) shows only here.
    pub full_rate: FullRate<'a>,
    /// The baseline's characteristic is fitted on the data (its stiffness is already free), not
    /// given by a configured joint.
    pub baseline_fitted: bool,
    /// The record has no spring: its deflection column is a joint position and its torque
    /// friction (see [`crate::identify::NO_SPRING_SHARE`]).
    pub no_spring: bool,
    /// The training part's samples at rest at the full rate and the current model's residual
    /// there: a line there is no error of the motion.
    at_rest: RestSamples<'a>,
    /// The residual's dominant frequency and the line found at rest, once asked for (several
    /// vibration causes ask).
    dominant: std::sync::OnceLock<(Option<f64>, Option<super::rest_line::RestLine>)>,
    /// Each candidate's grids by its index among the model's causes, once asked for: the
    /// selection's first step asks every candidate for its grids to schedule the searches, and
    /// each search asks again (a vibration's scan of the residual, twice).
    grids: std::sync::Mutex<std::collections::HashMap<usize, Vec<Parameter>>>,
}

/// The training part's samples at rest at the full rate, in runs (see
/// [`SearchContext::dominant_frequency_hz`]); empty without a stop.
///
/// ```
/// use jointctl_ident::identify::RestSamples;
/// let none = RestSamples::default();
/// assert!(none.t_s.is_empty() && none.residual_nm.is_empty());
/// ```
#[derive(Clone, Copy, Default)]
pub struct RestSamples<'a> {
    /// Time [s].
    pub t_s: &'a [f64],
    /// The current model's residual [Nm].
    pub residual_nm: &'a [f64],
}

/// Series of a contiguous full-rate stretch of the training part (see
/// [`SearchContext::full_rate`]).
#[derive(Clone, Copy)]
pub struct FullRate<'a> {
    /// Time [s].
    pub t_s: &'a [f64],
    /// Deflection rate [rad/s].
    pub velocity_rad_per_s: &'a [f64],
    /// The current model's residual [Nm].
    pub residual_nm: &'a [f64],
}

impl<'a> SearchContext<'a> {
    /// The context of one search step: the decimated part's series and the full-rate stretch's.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(excitation: Excitation, t_s: &'a [f64], velocity_rad_per_s: &'a [f64], residual_nm: &'a [f64], full_rate: FullRate<'a>, at_rest: RestSamples<'a>, baseline_fitted: bool, no_spring: bool) -> Self {
        SearchContext { excitation, t_s, velocity_rad_per_s, residual_nm, full_rate, at_rest, baseline_fitted, no_spring, dominant: std::sync::OnceLock::new(), grids: Default::default() }
    }

    /// The grids of the cause at `index` among the model's causes ([`CandidateCause::parameters`]
    /// in this context), computed once. Computed outside the lock: two threads that ask at once
    /// both compute them, alike.
    pub(crate) fn grids_of(&self, index: usize, cause: &dyn CandidateCause) -> Vec<Parameter> {
        let lock = || self.grids.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(grids) = lock().get(&index) {
            return grids.clone();
        }
        let grids = cause.parameters(self);
        lock().insert(index, grids.clone());
        grids
    }

    /// The largest |deflection rate| of the decimated training part [rad/s] (0 for a record that
    /// does not move): the scale of a speed parameter's grid.
    pub fn peak_speed_rad_per_s(&self) -> f64 {
        self.velocity_rad_per_s.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    /// The frequency of the residual's strongest component in the band a structural mode is
    /// looked for in [Hz], on the full-rate stretch (a mode may lie above the decimated part's
    /// Nyquist frequency); `None` when there is no mode there (see the `spectrum` module).
    /// Computed once per context, whichever cause asks first.
    ///
    /// ```
    /// use jointctl_ident::identify::{CandidateCause, Parameter, Refine, SearchContext, Samples};
    ///
    /// /// A ripple at the residual's own dominant frequency.
    /// struct Ripple;
    /// impl CandidateCause for Ripple {
    ///     fn name(&self) -> &str { "ripple" }
    ///     fn coefficient_names(&self) -> Vec<String> { vec!["sin_nm".into()] }
    ///     fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
    ///         let grid = c.dominant_frequency_hz().into_iter().collect();
    ///         vec![Parameter { name: "frequency_hz".into(), grid, refine: Refine::Not }]
    ///     }
    ///     fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
    ///         vec![s.t_s.iter().map(|t| (std::f64::consts::TAU * p[0] * t).sin()).collect()]
    ///     }
    /// }
    /// # assert_eq!(Ripple.name(), "ripple");
    /// ```
    pub fn dominant_frequency_hz(&self) -> Option<f64> {
        self.lines().0
    }

    /// The line searched and, where it is the line found at rest, that line, scanned once per
    /// context. The band's line on the full-rate stretch, unless the scan of the samples at rest
    /// found one below the band (which the band cannot see; see `rest_line`) that stands out
    /// on that stretch too (a steady vibration runs through the motion as well; a slow motion
    /// within one encoder count, read as rest, makes lines at rest that do not) and is the
    /// stronger there.
    fn lines(&self) -> (Option<f64>, Option<super::rest_line::RestLine>) {
        let f = self.full_rate;
        *self.dominant.get_or_init(|| {
            let band = super::spectrum::dominant_frequency(f.t_s, f.residual_nm, self.excitation.frequency_hz);
            let rest = super::rest_line::line_at_rest(self.at_rest.t_s, self.at_rest.residual_nm);
            let power = |hz: f64| {
                let (s, c) = super::spectrum::projection(f.t_s, f.residual_nm, std::f64::consts::TAU * hz, false);
                s * s + c * c
            };
            let below_band = |r: &super::rest_line::RestLine| f.t_s.len() > 2 && r.frequency_hz < super::spectrum::band(f.t_s, self.excitation.frequency_hz).0;
            // Steady: a line on the full-rate stretch too, standing out of its neighbours there.
            let steady = |r: &super::rest_line::RestLine| super::rest_line::stands_out(f.t_s, f.residual_nm, r.frequency_hz);
            match (band, rest) {
                (b, Some(r)) if below_band(&r) && steady(&r) && b.is_none_or(|b| power(r.frequency_hz) > power(b)) => (Some(r.frequency_hz), Some(r)),
                (b, _) => (b, None),
            }
        })
    }

    /// How many frequencies the scans behind [`SearchContext::dominant_frequency_hz`] resolve:
    /// the band's over the full-rate stretch, and where the line at rest is the one searched,
    /// the scan at rest's too (the look-elsewhere count of a cause at that frequency). Where the
    /// band's line is searched, the scan at rest changed nothing; under noise alone it adds its
    /// own false-alarm level (0.1 %).
    pub fn frequencies_scanned(&self) -> f64 {
        let band = super::spectrum::resolvable(self.full_rate.t_s, self.excitation.frequency_hz);
        band + self.lines().1.map_or(0.0, |r| r.resolvable)
    }
}

/// A non-linear parameter of a cause and the values to search.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// Name with its SI unit, as reported.
    pub name: String,
    /// Values to try.
    pub grid: Vec<f64>,
    /// How the best grid value is refined.
    pub refine: Refine,
}

/// The inputs of the model, as the torque channel sees them. A cause may transform them (a delay
/// shifts the channel, a dead zone maps the deflection the spring sees) before columns are built.
#[derive(Clone, Debug)]
pub struct Inputs {
    /// Time [s].
    pub t_s: Vec<f64>,
    /// Deflection [rad] as the torque channel sees it.
    pub deflection_rad: Vec<f64>,
    /// Deflection rate [rad/s] as the torque channel sees it.
    pub velocity_rad_per_s: Vec<f64>,
    /// Deflection the elastic element transmits torque for [rad] (after play); on a record read
    /// as a joint's friction, its position about the training part's mean (the zero of a joint
    /// position is arbitrary).
    pub elastic_rad: Vec<f64>,
    /// Sample period of these inputs [s] (the median step; the time stamps may jitter and gap).
    pub sample_period_s: f64,
}

/// What a candidate sees of one part of the data (training or held out).
pub struct Samples<'a> {
    /// Time [s].
    pub t_s: &'a [f64],
    /// Deflection [rad] as the torque channel sees it (shifted when a time delay is in the model).
    pub deflection_rad: &'a [f64],
    /// Deflection rate [rad/s] as the torque channel sees it.
    pub velocity_rad_per_s: &'a [f64],
    /// Deflection the elastic element transmits torque for [rad] (after a dead zone); on a record
    /// read as a joint's friction, its position about the training part's mean.
    pub elastic_rad: &'a [f64],
    /// Stiffness setting [mm] (0 when the data has none).
    pub pivot_mm: &'a [f64],
    /// Which repetition each sample belongs to, counted from 0: a new one begins where the
    /// record's time restarted (repetitions logged apart and concatenated), so its time since
    /// the one before is not known and a steady vibration's phase does not carry over. Empty
    /// for a record of one repetition, whatever part of it the samples are.
    pub repetition: &'a [u32],
    /// Deflections before this part's first piece, oldest first: the history a stateful effect
    /// starts from (later pieces take theirs from `restarts`).
    pub history_rad: &'a [f64],
    /// Where a piece of the part that does not follow on from the samples before it starts
    /// (training samples either side of the held-out window, the searches' pieces), each with its
    /// own history: a stateful effect starts again there. A cause whose columns carry a state
    /// from sample to sample (a loop, a ring since the last reversal) must start it again at
    /// each.
    pub restarts: &'a [Restart],
    /// The configured characteristic's torque at `elastic_rad` [Nm]; zeros when the baseline is
    /// fitted on the data.
    pub model_nm: &'a [f64],
    /// For a record read as bin averages, each sample's rate at its interval's start and end
    /// less its own [rad/s]: a term that is not a straight line in the rate averages over the
    /// interval (see `prepare::rate_edges`). Empty for point samples.
    pub rate_edges_rad_per_s: &'a [[f64; 2]],
    /// For a record read as bin averages, the interval each sample averages over [s] (the log's
    /// step, also where the samples are a decimated part's, bins apart); unused for point
    /// samples.
    pub bin_width_s: f64,
    /// The middle of the whole record's time span, on `t_s`'s scale [s]: what a cause in time
    /// is centred on (an offset's drift: the offset reported beside it is the one at the middle
    /// of the record's time, its mean for an evenly logged record). The same for every part of
    /// a record.
    pub record_middle_s: f64,
}

/// A piece of a part that does not follow on from the samples before it (see
/// [`Samples::restarts`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Restart {
    /// The piece's first sample in the part.
    pub at: usize,
    /// Deflections before the piece, oldest first [rad].
    pub history_rad: Vec<f64>,
}

/// What a cause adds to the observer's and the simulation's configuration, in the keys they load
/// (`sim.effects` for the plant; the joint plugin's `model_extension` for the observer).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fragments {
    /// Keys of the simulated joint's `sim.effects`.
    pub plant: Map<String, Value>,
    /// Keys of the joint plugin's observer model extension.
    pub observer: Map<String, Value>,
}

/// A cause: a model extension linear in its coefficients, with non-linear parameters searched on
/// grids. Built-in causes and user causes ([`crate::identify::IdentifyOptions::extra_candidates`])
/// implement the same trait and compete under the same criteria.
///
/// ```
/// use jointctl_ident::identify::{CandidateCause, Parameter, Refine, SearchContext, Samples};
///
/// /// Cogging: a torque ripple periodic in deflection, `a sin(w phi) + b cos(w phi)`.
/// struct Cogging;
///
/// impl CandidateCause for Cogging {
///     fn name(&self) -> &str { "cogging" }
///     fn coefficient_names(&self) -> Vec<String> { vec!["sin_nm".into(), "cos_nm".into()] }
///     fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
///         let grid = (1..=40).map(|k| k as f64 * 4.0 / c.excitation.amplitude_rad).collect();
///         vec![Parameter { name: "ripples_per_rad".into(), grid, refine: Refine::Between }]
///     }
///     fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
///         vec![
///             s.deflection_rad.iter().map(|x| (p[0] * x).sin()).collect(),
///             s.deflection_rad.iter().map(|x| (p[0] * x).cos()).collect(),
///         ]
///     }
/// }
/// assert_eq!(Cogging.coefficient_names().len(), 2);
/// ```
pub trait CandidateCause: Send + Sync {
    /// The name reported in the `effect` field.
    fn name(&self) -> &str;
    /// The model effect a built-in cause stands for (`None`, the default, for a user's own
    /// cause): its keys in the observer's and the plant's configuration and its dependence
    /// are the effect's, and [`CandidateCause::fragments`] writes those keys only.
    fn effect(&self) -> Option<Effect> {
        None
    }
    /// Names of the linear coefficients, SI units in the names.
    fn coefficient_names(&self) -> Vec<String>;
    /// The non-linear parameters and their grids (none by default). A parameter with an empty
    /// grid says the cause has nothing to look for in this data (no mode in the band).
    fn parameters(&self, context: &SearchContext) -> Vec<Parameter> {
        let _ = context;
        Vec::new()
    }
    /// Whether the cause can be told apart in this set-up at all (by default it can). A cause
    /// the baseline already contains (a stiffness error when the characteristic is fitted on the
    /// data) is not tried.
    fn applicable(&self, context: &SearchContext) -> bool {
        let _ = context;
        true
    }
    /// Changes what the torque channel sees (a delay, a dead zone); nothing by default.
    fn transform(&self, parameters: &[f64], inputs: &mut Inputs) {
        let _ = (parameters, inputs);
    }
    /// Whether the cause is named only when its coefficients are told from zero on the training
    /// part (their t values, squared and summed, at least the tests' quantile squared), whatever
    /// the held-out part says; by default only a cause named on the weakest evidence (a large,
    /// consistent held-out gain) is held to that. For a cause whose column can take up any slow
    /// misfit of the others: a line in time (an offset's drift) was named at 1.8 standard errors
    /// beside a Bouc-Wen loop that a Dahl loop fits only in part.
    fn held_to_its_coefficients(&self) -> bool {
        false
    }
    /// Whether a baseline term can take this cause as its own within the recorded rates, so that
    /// its held-out gain understates it: proposed by BIC and significant on the held-out part,
    /// it is then relevant too when its own term carries the noise floor (see
    /// `significance::Judgement::carrying`). A viscous friction only: eq. 3.5's arctan, `k_b`
    /// fitted, bends into a line and takes the damping, and beyond the recorded rates the two
    /// part. Elsewhere a large term with a small gain is one the others cancel: asked of every
    /// cause, a speed vibration carried more than the floor beside a triangle's viscous friction
    /// and was named (`tests/memory.rs`'s record).
    fn baseline_can_absorb(&self) -> bool {
        false
    }
    /// The time constant [s] of a first-order lag the torque reaches the log through (a
    /// sensor's filter), when the cause has one at `parameters`: every column of the model, and
    /// a given characteristic's torque, pass through it. `None` (the default): no lag. Only
    /// the last term with one counts.
    fn output_lag_s(&self, parameters: &[f64]) -> Option<f64> {
        let _ = parameters;
        None
    }
    /// Whether [`CandidateCause::transform`] changes the inputs (the search then refits the
    /// whole model for every value instead of projecting the cause's columns).
    fn transforms(&self) -> bool {
        false
    }
    /// The inputs its columns, segments and transform read (every one by default). A cause that
    /// says fewer keeps its columns when a transform of others changes the model (a dead zone's
    /// width leaves a friction's columns as they were); one that says too few is handed columns
    /// computed on other inputs.
    fn reads(&self) -> InputSet {
        InputSet::ALL
    }
    /// The inputs its transform changes: every one by default for a cause that transforms, none
    /// for one that does not.
    fn writes(&self) -> InputSet {
        if self.transforms() { InputSet::ALL } else { InputSet::NONE }
    }
    /// One column per coefficient, one value per sample.
    fn columns(&self, parameters: &[f64], samples: &Samples) -> Vec<Vec<f64>>;
    /// Why a fit is physically impossible (it is then rejected, not reported), or `None`.
    fn impossible(&self, parameters: &[f64], coefficients: &[f64]) -> Option<String> {
        let _ = (parameters, coefficients);
        None
    }
    /// [`Self::impossible`] on a record of this `excitation`, for a rule that reads the
    /// experiment's scales (a loop that runs the other way must turn within the stroke, see
    /// `causes::hysteresis`); [`Self::impossible`] by default.
    fn impossible_given(&self, parameters: &[f64], coefficients: &[f64], excitation: &Excitation) -> Option<String> {
        let _ = excitation;
        self.impossible(parameters, coefficients)
    }
    /// Whether, on a record read as a joint's friction, the search and the polish keep to the
    /// parameter values at which the cause's fit is possible ([`CandidateCause::impossible`]
    /// says nothing): its best fit is then the best possible one, the constrained optimum,
    /// rather than the best of all, rejected when it is impossible. For a cause whose bound is
    /// on a coefficient's sign alone, where another cause of the library, searched on its own,
    /// explains what the impossible fit takes (a Stribeck dip as wide as the recorded rates,
    /// upside down, is a viscous friction). Not beside a spring, where the friction is a small
    /// part of the torque: there a dip the data does not have was fitted to what a 20 Hz log's
    /// bin averages leave of eq. 3.5's arctan read as points, and the record was read as
    /// points (`tests/bin_averages.rs`, one of four seeds). False by default: a bound on a
    /// parameter (a ring's damping) or a sign that stands for no other cause (a negative loop
    /// is a delay's) is the search's to report, not to avoid.
    fn searched_within_bounds(&self) -> bool {
        false
    }
    /// Whether the cause's scale (its first parameter, refined between grid values) is searched
    /// over its whole grid at every step of the selection (see `search::narrow_to_warm`): its
    /// fit can have another basin, the lower once other causes are in (a joint's friction
    /// pre-slides over a thousandth of the stroke a loop first took for a viscous friction's
    /// phase). True by default; false for a cause whose scale trades with another cause's
    /// term rather than finding its own effect.
    fn scale_searched_whole(&self) -> bool {
        true
    }
    /// Segments (start indices) on each of which the coefficients are fitted anew, when they
    /// cannot carry over from one stretch of data to the next (the amplitude and phase of each
    /// ring of a structure, rung at random by each reversal). They are fitted on every part, the
    /// held-out one included, and every coefficient so fitted is charged for (Mallows' Cp on the
    /// held-out part, BIC on the training part). `None` (the default): one set of coefficients.
    fn segments(&self, parameters: &[f64], samples: &Samples) -> Option<Vec<usize>> {
        let _ = (parameters, samples);
        None
    }
    /// The parameters reported, SI units in the names (by default every coefficient and every
    /// non-linear parameter under its own name).
    fn report(&self, parameters: &[f64], parameter_names: &[String], coefficients: &[f64]) -> BTreeMap<String, f64> {
        let mut out: BTreeMap<String, f64> = self.coefficient_names().into_iter().zip(coefficients.iter().copied()).collect();
        out.extend(parameter_names.iter().cloned().zip(parameters.iter().copied()));
        out
    }
    /// A remark for the evidence column (a known confound), or `None`.
    fn remark(&self, parameters: &[f64], excitation: &Excitation, duration_s: f64) -> Option<String> {
        let _ = (parameters, excitation, duration_s);
        None
    }
    /// What the cause adds to the observer and the simulation (nothing by default).
    fn fragments(&self, parameters: &[f64], coefficients: &[f64]) -> Fragments {
        let _ = (parameters, coefficients);
        Fragments::default()
    }
    /// Look-elsewhere charge [BIC units] for a parameter chosen as the best of many resolvable
    /// values on the current residual (a frequency scan); 0 for ordinary grids.
    fn look_elsewhere(&self, context: &SearchContext) -> f64 {
        let _ = context;
        0.0
    }
}

/// Where each repetition of `samples` begins (see [`Samples::repetition`]), the first sample
/// included; `None` for a record of one repetition. Every part of a record of several gets
/// its starts, a part inside one repetition (the held-out part of a record of three) its one:
/// whatever is fitted on each repetition apart is so on every part, the held-out one anew, so
/// that no part's coefficients are laid out differently from another's.
pub(crate) fn repetition_starts(samples: &Samples) -> Option<Vec<usize>> {
    let r = samples.repetition;
    if r.is_empty() {
        return None;
    }
    Some(std::iter::once(0).chain((1..r.len()).filter(|i| r[*i] != r[i - 1])).collect())
}

/// The RMS amplitude of sine-cosine coefficient pairs (one pair per segment) [Nm].
pub(crate) fn rms_amplitude(pairs: &[f64]) -> f64 {
    let n = (pairs.len() / 2).max(1) as f64;
    (pairs.chunks(2).map(|ab| ab[0] * ab[0] + ab.get(1).map_or(0.0, |b| b * b)).sum::<f64>() / n).sqrt()
}

/// A JSON object from pairs, for fragments.
pub(crate) fn object<const N: usize>(pairs: [(&str, Value); N]) -> Map<String, Value> {
    pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Review finding: whether a cause was fitted per repetition was decided by each part on
    /// its own, so a part inside the first repetition of a restarted record (a training part
    /// of its first 50 000 samples, as the fits then took) fitted one set of coefficients and a part in a later one
    /// (the held-out part) a per-repetition layout; a prediction from one part's fit on the
    /// other zips coefficients with columns and would mix them up. Decided for the record now.
    #[test]
    fn every_part_of_a_restarted_record_is_fitted_per_repetition() {
        let samples = |repetition: &[u32]| -> Option<Vec<usize>> {
            let n = repetition.len();
            let (t, zeros) = ((0..n).map(|i| i as f64).collect::<Vec<f64>>(), vec![0.0; n]);
            repetition_starts(&Samples { t_s: &t, deflection_rad: &zeros, velocity_rad_per_s: &zeros, elastic_rad: &zeros, pivot_mm: &zeros, repetition, history_rad: &[], restarts: &[], model_nm: &zeros, rate_edges_rad_per_s: &[], bin_width_s: 0.0, record_middle_s: 0.0 })
        };
        // Inside the first repetition, inside a later one, across two.
        assert_eq!(samples(&[0, 0, 0]), Some(vec![0]));
        assert_eq!(samples(&[2, 2]), Some(vec![0]));
        assert_eq!(samples(&[0, 0, 1, 1, 2]), Some(vec![0, 2, 4]));
        // A record of one repetition carries no column.
        assert_eq!(samples(&[]), None);
    }

    /// Each built-in cause stands for its own effect, under the effect's name, and writes the
    /// effect's keys only: the observer and the plant load those keys (the model loop merges
    /// them into `model_extension` and `sim.effects`), and a key the effect does not list would
    /// be a term no one has checked is there.
    #[test]
    fn every_cause_writes_its_effects_keys_only() {
        for effect in Effect::ALL {
            let cause = cause_of(effect);
            assert_eq!((cause.effect(), cause.name()), (Some(effect), effect.name()));
            let coefficients = vec![0.5; cause.coefficient_names().len()];
            let fragments = cause.fragments(&[1e-3, 1e-3, 1.0, 1.0], &coefficients);
            for (keys, allowed, whose) in [(&fragments.observer, effect.observer_keys(), "observer"), (&fragments.plant, effect.plant_keys(), "plant")] {
                for key in keys.keys() {
                    assert!(allowed.contains(&key.as_str()), "{effect} writes `{key}` for the {whose}, not among its keys {allowed:?}");
                }
            }
        }
    }
}
