//! Preparation: dropouts out, the deflection rate, enough excitation, and the split into the
//! training part and the held-out part.

use std::borrow::Cow;

use super::causes::{Excitation, reversals};
use super::design::Part;
use crate::csv::Data;

/// One count of the SHERPA joints' 14-bit absolute encoders [rad] (thesis section 3.1).
pub const ENCODER_LSB_RAD: f64 = std::f64::consts::TAU / 16384.0;

/// Quantisation levels a deflection must span for a curve's shape to be told from its
/// quantisation (an assumption: 16 levels resolve a cubic's bend to a few percent).
pub const MIN_SPAN_LSB: f64 = 16.0;

/// Velocity reversals needed: one full cycle and a half, so that both directions of a
/// hysteresis loop and the held-out part see motion.
pub const MIN_REVERSALS: usize = 3;

/// Why the data cannot be identified.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PrepareError {
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
        "too little excitation: the deflection spans {span_rad:.3e} rad ({lsb:.1} encoder counts) with {reversals} reversals; identification needs at least {MIN_SPAN_LSB} counts and {MIN_REVERSALS} reversals (a sine of a few times the play, over one and a half cycles)"
    )]
    TooLittleExcitation {
        /// Range of the deflection [rad].
        span_rad: f64,
        /// The range in 14-bit encoder counts.
        lsb: f64,
        /// Velocity reversals found.
        reversals: usize,
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
pub(crate) struct Prepared {
    pub train: Part,
    pub test: Part,
    /// The training part, decimated to at most [`SEARCH_SAMPLES`] samples, for grid searches.
    pub coarse: Part,
    /// The first [`STRETCH_SAMPLES`] of the training part at the full rate: the searches that
    /// need it (a delay's samples, a mode above the decimated part's Nyquist frequency).
    pub stretch: Part,
    pub excitation: Excitation,
    pub samples: usize,
    pub dropped: usize,
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

/// Fits run on at most this many contiguous training samples (an assumption: 50 000 samples put
/// a coefficient's standard error at 0.45 % of the noise-to-signal ratio, 1/sqrt(n); more only
/// costs time, and every candidate the held-out part tests is fitted on them).
pub const FIT_SAMPLES: usize = 50_000;

/// The held-out part is at most this many samples after the split (an assumption: its test's
/// power grows with them, and it is predicted, not fitted, so they cost less).
pub const HELD_OUT_SAMPLES: usize = 200_000;

/// Exact zeros that the signal cannot have reached: a run of zeros between two readings farther
/// from zero than three encoder counts plus five typical steps per sample of the run. (A signal
/// that really crosses zero passes it within a step or two; thesis appendix A's lost CAN frames
/// jump there from anywhere.)
fn dropouts(series: &[f64], lsb: f64) -> Vec<bool> {
    let n = series.len();
    let mut steps: Vec<f64> = series.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    let typical = if steps.is_empty() {
        0.0
    } else {
        let mid = steps.len() / 2;
        *steps.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let mut dropped = vec![false; n];
    let mut i = 1;
    while i + 1 < n {
        if series[i] != 0.0 {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < n && series[j] == 0.0 {
            j += 1;
        }
        let reach = 3.0 * lsb + 5.0 * typical * (j - i + 1) as f64;
        if j < n && series[i - 1].abs() > reach && series[j].abs() > reach {
            dropped[i..j].iter_mut().for_each(|d| *d = true);
        }
        i = j;
    }
    dropped
}

/// Deflection rate: the slope of a local least-squares line (a Savitzky-Golay derivative) over
/// about a fiftieth of the excitation period: no lag, and it averages out the quantisation.
/// Running window sums make it one pass whatever the window; they are summed afresh around a new
/// time origin every 1024 samples so that rounding cannot build up over a long record.
fn velocity(t: &[f64], d: &[f64], half: usize) -> Vec<f64> {
    let n = d.len();
    let mut out = Vec::with_capacity(n);
    let (mut st, mut sd, mut stt, mut std_) = (0.0, 0.0, 0.0, 0.0);
    let (mut a, mut b, mut t0) = (0usize, 0usize, t[0]);
    for i in 0..n {
        let (lo, hi) = (i.saturating_sub(half), (i + half).min(n - 1) + 1);
        if i % 1024 == 0 {
            // Afresh: the window [lo, hi) around the origin t[lo].
            t0 = t[lo];
            (st, sd, stt, std_) = (0.0, 0.0, 0.0, 0.0);
            for k in lo..hi {
                let x = t[k] - t0;
                (st, sd, stt, std_) = (st + x, sd + d[k], stt + x * x, std_ + x * d[k]);
            }
            (a, b) = (lo, hi);
        }
        while b < hi {
            let x = t[b] - t0;
            (st, sd, stt, std_) = (st + x, sd + d[b], stt + x * x, std_ + x * d[b]);
            b += 1;
        }
        while a < lo {
            let x = t[a] - t0;
            (st, sd, stt, std_) = (st - x, sd - d[a], stt - x * x, std_ - x * d[a]);
            a += 1;
        }
        let m = (hi - lo) as f64;
        let den = stt - st * st / m;
        let num = std_ - st * sd / m;
        out.push(if den > 1e-300 { num / den } else { 0.0 });
    }
    out
}

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

pub(crate) fn prepare<'a>(data: &'a Data, train_fraction: f64) -> Result<Prepared, PrepareError> {
    let n_all = data.len();
    if n_all < 50 {
        return Err(PrepareError::TooFewSamples { samples: n_all, needed: 50 });
    }
    if let Some((column, len)) = data.uneven_column() {
        return Err(PrepareError::UnevenColumn { column, len, samples: n_all });
    }
    let mut lost = dropouts(&data.deflection, ENCODER_LSB_RAD);
    lost.iter_mut().zip(dropouts(&data.torque, 0.0)).for_each(|(a, b)| *a |= b);
    let dropped = lost.iter().filter(|l| **l).count();
    // The columns without the dropouts: borrowed when there are none (a long record is not
    // copied whole).
    let kept = |column: &'a [f64]| -> Cow<'a, [f64]> {
        if dropped == 0 { Cow::Borrowed(column) } else { Cow::Owned(column.iter().zip(&lost).filter(|(_, l)| !**l).map(|(x, _)| *x).collect()) }
    };
    let (d, t, tau, pivot) = (kept(&data.deflection), kept(&data.t), kept(&data.torque), kept(&data.pivot_mm));
    let period_samples = {
        let crossings = d.windows(2).filter(|w| w[0] < 0.0 && w[1] >= 0.0).count().max(1) as f64;
        d.len() as f64 / crossings
    };
    let v = velocity(&t, &d, ((period_samples / 50.0).round() as usize).clamp(2, 25));
    let (lo, hi) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
    let span = hi - lo;
    let turns = reversals(&d).len();
    let torque_moves = tau.iter().any(|x| *x != tau[0]);
    if span < MIN_SPAN_LSB * ENCODER_LSB_RAD || turns < MIN_REVERSALS || !torque_moves {
        return Err(PrepareError::TooLittleExcitation { span_rad: span, lsb: span / ENCODER_LSB_RAD, reversals: turns });
    }
    let spacing = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let t_split = split_time(&t, train_fraction);
    let split = t.partition_point(|x| *x < t_split);
    // A stateful effect's history: two cycles before the part (a Dahl state forgets within a
    // stroke far longer than its deflection scale, which the search keeps below a third of the
    // amplitude), not the whole record before it.
    let history = (2.0 * period_samples).max(100.0) as usize;
    let part = |r: std::ops::Range<usize>| Part {
        warm: d[r.start.saturating_sub(history)..r.start].to_vec(),
        t: t[r.clone()].to_vec(),
        d: d[r.clone()].to_vec(),
        v: v[r.clone()].to_vec(),
        tau: tau[r.clone()].to_vec(),
        // A pivot not given is none: the configured characteristic's own.
        pivot: if pivot.is_empty() { vec![0.0; r.len()] } else { pivot[r].iter().map(|p| if p.is_finite() { *p } else { 0.0 }).collect() },
        dt: spacing,
    };
    if split < 30 || t.len() - split < 20 {
        return Err(PrepareError::UnevenSplit { train_percent: 100.0 * train_fraction, train: split, held_out: t.len() - split });
    }
    // Searches see at least 100 samples a cycle (a Dahl state or a delay needs the motion, not
    // an alias of it): decimated up to that, then the first SEARCH_SAMPLES of them.
    let k = split.div_ceil(SEARCH_SAMPLES).min((period_samples / 100.0).floor().max(1.0) as usize);
    let coarse = part(0..split.min(k * SEARCH_SAMPLES)).every(k);
    // Final fits on at most FIT_SAMPLES contiguous training samples: parameters no longer move
    // beyond (their standard errors shrink as 1/sqrt(n)), and a long record stays fast.
    // The held-out part: its first HELD_OUT_SAMPLES after the split.
    let (train, test) = (part(0..split.min(FIT_SAMPLES)), part(split..t.len().min(split + HELD_OUT_SAMPLES)));
    let amplitude_rad = d.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-6);
    let frequency_hz = fundamental_hz(&t, &d);
    let excitation = Excitation { amplitude_rad, frequency_hz, sample_period_s: coarse.dt };
    let stretch = train.first(STRETCH_SAMPLES);
    Ok(Prepared { train, test, coarse, stretch, excitation, samples: n_all, dropped })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_running_sum_derivative_equals_the_local_line_slope_over_a_long_record() {
        // 2 million samples at 200 Hz: 10 000 s, where sums of t^2 would lose the window's spread.
        let t: Vec<f64> = (0..2_000_000).map(|i| 10.0 + i as f64 * 0.005).collect();
        let d: Vec<f64> = t.iter().map(|t| (1.3 * t).sin()).collect();
        let v = velocity(&t, &d, 5);
        for i in [0usize, 3, 250, 1023, 1024, 1_999_990, 1_999_999] {
            let (a, b) = (i.saturating_sub(5), (i + 5).min(1_999_999));
            let n = (b - a + 1) as f64;
            let (tm, dm) = (t[a..=b].iter().sum::<f64>() / n, d[a..=b].iter().sum::<f64>() / n);
            let num: f64 = (a..=b).map(|k| (t[k] - tm) * (d[k] - dm)).sum();
            let den: f64 = (a..=b).map(|k| (t[k] - tm).powi(2)).sum();
            assert!((v[i] - num / den).abs() < 1e-6, "{i}: {} vs {}", v[i], num / den);
        }
    }

    #[test]
    fn an_optional_column_of_another_length_is_an_error_and_an_absent_one_is_none() {
        let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.01).collect();
        let d: Vec<f64> = t.iter().map(|t| 0.05 * (std::f64::consts::TAU * 1.1 * t).sin()).collect();
        let tau = d.iter().map(|x| 80.0 * x).collect();
        let mut data = Data::from_columns(t, d, tau);
        assert!(prepare(&data, 0.7).is_ok());
        data.pivot_mm = vec![40.0; 10];
        let e = prepare(&data, 0.7).err().unwrap();
        assert_eq!(e, PrepareError::UnevenColumn { column: "pivot_mm", len: 10, samples: 400 });
        assert_eq!(e.to_string(), "column `pivot_mm` has 10 values for 400 samples");
    }

    #[test]
    fn a_zero_the_signal_passes_through_is_not_a_dropout_but_a_jump_to_zero_is() {
        // A slow ramp through zero, sampled so that one reading is exactly zero.
        let ramp: Vec<f64> = (-50..50).map(|i| i as f64 * ENCODER_LSB_RAD).collect();
        assert!(!dropouts(&ramp, ENCODER_LSB_RAD).iter().any(|d| *d));
        // Two counts either side of an exact zero: quantisation explains it.
        let near = [0.1, 2.0 * ENCODER_LSB_RAD, 0.0, -2.0 * ENCODER_LSB_RAD, -0.1];
        assert!(!dropouts(&near, ENCODER_LSB_RAD)[2]);
        // A zero in the middle of 0.05 rad: a lost frame.
        let mut lost = vec![0.05; 100];
        lost[40] = 0.0;
        assert_eq!(dropouts(&lost, ENCODER_LSB_RAD).iter().filter(|d| **d).count(), 1);
    }
}
