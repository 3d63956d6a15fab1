//! The design: a model is the baseline plus a list of terms (a cause and its non-linear
//! parameters); for a part of the data it becomes a fixed torque (a given characteristic),
//! columns fitted by least squares (QR), and segment-wise columns fitted anew on every segment.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};

use super::BaselineModel;
use super::causes::{CandidateCause, Inputs, Samples};

/// Prepared samples of one part of the data (training or held out).
#[derive(Clone, Debug)]
pub(crate) struct Part {
    /// Deflections before this part (a stateful effect carries over).
    pub warm: Vec<f64>,
    pub t: Vec<f64>,
    pub d: Vec<f64>,
    pub v: Vec<f64>,
    pub tau: Vec<f64>,
    pub pivot: Vec<f64>,
    /// Sample period [s].
    pub dt: f64,
}

impl Part {
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// The first `n` samples (a contiguous stretch keeps the full rate at a fraction of the cost).
    pub fn first(&self, n: usize) -> Part {
        let n = n.min(self.len());
        Part { warm: self.warm.clone(), t: self.t[..n].to_vec(), d: self.d[..n].to_vec(), v: self.v[..n].to_vec(), tau: self.tau[..n].to_vec(), pivot: self.pivot[..n].to_vec(), dt: self.dt }
    }

    /// Every `k`-th sample (for searches on long records).
    pub fn every(&self, k: usize) -> Part {
        let k = k.max(1);
        let pick = |v: &Vec<f64>| v.iter().step_by(k).copied().collect();
        Part { warm: pick(&self.warm), t: pick(&self.t), d: pick(&self.d), v: pick(&self.v), tau: pick(&self.tau), pivot: pick(&self.pivot), dt: self.dt * k as f64 }
    }
}

/// One extension of the model: a cause (index into the candidate list) and its parameters.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Term {
    pub cause: usize,
    pub params: Vec<f64>,
    /// The parameters' names, grids and refinement, as the search had them.
    pub grids: Vec<super::causes::Parameter>,
    /// Part of the baseline (the configured model), not a cause found in the data.
    pub baseline: bool,
}

/// A model: the baseline's characteristic plus terms.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Spec {
    pub terms: Vec<Term>,
}

impl Spec {
    pub fn with(&self, term: Term) -> Spec {
        let mut s = self.clone();
        s.terms.push(term);
        s
    }

    pub fn without(&self, cause: usize) -> Spec {
        Spec { terms: self.terms.iter().filter(|t| t.cause != cause).cloned().collect() }
    }

    pub fn term(&self, cause: usize) -> Option<&Term> {
        self.terms.iter().find(|t| t.cause == cause)
    }
}

/// A fitted model on one part.
#[derive(Clone, Debug)]
pub(crate) struct Fit {
    /// Coefficients of the ordinary columns.
    pub coefs: Vec<f64>,
    /// Each term's range in `coefs` (segment-wise terms: empty).
    pub spans: Vec<Range<usize>>,
    /// Each term's segment-wise coefficients, segment after segment (empty for ordinary terms).
    pub segment_coefs: Vec<Vec<f64>>,
    /// Residual sum of squares [Nm^2].
    pub rss: f64,
    /// Parameters estimated (coefficients, segment coefficients, non-linear parameters).
    pub parameters: usize,
}

impl Fit {
    /// The coefficients of term `i` (its segment coefficients for a segment-wise term).
    pub fn of(&self, i: usize) -> &[f64] {
        if self.segment_coefs[i].is_empty() { &self.coefs[self.spans[i].clone()] } else { &self.segment_coefs[i] }
    }
}

/// A fitted model's orthonormal design basis and residual on one part (see [`Model::projector`]).
pub(crate) struct Projector {
    q: DMatrix<f64>,
    residual: Vec<f64>,
    inputs: Inputs,
}

/// Predictions on a part, with the Cp charge of segment-wise coefficients fitted on it.
pub(crate) struct Prediction {
    pub torque_nm: Vec<f64>,
    /// Leverage of the coefficients fitted on this part, per sample (sums to their count).
    pub leverage: Vec<f64>,
}

/// A segment-wise term's columns and the start of each segment.
type Segmented = (Vec<Vec<f64>>, Vec<usize>);

struct Design {
    inputs: Inputs,
    fixed: Vec<f64>,
    cols: Vec<Vec<f64>>,
    spans: Vec<Range<usize>>,
    /// Per term: (columns, segment starts) of a segment-wise term.
    segmented: Vec<Option<Segmented>>,
    nonlinear: usize,
}

pub(crate) struct Model<'a> {
    pub baseline: &'a BaselineModel,
    pub causes: &'a [&'a dyn CandidateCause],
    /// Held-out errors of the models evaluated so far (selection, the final check and the report
    /// ask for the same models again).
    pub held_out: std::sync::Mutex<std::collections::HashMap<SpecKey, std::sync::Arc<super::select::HeldOut>>>,
}

/// A model's identity: its terms and their parameters, bit for bit.
pub(crate) type SpecKey = Vec<(usize, Vec<u64>, bool)>;

impl Spec {
    /// The key of this model in a cache.
    pub fn key(&self) -> SpecKey {
        self.terms.iter().map(|t| (t.cause, t.params.iter().map(|x| x.to_bits()).collect(), t.baseline)).collect()
    }
}

impl Model<'_> {
    fn design(&self, spec: &Spec, p: &Part) -> Design {
        let n = p.len();
        let mut inputs = Inputs { deflection_rad: p.d.clone(), velocity_rad_per_s: p.v.clone(), elastic_rad: p.d.clone(), sample_period_s: p.dt };
        for term in &spec.terms {
            self.causes[term.cause].transform(&term.params, &mut inputs);
        }
        let samples = Samples {
            t_s: &p.t,
            deflection_rad: &inputs.deflection_rad,
            velocity_rad_per_s: &inputs.velocity_rad_per_s,
            elastic_rad: &inputs.elastic_rad,
            pivot_mm: &p.pivot,
            history_rad: &p.warm,
        };
        let mut fixed = vec![0.0; n];
        let mut cols: Vec<Vec<f64>> = Vec::new();
        match self.baseline {
            BaselineModel::Polynomial(order) => {
                for k in 1..=*order {
                    cols.push(inputs.elastic_rad.iter().map(|x| x.powi(k as i32)).collect());
                }
            }
            BaselineModel::Given(f) => {
                for (i, out) in fixed.iter_mut().enumerate() {
                    *out = f(inputs.elastic_rad[i], p.pivot[i]);
                }
            }
        }
        let mut spans = Vec::new();
        let mut segmented = Vec::new();
        let mut nonlinear = 0;
        for term in &spec.terms {
            let cause = self.causes[term.cause];
            nonlinear += term.params.len();
            let c = cause.columns(&term.params, &samples);
            match cause.segments(&term.params, &samples) {
                Some(starts) => {
                    spans.push(cols.len()..cols.len());
                    segmented.push(Some((c, starts)));
                }
                None => {
                    let start = cols.len();
                    cols.extend(c);
                    spans.push(start..cols.len());
                    segmented.push(None);
                }
            }
        }
        Design { inputs, fixed, cols, spans, segmented, nonlinear }
    }

    /// The model fitted on a part, ready to score one more term at the cost of projecting its
    /// columns (Frisch-Waugh-Lovell: adding columns `C` to a least-squares fit lowers its RSS by
    /// what `C`, made orthogonal to the design, explains of the residual). `None` when the
    /// shortcut does not hold: segment-wise terms, or a baseline term held at its bound.
    pub fn projector(&self, spec: &Spec, p: &Part) -> Option<Projector> {
        let d = self.design(spec, p);
        if d.segmented.iter().any(Option::is_some) {
            return None;
        }
        let n = p.len();
        let y: Vec<f64> = (0..n).map(|i| p.tau[i] - d.fixed[i]).collect();
        let coefs = least_squares(&d.cols, &y)?;
        if self.at_bound(spec, &d.spans, &coefs).is_some() {
            return None;
        }
        let residual: Vec<f64> = (0..n).map(|i| y[i] - dot_row(&d.cols, &coefs, i)).collect();
        let live: Vec<&Vec<f64>> = d.cols.iter().filter(|c| c.iter().any(|x| *x != 0.0)).collect();
        let q = if live.is_empty() { DMatrix::zeros(n, 0) } else { DMatrix::from_fn(n, live.len(), |i, j| live[j][i]).qr().q() };
        Some(Projector { q, residual, inputs: d.inputs })
    }

    /// The RSS of the projector's model with `term` added (a term without an input transform).
    pub fn rss_with(&self, proj: &Projector, term: &Term, p: &Part) -> f64 {
        let cause = self.causes[term.cause];
        let samples = Samples {
            t_s: &p.t,
            deflection_rad: &proj.inputs.deflection_rad,
            velocity_rad_per_s: &proj.inputs.velocity_rad_per_s,
            elastic_rad: &proj.inputs.elastic_rad,
            pivot_mm: &p.pivot,
            history_rad: &p.warm,
        };
        let cols = cause.columns(&term.params, &samples);
        let r = &proj.residual;
        if let Some(starts) = cause.segments(&term.params, &samples) {
            // Rings are short and near-orthogonal to the smooth design: fitted on the residual.
            let (fitted, _, _) = fit_segments(&cols, &starts, r, false);
            return r.iter().zip(&fitted).map(|(a, b)| (a - b).powi(2)).sum();
        }
        let orthogonal: Vec<Vec<f64>> = cols
            .iter()
            .map(|c| {
                let cv = DVector::from_column_slice(c);
                let along = &proj.q * proj.q.tr_mul(&cv);
                (cv - along).iter().copied().collect()
            })
            .collect();
        match least_squares(&orthogonal, r) {
            Some(k) => (0..r.len()).map(|i| (r[i] - dot_row(&orthogonal, &k, i)).powi(2)).sum(),
            None => f64::INFINITY,
        }
    }

    /// The columns of a baseline term whose unconstrained fit is physically impossible (negative
    /// friction): the constrained optimum holds it at its bound, zero.
    fn at_bound(&self, spec: &Spec, spans: &[Range<usize>], coefs: &[f64]) -> Option<Range<usize>> {
        spec.terms
            .iter()
            .zip(spans)
            .find(|(term, span)| term.baseline && !span.is_empty() && self.causes[term.cause].impossible(&term.params, &coefs[(*span).clone()]).is_some())
            .map(|(_, span)| span.clone())
    }

    /// Least squares on a part (QR); `None` when the design is singular.
    pub fn fit(&self, spec: &Spec, p: &Part) -> Option<Fit> {
        let d = self.design(spec, p);
        let n = p.len();
        let mut segment_fit = vec![0.0; n];
        let mut segment_coefs: Vec<Vec<f64>> = vec![Vec::new(); spec.terms.len()];
        let has_segments = d.segmented.iter().any(Option::is_some);
        let mut coefs = Vec::new();
        // Backfitting: the ordinary columns on what the rings leave, the rings on what the
        // ordinary columns leave (two rounds; the rings are short and nearly orthogonal to the rest).
        for _ in 0..if has_segments { 2 } else { 1 } {
            let y: Vec<f64> = (0..n).map(|i| p.tau[i] - d.fixed[i] - segment_fit[i]).collect();
            coefs = least_squares(&d.cols, &y)?;
            // A baseline term whose fit is impossible (negative friction) is at its bound: zero.
            if let Some(span) = self.at_bound(spec, &d.spans, &coefs) {
                let keep: Vec<usize> = (0..d.cols.len()).filter(|j| !span.contains(j)).collect();
                let sub: Vec<Vec<f64>> = keep.iter().map(|j| d.cols[*j].clone()).collect();
                let solved = least_squares(&sub, &y)?;
                coefs = vec![0.0; d.cols.len()];
                for (k, j) in keep.iter().enumerate() {
                    coefs[*j] = solved[k];
                }
            }
            if has_segments {
                let r: Vec<f64> = (0..n).map(|i| p.tau[i] - d.fixed[i] - dot_row(&d.cols, &coefs, i)).collect();
                segment_fit = vec![0.0; n];
                for (k, seg) in d.segmented.iter().enumerate() {
                    if let Some((cols, starts)) = seg {
                        let rest: Vec<f64> = r.iter().zip(&segment_fit).map(|(a, b)| a - b).collect();
                        let (fitted, c, _) = fit_segments(cols, starts, &rest, false);
                        segment_fit.iter_mut().zip(&fitted).for_each(|(a, b)| *a += b);
                        segment_coefs[k] = c;
                    }
                }
            }
        }
        let rss = (0..n).map(|i| (p.tau[i] - d.fixed[i] - dot_row(&d.cols, &coefs, i) - segment_fit[i]).powi(2)).sum();
        let parameters = coefs.len() + segment_coefs.iter().map(Vec::len).sum::<usize>() + d.nonlinear;
        Some(Fit { coefs, spans: d.spans, segment_coefs, rss, parameters })
    }

    /// The model's torque on a part with coefficients from another; segment-wise coefficients
    /// are fitted on this part (they cannot carry over), with their leverage for the Cp charge.
    pub fn predict(&self, spec: &Spec, fit: &Fit, p: &Part) -> Prediction {
        let d = self.design(spec, p);
        let n = p.len();
        let mut torque: Vec<f64> = (0..n).map(|i| d.fixed[i] + dot_row(&d.cols, &fit.coefs, i)).collect();
        let mut leverage = vec![0.0; n];
        for (cols, starts) in d.segmented.iter().flatten() {
            let r: Vec<f64> = p.tau.iter().zip(&torque).map(|(y, m)| y - m).collect();
            let (fitted, _, lev) = fit_segments(cols, starts, &r, true);
            torque.iter_mut().zip(&fitted).for_each(|(a, b)| *a += b);
            leverage.iter_mut().zip(&lev).for_each(|(a, b)| *a += b);
        }
        Prediction { torque_nm: torque, leverage }
    }
}

fn dot_row(cols: &[Vec<f64>], coefs: &[f64], i: usize) -> f64 {
    cols.iter().zip(coefs).map(|(c, k)| c[i] * k).sum()
}

/// Least squares by Householder QR on unit-norm columns (their scales differ by orders of
/// magnitude: a cubic in radians next to a constant); `None` when a column is (numerically) a
/// combination of the others. An all-zero column gets a zero coefficient.
pub(crate) fn least_squares(cols: &[Vec<f64>], y: &[f64]) -> Option<Vec<f64>> {
    let n = y.len();
    let scale: Vec<f64> = cols.iter().map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt()).collect();
    let live: Vec<usize> = (0..cols.len()).filter(|j| scale[*j] > 0.0 && scale[*j].is_finite()).collect();
    let mut out = vec![0.0; cols.len()];
    if live.is_empty() {
        return Some(out);
    }
    if n < live.len() {
        return None;
    }
    let a = DMatrix::from_fn(n, live.len(), |i, j| cols[live[j]][i] / scale[live[j]]);
    let qr = a.qr();
    let mut b = DVector::from_column_slice(y);
    qr.q_tr_mul(&mut b);
    let r = qr.r();
    let biggest = (0..live.len()).map(|j| r[(j, j)].abs()).fold(0.0, f64::max);
    if (0..live.len()).any(|j| r[(j, j)].abs() <= 1e-10 * biggest) {
        return None;
    }
    let x = r.solve_upper_triangular(&b.rows(0, live.len()).into_owned())?;
    for (k, j) in live.iter().enumerate() {
        out[*j] = x[k] / scale[*j];
    }
    out.iter().all(|c| c.is_finite()).then_some(out)
}

/// Fits `cols` to `r` anew on every segment: the fitted values, every segment's coefficients
/// (segment after segment) and, when asked, each sample's leverage. Normal equations per segment are fine
/// here: a segment's two ring columns are near-orthogonal (sine and cosine under one envelope).
fn fit_segments(cols: &[Vec<f64>], starts: &[usize], r: &[f64], want_leverage: bool) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = r.len();
    let k = cols.len();
    let mut fitted = vec![0.0; n];
    let mut leverage = vec![0.0; n];
    let mut coefs = Vec::with_capacity(starts.len() * k);
    let mut gram = DMatrix::<f64>::zeros(k, k);
    let mut rhs = DVector::<f64>::zeros(k);
    let mut x = DVector::<f64>::zeros(k);
    for (s, &a) in starts.iter().enumerate() {
        let b = starts.get(s + 1).copied().unwrap_or(n).min(n);
        gram.fill(0.0);
        rhs.fill(0.0);
        for i in a..b.max(a) {
            for p in 0..k {
                rhs[p] += cols[p][i] * r[i];
                for q in 0..=p {
                    gram[(p, q)] += cols[p][i] * cols[q][i];
                }
            }
        }
        for p in 0..k {
            for q in 0..p {
                gram[(q, p)] = gram[(p, q)];
            }
        }
        let Some(chol) = (a < b).then(|| gram.clone().cholesky()).flatten() else {
            coefs.extend(std::iter::repeat_n(0.0, k));
            continue;
        };
        let c = chol.solve(&rhs);
        let inv = if want_leverage { chol.inverse() } else { DMatrix::zeros(k, k) };
        for i in a..b {
            for p in 0..k {
                x[p] = cols[p][i];
            }
            fitted[i] = x.dot(&c);
            if want_leverage {
                leverage[i] = (&inv * &x).dot(&x);
            }
        }
        coefs.extend(c.iter());
    }
    (fitted, coefs, leverage)
}
