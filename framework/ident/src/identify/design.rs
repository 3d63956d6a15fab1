//! The design: a model is the baseline plus a list of terms (a cause and its non-linear
//! parameters); for a part of the data it becomes a fixed torque (a given characteristic),
//! columns fitted by least squares (QR), and segment-wise columns fitted anew on every segment.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};

use super::least_squares::{ar1_inflated_variance, dot, dot_row, fit_segments, least_squares};
use super::numeric::{LagStart, lagged};

use super::baseline::BaselineModel;
use super::causes::{CandidateCause, Inputs, Samples};
pub(crate) use super::part::Part;

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

    /// `cause`'s searched parameters, empty without its term.
    pub fn params_of(&self, cause: usize) -> Vec<f64> {
        self.term(cause).map(|t| t.params.clone()).unwrap_or_default()
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

/// A model's errors on the held-out part.
pub(crate) struct HeldOut {
    /// Squared error per sample, with the Cp charge of coefficients fitted on the held-out part
    /// itself (segment-wise terms) [Nm^2].
    pub errors: Vec<f64>,
    /// Residual per sample, measured less predicted [Nm].
    pub residual_nm: Vec<f64>,
    /// Residual sum of squares without the charge [Nm^2].
    pub rss: f64,
    /// Coefficients fitted on the held-out part.
    pub fitted_here: usize,
    /// The model fitted on the training part.
    pub fit: Fit,
}

/// A fitted model's orthonormal design basis and residual on one part (see [`Model::projector`]).
pub(crate) struct Projector {
    q: DMatrix<f64>,
    residual: Vec<f64>,
    inputs: Inputs,
    history_rad: Option<Vec<f64>>,
    /// The given characteristic's torque on the inputs (zeros for a fitted baseline).
    model_nm: Vec<f64>,
    /// The part and the input transforms of the model it was fitted for, as in [`ColumnKey`]:
    /// a term's columns scored against it are the design's own, and shared with its cache.
    part: [u64; 5],
    transforms: SpecKey,
    /// The model's output lag: a term scored against it is seen through it too.
    lag: Option<OutputLag>,
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
    /// A stateful cause's history when the transforms changed it (else the part's `warm`).
    history_rad: Option<Vec<f64>>,
    fixed: Vec<f64>,
    cols: Vec<Vec<f64>>,
    spans: Vec<Range<usize>>,
    /// Per term: (columns, segment starts) of a segment-wise term.
    segmented: Vec<Option<Segmented>>,
    nonlinear: usize,
    /// The lag the torque reaches the log through (see [`CandidateCause::output_lag_s`]).
    lag: Option<OutputLag>,
    /// Behind a lag, the given characteristic's torque before it (what causes read); `fixed`
    /// is lagged.
    model_nm: Option<Vec<f64>>,
}

/// The longest step of a log, in the lag's time constants, that a lag runs on through (see
/// [`OutputLag::of`]). Assumption: five, after which the lag keeps `exp(-5)`, under 1 %, of
/// where it was, and starting it again settled on the input's line is as good.
const LAG_BRIDGED_TIME_CONSTANTS: f64 = 5.0;

/// A first-order lag on a part's columns (see [`CandidateCause::output_lag_s`]).
#[derive(Clone, Copy)]
struct OutputLag {
    tau_s: f64,
    /// Steps wider than this [s] start the lag again (gaps, joins of parts).
    max_step_s: f64,
}

impl OutputLag {
    /// The last lag of `spec`'s terms on `p`, if any. A step of the log up to
    /// [`LAG_BRIDGED_TIME_CONSTANTS`] time constants long (or ten sample periods) is bridged on
    /// the input's line: the sensor's filter runs on through a gap in the log, and started again
    /// at every gap of an irregular log (115 gaps over 12.8 ms in 32 s on the blind generator's
    /// seed 47, device D, behind a 22 ms lag) it read that lag 18 ms, 26 ms on the same
    /// device's regular logs.
    fn of(model: &Model, spec: &Spec, p: &Part) -> Option<OutputLag> {
        let tau_s = spec.terms.iter().rev().find_map(|t| model.causes[t.cause].output_lag_s(&t.params))?;
        Some(OutputLag { tau_s, max_step_s: (10.0 * p.dt).max(LAG_BRIDGED_TIME_CONSTANTS * tau_s) })
    }

    /// `column` on part `p` through the lag, started again where a piece of the part does not
    /// follow on (`Part::restarts`), settled on the column's line there.
    fn apply(&self, p: &Part, column: &mut Vec<f64>) {
        let starts: Vec<usize> = p.restarts.iter().map(|r| r.at).collect();
        *column = lagged(&p.t, column, self.tau_s, self.max_step_s, &starts, LagStart::Settled);
    }

    /// A segment-wise column through the lag, each segment on its own from zero (a ring is zero
    /// before the reversal that starts it, and its coefficients are the segment's own).
    fn apply_segments(&self, p: &Part, column: &mut Vec<f64>, segments: &[usize]) {
        let mut starts: Vec<usize> = p.restarts.iter().map(|r| r.at).chain(segments.iter().copied()).collect();
        starts.sort_unstable();
        *column = lagged(&p.t, column, self.tau_s, self.max_step_s, &starts, LagStart::Zero);
    }
}

pub(crate) struct Model<'a> {
    pub baseline: &'a BaselineModel,
    /// The deflection the baseline's polynomial and the causes' elastic deflection are taken
    /// about [rad]: zero for a spring (no torque at zero deflection, the thesis' fits); for a
    /// record read as a joint's friction, whose first column is a joint position with an
    /// arbitrary zero, the training part's mean position, so that a constant torque is a sensor
    /// offset's and not the polynomial's linear term, or a cubic's, times the distance of the
    /// motion from that zero.
    pub centre_rad: f64,
    /// The middle of the record's time span [s] (see [`Samples::record_middle_s`]).
    pub middle_s: f64,
    /// Read as a joint's friction (see [`CandidateCause::searched_within_bounds`]).
    pub friction_record: bool,
    pub causes: &'a [&'a dyn CandidateCause],
    /// Held-out errors of the models evaluated so far (selection, the final check and the report
    /// ask for the same models again).
    pub held_out: std::sync::Mutex<std::collections::HashMap<SpecKey, std::sync::Arc<HeldOut>>>,
    /// Columns of terms computed so far (see [`ColumnCache`]).
    pub columns: ColumnCache,
}

/// Which columns: the part (its length, first and last time stamp, sample period, whether it is
/// read as bin averages), the input transforms in force whose changes the term reads (terms that
/// shift or clip the deflection; see [`super::causes::InputSet`]) and the term, bit for bit.
type ColumnKey = ([u64; 5], SpecKey, (usize, Vec<u64>));

/// The columns of terms already computed, kept up to [`ColumnCache::BUDGET_BYTES`] (least
/// recently used go first). Every model of a search repeats the baseline's friction and the
/// causes already chosen (arctan and Dahl columns: a fifth of identify's time before the cache).
#[derive(Default)]
pub(crate) struct ColumnCache {
    entries: std::sync::Mutex<ColumnEntries>,
}

/// A term's columns, shared between the models that use them.
type Columns = std::sync::Arc<Vec<Vec<f64>>>;

#[derive(Default)]
struct ColumnEntries {
    /// Columns and when they were last used (the cache's clock).
    map: std::collections::HashMap<ColumnKey, (Columns, u64)>,
    bytes: usize,
    clock: u64,
}

impl ColumnCache {
    /// Assumption: 16 MiB, ten columns of a training part of 200 000 samples (the fits take at
    /// most 50 000); enough for the baseline and the chosen causes of a search, small beside the
    /// data of a long record.
    const BUDGET_BYTES: usize = 16 << 20;

    fn get_or(&self, key: ColumnKey, compute: impl FnOnce() -> Vec<Vec<f64>>) -> Columns {
        let lock = || self.entries.lock().unwrap_or_else(|e| e.into_inner());
        {
            let mut e = lock();
            e.clock += 1;
            let now = e.clock;
            if let Some((cols, used)) = e.map.get_mut(&key) {
                *used = now;
                return cols.clone();
            }
        }
        let cols = std::sync::Arc::new(compute());
        let size: usize = cols.iter().map(|c| c.len() * 8).sum();
        if size > Self::BUDGET_BYTES {
            return cols;
        }
        let mut e = lock();
        while e.bytes + size > Self::BUDGET_BYTES {
            let Some(oldest) = e.map.iter().min_by_key(|(_, (_, used))| *used).map(|(k, _)| k.clone()) else { break };
            if let Some((gone, _)) = e.map.remove(&oldest) {
                e.bytes -= gone.iter().map(|c| c.len() * 8).sum::<usize>();
            }
        }
        e.bytes += size;
        let now = e.clock;
        // Two threads that missed the same key both computed it: the second replaces the first,
        // whose bytes leave the count with it.
        if let Some((before, _)) = e.map.insert(key, (cols.clone(), now)) {
            e.bytes -= before.iter().map(|c| c.len() * 8).sum::<usize>();
        }
        cols
    }
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
    /// The part's and the model's input transforms' share of a [`ColumnKey`] (every transform:
    /// [`Model::seen_by`] keeps a term's own).
    fn column_key(&self, spec: &Spec, p: &Part) -> ([u64; 5], SpecKey) {
        // A part read as bin averages has other columns than the same part read as points.
        let part = [p.len() as u64, p.t.first().map_or(0, |t| t.to_bits()), p.t.last().map_or(0, |t| t.to_bits()), p.dt.to_bits(), p.rate_edges.len() as u64];
        (part, Spec { terms: spec.terms.iter().filter(|t| self.causes[t.cause].transforms()).cloned().collect() }.key())
    }

    /// The transforms (in order) whose changes reach what `cause` reads: from the last back, a
    /// transform that writes an input still needed is kept, and what it reads is needed too.
    fn seen_by(&self, transforms: &SpecKey, cause: usize) -> SpecKey {
        let mut needed = self.causes[cause].reads();
        let mut kept: SpecKey = Vec::new();
        for t in transforms.iter().rev() {
            let transform = self.causes[t.0];
            if transform.writes().meets(needed) {
                needed = needed.union(transform.reads());
                kept.push(t.clone());
            }
        }
        kept.reverse();
        kept
    }

    fn design(&self, spec: &Spec, p: &Part) -> Design {
        let n = p.len();
        // The transforms read the part's history first (see `Lead`), and the part's own samples
        // are kept. The history's deflections are `warm`; `Lead` holds their times and rates (a
        // part without them is read alone).
        let ahead = if p.lead.t.len() == p.warm.len() && p.lead.v.len() == p.warm.len() { p.warm.len() } else { 0 };
        let with_lead = |lead: &[f64], own: &[f64]| -> Vec<f64> { lead.iter().chain(own).copied().collect() };
        let deflection_rad = with_lead(&p.warm[..ahead], &p.d);
        // The elastic deflection about the centre, for the baseline and every cause that reads
        // it alike: a cubic of a friction record's position about that position's arbitrary zero
        // took a constant torque as its own (see `centre_rad`).
        let elastic_rad = deflection_rad.iter().map(|x| x - self.centre_rad).collect();
        let mut inputs = Inputs { t_s: with_lead(&p.lead.t[..ahead], &p.t), deflection_rad, velocity_rad_per_s: with_lead(&p.lead.v[..ahead], &p.v), elastic_rad, sample_period_s: p.dt };
        for term in &spec.terms {
            self.causes[term.cause].transform(&term.params, &mut inputs);
        }
        // A stateful cause's history runs into the part as its inputs do: taken as transformed.
        // Raw, a delayed part replayed the delay's last stretch after its history, a reversal the
        // joint never made: a Dahl state off at each part's start (a Bouc-Wen loop behind a 90 ms
        // delay, blind seed 41's 097: both refused once the history was read, the held-out error
        // 0.055 -> 0.092 Nm). `None` where the transforms left it as it was.
        let history_rad = (ahead > 0 && inputs.deflection_rad[..ahead] != p.warm[..]).then(|| inputs.deflection_rad[..ahead].to_vec());
        if ahead > 0 {
            for x in [&mut inputs.t_s, &mut inputs.deflection_rad, &mut inputs.velocity_rad_per_s, &mut inputs.elastic_rad] {
                x.drain(..ahead.min(x.len()));
            }
        }
        let mut fixed = vec![0.0; n];
        let mut cols: Vec<Vec<f64>> = Vec::new();
        match self.baseline {
            BaselineModel::Polynomial(order) => {
                // Each power from the one before (a power by a run-time exponent is a call a sample).
                for k in 1..=*order {
                    let next = match cols.last() {
                        Some(below) if k > 1 => below.iter().zip(&inputs.elastic_rad).map(|(b, x)| b * x).collect(),
                        _ => inputs.elastic_rad.clone(),
                    };
                    cols.push(next);
                }
            }
            BaselineModel::Given(f) => {
                for (i, out) in fixed.iter_mut().enumerate() {
                    *out = f(inputs.elastic_rad[i], p.pivot[i]);
                }
            }
        }
        let samples = Samples {
            t_s: &p.t,
            deflection_rad: &inputs.deflection_rad,
            velocity_rad_per_s: &inputs.velocity_rad_per_s,
            elastic_rad: &inputs.elastic_rad,
            pivot_mm: &p.pivot,
            repetition: &p.rep,
            history_rad: history_rad.as_deref().unwrap_or(&p.warm),
            restarts: &p.restarts,
            model_nm: &fixed,
            rate_edges_rad_per_s: &p.rate_edges,
            bin_width_s: p.bin_width_s,
            record_middle_s: self.middle_s,
        };
        let mut spans = Vec::new();
        let mut segmented = Vec::new();
        let mut nonlinear = 0;
        let (part, transforms) = self.column_key(spec, p);
        for term in &spec.terms {
            let cause = self.causes[term.cause];
            // A nested parameter left at its simpler value (a dead band of zero width) is no
            // freedom used: not charged.
            nonlinear += term.params.iter().enumerate().filter(|(j, x)| !term.grids.get(*j).is_some_and(|g| g.refine.is_nested() && g.grid.first() == Some(*x))).count();
            let key = (part, self.seen_by(&transforms, term.cause), (term.cause, term.params.iter().map(|x| x.to_bits()).collect()));
            let c = (*self.columns.get_or(key, || cause.columns(&term.params, &samples))).clone();
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
        // Behind a sensor's lag every modelled torque is seen lagged, the given characteristic's
        // too: the model is linear in its coefficients, so lagging the columns lags the torque.
        // What the causes read as the given characteristic's torque stays unlagged.
        let lag = OutputLag::of(self, spec, p);
        let model_nm = lag.map(|_| fixed.clone());
        if let Some(lag) = lag {
            for c in cols.iter_mut().chain(std::iter::once(&mut fixed)) {
                lag.apply(p, c);
            }
            for (c, starts) in segmented.iter_mut().flatten() {
                c.iter_mut().for_each(|c| lag.apply_segments(p, c, starts));
            }
        }
        Design { inputs, history_rad, fixed, model_nm, cols, spans, segmented, nonlinear, lag }
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
        let (part, transforms) = self.column_key(spec, p);
        Some(Projector { q, residual, inputs: d.inputs, history_rad: d.history_rad, model_nm: d.model_nm.unwrap_or(d.fixed), part, transforms, lag: d.lag })
    }

    /// The RSS of the projector's model with `term` added (a term without an input transform),
    /// and the term's coefficients: those of the whole model's fit (Frisch-Waugh-Lovell).
    pub fn fit_with(&self, proj: &Projector, term: &Term, p: &Part) -> (f64, Vec<f64>) {
        let cause = self.causes[term.cause];
        let samples = Samples {
            t_s: &p.t,
            deflection_rad: &proj.inputs.deflection_rad,
            velocity_rad_per_s: &proj.inputs.velocity_rad_per_s,
            elastic_rad: &proj.inputs.elastic_rad,
            pivot_mm: &p.pivot,
            repetition: &p.rep,
            history_rad: proj.history_rad.as_deref().unwrap_or(&p.warm),
            restarts: &p.restarts,
            model_nm: &proj.model_nm,
            rate_edges_rad_per_s: &p.rate_edges,
            bin_width_s: p.bin_width_s,
            record_middle_s: self.middle_s,
        };
        // The term leaves the inputs alone (see `search`), so its columns are those a design
        // with it would compute: from the cache, and into it (a profile scores the baseline
        // friction's grid again for every candidate).
        let key = (proj.part, self.seen_by(&proj.transforms, term.cause), (term.cause, term.params.iter().map(|x| x.to_bits()).collect()));
        let mut cols = self.columns.get_or(key, || cause.columns(&term.params, &samples));
        if let Some(lag) = proj.lag {
            let mut lagged = (*cols).clone();
            match cause.segments(&term.params, &samples) {
                Some(starts) => lagged.iter_mut().for_each(|c| lag.apply_segments(p, c, &starts)),
                None => lagged.iter_mut().for_each(|c| lag.apply(p, c)),
            }
            cols = lagged.into();
        }
        let r = &proj.residual;
        if let Some(starts) = cause.segments(&term.params, &samples) {
            // Rings are short and near-orthogonal to the smooth design: fitted on the residual.
            let (fitted, coefs, _) = fit_segments(&cols, &starts, r, false);
            return (r.iter().zip(&fitted).map(|(a, b)| (a - b).powi(2)).sum(), coefs);
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
            Some(k) => ((0..r.len()).map(|i| (r[i] - dot_row(&orthogonal, &k, i)).powi(2)).sum(), k),
            None => (f64::INFINITY, Vec::new()),
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

    /// Standard errors of the ordinary coefficients of `fit` (`spec` fitted on `p`), in the order
    /// of `fit.coefs`: `sqrt(s^2 (X'X)^-1)` with the residual variance `s^2` inflated for the
    /// residual's lag-1 autocorrelation `rho` by `(1 + rho) / (1 - rho)` (the AR(1) variance
    /// factor of a mean; an assumption where the residual is structure, not noise: it then
    /// widens the errors, as it should). `None` when the design is singular.
    pub fn standard_errors(&self, spec: &Spec, fit: &Fit, p: &Part) -> Option<Vec<f64>> {
        let d = self.design(spec, p);
        let (n, k) = (p.len(), d.cols.len());
        if k == 0 || n <= k {
            return Some(vec![0.0; k]);
        }
        let residual: Vec<f64> = (0..n).map(|i| p.tau[i] - d.fixed[i] - dot_row(&d.cols, &fit.coefs, i)).collect();
        let variance = ar1_inflated_variance(&residual, k);
        let scale: Vec<f64> = d.cols.iter().map(|c| dot(c, c).sqrt().max(1e-300)).collect();
        let gram = DMatrix::from_fn(k, k, |a, b| dot(&d.cols[a], &d.cols[b]) / (scale[a] * scale[b]));
        let inverse = gram.try_inverse()?;
        Some((0..k).map(|j| (variance * inverse[(j, j)].max(0.0)).sqrt() / scale[j]).collect())
    }

    /// The ordinary columns of `spec` on `p` (in the order of `fit.coefs`), the torque `fit`
    /// predicts there and what it leaves of the measured torque [Nm], the segment-wise terms'
    /// fits taken off: what a parameter's covariance is computed from (see
    /// `uncertainty::term_covariance`).
    pub fn columns_and_residual(&self, spec: &Spec, fit: &Fit, p: &Part) -> (Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
        let predicted = self.predict(spec, fit, p).torque_nm;
        let residual = p.tau.iter().zip(&predicted).map(|(y, m)| y - m).collect();
        (self.design(spec, p).cols, predicted, residual)
    }

    /// The RMS on `p` of the torque term `i` of `spec` predicts with `fit`'s coefficients [Nm]
    /// (its ordinary columns only; a segment-wise term has none). One design, no prediction:
    /// asked inside the selection, where a second design per proposal raised identify's peak.
    pub fn term_rms_nm(&self, spec: &Spec, fit: &Fit, i: usize, p: &Part) -> f64 {
        let d = self.design(spec, p);
        let span = d.spans[i].clone();
        let n = p.len();
        let sum: f64 = (0..n).map(|row| span.clone().map(|j| d.cols[j][row] * fit.coefs[j]).sum::<f64>().powi(2)).sum();
        (sum / n.max(1) as f64).sqrt()
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

#[cfg(test)]
mod tests;
