//! `jointctl identify`: given measured data, what the joint model gets wrong and why.
//!
//! Four steps, one module each:
//! 1. [`prepare`](self::prepare): readings that jumped to exactly zero (thesis appendix A's lost
//!    CAN frames) out, the deflection rate, a check that the data excites the joint enough, and
//!    the split: the first 70 % of the time range to fit, the last 30 % held out (or a window of
//!    30 % like the rest when the last 30 % moves unlike it: [`prepare::held_out_window`]).
//! 2. `design`: the baseline (the configured model and nothing more: eq. 3.5 friction only when
//!    the model has it) plus terms, each a cause of the vocabulary in [`causes`] with its
//!    non-linear parameters; least squares by QR.
//! 3. `search`: each cause's parameters on its grid, refined as it asks.
//! 4. `select`: forward selection; BIC on the training part proposes, a block t-test on the
//!    held-out part ([`significance`]) decides, and every cause must stay significant given the
//!    others.
//!
//! A cause is reported with the drop of the held-out RMSE it brings and the fragments it adds to
//! the observer's and the simulation's configuration.

use std::collections::BTreeMap;
use jointctl_models::effect::Effect;
use serde::Serialize;

use crate::csv::Data;

mod baseline;
mod confounded;
pub mod bin_reading;
pub mod causes;
mod design;
pub(crate) mod least_squares;
pub mod experiment;
mod friction_confound;
mod friction_parts;
mod held_at_stops;
mod lag;
mod numeric;
mod parallel;
mod part;
mod presliding;
mod registered;
mod rest_line;
pub use numeric::format_value;
pub mod prepare;
mod search;
mod select;
pub mod significance;
mod spectrum;
mod uncertainty;
mod unexplained;

pub use unexplained::{BEYOND_TRAINING_RANGE, BEYOND_TRAINING_RATE, FAR_ABOVE_NOISE, Unexplained};
use unexplained::unexplained;

pub use baseline::{BaselineModel, NO_SPRING_SHARE};
pub use friction_parts::{FrictionDip, NoSpring};
pub use confounded::confound_evidence;
use confounded::confound_rule;
use baseline::{friction_parts, is_friction_part, reads_as_friction};
pub use experiment::Confound;
pub use causes::{CandidateCause, Excitation, Fragments, FullRate, Inputs, Parameter, Refine, Restart, RestSamples, Samples, SearchContext};
pub use prepare::PrepareError;
pub use select::BIC_THRESHOLD;

use design::{Model, Spec};

/// A cause found in the data.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Cause {
    /// One of the vocabulary's names.
    pub effect: String,
    /// Estimated parameters (SI units in the names).
    pub params: BTreeMap<String, f64>,
    /// How much the held-out torque RMSE drops because of this cause [Nm].
    pub rmse_gain: f64,
    /// Standard errors of the estimated parameters, under their names (same units), from the
    /// training fit: the covariance of the cause's coefficients and non-linear parameters (a
    /// scale, a delay, a shape, a frequency), the larger of the classical one (the residual's
    /// autocorrelation charged) and the block sandwich (a residual that is structure), and each
    /// reported value's error through it (see `uncertainty`). A ring's coefficients, fitted
    /// segment by segment, have none.
    pub uncertainty: BTreeMap<String, f64>,
    /// Why it was selected: the training BIC and the held-out judgement.
    pub evidence: String,
    /// What it adds to the observer's and the simulation's configuration.
    #[serde(skip)]
    pub fragments: Fragments,
}

/// A cause with evidence whose gain is too small to matter: listed apart, not named.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct NegligibleCause {
    /// One of the vocabulary's names.
    pub effect: String,
    /// The judgement (gain and the relevance threshold it missed).
    pub evidence: String,
}

/// How significance was decided, for the report.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Significance {
    /// The test.
    pub test: String,
    /// One-sided level.
    pub level: f64,
    /// The relevance rule.
    pub relevance: String,
    /// Blocks of the held-out part.
    pub blocks: usize,
}

/// The result, in the documented JSON shape (plus traces for plots, not serialised).
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Samples read.
    pub samples: usize,
    /// Samples excluded as dropouts.
    pub dropped_samples: usize,
    /// Deflection readings excluded as glitches: a leap away and back within a few samples.
    pub glitch_samples: usize,
    /// Samples excluded at the torque sensor's limit (saturated; see `prepare`).
    pub saturated_samples: usize,
    /// Samples excluded after pauses, up to the motion's next turn (see `prepare::pauses`).
    pub after_pauses: prepare::AfterPauses,
    /// A torque that falls as the deflection rises: one column's sign reversed, likely.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    /// The deflection's resolution estimated from its own steps [rad].
    pub resolution_rad: f64,
    /// Segments of contiguous logging (split at gaps and where the time restarted).
    pub segments: usize,
    /// Held-out torque RMSE of the baseline [Nm].
    pub rmse_before: f64,
    /// Held-out torque RMSE of the extended model [Nm].
    pub rmse_after: f64,
    /// Causes, most important first; empty when no listed cause is relevant with evidence.
    pub causes: Vec<Cause>,
    /// Causes with evidence whose held-out gain is negligible (below the relevance threshold).
    pub negligible: Vec<NegligibleCause>,
    /// Named causes that the data cannot tell from another candidate (see [`Confound`]).
    pub confounded: Vec<Confound>,
    /// An experiment that would tell each confounded pair apart (none without pairs).
    pub experiment: Option<experiment::Experiment>,
    /// What is left unexplained, measured against the noise floor.
    pub unexplained: Unexplained,
    /// Set when the record has no spring (see [`NoSpring`]).
    pub no_spring: Option<NoSpring>,
    /// Beside a spring, the Stribeck dip found in the fitted baseline's friction (see
    /// [`FrictionDip`]); `None` when none was found, on a friction record (see [`NoSpring`]) and
    /// against a given characteristic.
    pub friction_dip: Option<FrictionDip>,
    /// Set when a slow log is read as bin averages (see [`bin_reading`]).
    pub bin_averages: Option<bin_reading::BinAverages>,
    /// Set when the rate is read otherwise than over the usual window: with sharper intervals or
    /// over wider windows, or a slow log's as narrow as one sample either side or through a local cubic (see
    /// [`bin_reading::choose_rate_reading`]).
    pub narrow_rate: Option<bin_reading::NarrowRate>,
    /// Set when a friction record's stops or turns are left out (see [`prepare::AtRest`]): the
    /// held-out figures above are then over the samples that slide.
    pub at_rest: Option<prepare::AtRest>,
    /// The part of the time range held out (fractions of it), and why it is not the last part
    /// when it is not (see [`prepare::held_out_window`]).
    pub held_out_window: prepare::HeldOutWindow,
    /// How a cause's held-out gain was judged.
    pub significance: Significance,
    /// Held-out part: (t, deflection, velocity, measured, baseline, extended) for plots.
    #[serde(skip)]
    pub held_out: Vec<[f64; 6]>,
    /// Candidates rejected: fits that are physically impossible (evidence for another cause) and
    /// causes whose held-out gain is not significant.
    #[serde(skip)]
    pub rejected: Vec<String>,
}

/// How to identify.
pub struct IdentifyOptions {
    /// The baseline's elastic model.
    pub baseline: BaselineModel,
    /// Eq. 3.5's friction `k_a atan(k_b dphi/dt)` is part of the baseline (the model has it);
    /// otherwise it is a cause (`coulomb_friction`) like any other.
    pub baseline_friction: bool,
    /// Fraction of the time range used for fitting (the rest is held out).
    pub train_fraction: f64,
    /// Which part is held out (see [`prepare::held_out_window`]).
    pub held_out: prepare::HeldOut,
    /// Most causes reported.
    pub max_causes: usize,
    /// Causes beyond the built-in vocabulary, tested with the same criteria.
    pub extra_candidates: Vec<Box<dyn CandidateCause>>,
}

impl Default for IdentifyOptions {
    /// The thesis' structure: a linear characteristic through zero and eq. 3.5's friction.
    fn default() -> Self {
        IdentifyOptions { baseline: BaselineModel::Polynomial(1), baseline_friction: true, train_fraction: 0.7, held_out: prepare::HeldOut::default(), max_causes: 3, extra_candidates: Vec::new() }
    }
}

/// Why [`identify`] failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    /// The data cannot be identified as it is.
    #[error(transparent)]
    Data(#[from] PrepareError),
    /// A model's least-squares problem is singular (degenerate data).
    #[error("the {model} model cannot be fitted (degenerate data: a column is a combination of the others)")]
    Degenerate {
        /// "baseline" or "extended".
        model: &'static str,
    },
    /// A cause panicked while it was searched or fitted.
    #[error("a cause panicked during the search ({message}); the built-in causes do not, so look at the registered ones: {registered:?}")]
    CausePanicked {
        /// The panic's message.
        message: String,
        /// The registered causes' names.
        registered: Vec<String>,
    },
    /// A registered cause reuses a built-in or an earlier registered cause's name.
    #[error("registered cause `{name}`: the name is already taken")]
    CauseNameTaken {
        /// The cause's name.
        name: String,
    },
    /// A registered cause says it is one of the built-in model effects: each has its built-in
    /// cause, and identify treats a cause by its effect (a friction's part on a friction record,
    /// the experiment that separates a confound), which a user's cause must not borrow.
    #[error("registered cause `{name}`: it says it is the built-in effect `{effect}`, which has its own cause; a registered cause's effect() must be None")]
    CauseClaimsEffect {
        /// The cause's name.
        name: String,
        /// The effect it claimed.
        effect: jointctl_models::effect::Effect,
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
    // Read once: each reading of the rate starts from the record as read (see `prepare::Read`).
    let read = prepare::Read::of(data, opts.train_fraction, opts.held_out)?;
    // The usual reading and, unless the log may hold bin averages (whose narrowest window the
    // data choose first), the ones screened beside it, read together (see `ReadAhead`).
    let usual = prepare::RateReading::usual(prepare::NARROWEST_RATE_WINDOW);
    let screened = opts.baseline_friction && !prepare::tried_as_bins(read.spacing_s);
    let ahead: Vec<_> = std::iter::once(usual).chain(screened.then(|| bin_reading::other_readings(prepare::NARROWEST_RATE_WINDOW)).into_iter().flatten().map(|(_, r)| r)).collect();
    let ahead = prepare::ReadAhead::new(&read, &ahead);
    let p = ahead.prepare(usual)?;
    let builtin = causes::builtin();
    let all: Vec<&dyn CandidateCause> = builtin.iter().chain(&opts.extra_candidates).map(|c| c.as_ref()).collect();
    // A slow log's rate as narrow as one sample either side, should the baseline read better
    // so, and sharper intervals or wider windows for the whole model to confirm (see
    // `bin_reading`); should the screening fail (it fits the built-in friction only), the usual
    // reading.
    let reading = |p: std::borrow::Cow<prepare::Prepared>, r| std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| bin_reading::choose_rate_reading(&ahead, opts, &all, centre(&p, &opts.baseline), p, r))).unwrap_or_default();
    let slow = p.may_hold_bins() && opts.baseline_friction;
    let (p, rate) = slow.then(|| reading(std::borrow::Cow::Borrowed(&p), bin_reading::RateReadings::Narrow).into_iter().next()).flatten().map_or((p, None), |(rate, q)| (q, Some(rate)));
    let narrowest = if rate.is_some() { 1 } else { prepare::NARROWEST_RATE_WINDOW };
    // Screened before any report holds its held-out series, on the first reading handed over
    // and prepared again: on a 2-million-sample sine the peak was 14 MB higher screened after
    // the first pass, 8 MB beside the first reading, unchanged so (0.5 s longer, of 1.8 s).
    let (other_reading, p) = match opts.baseline_friction {
        true => (reading(std::borrow::Cow::Owned(p), bin_reading::RateReadings::Other { narrowest }), ahead.prepare(prepare::RateReading::usual(narrowest))?),
        false => (Vec::new(), p),
    };
    // Kept only for a slow log's cubic and a holds record's crossings: no long record's times held.
    drop(ahead);
    let holds = opts.baseline_friction && read.holds_between_moves(prepare::WIDEST_RATE_REACH_S);
    let read = (slow || holds).then_some(read);
    // A cause that panics (a registered cause's bug) is an error, not a crash of the caller and
    // not a candidate silently lost. The caches a panic may leave behind are dropped with it.
    let checked_and_extended = || {
        registered::check(&builtin, &opts.extra_candidates, &p, &opts.baseline)?;
        extend(&p, rate.as_ref(), &all, opts, false)
    };
    let first = std::panic::catch_unwind(std::panic::AssertUnwindSafe(checked_and_extended)).unwrap_or_else(|panic| {
        let message = panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned()).unwrap_or_else(|| "no message".into());
        Err(IdentifyError::CausePanicked { message, registered: opts.extra_candidates.iter().map(|c| c.name().to_string()).collect() })
    })?;
    // Each further reading apart: whatever befalls it (a registered cause that panics on it, a
    // degenerate fit), the first result stands (see `bin_reading::best_reading`).
    let again = |q: &prepare::Prepared, rate: Option<&bin_reading::NarrowRate>, force_bins: bool| std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| extend(q, rate, &all, opts, force_bins).ok())).ok().flatten();
    // Each reading's preparation is let go once its model is identified, the first's once no
    // other reading needs it (the bins reuse it), the cubic's prepared only then: a sharper
    // reading's model is identified beside the first's report alone (on a 2-million-sample
    // triangle whose sharper reading is taken, 158 MB with the first reading still held, over
    // issue 13's 150; 148 now).
    let mut others = Vec::new();
    // A slow log's rate through a local cubic and the crossings of a record of holds between
    // moves (after the first reading is let go), each judged on the whole model (see `best_reading`).
    let cubic = read.as_ref().filter(|_| slow).and_then(|read| read.prepare(prepare::RateReading::Cubic).ok());
    others.extend(cubic.and_then(|c| again(&c, None, false)).map(|e| (bin_reading::Reading::Cubic, e)));
    // A friction record's lag is part of its friction (`no_spring.lag`), not a cause: not asked.
    // A loop too: the baseline lacks it, and it may be read over each bin (`causes::hysteresis`).
    let tips_the_reading = |e: &str| e == Effect::TimeDelay.name() || e == Effect::Hysteresis.name();
    let tipped = first.report.causes.iter().any(|c| tips_the_reading(&c.effect));
    others.extend((slow && first.report.bin_averages.is_none() && tipped).then(|| again(&p, rate.as_ref(), true)).flatten().map(|e| (bin_reading::Reading::AsBins, e)));
    drop(p);
    others.extend(read.filter(|_| holds).and_then(|read| bin_reading::through_crossings(&read, |c| again(c, None, false))));
    others.extend(other_reading.into_iter().filter_map(|(r, q)| again(&q, Some(&r), false)).map(|e| (bin_reading::Reading::Other, e)));
    Ok(bin_reading::best_reading(first, others))
}

/// The deflection the baseline is centred on [rad]: a friction record's training mean (its
/// `deflection` is a position), 0 for a spring's deflection.
fn centre(p: &prepare::Prepared, baseline: &BaselineModel) -> f64 {
    if reads_as_friction(p.spring_share, baseline) { p.train.d.iter().sum::<f64>() / p.train.len().max(1) as f64 } else { 0.0 }
}

/// The search, the selection and the report on prepared data.
fn extend(p: &prepare::Prepared, rate: Option<&bin_reading::NarrowRate>, all: &[&dyn CandidateCause], opts: &IdentifyOptions, force_bins: bool) -> Result<bin_reading::Extended, IdentifyError> {
    // A friction record's stops and turns are left out of the fit and the judgement (see
    // `prepare::rest` and `prepare::turns`).
    let whole = p;
    let sliding;
    let mut at_rest = None;
    let p = match reads_as_friction(p.spring_share, &opts.baseline).then(|| p.sliding_only()).flatten() {
        Some((s, rest)) => {
            sliding = s;
            at_rest = Some(rest);
            &sliding
        }
        None => p,
    };
    let centre_rad = centre(p, &opts.baseline);
    let model = Model { baseline: &opts.baseline, centre_rad, middle_s: p.record_middle_s, friction_record: reads_as_friction(p.spring_share, &opts.baseline), causes: all, held_out: Default::default(), columns: Default::default() };
    let name = |c: usize| all[c].name().to_string();

    // The baseline: the configured model, with eq. 3.5's k_b searched when it has that friction.
    // A slow log with that friction is read as bin averages when they fit better (see
    // `bin_reading`), and its noise floor read again on what the baseline leaves (the friction's
    // flips are what the prepared floor took for noise; a configured model without friction
    // removes none: the 100 Hz elbow example's named causes went from 8 to 14 times its floor).
    // Without that friction a slow log is read as points.
    let mut base = Spec::default();
    let mut bin_averages = None;
    let read;
    let p = if opts.baseline_friction && p.may_hold_bins() {
        let points = p.as_points();
        let (bins, term, reading) = bin_reading::choose(&model, all, p, &points, force_bins)?;
        base.terms.push(term);
        bin_averages = reading;
        let mut chosen = if bins { p.clone() } else { points };
        if let Some(floor) = bin_reading::floor_under(&model, &base, &chosen) {
            chosen.noise_floor_nm = floor;
        }
        read = chosen;
        &read
    } else if p.may_hold_bins() {
        read = p.as_points();
        &read
    } else {
        if opts.baseline_friction {
            base.terms.push(bin_reading::baseline_friction(&model, all, p)?);
        }
        p
    };
    let before = select::held_out_errors(&model, &base, p).ok_or(IdentifyError::Degenerate { model: "baseline" })?;
    let mut selection = select::select(&model, p, base.clone(), opts.max_causes, name);
    // The floor read again on what the named causes leave, and the selection made again when it
    // falls clearly (see `bin_reading::FLOOR_FALL`): a steady vibration near the Nyquist
    // frequency had counted as noise. That floor is what those causes leave: a selection on it
    // that refuses one of them does not stand (see `bin_reading::stands_on_fallen_floor`).
    let refloored;
    let p = match (!selection.chosen.is_empty()).then(|| bin_reading::floor_fallen(&model, &selection.spec, p)).flatten() {
        Some(q) => {
            let again = select::select(&model, &q, base.clone(), opts.max_causes, name);
            let causes = |s: &select::Selection| s.chosen.iter().map(|c| c.cause).collect::<Vec<_>>();
            match bin_reading::stands_on_fallen_floor(&causes(&selection), &causes(&again)) {
                true => {
                    refloored = q;
                    selection = again;
                    &refloored
                }
                false => p,
            }
        }
        None => p,
    };
    let held_out_said = friction_confound::decide_on_held_out(&model, &mut selection, &base, p, opts.max_causes, &name);
    friction_confound::resplit_on_held_out(&model, &mut selection, p, &name);
    // The loop's LuGre parts: its pre-sliding damping (for a lead named beside it), and a
    // friction's Stribeck curve in it (see `presliding`).
    presliding::loop_parts(&model, &mut selection, p, whole, &name);
    // With no cause the extension is the baseline as it was fitted, not one whose parameters
    // the search moved on the way: rmse_after then equals rmse_before.
    // A named delay read again as a transport delay behind a lag (see `lag`), in the models
    // causes were judged against too; the other causes judged again beside it, as the selection
    // judged them (`select::prune`): one that made up for a pure delay's misfit leaves.
    if let Some(lagged) = (!selection.chosen.is_empty()).then(|| lag::behind_named_delay(&model, &selection.spec, p)).flatten() {
        selection.chosen.iter_mut().filter_map(|c| c.against.as_mut()).for_each(|a| *a = lag::with_lag_of(&model, &lagged, a));
        selection.spec = lagged;
        select::prune(&model, p, &mut selection, &name);
    }
    let spec = if selection.chosen.is_empty() { base.clone() } else { selection.spec.clone() };
    let after = select::held_out_errors(&model, &spec, p).ok_or(IdentifyError::Degenerate { model: "extended" })?;
    let fit = &after.fit;
    let rmse_after = select::rmse(&after.errors);
    // Over every held-out sample as well, the stops and turns included (not through the
    // held-out cache: it knows a model by its terms, not by the samples it is scored on).
    let at_rest = at_rest.map(|r| held_at_stops::over_every_sample(&model, p, whole, &base, &spec, r));

    let duration = p.train_duration_s + p.test.t[p.test.len() - 1] - p.test.t[0];
    // `fit` is the training part's (see `select::compute_held_out`); the parameters' errors are
    // read from its derivatives, computed once for every named cause.
    let jacobian = (!selection.chosen.is_empty()).then(|| uncertainty::Jacobian::new(&model, &spec, fit, &p.train));
    let mut found = Vec::new();
    for chosen in &selection.chosen {
        let i = spec.terms.iter().position(|t| t.cause == chosen.cause).ok_or(IdentifyError::Degenerate { model: "extended" })?;
        let (cause, term) = (all[chosen.cause], &spec.terms[i]);
        let names: Vec<String> = term.grids.iter().map(|p| p.name.clone()).collect();
        // Against the model without it and what turns impossible then (as `prune` judges it), or the one it was judged against.
        let gain = select::held_out_errors(&model, &chosen.against.clone().unwrap_or_else(|| select::without_and_impossible(&model, &spec, chosen.cause, p).0), p).map_or(0.0, |e| select::rmse(&e.errors) - rmse_after);
        let mut evidence = chosen.evidence.clone();
        if let Some(remark) = cause.remark(&term.params, &p.excitation, duration) {
            evidence += &format!("; {remark}");
        }
        let params = cause.report(&term.params, &names, fit.of(i));
        let covariance = jacobian.as_ref().and_then(|j| uncertainty::term_covariance(j, &spec, fit, i));
        let uncertainty = uncertainty::uncertainty_of(cause, &term.params, &names, fit.of(i), covariance.as_ref(), &params);
        found.push(Cause {
            effect: cause.name().into(),
            params,
            uncertainty,
            rmse_gain: gain,
            evidence,
            fragments: cause.fragments(&term.params, fit.of(i)),
        });
    }
    if p.dropped > 0 {
        let params = [("count".to_string(), p.dropped as f64), ("fraction".to_string(), p.dropped as f64 / p.samples as f64)].into_iter().collect();
        found.push(Cause {
            effect: "dropout".into(),
            params,
            uncertainty: BTreeMap::new(),
            rmse_gain: 0.0,
            evidence: format!("{} readings jumped to exactly zero from farther than the 14-bit quantisation and the signal's rate explain (appendix A's lost frames); excluded before fitting", p.dropped),
            fragments: Fragments::default(),
        });
    }
    // An offset's drift is reported as part of the offset.
    let index = |n: &str| all.iter().position(|c| c.name() == n);
    causes::fold_drift_into_offset(&mut found, !p.train.rep.is_empty(), || {
        let without = |s: &design::Spec, n: &str| -> Option<design::Spec> { Some(select::without_and_impossible(&model, s, index(n)?, p).0) };
        let both = without(&without(&spec, causes::DRIFT_NAME)?, Effect::SensorOffset.name())?;
        Some(select::rmse(&select::held_out_errors(&model, &both, p)?.errors) - rmse_after)
    });
    found.sort_by(|a, b| b.rmse_gain.total_cmp(&a.rmse_gain));

    let base_pred = model.predict(&base, &before.fit, &p.test).torque_nm;
    let ext_pred = model.predict(&spec, fit, &p.test).torque_nm;
    let t = &p.test;
    let held_out: Vec<[f64; 6]> = (0..t.len()).map(|i| [p.t0 + t.t[i], t.d[i], t.v[i], t.tau[i], base_pred[i], ext_pred[i]]).collect();
    let reach = |part: &design::Part| {
        let rms_rate = (part.v.iter().map(|v| v * v).sum::<f64>() / part.len().max(1) as f64).sqrt();
        let (lo, hi) = part.d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
        (rms_rate, hi - lo)
    };
    let ((rate_train, range_train), (rate_test, range_test)) = (reach(&p.train), reach(&p.test));
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::INFINITY };
    let held_out_reach = [ratio(rate_test, rate_train), ratio(range_test, range_train)];
    // The friction's parts (reported with it below) are not causes.
    let parts = friction_parts(p.spring_share, &opts.baseline);
    let no_cause = !found.iter().any(|c| c.effect != "dropout" && !parts.iter().any(|e| e.name() == c.effect));
    let unexplained = unexplained(&held_out, &after.errors, p.noise_floor_nm, no_cause, held_out_reach, opts.held_out);
    // A friction record's loop, dip and lag are its friction's parts (see `no_spring` below),
    // not causes: two of them are not a pair of causes.
    let friction_part = |c: usize| is_friction_part(p.spring_share, &opts.baseline, all[c]);
    let mut confounded: Vec<Confound> = selection
        .confounded
        .iter()
        .filter(|c| !(friction_part(c.named) && friction_part(c.alternative)))
        .map(|c| Confound {
            effect: name(c.named),
            alternative: name(c.alternative),
            bic: [c.bic[0], c.bic[1]],
            evidence: c.held_out_said(&name(c.named), &name(c.alternative)).unwrap_or_else(|| confound_evidence(&name(c.named), &name(c.alternative), c.bic[0], c.bic[1], c.bic[2])),
        })
        .collect();
    // Within the recorded rates eq. 3.5's nearly straight arctan and a viscous friction are both
    // straight lines; they part only where the arctan saturates, faster than the arm was driven,
    // and their experiment goes there.
    // So are an arctan named as a cause and a viscous friction, confounded, the arctan nearly
    // straight: their experiment goes there too, not slower.
    let friction = friction_confound::baseline_friction_confound(&model, &spec, p);
    let straight_pair = friction_confound::pair_saturates(&model, &spec, &selection.confounded, p).map(|(named, other, k_b, peak, share)| (name(named), name(other), k_b, peak, share));
    let is_straight_pair = |c: &Confound| straight_pair.as_ref().is_some_and(|(named, other, ..)| c.effect == *named && c.alternative == *other);
    let saturates = friction.as_ref().map(|c| c.k_b_s_per_rad).or(straight_pair.as_ref().map(|s| s.2)).map(|k_b| friction_confound::SATURATES / k_b);
    let pairs: Vec<(String, String)> = confounded.iter().filter(|c| !is_straight_pair(c)).map(|c| (c.effect.clone(), c.alternative.clone())).collect();
    let experiment = experiment::propose(&pairs, p.excitation.amplitude_rad, p.excitation.frequency_hz, saturates);
    if let Some((_, _, k_b, peak, share)) = straight_pair
        && let Some(c) = confounded.iter_mut().find(|c| is_straight_pair(c))
    {
        c.evidence.push_str(&friction_confound::straight_pair_sentence(k_b, peak, share, experiment.as_ref().and_then(experiment::fastest_for_saturation).is_some()));
    }
    if let Some(c) = friction {
        let [with, instead, before] = c.bic;
        let why = confound_rule(with, instead, before, "the arctan");
        let shape = format!(
            "{} {} explains the training part about as well ({why}): the baseline's arctan has k_b = {} s/rad, and at the recorded peak rate ({} rad/s) it still reaches {:.0} % of its tangent's line: nearly straight, as a viscous friction is; no viscous friction is named. The two part where the arctan saturates, above about {} rad/s (3 / k_b): beyond the training part's rates; {}; {}",
            name(c.viscous),
            match c.beside_saturating_k_b {
                None => "in place of eq. 3.5's friction in the baseline".to_string(),
                Some(k_b) => format!("beside eq. 3.5's arctan held to saturate within the training part's rates (k_b = {} s/rad)", format_value(k_b)),
            },
            format_value(c.k_b_s_per_rad),
            format_value(c.peak_rad_per_s),
            100.0 * c.share,
            format_value(friction_confound::SATURATES / c.k_b_s_per_rad),
            held_out_said.as_ref().map_or_else(|| "the held-out part was not asked".to_string(), ToString::to_string),
            match experiment.as_ref().and_then(experiment::fastest_for_saturation) {
                Some(fastest) => format!("the experiment proposed runs the recorded amplitude up to {} rad/s, beyond what the arm did", format_value(fastest)),
                None => "no experiment is proposed for them (the recorded excitation gives no amplitude and frequency to run faster, or that rate needs a segment above the highest frequency one may have)".to_string(),
            }
        );
        confounded.push(Confound { effect: name(c.friction), alternative: name(c.viscous), bic: [with, instead], evidence: shape });
    }
    let no_spring = friction_parts::no_spring(p, &opts.baseline, &mut found);
    let friction_dip = friction_parts::friction_dip(p, &opts.baseline, &mut found);
    let negligible = selection.negligible.iter().map(|(c, evidence)| NegligibleCause { effect: name(*c), evidence: evidence.clone() }).collect();
    let mut rejected = selection.rejected;
    rejected.sort();
    rejected.dedup();
    let training_bic = select::bic(fit.rss, p.train.len(), fit.parameters);
    let report = Report {
        samples: p.samples,
        dropped_samples: p.dropped,
        glitch_samples: p.glitches,
        saturated_samples: p.saturated,
        after_pauses: p.after_pauses.clone(),
        warning: p.reversed_sign.clone(),
        resolution_rad: p.resolution_rad,
        segments: p.segments,
        rmse_before: select::rmse(&before.errors),
        rmse_after,
        causes: found,
        negligible,
        experiment,
        confounded,
        unexplained,
        no_spring,
        friction_dip,
        bin_averages,
        narrow_rate: rate.cloned(),
        at_rest,
        held_out_window: p.held_out.clone(),
        significance: Significance {
            test: format!(
                "block t-test of held-out squared-error differences (Diebold-Mariano with batch means, AR(1)-corrected), one-sided; or forecast encompassing (the held-out residual regressed on the cause's correction, batch-means variance, the blocks' effective number as degrees of freedom) with a slope of at least {:.2} in each of {} parts of the held-out record where the correction acts; or, where the residual is structure, a gain of at least {:.0} % of the excess over the noise floor that worsens none of those parts and betters most of those with something to explain; for coefficients fitted on each ring, a gain of at least {:.0} % of the excess (consistent over those parts where the residual is structure) and a chi-square test of the held-out error drop",
                significance::CONFIRMED_SLOPE,
                significance::CONSISTENCY_PARTS,
                100.0 * significance::LARGE_SHARE_OF_EXCESS,
                100.0 * significance::LARGE_SHARE_OF_EXCESS
            ),
            level: significance::LEVEL,
            relevance: format!(
                "a held-out MSE gain of at least {:.0} % of the noise floor's variance and {:.0} % of the excess of the model without the cause over that floor",
                100.0 * significance::RELEVANT_SHARE_OF_NOISE,
                100.0 * significance::RELEVANT_SHARE_OF_EXCESS
            ),
            blocks: significance::blocks_for(t.len()),
        },
        held_out,
        rejected,
    };
    Ok(bin_reading::Extended { report, training_bic, samples: bin_reading::samples_of(p) })
}
