//! The deflection rate: a local least-squares slope whose window follows the motion and
//! narrows where the deflection bends faster than its noise allows.

use super::super::parallel::parallel_map;
use crate::identify::numeric::segment_ranges;

/// The half-width of the velocity's window is this fraction of the local period of the motion:
/// a least-squares slope over +-P/50 reads a sine's rate 0.16 % low (its gain is
/// `3 (sin x - x cos x) / x^3`, `x = 2 pi / 50`).
pub const VELOCITY_WINDOWS_PER_PERIOD: f64 = 50.0;

/// Wider windows for the data to choose from, as [`VELOCITY_WINDOWS_PER_PERIOD`]'s divisor of the
/// local period (see `bin_reading::choose_rate_reading`). The usual window is sized on the
/// motion's bias alone: a slope over +-P/50 of a sine is 0.16 % low. Where the encoder's counts
/// are coarse beside the stroke the staircase is what matters: a stroke of 46 counts of a 14-bit
/// encoder at 1 kHz (the third generator's seed 6's 062, a chirp at up to 2.5 Hz, eq. 3.5's
/// friction 0.70 Nm beside a spring's 0.51) read its rate over +-8 samples through the counts,
/// the arctan turned at the wrong instants, and the baseline left 0.0689 Nm held out for a noise
/// floor of 0.0385; over +-P/12.5, 0.0392. The interval test cannot see that: a window inside one
/// count has a slope of zero within its reach. +-P/12.5 reads a sine's rate 2.6 % low (an
/// assumption: wider still, a viscous friction's damping comes out that much larger; where the
/// motion bends more than the noise the interval test narrows the window anyway). One step: with
/// a 25th as well, the third generator's seeds 3-10 named 456 of their 488 hidden effects against
/// 458 with this one alone, and each record paid a second screening.
pub const WIDER_WINDOWS_PER_PERIOD: [f64; 1] = [12.5];

/// The widest the velocity window may be per sample [samples]: [`VELOCITY_WINDOWS_PER_PERIOD`]
/// of the local period, twice the stroke between the reversals around the sample (debounced at
/// a tenth of the range), never more than of the fundamental's `period_samples`; between
/// `narrowest` ([`NARROWEST_RATE_WINDOW`], or one sample for a slow log that the data reads
/// better so: see `bin_reading`) and `widest` ([`widest_rate_window`]). A slow characterisation with fast bursts, a sweep or a multi-sine moves far faster
/// in places than its fundamental says: a window sized on the fundamental reads those rates low,
/// and every rate-driven torque (viscous friction most) comes out too large. Where the motion
/// bends faster than its strokes tell (a corner between a hold and a ramp; every sample of a
/// slow log), [`adaptive_velocity`] narrows the window further.
pub(super) fn velocity_half_widths(n: usize, reversals: &[usize], period_samples: f64, windows_per_period: f64, [narrowest, widest]: [usize; 2]) -> Vec<usize> {
    let half = |period: f64| ((period.min(period_samples) / windows_per_period).round() as usize).clamp(narrowest, widest.max(narrowest));
    let mut out = vec![half(period_samples); n];
    for w in reversals.windows(2) {
        let h = half(2.0 * (w[1] - w[0]) as f64);
        out[w[0]..w[1].min(n)].iter_mut().for_each(|x| *x = h);
    }
    out
}

/// The widest the rate's window may reach either side [s] (an assumption: where a hand's motion
/// of a few hertz bends; the motion's own strokes and [`adaptive_velocity`] narrow it further).
pub const WIDEST_RATE_REACH_S: f64 = 0.1;

/// The widest the rate's window may be either side [samples], at the median time step
/// `median_step_s`: [`WIDEST_RATE_REACH_S`], and never fewer than 100 samples. The cap was first
/// 100 samples, +-0.1 s at 1 kHz: at 2 kHz that halved the reach, and a 14-bit encoder's
/// staircase on a slow stroke (a count every 50 ms at 0.1 Hz) stayed in the rate, the torque's
/// eq. 3.5 arctan read through it. The floor keeps a slow log's window, where the strokes and
/// the intervals decide. A reach of 0.25 s was measured and not taken: on the blind generator it
/// named two viscous frictions fewer, and raised 45 records' held-out error by more than 1 %
/// (16 fell).
///
/// ```
/// use jointctl_ident::identify::prepare::widest_rate_window;
/// assert_eq!(widest_rate_window(1e-3), 100);
/// assert_eq!(widest_rate_window(5e-4), 200);
/// assert_eq!(widest_rate_window(5e-3), 100);
/// ```
pub fn widest_rate_window(median_step_s: f64) -> usize {
    let reach = WIDEST_RATE_REACH_S / median_step_s;
    if reach.is_finite() { (reach.round() as usize).max(WIDEST_RATE_WINDOW_FLOOR) } else { WIDEST_RATE_WINDOW_FLOOR }
}

/// The fewest samples [`widest_rate_window`] allows either side (see there).
const WIDEST_RATE_WINDOW_FLOOR: usize = 100;

/// The narrowest the widest rate window may be, samples either side (an assumption: at +-1 a
/// slope is a central difference, the quantisation's step over two sample periods; a slow log
/// of a motion of about 1 Hz may read better so, which the data decides, see `bin_reading`).
pub const NARROWEST_RATE_WINDOW: usize = 2;

/// Deflection rate: the slope of a local least-squares line (a Savitzky-Golay derivative) over
/// `+-half[i]` samples around sample `i`: no lag, and it averages out the quantisation. Running window sums
/// make it one pass whatever the window; they are summed afresh around a new time origin every
/// 1024 samples so that rounding cannot build up over a long record.
#[cfg(test)]
pub(super) fn velocity(t: &[f64], d: &[f64], half: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(d.len());
    each_window(t, d, |i| half[i], |_, w| out.push(w.slope));
    out
}

/// One window's least-squares line.
struct Window {
    /// Its slope [rad/s].
    slope: f64,
    /// The spread of its time stamps about their mean, `sum (t - mean t)^2` [s^2].
    spread: f64,
    /// Its samples.
    samples: f64,
}

/// [`velocity`]'s windows, sample by sample, each handed to `visit` with its sample's index:
/// its slope, the spread of its time stamps (a slope's standard error is the deflection's noise
/// over its root) and its number of samples; `half(i)` is sample `i`'s half-width. Handed over,
/// not collected: a list of every window, and of every sample's half-width for each rung of
/// [`adaptive_velocity`]'s ladder, took 64 MB more on a 2-million-row record than the rate
/// itself (the record's peak 212 MB against the 150 MB of issue 13).
fn each_window(t: &[f64], d: &[f64], half: impl Fn(usize) -> usize, mut visit: impl FnMut(usize, Window)) {
    let n = d.len();
    if n == 0 {
        return;
    }
    let (mut st, mut sd, mut stt, mut std_) = (0.0, 0.0, 0.0, 0.0);
    let (mut a, mut b, mut t0) = (0usize, 0usize, t[0]);
    for i in 0..n {
        let h = half(i);
        let (lo, hi) = (i.saturating_sub(h), (i + h).min(n - 1) + 1);
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
        // The window moves on and, where its width changes, grows or shrinks at either end.
        while b < hi {
            let x = t[b] - t0;
            (st, sd, stt, std_) = (st + x, sd + d[b], stt + x * x, std_ + x * d[b]);
            b += 1;
        }
        while b > hi {
            b -= 1;
            let x = t[b] - t0;
            (st, sd, stt, std_) = (st - x, sd - d[b], stt - x * x, std_ - x * d[b]);
        }
        while a < lo {
            let x = t[a] - t0;
            (st, sd, stt, std_) = (st - x, sd - d[a], stt - x * x, std_ - x * d[a]);
            a += 1;
        }
        while a > lo {
            a -= 1;
            let x = t[a] - t0;
            (st, sd, stt, std_) = (st + x, sd + d[a], stt + x * x, std_ + x * d[a]);
        }
        let m = (hi - lo) as f64;
        let den = stt - st * st / m;
        let num = std_ - st * sd / m;
        visit(i, if den > 1e-300 { Window { slope: num / den, spread: den, samples: m } } else { Window { slope: 0.0, spread: 0.0, samples: m } });
    }
}

/// The half-widths the rate's window is chosen from [samples], narrowest first (an assumption:
/// steps of about 1.4 in width, so the chosen window is at most 40 % narrower than the widest
/// the data allow, up to 800 samples, 0.1 s at 8 kHz: see [`widest_rate_window`]).
const RATE_HALF_WIDTHS: [usize; 19] = [1, 2, 3, 4, 6, 8, 11, 16, 25, 35, 50, 70, 100, 140, 200, 280, 400, 560, 800];

/// Standard errors a wider window's slope may lie from every narrower one's before the wider
/// window is refused (an assumption: three, a 0.3 % chance each that noise alone refuses it).
const RATE_WINDOW_SIGMAS: f64 = 3.0;

/// Deflection rate with a window chosen at each sample by the intersection of confidence
/// intervals (Goldenshluger and Nemirovski 1997; Katkovnik 1999): the slope of the widest window
/// among [`RATE_HALF_WIDTHS`] narrower than `widest[i]` (see [`velocity_half_widths`]) and
/// `widest[i]` itself whose interval (`slope +-` [`DeflectionNoise::slope_reach`]) still meets
/// the intervals of all narrower ones. Where the motion is a line to within
/// the noise it is the widest window (quantisation averaged out); where it bends more than the
/// noise, narrower. The window sized on the motion's strokes alone read a 20 Hz log's rate over
/// +-2 to +-7 samples (0.2-0.7 s): the corners between its holds and ramps were smeared, and a
/// delay of 85 ms with them (the blind devices' delay binned to 20 Hz was not named).
fn adaptive_velocity(t: &[f64], d: &[f64], noise: DeflectionNoise, reach_scales: &[f64], widest: &[usize]) -> Vec<Vec<f64>> {
    let (n, k) = (d.len(), reach_scales.len());
    // One rate per reach scale, each with its own intervals, a sample's side by side: the
    // windows and their reach are the same for all.
    let mut bounds = vec![(f64::NEG_INFINITY, f64::INFINITY); n * k];
    let mut out = vec![vec![0.0; n]; k];
    // A rung no narrower than every sample's widest window would be passed over at each
    // sample: it is not computed (on a slow sine sampled fast, 5 of the 13).
    let widest_of_all = widest.iter().copied().max().unwrap_or(0);
    // The ladder's rungs narrower than the widest allowed (`None`), then the widest itself. A
    // sample's intervals only narrow: once they no longer meet (`lo > hi`) its rate is chosen.
    for rung in RATE_HALF_WIDTHS.iter().filter(|h| **h < widest_of_all).map(|h| Some(*h)).chain(std::iter::once(None)) {
        each_window(t, d, |i| rung.unwrap_or(widest[i]), |i, Window { slope, spread, samples }| {
            if rung.is_some_and(|h| h >= widest[i]) {
                return;
            }
            let reach = if spread > 0.0 { noise.slope_reach(samples, spread) } else { f64::INFINITY };
            for (r, (lo, hi)) in bounds[i * k..(i + 1) * k].iter_mut().enumerate() {
                if *lo > *hi {
                    continue;
                }
                let reach = if spread > 0.0 { reach_scales[r] * reach } else { f64::INFINITY };
                *lo = lo.max(slope - reach);
                *hi = hi.min(slope + reach);
                if *lo <= *hi {
                    out[r][i] = slope;
                }
            }
        });
    }
    out
}

/// What scatters a deflection reading about the motion: its quantisation and its own noise.
#[derive(Clone, Copy, Debug)]
pub(super) struct DeflectionNoise {
    /// The coarsest quantiser's step in the deflection [rad] ([`coarsest_tick_rad`]): a reading
    /// is off by at most half of it. The data's smallest common step is not that for a
    /// deflection that is the difference of two encoders through a ratio (the simulated elbow):
    /// bounded by it, a 0.02 rad stroke at 1 kHz through a 14-bit output and a 20-bit motor
    /// encoder read its rate 157 % of its rms off (0.9 % now); taking the step from the scatter
    /// (`2 sqrt 3` times it) left 76 %.
    pub quantum_rad: f64,
    /// The deflection's scatter about a line from sample to sample, rms [rad] (quantisation's
    /// share included: counted twice on a clean staircase, a margin on the safe side).
    pub scatter_rad: f64,
}

impl DeflectionNoise {
    /// How far a window's least-squares slope may lie from the motion's rate [rad/s], for a
    /// window of `m` samples whose time stamps spread `spread` [s^2] about their mean:
    /// [`RATE_WINDOW_SIGMAS`] standard errors of the scatter, plus the most that quantisation
    /// can tilt it. Quantisation is no white noise on a slow motion: its error is a sawtooth that
    /// keeps its sign for many samples, bounded by half a step, so its tilt is bounded by
    /// `q/2 sum|t - mean t| / spread <= q/2 sqrt(m / spread)` (Cauchy-Schwarz). Taken as white
    /// (`q / sqrt 12` per sample), a 14-bit encoder's staircase at 1 kHz refused every window
    /// wider than a few samples on a slow stroke: on the blind device devE at 1 kHz (a 14-bit
    /// encoder, a viscous friction of 8.2 Nm s/rad beside an arctan of 0.14 Nm x 69 s/rad) the
    /// rate read 1.6e-3 rad/s rms off a +-50-sample slope, a tenth of its rms, and the held-out
    /// error after the offset was 0.041 Nm for 0.029 now (noise 0.024). That viscous friction is
    /// still not named at full rate: eq. 3.5's arctan at a low `k_b` stands in for it.
    pub fn slope_reach(&self, m: f64, spread: f64) -> f64 {
        RATE_WINDOW_SIGMAS * self.scatter_rad / spread.sqrt() + 0.5 * self.quantum_rad * (m / spread).sqrt()
    }
}

/// The shares of [`DeflectionNoise::slope_reach`] a sharper reading of the rate gives each
/// window's interval, for the data to choose from (see `bin_reading::choose_rate_reading`). The
/// reach is a bound: three standard errors of the scatter and the most quantisation can tilt a
/// slope. Where the rate turns in a sample or two (a triangle's reversal), a window whose slope
/// is biased by less than that bound is kept, and the rate is smeared over the corner: on the
/// blind generator's seed-11 triangle at 250 Hz through a 14-bit encoder (a viscous friction
/// of 77 Nm s/rad), eight samples after a reversal the rate read 0.089 rad/s for 0.114, and
/// the baseline's held-out error was 0.61 Nm for a noise floor of 0.13. Intersection of
/// confidence intervals takes its threshold as a parameter chosen from the data (Katkovnik,
/// Egiazarian and Astola 2006, cross-validated); here the baseline's training fit proposes, the
/// held-out part must not disagree, and the whole model identified on the reading must be
/// better. Halving steps, down to a quarter (an assumption: at a tenth of the reach that
/// record's baseline left 1.49 Nm, the noise let through).
pub const SHARPER_REACH_SCALES: [f64; 2] = [0.5, 0.25];

/// Isolated ticks the coarsest quantiser is read from, at least (an assumption: fewer say
/// nothing of a distribution's upper tenth).
const MIN_TICKS: usize = 20;

/// The step of the coarsest quantiser in the deflection [rad]: the 90th percentile of its
/// isolated ticks (a change between two samples with the reading held before and after, inside
/// one segment), at least `resolution_rad` (the smallest common step). A single encoder's
/// isolated ticks are its count; a deflection that is a coarse output encoder less a fine motor
/// encoder through a ratio ticks by the motor's step mostly and by the output's count now and
/// then, and its readings are off by half the latter; data that never holds (a 20 Hz log, an
/// unquantised signal) has too few ticks, and the smallest step stands.
pub(super) fn coarsest_tick_rad(d: &[f64], starts: &[usize], resolution_rad: f64) -> f64 {
    let mut ticks = Vec::new();
    for std::ops::Range { start: a, end: b } in segment_ranges(starts, d.len()) {
        for i in a + 1..b.saturating_sub(2) {
            let step = (d[i + 1] - d[i]).abs();
            if step > 0.0 && d[i] == d[i - 1] && d[i + 2] == d[i + 1] {
                ticks.push(step);
            }
        }
    }
    if ticks.len() < MIN_TICKS {
        return resolution_rad;
    }
    let at = ticks.len() * 9 / 10;
    ticks.select_nth_unstable_by(at, f64::total_cmp).1.max(resolution_rad)
}

/// Samples [`adaptive_velocity`] works on at once in one block, beside the windows' reach either
/// side (an assumption: its intervals then take 0.2 MB a core, not 24 bytes a sample of the whole
/// record; far beyond the widest reach, 100 samples, so that the blocks' overlap costs little; wider at a fast log's [`widest_rate_window`]).
/// The same on every machine: where the blocks part moves the rates' last bits (each block sums
/// its windows from its own start), so the blocks must not follow the number of cores.
const RATE_BLOCK: usize = 1 << 13;

/// A block of [`velocity_by_segment`]: the samples it gives the rate of, and those its windows read.
type RateBlock = (std::ops::Range<usize>, std::ops::Range<usize>);

/// The blocks of [`velocity_by_segment`], in order: they tile `0..n`, none empty. A segment (from
/// each of `starts` to the next) goes in blocks of [`RATE_BLOCK`] samples, each reading the samples
/// its windows reach on either side within the segment (the widest half-width of `half`, at least
/// [`WIDEST_RATE_WINDOW_FLOOR`]).
fn rate_blocks(starts: &[usize], n: usize, half: &[usize]) -> Vec<RateBlock> {
    let mut blocks = Vec::new();
    for std::ops::Range { start: a, end: b } in segment_ranges(starts, n) {
        let reach = half[a..b].iter().copied().max().unwrap_or(0).max(WIDEST_RATE_WINDOW_FLOOR);
        let mut from = a;
        while from < b {
            let to = (from + RATE_BLOCK).min(b);
            blocks.push((from..to, from.saturating_sub(reach).max(a)..(to + reach).min(b)));
            from = to;
        }
    }
    blocks
}

/// The deflection rate of [`adaptive_velocity`], segment by segment, once for each of
/// `reach_scales`, the share of its reach ([`DeflectionNoise::slope_reach`]) each window's
/// interval is given: 1 as this module derives it, less for a sharper reading (see
/// [`SHARPER_REACH_SCALES`]); readings whose windows are the same share them (see
/// `Read::rates`). Never differenced
/// across a gap. A long segment goes in blocks ([`rate_blocks`]), each with the samples its
/// windows reach on either side, so that every window is the one the whole segment would give
/// it; the blocks are spread over the cores (a tenth of identify's time on a 100 000-sample
/// record was this rate, on one core). A segment of one sample has no rate (0).
pub(super) fn velocity_by_segment(t: &[f64], d: &[f64], starts: &[usize], noise: DeflectionNoise, reach_scales: &[f64], half: &[usize]) -> Vec<Vec<f64>> {
    // Each block writes its own slice of each rate (no second copy of the column: a
    // 2-million-row record's peak memory is held to issue 13's 150 MB).
    let mut v: Vec<Vec<f64>> = reach_scales.iter().map(|_| vec![0.0; d.len()]).collect();
    let mut rests: Vec<&mut [f64]> = v.iter_mut().map(|x| x.as_mut_slice()).collect();
    let mut work = Vec::new();
    for (own, read) in rate_blocks(starts, d.len(), half) {
        let mut mine = Vec::with_capacity(rests.len());
        for rest in rests.iter_mut() {
            let (slice, others) = std::mem::take(rest).split_at_mut(own.len());
            *rest = others;
            mine.push(slice);
        }
        work.push((own, read, std::sync::Mutex::new(mine)));
    }
    parallel_map(&work, |(own, read, out)| {
        if read.len() >= 2 {
            let rates = adaptive_velocity(&t[read.clone()], &d[read.clone()], noise, reach_scales, &half[read.clone()]);
            // Each slice is its block's alone: the lock is never contended.
            for (out, rate) in out.lock().unwrap_or_else(|e| e.into_inner()).iter_mut().zip(&rates) {
                out.copy_from_slice(&rate[own.start - read.start..own.end - read.start]);
            }
        }
    });
    drop(work);
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use super::super::prepare;
    use crate::csv::Data;

    #[test]
    fn the_rate_of_a_deflection_between_two_encoders_is_read_over_a_wide_window() {
        // Finding (the project's simulated elbow, after the rate's window began to narrow where
        // the deflection bends): the deflection is a 14-bit output encoder less a finer motor
        // encoder through the tendon ratio, so its steps come in many sizes and its smallest
        // common step (1.5e-5 rad) is far below its scatter. Taken as its noise, every window
        // wider than +-2 samples looked bent, and the rate read 35 % high at mid-stroke; the
        // identified hysteresis came out at 357 Nm/rad instead of about 100.
        use std::f64::consts::TAU;
        let (q_out, q_motor) = (TAU / 16384.0, TAU / 1_048_576.0);
        let t: Vec<f64> = (0..16_000).map(|i| f64::from(i) * 0.005).collect();
        let deflection: Vec<f64> = t
            .iter()
            .map(|t| {
                let motor = 1e-3 * (TAU * 0.25 * t + 0.3).sin();
                let output = 2.0 * motor + 0.1 * (TAU * 0.25 * t).sin();
                (output / q_out).round() * q_out - 2.0 * (motor / q_motor).round() * q_motor
            })
            .collect();
        let torque = deflection.iter().map(|d| 100.0 * d).collect();
        let p = prepare(&Data::from_columns(t, deflection, torque), 0.7, super::super::HeldOut::Last).expect("prepared");
        let truth = |t: f64| 0.1 * TAU * 0.25 * (TAU * 0.25 * t).cos();
        let worst = p.train.t.iter().zip(&p.train.v).skip(100).map(|(t, v)| (v - truth(*t)).abs()).fold(0.0, f64::max);
        assert!(worst < 0.05 * 0.1 * TAU * 0.25, "rate off by up to {worst} rad/s");
    }

    #[test]
    fn a_slow_stroke_through_a_coarse_encoder_at_a_high_rate_is_read_through_its_staircase() {
        // Finding (the blind device devE's rate at 1 kHz read a tenth of its rms off): a
        // 14-bit encoder's step taken as white noise made every window wider than a few samples
        // look bent on a slow stroke (its quantisation error is a sawtooth that keeps its sign),
        // and a window cap of 25 samples (+-25 ms) could not average the staircase out; the rate
        // was off, which an arctan friction's slope turned into torque. Here it was off by
        // 4.5 % of its rms (0.5 % now). The stroke's widest window (P/50) is the cap, +-100.
        // A 0.2 Hz sine of 0.04 rad (about 100 counts) at 1 kHz, and its truth.
        use std::f64::consts::TAU;
        let q = TAU / 16384.0;
        let t: Vec<f64> = (0..40_000).map(|i| f64::from(i) * 1e-3).collect();
        let deflection: Vec<f64> = t.iter().map(|t| (0.04 * (TAU * 0.2 * t).sin() / q).round() * q).collect();
        let share = rate_error_share(t, deflection, |t| 0.04 * TAU * 0.2 * (TAU * 0.2 * t).cos());
        assert!(share < 0.015, "the rate is off by {:.1} % of its rms", 100.0 * share);
    }

    #[test]
    fn a_small_stroke_between_two_encoders_at_a_high_rate_is_read_through_both_staircases() {
        // Finding (review): the bound on quantisation's tilt took the data's smallest step as the
        // quantiser. A deflection that is a 14-bit output encoder less a finer motor encoder
        // through a ratio steps by far less than it jumps, and on a 0.02 rad stroke at 1 kHz
        // the rate read 157 % of its rms off (0.9 % with the coarsest isolated tick).
        use std::f64::consts::TAU;
        let (q_out, q_motor) = (TAU / 16384.0, TAU / 1_048_576.0);
        let t: Vec<f64> = (0..40_000).map(|i| f64::from(i) * 0.001).collect();
        let deflection: Vec<f64> = t
            .iter()
            .map(|t| {
                let motor = 1e-3 * (TAU * 0.25 * t + 0.3).sin();
                let output = 2.0 * motor + 0.02 * (TAU * 0.25 * t).sin();
                (output / q_out).round() * q_out - 2.0 * (motor / q_motor).round() * q_motor
            })
            .collect();
        let share = rate_error_share(t, deflection, |t| 0.02 * TAU * 0.25 * (TAU * 0.25 * t).cos());
        assert!(share < 0.05, "the rate is off by {:.1} % of its rms", 100.0 * share);
    }

    /// The rms error of the rate `prepare` reads on the training part (its first 200 samples
    /// left out) as a share of the rms of the true rate `truth(t)`.
    fn rate_error_share(t: Vec<f64>, deflection: Vec<f64>, truth: impl Fn(f64) -> f64) -> f64 {
        let torque = deflection.iter().map(|d| 60.0 * d).collect();
        let p = prepare(&Data::from_columns(t, deflection, torque), 0.7, super::super::HeldOut::Last).expect("prepared");
        let (mut error, mut signal) = (0.0, 0.0);
        for (t, v) in p.train.t.iter().zip(&p.train.v).skip(200) {
            error += (v - truth(*t)).powi(2);
            signal += truth(*t).powi(2);
        }
        (error / signal).sqrt()
    }

    /// The least-squares line's slope through samples `a..=b`, summed directly.
    fn line_slope(t: &[f64], d: &[f64], a: usize, b: usize) -> f64 {
        let n = (b - a + 1) as f64;
        let (tm, dm) = (t[a..=b].iter().sum::<f64>() / n, d[a..=b].iter().sum::<f64>() / n);
        let num: f64 = (a..=b).map(|k| (t[k] - tm) * (d[k] - dm)).sum();
        let den: f64 = (a..=b).map(|k| (t[k] - tm).powi(2)).sum();
        num / den
    }

    #[test]
    fn the_running_sum_derivative_equals_the_local_line_slope_over_a_long_record() {
        // 2 million samples at 200 Hz: 10 000 s, where sums of t^2 would lose the window's spread.
        let t: Vec<f64> = (0..2_000_000).map(|i| 10.0 + i as f64 * 0.005).collect();
        let d: Vec<f64> = t.iter().map(|t| (1.3 * t).sin()).collect();
        let v = velocity(&t, &d, &vec![5; t.len()]);
        for i in [0usize, 3, 250, 1023, 1024, 1_999_990, 1_999_999] {
            let slope = line_slope(&t, &d, i.saturating_sub(5), (i + 5).min(1_999_999));
            assert!((v[i] - slope).abs() < 1e-6, "{i}: {} vs {slope}", v[i]);
        }
    }

    #[test]
    fn a_window_that_changes_width_is_still_the_local_line_slope() {
        // Widths that grow and shrink by several samples from one sample to the next.
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 0.004 + 0.0005 * ((i * 7) % 3) as f64).collect();
        let d: Vec<f64> = t.iter().map(|t| (2.1 * t).sin() + 0.3 * (9.0 * t).cos()).collect();
        let half: Vec<usize> = (0..3000).map(|i| [2, 9, 25, 4, 13][(i / 37) % 5]).collect();
        let v = velocity(&t, &d, &half);
        for i in (0..3000usize).step_by(7) {
            let slope = line_slope(&t, &d, i.saturating_sub(half[i]), (i + half[i]).min(2999));
            assert!((v[i] - slope).abs() < 1e-6, "{i}: {} vs {slope}", v[i]);
        }
    }

    #[test]
    fn the_window_follows_the_local_motion() {
        // Strokes of 1000 samples (a period of 2000, capped by the fundamental's 1000: a
        // window of +-20), then of 50 (+-2); after the last reversal the fundamental's.
        let reversals = [0, 1000, 2000, 2050, 2100, 2150];
        let half = velocity_half_widths(2300, &reversals, 1000.0, VELOCITY_WINDOWS_PER_PERIOD, [NARROWEST_RATE_WINDOW, 100]);
        assert_eq!((half[500], half[1500], half[2020], half[2120], half[2200]), (20, 20, 2, 2, 20));
    }

    #[test]
    fn the_blocks_tile_every_segment_in_order_none_empty() {
        for lengths in [vec![1], vec![2], vec![RATE_BLOCK], vec![RATE_BLOCK + 1], vec![3 * RATE_BLOCK + 1, 1, 5, RATE_BLOCK - 1], vec![1, 1, 1]] {
            let n: usize = lengths.iter().sum();
            let starts: Vec<usize> = lengths.iter().scan(0, |at, len| Some(std::mem::replace(at, *at + len))).collect();
            let blocks = rate_blocks(&starts, n, &vec![20; n]);
            let mut next = 0;
            for (own, read) in &blocks {
                assert!(own.start == next && !own.is_empty() && read.start <= own.start && read.end >= own.end, "{lengths:?}: {blocks:?}");
                // Never read across a segment's start.
                assert!(starts.iter().all(|s| !(read.start < *s && *s < read.end) || (own.start < *s && *s < own.end) || *s == own.start), "{lengths:?}: {blocks:?}");
                next = own.end;
            }
            assert_eq!(next, n, "{lengths:?}");
        }
    }

    #[test]
    fn segments_in_blocks_read_the_rate_each_whole_segment_gives() {
        // Three segments (gaps between them): a long one of several blocks and one sample more
        // (a last block of one sample, which still has a rate), a short one, and one of a single
        // sample (no rate).
        let q = std::f64::consts::TAU / 16384.0;
        let long = 3 * RATE_BLOCK + 1;
        let mut t: Vec<f64> = (0..long).map(|i| i as f64 * 1e-3).collect();
        t.extend((0..3000).map(|i| 100.0 + i as f64 * 1e-3));
        t.push(200.0);
        let d: Vec<f64> = t.iter().map(|t| ((0.05 * (1.3 * t).sin() + 0.002 * (17.0 * t).sin()) / q).round() * q).collect();
        let starts = [0, long, long + 3000];
        let half = velocity_half_widths(d.len(), &crate::identify::causes::reversals(&d), 5000.0, VELOCITY_WINDOWS_PER_PERIOD, [NARROWEST_RATE_WINDOW, 100]);
        let noise = DeflectionNoise { quantum_rad: q, scatter_rad: q / 12f64.sqrt() };
        let shared = velocity_by_segment(&t, &d, &starts, noise, &[1.0], &half).remove(0);
        let mut whole = adaptive_velocity(&t[..long], &d[..long], noise, &[1.0], &half[..long]).remove(0);
        assert!(whole[long - 1] != 0.0);
        whole.extend(adaptive_velocity(&t[long..long + 3000], &d[long..long + 3000], noise, &[1.0], &half[long..long + 3000]).remove(0));
        whole.push(0.0);
        assert_eq!(shared.len(), whole.len());
        let worst = whole.iter().zip(&shared).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "{worst}");
    }

    #[test]
    fn a_long_segment_in_blocks_reads_the_rate_the_whole_segment_gives() {
        // 2.5 blocks of a 14-bit sine with a burst of fast motion across a block's edge.
        let n = RATE_BLOCK * 5 / 2;
        let q = std::f64::consts::TAU / 16384.0;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let edge = RATE_BLOCK as f64 * 1e-3;
        let d: Vec<f64> = t.iter().map(|t| ((0.05 * (1.3 * t).sin() + 0.01 * (40.0 * t).sin() * (-(t - edge).powi(2)).exp()) / q).round() * q).collect();
        let half = velocity_half_widths(n, &crate::identify::causes::reversals(&d), 5000.0, VELOCITY_WINDOWS_PER_PERIOD, [NARROWEST_RATE_WINDOW, 100]);
        let noise = DeflectionNoise { quantum_rad: q, scatter_rad: q / 12f64.sqrt() };
        let (whole, blocks) = (adaptive_velocity(&t, &d, noise, &[1.0], &half).remove(0), velocity_by_segment(&t, &d, &[0], noise, &[1.0], &half).remove(0));
        assert_eq!(whole.len(), blocks.len());
        let worst = whole.iter().zip(&blocks).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "{worst}");
    }

    /// Readings whose windows are the same, read together, are each the rate read alone, bit
    /// for bit: the usual and the sharper readings that identify screens share the ladder.
    #[test]
    fn readings_read_together_are_each_the_rate_read_alone() {
        let n = RATE_BLOCK * 5 / 2;
        let q = std::f64::consts::TAU / 16384.0;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3 + if i > n / 2 { 0.5 } else { 0.0 }).collect();
        // A triangle (its rate turns in a sample: the sharper readings differ there).
        let d: Vec<f64> = t.iter().map(|t| ((0.05 * (2.0 * (0.7 * t).fract() - 1.0).abs() + 0.001 * (9.0 * t).sin()) / q).round() * q).collect();
        let starts = super::super::segment_starts(&t);
        let half = velocity_half_widths(n, &crate::identify::causes::reversals(&d), 1400.0, VELOCITY_WINDOWS_PER_PERIOD, [NARROWEST_RATE_WINDOW, 100]);
        let noise = DeflectionNoise { quantum_rad: q, scatter_rad: q / 12f64.sqrt() };
        let scales = [1.0, 0.5, 0.25];
        let together = velocity_by_segment(&t, &d, &starts, noise, &scales, &half);
        for (k, scale) in scales.iter().enumerate() {
            assert_eq!(together[k], velocity_by_segment(&t, &d, &starts, noise, &[*scale], &half).remove(0), "reading {k}");
        }
        // The readings differ: each was read with its own intervals.
        assert!(together[0] != together[2]);
    }
}
