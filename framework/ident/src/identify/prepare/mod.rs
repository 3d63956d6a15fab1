//! Preparation: dropouts out, the deflection rate, enough excitation, and the split into the
//! training part and the held-out part.

mod bins;
mod bursts;
mod crossings;
mod cubic_rate;
mod dropouts;
mod glitches;
mod lattice;
mod saturation;
mod spring;
mod sign;
mod noise;
mod pauses;
mod pieces;
mod read;
mod rate;
mod rest;
mod turns;
mod window;

pub use noise::noise_floor;
pub use pauses::{AfterPauses, before_the_next_turn, unseen_paths};
pub use rest::{AtRest, REST_S};
pub(crate) use rest::{interval_of, scored_on_every_sample};
pub use window::{HeldOut, HeldOutWindow, REACH_TOLERANCE, held_out_window};
pub use glitches::MAX_GLITCH_SAMPLES;
pub(crate) use spring::spring_share;
pub use crossings::{REST_SHARE, STAIRCASE_HELD_SHARE};
pub use bins::{BIN_READING_MIN_STEP_S, rate_edges, tried_as_bins};
pub use rate::{NARROWEST_RATE_WINDOW, SHARPER_REACH_SCALES, VELOCITY_WINDOWS_PER_PERIOD, WIDER_WINDOWS_PER_PERIOD, WIDEST_RATE_REACH_S, widest_rate_window};
pub(crate) use read::{Read, ReadAhead};

use super::causes::Excitation;
use super::design::Part;

/// One count of the SHERPA joints' 14-bit absolute encoders [rad] (thesis section 3.1): the
/// coarsest resolution assumed when the data's own steps cannot tell (see [`resolution_rad`]).
pub const ENCODER_LSB_RAD: f64 = std::f64::consts::TAU / 16384.0;

/// A gap in the time stamps longer than this many median steps splits the record into segments
/// (an assumption: a logger's jitter stays within a few steps; real irregular logs have a 99th
/// percentile of 5-8 median steps, and a segment boundary only restarts the rate estimate).
pub const GAP_STEPS: f64 = 10.0;

/// The deflection's resolution [rad], from the data's own steps: the smallest step that is
/// common (the 2nd percentile of the non-zero changes between samples), at most one count of the
/// 14-bit encoder. A 14-bit encoder gives its count, a 17-bit or a 2e-6 rad linear encoder
/// theirs, bin-averaged or unquantised data a step far below any count.
///
/// ```
/// use jointctl_ident::identify::prepare::resolution_rad;
/// let d: Vec<f64> = (0..2000).map(|i| ((i as f64 * 0.01).sin() * 2000.0).round() * 2e-6).collect();
/// assert!((resolution_rad(&d) - 2e-6).abs() < 1e-9);
/// ```
pub fn resolution_rad(deflection_rad: &[f64]) -> f64 {
    let mut steps: Vec<f64> = deflection_rad.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|s| *s > 1e-15).collect();
    if steps.is_empty() {
        return ENCODER_LSB_RAD;
    }
    let at = steps.len() / 50;
    let step = *steps.select_nth_unstable_by(at, f64::total_cmp).1;
    step.min(ENCODER_LSB_RAD)
}

/// Where each segment of contiguous logging starts: at 0 and after every gap longer than
/// [`GAP_STEPS`] median steps (a logger's pause, a repetition's restart). Rates are never
/// differenced across a gap.
///
/// ```
/// let t = [0.0, 0.001, 0.002, 0.5, 0.501, 0.502];
/// assert_eq!(jointctl_ident::identify::prepare::segment_starts(&t), vec![0, 3]);
/// ```
pub fn segment_starts(t_s: &[f64]) -> Vec<usize> {
    let mut steps: Vec<f64> = t_s.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return vec![0];
    }
    let mid = steps.len() / 2;
    let median = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
    std::iter::once(0).chain((1..t_s.len()).filter(|i| t_s[*i] - t_s[i - 1] > GAP_STEPS * median)).collect()
}

/// Quantisation levels a deflection must span for a curve's shape to be told from its
/// quantisation (an assumption: 16 levels resolve a cubic's bend to a few percent).
pub const MIN_SPAN_LSB: f64 = 16.0;

/// Velocity reversals needed: one, a motion out and back, so that the record holds both
/// directions (the training part may hold one only: a step-and-hold test's return may lie in
/// the held-out part, where a cause fitted without it is still judged). Three were asked for (a
/// cycle and a half) until such records of an independent generator (out, a long hold, back)
/// were refused with their offset, cubic or hysteresis unnamed; now the held-out test names what
/// the data shows, and nothing on the clean ones (blind seeds 1-4: one record named more, six
/// no longer refused, no clean record with a cause).
pub const MIN_REVERSALS: usize = 1;

/// Why the data cannot be identified.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PrepareError {
    /// Too many samples at the torque sensor's limit: too few left.
    #[error("the torque sits at its sensor's limit in {saturated} of {samples} samples (a sensor past its range): {left} left, too few to identify anything (at least {needed})")]
    Saturated {
        /// Samples at the limit.
        saturated: usize,
        /// Samples read.
        samples: usize,
        /// Samples left.
        left: usize,
        /// Samples needed.
        needed: usize,
    },
    /// Too few samples to identify anything.
    #[error("{samples} samples are too few to identify anything (at least {needed})")]
    TooFewSamples {
        /// Samples given.
        samples: usize,
        /// Samples needed.
        needed: usize,
    },
    /// The deflection hardly moves: nothing can be told from its quantisation.
    #[error(
        "too little excitation: the deflection spans {span_rad:.3e} rad ({lsb:.1} counts of the encoder's resolution, as its steps in the data show) with {reversals} reversals; identification needs at least {MIN_SPAN_LSB} counts and {MIN_REVERSALS} reversal (a motion of a few times the play, out and back)"
    )]
    TooLittleExcitation {
        /// Range of the deflection [rad].
        span_rad: f64,
        /// The range in counts of the encoder's resolution, as estimated from the data.
        lsb: f64,
        /// Velocity reversals found.
        reversals: usize,
    },
    /// The torque never changes: there is nothing to explain (a sensor that was not connected or
    /// not logged).
    #[error("the torque is {value_nm} Nm in every sample: nothing to identify (was the torque sensor connected and logged?)")]
    ConstantTorque {
        /// The one value [Nm].
        value_nm: f64,
    },
    /// A column's length is neither the samples' nor (an optional column) zero.
    #[error("column `{column}` has {len} values for {samples} samples")]
    UnevenColumn {
        /// The column.
        column: &'static str,
        /// Its length.
        len: usize,
        /// Samples (the time column's length).
        samples: usize,
    },
    /// One side of the split has too few samples.
    #[error("too few samples on one side of the {train_percent:.0}/{:.0} fit/held-out split ({train} and {held_out})", 100.0 - train_percent)]
    UnevenSplit {
        /// Fraction for fitting [%].
        train_percent: f64,
        /// Samples for fitting.
        train: usize,
        /// Samples held out.
        held_out: usize,
    },
}

/// The data ready for the search.
#[derive(Clone)]
pub(crate) struct Prepared {
    /// The middle of the record's time span [s] from its first sample (the dropouts left out),
    /// set once for the record: every reading of it and every part agrees (see
    /// [`super::Samples::record_middle_s`]).
    pub record_middle_s: f64,
    pub train: Part,
    pub test: Part,
    /// The training part, decimated to at most [`SEARCH_SAMPLES`] samples in pieces spread over
    /// it (see [`pieces::spread`]), for grid searches.
    pub coarse: Part,
    /// The first [`STRETCH_SAMPLES`] of the training part at the full rate: the searches that
    /// need it (a delay's samples, a mode above the decimated part's Nyquist frequency).
    pub stretch: Part,
    /// Whether `train` holds every training sample (at most [`FIT_SAMPLES`] of them).
    pub train_at_full_rate: bool,
    pub excitation: Excitation,
    pub samples: usize,
    /// Samples left out as dropouts (see `dropouts`).
    pub dropped: usize,
    /// Deflection readings left out as glitches, not already dropouts (see `glitches`).
    pub glitches: usize,
    /// Samples left out at the torque sensor's limit, not already dropouts (see `saturation`).
    pub saturated: usize,
    /// Samples left out after pauses, up to the motion's next turn (see `pauses`).
    pub after_pauses: AfterPauses,
    /// A torque that falls as the deflection rises, said (see `sign`).
    pub reversed_sign: Option<String>,
    /// The deflection's resolution estimated from the data [rad].
    pub resolution_rad: f64,
    /// Segments of contiguous logging in the whole (kept) record.
    pub segments: usize,
    /// The first time stamp of the record [s]: times inside are counted from it (Unix-epoch time
    /// stamps keep their precision so).
    pub t0: f64,
    /// The torque's noise floor [Nm] (see [`noise_floor`]), on what a line in the deflection,
    /// its rate and an offset leave of the torque (the spring's own curvature out of it).
    pub noise_floor_nm: f64,
    /// The share of the training part's torque variance a line in the deflection explains, of
    /// the whole or beside the friction (see [`spring_share`]).
    pub spring_share: f64,
    /// The part of the time range held out.
    pub held_out: HeldOutWindow,
    /// The time the training part spans [s] (without the held-out window inside it).
    pub train_duration_s: f64,
    /// Where the joint is at rest, `(start, end)` [s] from `t0` (see `rest`); left out of a
    /// friction record's fit and judgement.
    pub stops: Vec<(f64, f64)>,
    /// The training part's samples inside those stops at the full rate, the longest runs first,
    /// at most [`REST_SAMPLES`]; `None` without a stop on the training part.
    pub at_rest: Option<Part>,
    /// Where the reading stays on the count at which the motion turned, `(start, end)` [s] from
    /// `t0` (see `turns`); left out of a friction record's fit and judgement as well.
    pub turns: Vec<(f64, f64)>,
}

impl Prepared {
    /// The full-rate training samples a parameter that needs the full rate is chosen on (a
    /// dead band against an encoder's flicker, see [`super::Refine::Nested`]): the whole
    /// training part when it is kept at the full rate (its two sides of the held-out window
    /// joined, a loop's state started again after the join), the contiguous stretch otherwise. The
    /// stretch alone is one piece of [`STRETCH_SAMPLES`]: on a record that holds in that piece
    /// and flickers while it moves later (the blind generator's 2e-6 rad encoder, seed 1's
    /// 013), a band chosen there was none, and the Dahl loop driven by the flicker left 0.30 Nm
    /// held out for 0.155 with the band (its noise).
    pub fn full_rate_training(&self) -> &Part {
        if self.train_at_full_rate { &self.train } else { &self.stretch }
    }
}

/// Grid searches run on at most this many samples, decimated to no fewer than 100 a cycle of
/// the excitation (an assumption, checked by the hidden-effect suite: its 60 s records search on
/// 4200 samples, every second one, and meet its targets; its 500 s records search on 5000, every
/// fifth to every fourteenth, and meet them too. At 4000 the 60 s records search on 2800 and
/// 69 of 71 cases are named instead of 71).
pub const SEARCH_SAMPLES: usize = 5000;

/// Contiguous full-rate training samples for the searches that need the full rate: a delay's
/// every sample, a mode's frequency above the decimated part's Nyquist frequency (an
/// assumption: 80 s at 200 Hz, 16 cycles of a 0.2 Hz excitation).
pub const STRETCH_SAMPLES: usize = 16_000;

/// Full-rate training samples at rest kept for the scan of a line there (an assumption: 8 s
/// of a 1 kHz log's holds resolve a line to 0.13 Hz, and a search step's residual on them
/// costs about what its residual on the searches' part does).
pub const REST_SAMPLES: usize = 8_192;

/// Fits run on at most this many training samples, taken evenly over the training part (an assumption: 50 000 samples put
/// a coefficient's standard error at 0.45 % of the noise-to-signal ratio, 1/sqrt(n); more only
/// costs time, and every candidate the held-out part tests is fitted on them).
pub const FIT_SAMPLES: usize = 50_000;

/// The held-out part is at most this many samples, taken evenly over its window (an assumption:
/// its test's power grows with them, and it is predicted, not fitted, so they cost less).
pub const HELD_OUT_SAMPLES: usize = 200_000;

/// The excitation's fundamental [Hz]: the slope of the upward mean-crossing times (each
/// interpolated between samples) against their count, a least-squares line. Exact to a small
/// fraction of 1/duration even when the amplitude varies, which harmonics of it (periodic model
/// errors) must be told from modes by. Falls back to crossings per second with fewer than three.
fn fundamental_hz(t: &[f64], d: &[f64]) -> f64 {
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let (lo, hi) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
    // Debounced like the reversals: a crossing counts after the signal went a tenth of its
    // range below the mean.
    let band = 0.1 * (hi - lo);
    let mut armed = false;
    let mut times = Vec::new();
    for i in 1..d.len() {
        let (a, b) = (d[i - 1] - mean, d[i] - mean);
        if a < -band {
            armed = true;
        }
        if armed && a < 0.0 && b >= 0.0 {
            times.push(t[i - 1] + (t[i] - t[i - 1]) * (-a / (b - a)));
            armed = false;
        }
    }
    let duration = (t[t.len() - 1] - t[0]).max(1e-9);
    if times.len() < 3 {
        return (times.len() as f64 / duration).max(0.01);
    }
    let n = times.len() as f64;
    let km = (n - 1.0) / 2.0;
    let tm = times.iter().sum::<f64>() / n;
    let (num, den) = times.iter().enumerate().fold((0.0, 0.0), |(p, q), (k, x)| (p + (k as f64 - km) * (x - tm), q + (k as f64 - km).powi(2)));
    if num > 0.0 { den / num } else { (n / duration).max(0.01) }
}

/// Where the held-out part starts [s]: after `train_fraction` of the time range. A sample at or
/// after it is held out. Whatever scores a model on "the held-out part" (the model loop's
/// simulation and observer gains) takes it from here.
///
/// ```
/// assert_eq!(jointctl_ident::identify::prepare::split_time(&[0.0, 5.0, 10.0], 0.7), 7.0);
/// ```
pub fn split_time(t_s: &[f64], train_fraction: f64) -> f64 {
    match (t_s.first(), t_s.last()) {
        (Some(a), Some(b)) => a + train_fraction * (b - a),
        _ => 0.0,
    }
}

/// `data` prepared with the rate over the usual windows (see [`Read`]).
#[cfg(test)]
pub(crate) fn prepare(data: &crate::csv::Data, train_fraction: f64, how: HeldOut) -> Result<Prepared, PrepareError> {
    Read::of(data, train_fraction, how)?.prepare(RateReading::usual(NARROWEST_RATE_WINDOW))
}

/// How the deflection's rate is read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum RateReading {
    /// A least-squares line over a window chosen at each sample, at least `narrowest` samples
    /// either side (see [`NARROWEST_RATE_WINDOW`]), each window's interval `reach_scale` of its
    /// reach (1 as derived, less for a sharper reading: see [`SHARPER_REACH_SCALES`]), none
    /// wider than the local period over `windows_per_period` (see [`WIDER_WINDOWS_PER_PERIOD`]).
    Adaptive { narrowest: usize, reach_scale: f64, windows_per_period: f64 },
    /// A slow log's: the slope of a local cubic through two samples either side (see
    /// `cubic_rate::cubic_rate_by_segment`).
    Cubic,
    /// For a record of holds between moves: through its count's crossings within `reach_s`
    /// either side [s] (see `crossings::crossing_rate_by_segment`).
    Crossings { reach_s: f64 },
}

impl RateReading {
    /// The usual reading: adaptive windows at least `narrowest` samples either side, their
    /// intervals at full reach, none wider than [`VELOCITY_WINDOWS_PER_PERIOD`] allows.
    pub(crate) fn usual(narrowest: usize) -> Self {
        RateReading::Adaptive { narrowest, reach_scale: 1.0, windows_per_period: VELOCITY_WINDOWS_PER_PERIOD }
    }
}

impl Read<'_> {
    /// The record prepared with its rate read as `rate` says.
    pub(crate) fn prepare(&self, rate: RateReading) -> Result<Prepared, PrepareError> {
        self.prepare_with_rate(&self.rate(rate))
    }

    /// The record prepared with its rate `v` [rad/s] (see [`Read::rate`]).
    pub(crate) fn prepare_with_rate(&self, v: &[f64]) -> Result<Prepared, PrepareError> {
        let Read { data, d, tau, pivot, rep, t, t0, starts, frequency_hz, period_samples, spacing_s: spacing, resolution_rad: resolution, scatter_rad: deflection_scatter, .. } = self;
        let (t0, frequency_hz, period_samples, spacing, resolution, deflection_scatter) = (*t0, *frequency_hz, *period_samples, *spacing, *resolution, *deflection_scatter);
        // The torque's floor under a line in the deflection and its rate, each residual computed
        // where it is needed (a long record's residual is not held: see `noise_floor_of`).
        let noise_floor_nm = match line_in_deflection_and_rate(d, v, tau) {
            Some([a, b, c]) => noise::noise_floor_of(tau.len(), |i| tau[i] - a * d[i] - b * v[i] - c, starts),
            None => noise_floor(tau, starts),
        };
        let (held_out, train_fraction) = (self.held_out.clone(), self.train_fraction);
        // A slow log's rate at each interval's ends, should it hold bin averages (see `bins`).
        let edges = if tried_as_bins(spacing) { rate_edges(v, starts) } else { Vec::new() };
        let (from, to) = held_out.times(&data.t);
        let lo = t.partition_point(|x| *x < from - t0);
        let hi = if held_out.end >= 1.0 { t.len() } else { t.partition_point(|x| *x < to - t0) };
        // A stateful effect's history: back over a travel of twice the amplitude, at least two
        // cycles (a Dahl state forgets within a travel far longer than its deflection scale, which
        // the search keeps below a third of the amplitude), not the whole record before it. Counted
        // in travel, not time: a held-out part that starts in a hold took two cycles of the hold as
        // its history, its Dahl state started at zero where the joint held its loop's limit, and
        // the right hysteresis (blind suite, LuGre) made the held-out part worse than none.
        let amplitude_rad = d.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-6);
        let cycles = (2.0 * period_samples).max(100.0) as usize;
        let warm_start = |start: usize| {
            let mut travel = 0.0;
            let mut i = start;
            while i > 0 && (start - i < cycles || travel < 2.0 * amplitude_rad) {
                travel += (d[i] - d[i - 1]).abs();
                i -= 1;
            }
            i
        };
        // After a pause whose path the log does not show, up to the motion's next turn (see
        // `pauses`): no model knows a loop's state there, so the parts that are fitted and judged
        // leave those samples out (a part's history keeps them; inside a part the loop steps from
        // the reading before the pause to the one at the turn whole). The full-rate stretch keeps
        // them (it is contiguous), so a choice made on it sees them. Not when a part would be
        // left with too few samples: the record is judged whole, as before.
        let unseen = {
            let out = before_the_next_turn(t, d, tau, noise_floor_nm, &self.turning, spacing);
            let kept = |r: std::ops::Range<usize>| r.filter(|i| !out[*i]).count();
            if kept(lo..hi) < window::MIN_HELD_OUT || kept(0..lo) + kept(hi..t.len()) < window::MIN_TRAINING { vec![false; t.len()] } else { out }
        };
        let after_pauses = AfterPauses::of(&unseen, t, t0);
        // Every `k`-th sample of the range `r` (its history too), those after pauses left out but
        // for a contiguous stretch (`whole`), picked without a full-rate copy.
        let part_every_of = |r: std::ops::Range<usize>, k: usize, whole: bool| {
            let picked: Vec<usize> = r.clone().step_by(k).filter(|i| whole || after_pauses.samples == 0 || !unseen[*i]).collect();
            let pick = |x: &[f64]| picked.iter().map(|i| x[*i]).collect::<Vec<f64>>();
            // The history's samples, which a delay reads before the part's own and a stateful
            // cause reads transformed with them (see `part::Lead`).
            let lead: Vec<usize> = (warm_start(r.start)..r.start).step_by(k.max(1)).collect();
            let lead_of = |x: &[f64]| lead.iter().map(|i| x[*i]).collect::<Vec<f64>>();
            Part {
                lead: crate::identify::part::Lead { t: lead_of(t), v: lead_of(v) },
                warm: lead_of(d),
                restarts: Vec::new(),
                t: pick(t),
                d: pick(d),
                v: pick(v),
                tau: pick(tau),
                // A pivot not given is none: the configured characteristic's own.
                pivot: if pivot.is_empty() { vec![0.0; picked.len()] } else { pick(pivot).into_iter().map(|p| if p.is_finite() { p } else { 0.0 }).collect() },
                rep: if rep.is_empty() { Vec::new() } else { picked.iter().map(|i| rep[*i]).collect() },
                rate_edges: if edges.is_empty() { Vec::new() } else { picked.iter().map(|i| edges[*i]).collect() },
                bin_width_s: spacing,
                dt: spacing * k as f64,
            }
        };
        let part_every = |r: std::ops::Range<usize>, k: usize| part_every_of(r, k, false);
        let part = |r: std::ops::Range<usize>| part_every_of(r, 1, true);
        let trained = lo + (t.len() - hi);
        if trained < window::MIN_TRAINING || hi - lo < window::MIN_HELD_OUT {
            return Err(PrepareError::UnevenSplit { train_percent: 100.0 * train_fraction, train: trained, held_out: hi - lo });
        }
        // The first `limit` training samples: those before the held-out window, then those after
        // it. Where the two meet, a loop's state starts again from the history before the second
        // (`Part::then`).
        let first = |limit: usize| {
            let before = 0..lo.min(limit);
            (before.clone(), hi..t.len().min(hi + limit.saturating_sub(before.len())))
        };
        // Every `k`-th of them, counted on across the held-out window.
        let training = |limit: usize, k: usize| {
            let (before, after) = first(limit);
            let skip = (k - before.len() % k) % k;
            let after = (after.start + skip).min(after.end)..after.end;
            if after.is_empty() { part_every(before, k) } else { part_every(before, k).then(&part_every(after, k)) }
        };
        // Searches see at least 100 samples a cycle (a Dahl state or a delay needs the motion, not
        // an alias of it): decimated up to that, then SEARCH_SAMPLES of them in pieces of at least
        // two histories (four cycles) spread over the whole training part.
        let k = trained.div_ceil(SEARCH_SAMPLES).min((period_samples / 100.0).floor().max(1.0) as usize);
        // (`spread` returns no range only for an empty training part, refused above.)
        let coarse = pieces::spread(lo, hi, t.len(), k * SEARCH_SAMPLES, 2 * cycles).into_iter().map(|r| part_every(r, k)).reduce(|a, b| a.then(&b)).unwrap_or_else(|| training(k * SEARCH_SAMPLES, k));
        // Final fits on at most FIT_SAMPLES training samples, taken evenly over the whole training
        // part: parameters no longer move beyond (their standard errors shrink as 1/sqrt(n)), and a
        // long record stays fast. Its first FIT_SAMPLES instead left out what came later: a 46 s
        // record at 2 kHz whose sweep speeds up after 27 s (blind seed 7's 000) was fitted on its
        // first 25 s only, at a tenth of the rates it reached, and its viscous friction (13.6 Nm
        // s/rad beside an arctan of 0.07 Nm) was taken for the arctan. The held-out part likewise:
        // at most HELD_OUT_SAMPLES, evenly over the whole window.
        let every_fit = trained.div_ceil(FIT_SAMPLES).max(1);
        let every_test = (hi - lo).div_ceil(HELD_OUT_SAMPLES).max(1);
        let (train, test) = (training(every_fit * FIT_SAMPLES, every_fit), part_every(lo..hi, every_test));
        let excitation = Excitation { amplitude_rad, frequency_hz, sample_period_s: coarse.dt, deflection_scatter_rad: deflection_scatter, resolution_rad: resolution, quantum_rad: self.quantum_rad.max(self.lattice_rad), turn_step_rad: self.turn_step_rad, bin_width_s: if edges.is_empty() { 0.0 } else { spacing } };
        // The full-rate stretch is contiguous (a delay's samples, a periodogram): the piece before
        // the held-out window, or the one after it when that is longer.
        let stretch = if lo >= STRETCH_SAMPLES.min(t.len() - hi) { part(0..lo.min(STRETCH_SAMPLES)) } else { part(hi..t.len().min(hi + STRETCH_SAMPLES)) };
        let train_duration_s = {
            let (before, after) = first(every_fit * FIT_SAMPLES);
            let span = |r: std::ops::Range<usize>| if r.is_empty() { 0.0 } else { t[r.end - 1] - t[r.start] };
            span(before) + span(after)
        };
        let spring_share = spring_share(&train);
        let stops = rest::stops(t, d, v, spacing, resolution);
        // The stops as index ranges. The floor where the joint holds, when clearly lower than the
        // floor over the whole record: the second differences in motion also take what the model
        // misses between samples (see `noise::floor_at_rest`).
        let rest_ranges: Vec<std::ops::Range<usize>> = stops.iter().map(|(a, b)| t.partition_point(|x| *x < *a)..t.partition_point(|x| *x <= *b)).collect();
        let noise_floor_nm = match noise::floor_at_rest(t, tau, &rest_ranges, GAP_STEPS * spacing) {
            Some(at_rest) if at_rest < noise::REST_FLOOR_FALL * noise_floor_nm => at_rest,
            _ => noise_floor_nm,
        };
        // The training part's samples at rest, at the full rate, for the scan of a line there
        // (`rest_line`): the longest runs first, at most REST_SAMPLES, then in time order. The
        // searches' part is decimated without a filter, and a line above its Nyquist frequency
        // folds below it (a 46.2 Hz vibration logged at 2 kHz read 37.1 Hz there).
        let at_rest = {
            let mut runs: Vec<std::ops::Range<usize>> = rest_ranges
                .iter()
                .flat_map(|r| [r.start.min(lo)..r.end.min(lo), r.start.max(hi)..r.end.max(hi)])
                .filter(|r| r.len() >= 16)
                .collect();
            runs.sort_by_key(|r| std::cmp::Reverse(r.len()));
            let mut left = REST_SAMPLES;
            let mut kept: Vec<std::ops::Range<usize>> = runs
                .into_iter()
                .filter_map(|r| {
                    let take = r.len().min(left);
                    left -= take;
                    (take >= 16).then_some(r.start..r.start + take)
                })
                .collect();
            kept.sort_by_key(|r| r.start);
            kept.into_iter().map(part).reduce(|a, b| a.then(&b))
        };
        let record_middle_s = 0.5 * t.last().copied().unwrap_or(0.0);
        Ok(Prepared { record_middle_s, train, test, coarse, stretch, train_at_full_rate: every_fit == 1, excitation, samples: data.len(), dropped: self.dropouts, glitches: self.glitches, saturated: self.saturated, after_pauses, reversed_sign: self.reversed_sign.clone(), resolution_rad: resolution, segments: starts.len(), t0, noise_floor_nm, spring_share, held_out, train_duration_s, stops, at_rest, turns: self.turn_runs.clone() })
    }
}

/// The least-squares `tau = a d + b v + c` [Nm/rad, Nm s/rad, Nm] from sums over the samples
/// about their means, in one pass: the design's columns are not copied (with them and the
/// general QR of `least_squares`, a 2-million-row record's peak through `jointctl identify`
/// was 173 MB, 159 MB without). `None` when the deflection and the rate are collinear or
/// constant.
fn line_in_deflection_and_rate(d: &[f64], v: &[f64], tau: &[f64]) -> Option<[f64; 3]> {
    let n = d.len().min(v.len()).min(tau.len());
    if n == 0 {
        return None;
    }
    let mean = |x: &[f64]| x[..n].iter().sum::<f64>() / n as f64;
    let (md, mv, mt) = (mean(d), mean(v), mean(tau));
    let (mut dd, mut dv, mut vv, mut dt, mut vt) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (x, y, z) = (d[i] - md, v[i] - mv, tau[i] - mt);
        dd += x * x;
        dv += x * y;
        vv += y * y;
        dt += x * z;
        vt += y * z;
    }
    let det = dd * vv - dv * dv;
    if !(det > 1e-12 * dd * vv) || !det.is_finite() {
        return None;
    }
    let (a, b) = ((dt * vv - vt * dv) / det, (vt * dd - dt * dv) / det);
    Some([a, b, mt - a * md - b * mv])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csv::Data;

    /// Issue 40, finding 10: a constant torque was refused as "too little excitation: 413.7
    /// counts, 20 reversals; needs at least 16 and 3", a reason the data meets.
    #[test]
    fn a_constant_torque_is_refused_as_such() {
        let t: Vec<f64> = (0..2000).map(|i| f64::from(i) * 0.01).collect();
        let deflection = t.iter().map(|t| 0.05 * (std::f64::consts::TAU * 0.5 * t).sin()).collect();
        let data = Data::from_columns(t, deflection, vec![1.5; 2000]);
        let e = prepare(&data, 0.7, HeldOut::Last).err().expect("refused");
        assert!(matches!(e, PrepareError::ConstantTorque { value_nm } if value_nm == 1.5), "{e}");
        assert!(e.to_string().starts_with("the torque is 1.5 Nm in every sample"), "{e}");
    }

    #[test]
    fn an_optional_column_of_another_length_is_an_error_and_an_absent_one_is_none() {
        let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.01).collect();
        let d: Vec<f64> = t.iter().map(|t| 0.05 * (std::f64::consts::TAU * 1.1 * t).sin()).collect();
        let tau = d.iter().map(|x| 80.0 * x).collect();
        let mut data = Data::from_columns(t, d, tau);
        assert!(prepare(&data, 0.7, HeldOut::Last).is_ok());
        data.pivot_mm = vec![40.0; 10];
        let e = prepare(&data, 0.7, HeldOut::Last).err().unwrap();
        assert_eq!(e, PrepareError::UnevenColumn { column: "pivot_mm", len: 10, samples: 400 });
        assert_eq!(e.to_string(), "column `pivot_mm` has 10 values for 400 samples");
    }

    #[test]
    fn the_fitted_and_the_held_out_samples_span_their_whole_parts() {
        // Finding (issue 31, blind seed 7's 000): the fits took the training part's first
        // FIT_SAMPLES, and the held-out part was its window's first HELD_OUT_SAMPLES; what came
        // later (a sweep that sped up) was never fitted. A million samples at 1 kHz, the last
        // 30 % held out: both parts reach their ends, at most their budgets each.
        let n = 1_000_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let d: Vec<f64> = t.iter().map(|t| 0.05 * (std::f64::consts::TAU * 0.5 * t).sin()).collect();
        let tau = d.iter().enumerate().map(|(i, x)| 80.0 * x + 0.01 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)).collect();
        let p = prepare(&Data::from_columns(t, d, tau), 0.7, HeldOut::Last).unwrap();
        assert!(p.train.len() <= FIT_SAMPLES && p.test.len() <= HELD_OUT_SAMPLES, "{} {}", p.train.len(), p.test.len());
        let (train_end, test_start, test_end) = (p.train.t[p.train.len() - 1], p.test.t[0], p.test.t[p.test.len() - 1]);
        assert!(train_end > 699.0 && test_start >= 699.9, "training to {train_end} s, held out from {test_start} s");
        assert!(test_end > 999.0, "held out to {test_end} s");
        assert!((p.train_duration_s - 700.0).abs() < 0.1, "{}", p.train_duration_s);
    }
}
