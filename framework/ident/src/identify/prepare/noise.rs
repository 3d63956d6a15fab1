//! How noisy a series is, from its own samples: the white part of the noise (the torque's floor)
//! and the scatter from sample to sample (the deflection's).

use crate::identify::numeric::segment_ranges;

/// The squared pseudo-residuals `(y[i-1] + y[i+1]) / 2 - y[i]` within each segment, scaled to
/// unit variance for white noise (a factor 2/3 on their mean square).
pub(super) fn pseudo_residual_squares(y: &[f64], starts: &[usize]) -> Vec<f64> {
    pseudo_residual_squares_of(y.len(), |i| y[i], starts)
}

/// [`pseudo_residual_squares`] of the series `y(i)` of `n` samples, each sample computed where
/// it is needed: a long record's residual is not held beside its squares (16 MB on 2 million
/// samples).
fn pseudo_residual_squares_of(n: usize, y: impl Fn(usize) -> f64, starts: &[usize]) -> Vec<f64> {
    let mut squares = Vec::with_capacity(n);
    for std::ops::Range { start: a, end: b } in segment_ranges(starts, n) {
        for i in a + 1..b.saturating_sub(1) {
            let e = 0.5 * (y(i - 1) + y(i + 1)) - y(i);
            squares.push(e * e / 1.5);
        }
    }
    squares
}

/// The noise floor of a series in time order [same unit]: Gasser, Sroka and Jennen-Steinmetz's
/// (1986) pseudo-residuals, `(y[i-1] + y[i+1]) / 2 - y[i]` scaled to unit variance for white
/// noise (a factor 2/3 on their mean square), within each segment; the median of the squares
/// over ln 2's quantile ratio (0.4549) makes it robust to the few steps where the signal itself
/// jumps (a reversal, a gap left inside a segment). A smooth signal sampled finely adds almost
/// nothing; what is left is the white part of the noise.
///
/// ```
/// use jointctl_ident::identify::prepare::noise_floor;
/// let t: Vec<f64> = (0..20_000).map(|i| i as f64 * 0.001).collect();
/// let mut rng = 12345u64;
/// let y: Vec<f64> = t.iter().map(|t| {
///     // Two uniforms summed: a noise of standard deviation 0.1 * sqrt(2 / 12).
///     let mut u = || { rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17; (rng % 1_000_000) as f64 / 1e6 };
///     10.0 * (3.0 * t).sin() + 0.1 * (u() + u() - 1.0)
/// }).collect();
/// let floor = noise_floor(&y, &[0]);
/// assert!((floor / (0.1 * (2.0f64 / 12.0).sqrt()) - 1.0).abs() < 0.1, "{floor}");
/// ```
pub fn noise_floor(y: &[f64], starts: &[usize]) -> f64 {
    noise_floor_of(y.len(), |i| y[i], starts)
}

/// [`noise_floor`] of the series `y(i)` of `n` samples, each computed where it is needed (see
/// [`pseudo_residual_squares_of`]).
pub(super) fn noise_floor_of(n: usize, y: impl Fn(usize) -> f64, starts: &[usize]) -> f64 {
    let mut squares = pseudo_residual_squares_of(n, y, starts);
    if squares.is_empty() {
        return 0.0;
    }
    floor_from_squares(&mut squares)
}

/// The floor from a non-empty set of scaled pseudo-residual squares: their median over a
/// chi-square's with one degree of freedom, which is 0.4549 times its mean.
fn floor_from_squares(squares: &mut [f64]) -> f64 {
    let mid = squares.len() / 2;
    (*squares.select_nth_unstable_by(mid, f64::total_cmp).1 / 0.4549).sqrt()
}

/// At least this many pseudo-residuals at rest before the floor read there counts (an
/// assumption: the median of that many squares gives the floor within about 16 %, one standard
/// error of a chi-square's median; neighbouring pseudo-residuals are correlated, so somewhat
/// more). 200 would be safer statistically, but a 20 Hz log's holds hold fewer: at 200 the five
/// 20 Hz records whose causes the floor at rest changed all went back to what they were.
pub(super) const REST_RESIDUALS: usize = 50;

/// How far the floor at rest must fall below the floor read over the whole record to replace
/// it (an assumption, as `bin_reading::FLOOR_FALL`: a fifth). At [`REST_RESIDUALS`] that is
/// about 1.3 of the estimate's standard errors, so a short hold can read low by chance and the
/// floor taken is then biased low: over the 374 slow logs with a generator's noise, 7 floors
/// below half of it against 2 before, none with a cause more.
pub(super) const REST_FLOOR_FALL: f64 = 0.8;

/// The torque's noise floor over the samples at rest only [Nm]: [`noise_floor`]'s
/// pseudo-residuals within each interval `stops` gives (index ranges, their ends excluded), none
/// across a step longer than `max_step_s`. `None` with fewer than [`REST_RESIDUALS`] of them.
/// Where the deflection holds, so does every modelled torque (a spring's, a loop's state, a
/// friction's stick), and what moves from sample to sample is the sensor's noise; in motion the
/// second differences also take the curvature of what the model misses between samples. On a
/// slow log that curvature is large: a 20 Hz log of 50 ms means (blind devices 51's device C, a
/// dead zone) read a floor of 0.058 Nm for the generator's 0.0049, and "no cause" was said at
/// "1.3 times the noise floor" over a held-out error 15.6 times the noise.
/// Assumed: the sensor's noise is the same at rest as in motion. One noisier in motion (a
/// gear's or a motor's ripple) reads a floor too low here, and more causes pass as relevant.
pub(super) fn floor_at_rest(t: &[f64], y: &[f64], stops: &[std::ops::Range<usize>], max_step_s: f64) -> Option<f64> {
    let mut squares = Vec::new();
    for r in stops {
        for i in r.start + 1..r.end.min(y.len()).min(t.len()).saturating_sub(1) {
            if t[i] - t[i - 1] <= max_step_s && t[i + 1] - t[i] <= max_step_s {
                let e = 0.5 * (y[i - 1] + y[i + 1]) - y[i];
                squares.push(e * e / 1.5);
            }
        }
    }
    (squares.len() >= REST_RESIDUALS).then(|| floor_from_squares(&mut squares))
}

/// The share of Gasser, Sroka and Jennen-Steinmetz's pseudo-residuals (see [`noise_floor`])
/// that [`scatter_rms`] keeps: the smallest 90 % (an assumption: a slow log's corners between
/// holds and ramps, a few per cent of its samples, are bends, not scatter).
const SCATTER_KEPT: f64 = 0.9;

/// The mean of a normal variable's square over its central 90 %, as a share of its variance:
/// `1 - 2 z phi(z) / 0.9` at `z = 1.645`.
const SCATTER_TRIMMED_SHARE: f64 = 0.623;

/// The deflection's scatter about a line from sample to sample: the root mean square of the
/// smallest [`SCATTER_KEPT`] of the pseudo-residuals within each segment, scaled back to a
/// normal variable's standard deviation. Not the median: a deflection that is the difference of
/// two quantised encoders (an output encoder less a finer motor encoder through a gear ratio)
/// moves in steps of many sizes; the median of its pseudo-residuals is zero where it holds a
/// count, and its 2nd-percentile step (the resolution) 1.5e-5 rad on the elbow, where it
/// scatters ten times that. Not the whole mean either: the corners of a 20 Hz log's holds and
/// ramps are bends of the motion, and taken as scatter they widened every window again.
pub(super) fn scatter_rms(y: &[f64], starts: &[usize]) -> f64 {
    let mut squares = pseudo_residual_squares(y, starts);
    if squares.is_empty() {
        return 0.0;
    }
    let keep = ((squares.len() as f64 * SCATTER_KEPT).ceil() as usize).clamp(1, squares.len());
    squares.select_nth_unstable_by(keep - 1, f64::total_cmp);
    (squares[..keep].iter().sum::<f64>() / keep as f64 / SCATTER_TRIMMED_SHARE).sqrt()
}
