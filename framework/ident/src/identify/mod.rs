//! `jointctl identify`: given measured data, what the joint model gets wrong and why.
//!
//! Four steps, one module each:
//! 1. [`prepare`](self::prepare): readings that jumped to exactly zero (thesis appendix A's lost
//!    CAN frames) out, the deflection rate, a check that the data excites the joint enough, and
//!    the split: the first 70 % of the time range to fit, the last 30 % held out.
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

use serde::Serialize;

use crate::csv::Data;

pub mod causes;
mod design;
pub mod prepare;
mod search;
mod select;
pub mod significance;
mod spectrum;

pub use causes::{CandidateCause, Excitation, Fragments, FullRate, Inputs, Parameter, Refine, Samples, SearchContext};
pub use prepare::PrepareError;
pub use select::BIC_THRESHOLD;

use design::{Model, Spec, Term};

/// A cause found in the data.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Cause {
    /// One of the vocabulary's names.
    pub effect: String,
    /// Estimated parameters (SI units in the names).
    pub params: BTreeMap<String, f64>,
    /// How much the held-out torque RMSE drops because of this cause [Nm].
    pub rmse_gain: f64,
    /// Why it was selected: the training BIC and the held-out test.
    pub evidence: String,
    /// What it adds to the observer's and the simulation's configuration.
    #[serde(skip)]
    pub fragments: Fragments,
}

/// How significance was decided, for the report.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Significance {
    /// The test.
    pub test: String,
    /// One-sided level.
    pub level: f64,
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
    /// Held-out torque RMSE of the baseline [Nm].
    pub rmse_before: f64,
    /// Held-out torque RMSE of the extended model [Nm].
    pub rmse_after: f64,
    /// Causes, most important first; empty when the baseline explains the data.
    pub causes: Vec<Cause>,
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
    /// Eq. 3.5's friction `k_a atan(k_b dphi/dt)` is part of the baseline (the model has it);
    /// otherwise it is a cause (`coulomb_friction`) like any other.
    pub baseline_friction: bool,
    /// Fraction of the time range used for fitting (the rest is held out).
    pub train_fraction: f64,
    /// Most causes reported.
    pub max_causes: usize,
    /// Causes beyond the built-in vocabulary, tested with the same criteria.
    pub extra_candidates: Vec<Box<dyn CandidateCause>>,
}

impl Default for IdentifyOptions {
    /// The thesis' structure: a linear characteristic through zero and eq. 3.5's friction.
    fn default() -> Self {
        IdentifyOptions { baseline: BaselineModel::Polynomial(1), baseline_friction: true, train_fraction: 0.7, max_causes: 3, extra_candidates: Vec::new() }
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
fn check_registered(builtin: &[Box<dyn CandidateCause>], registered: &[Box<dyn CandidateCause>], p: &prepare::Prepared, baseline_fitted: bool) -> Result<(), IdentifyError> {
    let taken: Vec<&str> = builtin.iter().map(|c| c.name()).chain(["dropout"]).collect();
    let part = &p.coarse;
    for (i, c) in registered.iter().enumerate() {
        let name = c.name();
        if taken.contains(&name) || registered[..i].iter().any(|o| o.name() == name) {
            return Err(IdentifyError::CauseNameTaken { name: name.into() });
        }
        let full_rate = FullRate { t_s: &p.stretch.t, velocity_rad_per_s: &p.stretch.v, residual_nm: &p.stretch.tau };
        let ctx = SearchContext::new(p.excitation, &part.t, &part.v, &part.tau, full_rate, baseline_fitted);
        let values: Vec<f64> = c.parameters(&ctx).iter().map(|p| p.grid.first().copied().unwrap_or(0.0)).collect();
        let model_nm = vec![0.0; part.len()];
        let samples = Samples { t_s: &part.t, deflection_rad: &part.d, velocity_rad_per_s: &part.v, elastic_rad: &part.d, pivot_mm: &part.pivot, history_rad: &part.warm, model_nm: &model_nm };
        let columns = c.columns(&values, &samples);
        let expected = c.coefficient_names().len();
        if columns.len() != expected || columns.iter().any(|col| col.len() != part.len()) {
            let lengths: Vec<usize> = columns.iter().map(Vec::len).collect();
            return Err(IdentifyError::CauseColumns { name: name.into(), lengths, expected_columns: expected, samples: part.len() });
        }
    }
    Ok(())
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
    let p = prepare::prepare(data, opts.train_fraction)?;
    let builtin = causes::builtin();
    // A cause that panics (a registered cause's bug) is an error, not a crash of the caller and
    // not a candidate silently lost. The caches a panic may leave behind are dropped with it.
    let checked_and_extended = || {
        check_registered(&builtin, &opts.extra_candidates, &p, matches!(opts.baseline, BaselineModel::Polynomial(_)))?;
        extend(&p, &builtin, opts)
    };
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(checked_and_extended)).unwrap_or_else(|panic| {
        let message = panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned()).unwrap_or_else(|| "no message".into());
        Err(IdentifyError::CausePanicked { message, registered: opts.extra_candidates.iter().map(|c| c.name().to_string()).collect() })
    })
}

/// The search, the selection and the report on prepared data.
fn extend(p: &prepare::Prepared, builtin: &[Box<dyn CandidateCause>], opts: &IdentifyOptions) -> Result<Report, IdentifyError> {
    let all: Vec<&dyn CandidateCause> = builtin.iter().chain(&opts.extra_candidates).map(|c| c.as_ref()).collect();
    let model = Model { baseline: &opts.baseline, causes: &all, held_out: Default::default(), columns: Default::default() };
    let name = |c: usize| all[c].name().to_string();

    // The baseline: the configured model, with eq. 3.5's k_b searched when it has that friction.
    let mut base = Spec::default();
    if opts.baseline_friction {
        let friction = all.iter().position(|c| c.name() == "coulomb_friction").ok_or(IdentifyError::Degenerate { model: "baseline" })?;
        let mut residuals = Default::default();
        let ctx = select::context(&model, &base, p, &mut residuals);
        let term = search::search(&model, &base, friction, &ctx, &p.coarse, &p.stretch, None).ok_or(IdentifyError::Degenerate { model: "baseline" })?;
        base.terms.push(Term { baseline: true, ..term });
    }
    let before = select::held_out_errors(&model, &base, p).ok_or(IdentifyError::Degenerate { model: "baseline" })?;
    let selection = select::select(&model, p, base.clone(), opts.max_causes, name);
    let spec = selection.spec;
    let after = select::held_out_errors(&model, &spec, p).ok_or(IdentifyError::Degenerate { model: "extended" })?;
    let fit = &after.fit;
    let rmse_after = select::rmse(&after.errors);

    let duration = p.train.t[p.train.len() - 1] - p.train.t[0] + p.test.t[p.test.len() - 1] - p.test.t[0];
    let mut found = Vec::new();
    for chosen in &selection.chosen {
        let i = spec.terms.iter().position(|t| t.cause == chosen.cause).ok_or(IdentifyError::Degenerate { model: "extended" })?;
        let (cause, term) = (all[chosen.cause], &spec.terms[i]);
        let names: Vec<String> = term.grids.iter().map(|p| p.name.clone()).collect();
        let gain = select::held_out_errors(&model, &spec.without(chosen.cause), p).map_or(0.0, |e| select::rmse(&e.errors) - rmse_after);
        let mut evidence = chosen.evidence.clone();
        if let Some(remark) = cause.remark(&term.params, &p.excitation, duration) {
            evidence += &format!("; {remark}");
        }
        found.push(Cause {
            effect: cause.name().into(),
            params: cause.report(&term.params, &names, fit.of(i)),
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
            rmse_gain: 0.0,
            evidence: format!("{} readings jumped to exactly zero from farther than the 14-bit quantisation and the signal's rate explain (appendix A's lost frames); excluded before fitting", p.dropped),
            fragments: Fragments::default(),
        });
    }
    found.sort_by(|a, b| b.rmse_gain.total_cmp(&a.rmse_gain));

    let base_pred = model.predict(&base, &before.fit, &p.test).torque_nm;
    let ext_pred = model.predict(&spec, fit, &p.test).torque_nm;
    let t = &p.test;
    let held_out = (0..t.len()).map(|i| [t.t[i], t.d[i], t.v[i], t.tau[i], base_pred[i], ext_pred[i]]).collect();
    let mut rejected = selection.rejected;
    rejected.sort();
    rejected.dedup();
    Ok(Report {
        samples: p.samples,
        dropped_samples: p.dropped,
        rmse_before: select::rmse(&before.errors),
        rmse_after,
        causes: found,
        significance: Significance {
            test: "block t-test of held-out squared-error differences (Diebold-Mariano with batch means, AR(1)-corrected), one-sided; for coefficients fitted on each ring, a chi-square test of the held-out error drop".into(),
            level: significance::LEVEL,
            blocks: significance::blocks_for(t.len()),
        },
        held_out,
        rejected,
    })
}
