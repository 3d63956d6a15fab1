//! The uncertainty of a named cause's parameters: the covariance of its coefficients and its
//! non-linear parameters (a loop's scale, a delay, a dead band, a frequency) from the training
//! fit, and each reported parameter's standard error through it (the delta method).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use super::baseline::is_friction_part;
use super::causes::CandidateCause;
use super::design::{Fit, HeldOut, Model, Part, Spec};
use super::numeric::format_value;
use super::prepare::Prepared;
use super::least_squares::{ar1_inflated_variance, dot};
use super::parallel::parallel_map;
use super::significance::{Z, blocks_for, is_structured};

/// The relative step of a numerical derivative: small against every parameter's scale (a
/// frequency's phase over a long record turns with `t * df`), large against rounding.
const STEP: f64 = 1e-6;

/// The covariance of one term's coefficients and non-linear parameters.
pub(crate) struct TermCovariance {
    /// The term's coefficients, then its non-linear parameters (those estimated: a nested
    /// parameter left at its simpler value is not).
    at: Vec<f64>,
    /// Which entries of `at` are non-linear parameters (their index in the term's `params`).
    nonlinear: Vec<Option<usize>>,
    /// Two covariances of `at`: the residual's variance with its lag-1 autocorrelation
    /// (`s^2 (1 + rho) / (1 - rho) (J'J)^-1`), and the block sandwich.
    classical: DMatrix<f64>,
    blocks: DMatrix<f64>,
    /// The Gauss-Newton step from `at` towards the training fit's optimum: how far the search,
    /// which ranks values on the decimated training part and refines them to a resolution (a
    /// delay in whole steps, a scale to a golden section's tolerance), stopped from it.
    displacement: Vec<f64>,
    /// Estimated non-linear parameters whose error the fit cannot give (the torque does not
    /// move along them at their value, or they move it as the others do): a value that depends
    /// on one has no error claimed.
    unmeasured: Vec<usize>,
}

impl TermCovariance {
    /// The standard errors of the term's own coefficients (in the order of the fit's), joint
    /// with its non-linear parameters: the larger of the classical and the block error.
    pub(crate) fn coefficient_errors(&self) -> Vec<f64> {
        (0..self.at.len()).filter(|e| self.nonlinear[*e].is_none()).map(|e| self.classical[(e, e)].max(self.blocks[(e, e)]).sqrt()).collect()
    }

    /// The block errors alone of the term's own coefficients: what they move from one stretch of
    /// the training part to the next (see [`untold_from_zero`]).
    fn coefficient_block_errors(&self) -> Vec<f64> {
        (0..self.at.len()).filter(|e| self.nonlinear[*e].is_none()).map(|e| self.blocks[(e, e)].sqrt()).collect()
    }
}

/// The training fit's columns, its residual, and the model's derivative along every estimated
/// non-linear parameter of every term: computed once for all the named causes.
pub(crate) struct Jacobian {
    cols: Vec<Vec<f64>>,
    residual: Vec<f64>,
    /// Per term, per parameter: its derivative column; `None` for a parameter not estimated (a
    /// nested one left at its simpler value) or one the torque does not follow smoothly at its
    /// value (see [`moves_smoothly`]: no error the fit can give).
    derivatives: Vec<Vec<Option<Vec<f64>>>>,
    /// Per term, per parameter: whether it was estimated (a value to account for).
    estimated: Vec<Vec<bool>>,
}

impl Jacobian {
    /// The columns of `spec` fitted on `train` as `fit`, its residual and its derivatives (a
    /// forward difference from the fitted torque, backward at the top of a parameter's grid;
    /// the parameters spread over the cores).
    pub(crate) fn new(model: &Model, spec: &Spec, fit: &Fit, train: &Part) -> Jacobian {
        // The prediction itself, not the torque less the residual: a parameter that moves no
        // sample must give a column of exact zeros (see `moves_smoothly`).
        let (cols, fitted, residual) = model.columns_and_residual(spec, fit, train);
        let estimated: Vec<Vec<bool>> = spec
            .terms
            .iter()
            .map(|term| {
                term.params
                    .iter()
                    .enumerate()
                    .map(|(j, &x)| {
                        let simpler = term.grids.get(j).is_some_and(|g| g.refine.is_nested() && g.grid.first() == Some(&x));
                        x.is_finite() && !simpler
                    })
                    .collect()
            })
            .collect();
        let jobs: Vec<(usize, usize)> = estimated.iter().enumerate().flat_map(|(t, e)| e.iter().enumerate().filter(|(_, e)| **e).map(move |(j, _)| (t, j))).collect();
        let columns = parallel_map(&jobs, |&(t, j)| derivative(model, spec, fit, train, &fitted, t, j).filter(|c| moves_smoothly(c)));
        let mut derivatives: Vec<Vec<Option<Vec<f64>>>> = spec.terms.iter().map(|t| vec![None; t.params.len()]).collect();
        for ((t, j), column) in jobs.into_iter().zip(columns) {
            derivatives[t][j] = column;
        }
        Jacobian { cols, residual, derivatives, estimated }
    }
}

/// Whether a derivative column is one the Gauss-Newton linearisation can use: the torque moves
/// at [`SMOOTH_SHARE`] of the samples at least. A parameter whose small step moves the torque at
/// a few samples only is a step function there (a loop's input dead band on a quantised
/// reading moves the loop only where a reading crosses its edge; a dead zone's ramp of zero
/// width, stepped, covers a handful), and its linearised error came out absurd (a ramp's share
/// of 0 +- 2e10).
fn moves_smoothly(column: &[f64]) -> bool {
    let moving = column.iter().filter(|v| **v != 0.0).count();
    moving as f64 >= SMOOTH_SHARE * column.len() as f64 && moving > 0
}

/// The share of the samples a parameter's derivative must move (see [`moves_smoothly`]; an
/// assumption: a hundredth, far above the few samples of a step function and far below what a
/// scale, a delay or a shape moves, every sample in motion).
const SMOOTH_SHARE: f64 = 0.01;

/// The covariance of term `i`'s coefficients and non-linear parameters (see [`Jacobian`]);
/// `None` when the term has no coefficients of its own and no estimated non-linear parameter,
/// or the design is singular.
///
/// The non-linear parameters enter as the model's derivative along each (the Gauss-Newton
/// linearisation, Bates and Watts, *Nonlinear Regression Analysis*, ch. 2) beside every ordinary
/// column of the model, so that their errors are the joint ones, not conditional on the
/// coefficients. Two covariances are kept, and a parameter's error is the larger:
/// - the classical one, the residual taken as noise (its lag-1 autocorrelation charged as in
///   `design::Model::standard_errors`);
/// - the block sandwich `(J'J)^-1 (sum_b g_b g_b') (J'J)^-1 B / (B - 1)`, `g_b` the score
///   `J' e` of one of `B` contiguous blocks of the training part (the cluster-robust covariance
///   with blocks as clusters; White 1982 for a misspecified model). A residual that is structure
///   (an effect that no cause models exactly, a LuGre loop where identify fits Dahl's) moves the
///   parameters from one stretch of the record to another, and the classical error does not see
///   it: on the blind devices, one device's variants (irregular, binned, one and three
///   repetitions) differed by several classical errors.
pub(crate) fn term_covariance(jacobian: &Jacobian, spec: &Spec, fit: &Fit, i: usize) -> Option<TermCovariance> {
    let (cols, residual) = (&jacobian.cols, &jacobian.residual);
    let span = fit.spans.get(i)?.clone();
    // Segment-wise coefficients (a ring's) are fitted anew on every segment: not in `cols`.
    let own: Vec<usize> = if fit.segment_coefs[i].is_empty() { span.collect() } else { Vec::new() };
    let mut unmeasured = Vec::new();
    // The derivatives along this term's non-linear parameters, and along the other terms' (the
    // baseline's arctan steepness trades off with a delay: held, the delay's error was a sixth
    // of its spread over records that differed in their noise).
    // This term's (parameter index, value, derivative), and the other terms' derivatives.
    let mut mine: Vec<(usize, f64, &Vec<f64>)> = Vec::new();
    let mut others: Vec<&Vec<f64>> = Vec::new();
    for (t, term) in spec.terms.iter().enumerate() {
        for (j, &x) in term.params.iter().enumerate() {
            if !jacobian.estimated[t][j] {
                continue;
            }
            match (jacobian.derivatives[t][j].as_ref(), t == i) {
                (Some(c), true) => mine.push((j, x, c)),
                (None, true) => unmeasured.push(j),
                (Some(c), false) => others.push(c),
                (None, false) => {}
            }
        }
    }
    // A parameter whose error (the search's distance from the optimum included) is wider than
    // the values its search looked over is not determined by the data, or not near enough to
    // a parabola for the linearisation (a loop's input dead band a few fine encoder steps wide
    // came out 9e-6 +- 8e3 rad, a loop's shape 2 +- 9.6): it is left unmeasured, and the
    // others' errors are taken without it.
    let spans: Vec<f64> = spec.terms[i].grids.iter().map(|g| g.grid.iter().copied().fold(f64::NEG_INFINITY, f64::max) - g.grid.iter().copied().fold(f64::INFINITY, f64::min)).collect();
    loop {
        let covariance = covariances(cols, residual, &own, fit, &mine, &others, unmeasured.clone())?;
        // The widest against its span first, one at a time: with it gone, a parameter it
        // traded off with may be determined.
        let widest = covariance
            .nonlinear
            .iter()
            .enumerate()
            .filter_map(|(e, j)| {
                let span = spans.get((*j)?).copied().filter(|s| s.is_finite() && *s > 0.0)?;
                let error = (covariance.classical[(e, e)].max(covariance.blocks[(e, e)]) + covariance.displacement[e].powi(2)).sqrt();
                (error > span).then_some(((*j)?, error / span))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((wide, _)) = widest else { return Some(covariance) };
        mine.retain(|m| m.0 != wide);
        unmeasured.push(wide);
    }
}

/// This term's covariance with its own non-linear parameters `mine` (index, value, derivative)
/// beside the ordinary columns `cols`, and the other terms' derivatives `others` (see
/// [`term_covariance`]).
fn covariances(cols: &[Vec<f64>], residual: &[f64], own: &[usize], fit: &Fit, mine: &[(usize, f64, &Vec<f64>)], others: &[&Vec<f64>], unmeasured: Vec<usize>) -> Option<TermCovariance> {
    let mut at: Vec<f64> = own.iter().map(|&k| fit.coefs[k]).collect();
    let mut nonlinear: Vec<Option<usize>> = vec![None; own.len()];
    let mut index: Vec<usize> = own.to_vec();
    for (k, (j, x, _)) in mine.iter().enumerate() {
        index.push(cols.len() + k);
        at.push(*x);
        nonlinear.push(Some(*j));
    }
    if index.is_empty() {
        return None;
    }
    let all = |with_others: bool| -> Vec<&[f64]> { cols.iter().map(Vec::as_slice).chain(mine.iter().map(|m| m.2.as_slice())).chain(others.iter().filter(|_| with_others).map(|c| c.as_slice())).collect() };
    let entries = Entries { index, at, nonlinear, unmeasured };
    let again = Entries { index: entries.index.clone(), at: entries.at.clone(), nonlinear: entries.nonlinear.clone(), unmeasured: entries.unmeasured.clone() };
    // The errors are the joint ones, with the other terms' parameters; the search's distance from
    // the optimum is this term's own Gauss-Newton step, the other terms held: with them, the
    // step is a linearisation over a ridge (the arctan's steepness and a delay), and it stepped
    // delays found at the lattice point nearest their truth a millisecond past it. Near-singular
    // with its own parameters (they move the torque as the coefficients do): those unmeasured,
    // the coefficients' still given.
    let conditional = match covariance_of(&all(false), residual, entries) {
        Ok(covariance) => covariance,
        Err(entries) => return retry_without_nonlinear(&all(false)[..cols.len()], residual, entries, own.len()),
    };
    if others.is_empty() {
        return Some(conditional);
    }
    match covariance_of(&all(true), residual, again) {
        Ok(joint) => Some(TermCovariance { displacement: conditional.displacement, ..joint }),
        Err(_) => Some(conditional),
    }
}

/// The coefficients' covariance alone, the non-linear parameters marked unmeasured.
fn retry_without_nonlinear(cols: &[&[f64]], residual: &[f64], entries: Entries, own: usize) -> Option<TermCovariance> {
    if entries.index.len() == own {
        return None;
    }
    let mut unmeasured = entries.unmeasured;
    unmeasured.extend(entries.nonlinear.iter().flatten());
    let only = Entries { index: entries.index[..own].to_vec(), at: entries.at[..own].to_vec(), nonlinear: vec![None; own], unmeasured };
    covariance_of(cols, residual, only).ok()
}

/// Which columns a term's entries are, their values, and which are non-linear parameters.
struct Entries {
    index: Vec<usize>,
    at: Vec<f64>,
    nonlinear: Vec<Option<usize>>,
    unmeasured: Vec<usize>,
}

/// The classical and the block covariance of `entries` in the fit of `cols` that leaves
/// `residual` (see [`term_covariance`]); the entries back when the columns are (near) singular.
fn covariance_of(cols: &[&[f64]], residual: &[f64], entries: Entries) -> Result<TermCovariance, Entries> {
    let (n, k) = (residual.len(), cols.len());
    // Columns scaled to unit norm: a frequency's derivative (Nm per Hz, times seconds) and an
    // offset's column differ by orders of magnitude.
    let scale: Vec<f64> = cols.iter().map(|c| dot(c, c).sqrt()).collect();
    if n <= k + 1 || scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(entries);
    }
    let gram = DMatrix::from_fn(k, k, |a, b| dot(cols[a], cols[b]) / (scale[a] * scale[b]));
    let Some(inverse) = invertible(gram) else { return Err(entries) };
    let variance = ar1_inflated_variance(residual, k);
    let blocks = blocks_for(n);
    let mut meat = DMatrix::<f64>::zeros(k, k);
    for b in 0..blocks {
        let rows = b * n / blocks..(b + 1) * n / blocks;
        let score: Vec<f64> = (0..k).map(|a| rows.clone().map(|r| cols[a][r] * residual[r]).sum::<f64>() / scale[a]).collect();
        for a in 0..k {
            for c in 0..k {
                meat[(a, c)] += score[a] * score[c];
            }
        }
    }
    let sandwich = &inverse * &meat * &inverse * (blocks as f64 / (blocks - 1) as f64);
    let gradient = DVector::from_fn(k, |a, _| dot(cols[a], residual) / scale[a]);
    let step = &inverse * gradient;
    let index = &entries.index;
    let pick = |m: &DMatrix<f64>, f: f64| DMatrix::from_fn(index.len(), index.len(), |a, b| f * m[(index[a], index[b])] / (scale[index[a]] * scale[index[b]]));
    let (classical, blocks) = (pick(&inverse, variance), pick(&sandwich, 1.0));
    let displacement = index.iter().map(|&a| step[a] / scale[a]).collect();
    Ok(TermCovariance { at: entries.at, nonlinear: entries.nonlinear, classical, blocks, displacement, unmeasured: entries.unmeasured })
}

/// The inverse of a Gram matrix of unit-norm columns, or `None` when it is singular or so near
/// it (a condition number above 1e12) that its inverse would be rounding: a band of the input
/// of a loop that the encoder's steps hide moves the torque as the loop's scale does.
fn invertible(gram: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let values = gram.clone().symmetric_eigenvalues();
    let (smallest, largest) = values.iter().fold((f64::INFINITY, 0.0f64), |(s, l), v| (s.min(*v), l.max(*v)));
    if !(smallest > largest * 1e-12) {
        return None;
    }
    gram.try_inverse()
}

/// The model's torque's derivative along term `i`'s parameter `j`, the coefficients held: a
/// forward difference from the fitted torque `fitted`, backward at the top of the parameter's
/// grid.
fn derivative(model: &Model, spec: &Spec, fit: &Fit, train: &Part, fitted: &[f64], i: usize, j: usize) -> Option<Vec<f64>> {
    let x = spec.terms[i].params[j];
    let grid = spec.terms[i].grids.get(j).map(|g| g.grid.as_slice()).unwrap_or(&[]);
    let (lo, hi) = grid.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), g| (lo.min(*g), hi.max(*g)));
    let h = STEP * if x != 0.0 { x.abs() } else if hi > lo { hi - lo } else { 1.0 };
    let h = if x + h > hi && x - h >= lo { -h } else { h };
    // The step as the parameter takes it (x + h rounded), so the difference quotient divides
    // by what was added.
    let h = (x + h) - x;
    let mut s = spec.clone();
    s.terms[i].params[j] = x + h;
    let moved = model.predict(&s, fit, train).torque_nm;
    let column: Vec<f64> = moved.iter().zip(fitted).map(|(u, f)| (u - f) / h).collect();
    column.iter().all(|v| v.is_finite()).then_some(column)
}

/// The standard errors of a cause's reported parameters, by the delta method through
/// `covariance` (see [`term_covariance`]): each reported value's gradient along the term's
/// coefficients and non-linear parameters, taken numerically through the cause's own `report`
/// (a Dahl `sigma = limit / lambda` gets both errors, with their correlation): the larger of
/// the classical and the block error, and the distance the search stopped from the training
/// fit's optimum (the Gauss-Newton step), added in quadrature. A ring's parameters fitted
/// segment by segment have no covariance here: only its non-linear parameters get an error.
pub(crate) fn uncertainty_of(cause: &dyn CandidateCause, params: &[f64], names: &[String], coefs: &[f64], covariance: Option<&TermCovariance>, reported: &BTreeMap<String, f64>) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let Some(cov) = covariance else { return out };
    let own = cov.nonlinear.iter().filter(|j| j.is_none()).count();
    let segment_wise = own == 0 && !coefs.is_empty();
    // The reported values with entry `e` of `at` moved by `d`.
    let moved = |e: usize, d: f64| {
        let (mut c, mut p) = (coefs.to_vec(), params.to_vec());
        match cov.nonlinear[e] {
            None => c[e] += d,
            Some(j) => p[j] += d,
        }
        cause.report(&p, names, &c)
    };
    // Each entry's step and the values reported a step either side.
    type Reported = BTreeMap<String, f64>;
    // The step relative to the entry, or for an entry at zero a thousandth of its own error (an
    // absolute floor vanished in rounding beside terms of order one).
    let steps: Vec<(f64, Reported, Reported)> = (0..cov.at.len())
        .map(|e| {
            let error = cov.classical[(e, e)].max(cov.blocks[(e, e)]).sqrt();
            let h = if cov.at[e] != 0.0 { STEP * cov.at[e].abs() } else { (1e-3 * error).max(f64::MIN_POSITIVE) };
            (h, moved(e, h), moved(e, -h))
        })
        .collect();
    // Values that move with a parameter whose error is not measured.
    let unmeasured: Vec<BTreeMap<String, f64>> = cov
        .unmeasured
        .iter()
        .map(|&j| {
            let mut p = params.to_vec();
            p[j] += STEP * p[j].abs().max(1e-12);
            cause.report(&p, names, coefs)
        })
        .collect();
    for (name, value) in reported {
        if unmeasured.iter().any(|m| m.get(name) != Some(value)) {
            continue;
        }
        let gradient: Option<Vec<f64>> = steps.iter().map(|(h, up, down)| Some((up.get(name)? - down.get(name)?) / (2.0 * h))).collect();
        // A value that moves with none of the entries is not estimated here (a registered
        // cause's nested parameter at its simpler value): no error, rather than zero.
        let Some(g) = gradient.filter(|g| g.iter().any(|v| *v != 0.0)) else { continue };
        // A value that moves with a segment's coefficients has more error than the covariance
        // holds: none claimed.
        let is_nonlinear = names.iter().any(|n| n == name);
        if segment_wise && !is_nonlinear {
            continue;
        }
        let along = |m: &DMatrix<f64>| (0..g.len()).flat_map(|a| (0..g.len()).map(move |b| (a, b))).map(|(a, b)| g[a] * m[(a, b)] * g[b]).sum::<f64>();
        // The search's distance from the optimum adds to the statistical error. The joint
        // Gauss-Newton step moves the coefficients with the non-linear parameters (and a
        // baseline term held at its bound, or a ring's backfit, leaves the residual not quite
        // orthogonal to the columns): a coefficient's share of it is charged too, on purpose.
        let off: f64 = g.iter().zip(&cov.displacement).map(|(a, b)| a * b).sum();
        let variance = along(&cov.classical).max(along(&cov.blocks)) + off * off;
        if variance.is_finite() && variance >= 0.0 {
            out.insert(name.clone(), variance.sqrt());
        }
    }
    out
}

/// Why `cause`'s coefficients in `spec` (fitted on the training part: `full.fit`, whose
/// derivatives are `jacobian`) are not told from zero there, if they are not: their t values
/// (each coefficient over its standard error), squared and summed, stay below [`Z`] squared. For
/// one coefficient that is `|c| < Z se`, the tests' one-sided 0.1 % quantile taken either way
/// (two-sided 0.2 %); for a pair (a vibration's sine and cosine) a length that does not depend
/// on how the pair splits it. The errors are those of the covariance the reported uncertainty
/// comes from (`uncertainty::term_covariance`): joint with the term's non-linear parameters
/// where the fit gives them, the larger of the classical and the block error, or, where the
/// training residual is structure (`significance::is_structured`), the block error alone,
/// without the search's distance from the optimum that the report adds. A cause whose held-out gain is large
/// and consistent but passes no test (the weakest evidence the rule accepts, see
/// `significance`) is held to it, and so is one that asks for it whatever its evidence
/// (`CandidateCause::held_to_its_coefficients`, an offset's drift): a coefficient that moves from one stretch of the training
/// part to the next by more than its size is taking up structure there, not measuring an effect
/// (the finding and the figures: `docs/identify/significance.md`, 2026-11-29). `None` also for
/// a cause without ordinary coefficients (a play, a delay: a
/// transform, nothing to tell from zero), with coefficients fitted on each segment (a ring: its
/// own test), that a friction record reports as part of its friction, or whose covariance the fit
/// cannot give (a singular design: the rule cannot be applied, and the cause stays).
pub(crate) fn untold_from_zero(model: &Model, spec: &Spec, full: &HeldOut, jacobian: &Jacobian, cause: usize, p: &Prepared) -> Option<String> {
    // In a friction record a loop, a dip or a lag is part of the friction, not named (and its
    // level trades off with the baseline's arctan there, which widens its error).
    if is_friction_part(p.spring_share, model.baseline, model.causes[cause]) {
        return None;
    }
    let i = spec.terms.iter().position(|t| t.cause == cause)?;
    let span = full.fit.spans.get(i)?.clone();
    if span.is_empty() || !full.fit.segment_coefs[i].is_empty() {
        return None;
    }
    let covariance = term_covariance(jacobian, spec, &full.fit, i)?;
    // Where the training residual is structure, the classical error's premise (the residual
    // is noise, its correlation AR(1)) fails: a smooth misfit sampled fast reads as a lag-1
    // correlation near 1, clamped at 0.99, a variance inflated 199 times whatever the
    // coefficient does, so the error grows with the sampling rate. What the rule asks, whether
    // the coefficient holds from one stretch of the training part to the next, is the block
    // error's measure, and it alone decides there.
    let mse = dot(&jacobian.residual, &jacobian.residual) / jacobian.residual.len().max(1) as f64;
    let errors = if is_structured(mse, p.noise_floor_nm.powi(2)) { covariance.coefficient_block_errors() } else { covariance.coefficient_errors() };
    let coefs = &full.fit.coefs[span];
    let length: f64 = coefs.iter().zip(&errors).map(|(c, e)| if *e > 0.0 { (c / e).powi(2) } else if *c != 0.0 { f64::INFINITY } else { 0.0 }).sum();
    let names = model.causes[cause].coefficient_names();
    (length < Z * Z).then(|| {
        let each: Vec<String> = coefs.iter().zip(&errors).enumerate().map(|(k, (c, e))| format!("{} = {} +- {}", names.get(k).map_or("coefficient", |n| n.as_str()), format_value(*c), format_value(*e))).collect();
        format!("{} is not told from zero", each.join(", "))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight line `y = 1 + 2 x` with noise of 0.1 on 400 samples: the classical error of the
    /// slope is the textbook `s / sqrt(sum (x - mean)^2)` (no autocorrelation in the noise).
    #[test]
    fn the_classical_error_of_a_line_is_the_textbook_one() {
        let mut rng = jointctl_test_support::XorShift64::new(7);
        let x: Vec<f64> = (0..400).map(|i| i as f64 / 400.0).collect();
        let noise: Vec<f64> = x.iter().map(|_| 0.1 * rng.normal()).collect();
        let y: Vec<f64> = x.iter().zip(&noise).map(|(x, e)| 1.0 + 2.0 * x + e).collect();
        let ones = vec![1.0; x.len()];
        let fitted = super::super::least_squares::least_squares(&[ones.clone(), x.clone()], &y).unwrap();
        let residual: Vec<f64> = (0..x.len()).map(|i| y[i] - fitted[0] - fitted[1] * x[i]).collect();
        let entries = Entries { index: vec![1], at: vec![fitted[1]], nonlinear: vec![None], unmeasured: Vec::new() };
        let Ok(c) = covariance_of(&[&ones, &x], &residual, entries) else { panic!("singular") };
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let s = (dot(&residual, &residual) / (x.len() - 2) as f64).sqrt();
        let rho = (residual.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / dot(&residual, &residual)).clamp(0.0, 0.99);
        let textbook = s / x.iter().map(|v| (v - mean).powi(2)).sum::<f64>().sqrt() * ((1.0 + rho) / (1.0 - rho)).sqrt();
        assert!((c.classical[(0, 0)].sqrt() / textbook - 1.0).abs() < 1e-9, "{} vs {textbook}", c.classical[(0, 0)].sqrt());
        // Fitted at the optimum: no step left.
        assert!(c.displacement[0].abs() < 1e-9 * fitted[1].abs());
    }

    /// A residual that is structure (a term the model misses, of opposite sign in the record's
    /// two halves): the block error of the column it follows is several times the classical one.
    #[test]
    fn a_residual_that_is_structure_widens_the_block_error() {
        let n = 2000;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 / n as f64 * 6.0 * std::f64::consts::TAU).sin()).collect();
        let ones = vec![1.0; n];
        // What a model leaves when it misses a term that moves with x in one half of the record
        // and against it in the other, beside white noise as large (a lag-1 correlation the
        // classical error charges, small).
        let mut rng = jointctl_test_support::XorShift64::new(11);
        let residual: Vec<f64> = (0..n).map(|i| if i < n / 2 { 0.3 } else { -0.3 } * x[i] + 0.3 * rng.normal()).collect();
        let entries = Entries { index: vec![1], at: vec![0.0], nonlinear: vec![None], unmeasured: Vec::new() };
        let Ok(c) = covariance_of(&[&ones, &x], &residual, entries) else { panic!("singular") };
        assert!(c.blocks[(0, 0)].sqrt() > 3.0 * c.classical[(0, 0)].sqrt(), "blocks {} classical {}", c.blocks[(0, 0)].sqrt(), c.classical[(0, 0)].sqrt());
    }

    #[test]
    fn a_nearly_singular_gram_is_refused() {
        let gram = DMatrix::from_row_slice(2, 2, &[1.0, 1.0 - 1e-14, 1.0 - 1e-14, 1.0]);
        assert!(invertible(gram).is_none());
        assert!(invertible(DMatrix::identity(2, 2)).is_some());
    }
}
