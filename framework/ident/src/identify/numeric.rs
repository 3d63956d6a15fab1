//! Numerical helpers of the search that know nothing of causes or models: a log-spaced grid,
//! a golden-section minimum on a log scale, a mean over an interval, a series' segments, a
//! first-order lag on any time stamps, and how a report prints a value. A leaf: every other module of `identify` may use it.

/// A log-spaced grid of `n` values from `lo` to `hi` (both > 0).
pub fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n < 2 {
        return vec![lo];
    }
    (0..n).map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64)).collect()
}

/// `x` through a first-order lag of time constant `tau` [s] (`y' = (x - y) / tau`), exact for
/// an input that runs between the samples at times `t` (any steps) along the cubic through the
/// two samples with their rates ([`sample_rates`]). Between samples far apart a line is a
/// low-pass of its own, and the lag fitted through it comes out short: a spring's torque behind
/// a 62 ms transport delay and a 22.4 ms lag, 14-bit deflection, read from its 20 Hz bins as a
/// lag of 9.3 ms, 22.1 ms at full rate; along the cubic 20.1 ms (noise-free, the line's output
/// was 0.12 Nm off the bins of the lagged torque of 5 Nm, the cubic's 0.03). It starts, and
/// starts again after a step wider than `max_step` (a logging gap, a join of parts) and at the
/// sorted indices `starts` (pieces that do not follow on), as `from` says: settled, as if the
/// input had run along its line over the next `tau` for long: that slope times `tau` behind the
/// input. What came before is not known here, and a part that starts where the input bends
/// starts off (a 3.7 Hz sine through a 40 ms lag: 1.5 Nm, gone within `5 tau`). Started at the
/// input instead, a spring's column on a part that starts in motion began `K v tau` off; along
/// its first step's slope, a quantised deflection's one count in a millisecond put a held-out
/// part's first 0.2 s 7 Nm off; along a parabola fitted over `2 tau`, the searched delays' fits
/// were worse.
pub(crate) fn lagged(t: &[f64], x: &[f64], tau: f64, max_step: f64, starts: &[usize], from: LagStart) -> Vec<f64> {
    let n = x.len().min(t.len());
    // Whether sample i + 1 follows on from sample i: no gap and no start marked there.
    let within = |i: usize| i + 1 < n && t[i + 1] - t[i] > 0.0 && t[i + 1] - t[i] <= max_step && starts.binary_search(&(i + 1)).is_err();
    let settled = |i: usize| {
        let mut j = i;
        while within(j) && (j == i || t[j + 1] - t[i] <= tau) {
            j += 1;
        }
        if j > i { x[i] - tau * (x[j] - x[i]) / (t[j] - t[i]) } else { x[i] }
    };
    let rates = sample_rates(t, &x[..n], &within);
    let mut out = Vec::with_capacity(n);
    let mut y = 0.0;
    for i in 0..n {
        let (rate_before, rate_here) = (if i > 0 { rates[i - 1] } else { 0.0 }, rates[i]);
        y = if i > 0 && within(i - 1) {
            // Over the step the input is the cubic `a + b s + c s^2 + d s^3` (s from t[i-1]);
            // the lag follows it along `u - tau u' + tau^2 u'' - tau^3 u'''` (exact for a
            // cubic), and its distance from that curve decays.
            let h = t[i] - t[i - 1];
            let chord = (x[i] - x[i - 1]) / h;
            let c = (3.0 * chord - 2.0 * rate_before - rate_here) / h;
            let d = (rate_before + rate_here - 2.0 * chord) / (h * h);
            let (tau2, tau3) = (tau * tau, tau * tau * tau);
            let follow_start = x[i - 1] - tau * rate_before + tau2 * 2.0 * c - tau3 * 6.0 * d;
            let follow_end = x[i] - tau * rate_here + tau2 * (2.0 * c + 6.0 * d * h) - tau3 * 6.0 * d;
            follow_end + (y - follow_start) * (-h / tau).exp()
        } else {
            match from {
                LagStart::Settled => settled(i),
                LagStart::Zero => 0.0,
            }
        };
        out.push(y);
    }
    out
}

/// The rate of `x` at each sample for interpolating between the samples (not a physical rate
/// estimate: no smoothing against noise), where `within(i)` says that sample `i + 1` follows on
/// from sample `i`: the chord of its neighbours within the run (Catmull-Rom's), else the one step
/// it has on its run, zero alone. A five-point difference on equal steps was measured and not
/// taken: closer on a noise-free sine, but on the blind generator's 20 Hz bins of a delay behind
/// a 7-11 Hz low-pass it read the lag 22, 20 and 0 ms (device D of seeds 47, 59, 42; the chord
/// 21, 19 and 9, one run at full rate 26, 18 and 19), and 16.9 ms for the 22.4 of [`lagged`]'s
/// record (the chord 20.1).
fn sample_rates(t: &[f64], x: &[f64], within: &dyn Fn(usize) -> bool) -> Vec<f64> {
    let rate = |i: usize| {
        let back = i > 0 && within(i - 1);
        let (a, b) = (if back { i - 1 } else { i }, if within(i) { i + 1 } else { i });
        if b > a { (x[b] - x[a]) / (t[b] - t[a]) } else { 0.0 }
    };
    (0..x.len().min(t.len())).map(rate).collect()
}

/// Where [`lagged`] starts a run: settled on the input's line, or from zero (a ring, which is
/// zero before the reversal that starts it).
#[derive(Clone, Copy)]
pub(crate) enum LagStart {
    Settled,
    Zero,
}

/// Golden-section minimum of `f` over [lo, hi] on a log scale (both > 0).
pub(crate) fn refine_log(f: impl Fn(f64) -> f64, lo: f64, hi: f64, iterations: usize) -> f64 {
    let (mut a, mut b) = (lo.ln(), hi.ln());
    let g = 0.618_033_988_749_895;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c.exp()), f(d.exp()));
    for _ in 0..iterations {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c.exp());
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d.exp());
        }
    }
    (0.5 * (a + b)).exp()
}

/// The median step between time stamps [s], steps of zero left out: the sampling's own period
/// where a log jitters, gaps, or a part leaves stretches of the record out (the span over the
/// count would read those as slower sampling). 1 s when there is no step.
pub(crate) fn median_step(t: &[f64]) -> f64 {
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).filter(|s| *s > 0.0).collect();
    median(&mut steps).unwrap_or(1.0)
}

/// The index range of each segment of a series of `n` samples whose segments start at each of
/// `starts` (in order, the first 0, see `prepare::segment_starts`): from one start to the next,
/// the last to `n`.
pub(crate) fn segment_ranges(starts: &[usize], n: usize) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    starts.iter().enumerate().map(move |(k, &a)| {
        let b = starts.get(k + 1).copied().unwrap_or(n).min(n);
        a.min(b)..b
    })
}

/// The median of `values` (the upper one of an even count), by a partition that reorders them;
/// `None` when there are none.
pub(crate) fn median(values: &mut [f64]) -> Option<f64> {
    let mid = values.len() / 2;
    (!values.is_empty()).then(|| *values.select_nth_unstable_by(mid, f64::total_cmp).1)
}

/// A parameter's value as the reports print it: below 0.01 (and from 1e6) in scientific notation
/// with five significant figures, else with five decimals (a band of 2.2e-5 rad printed with five
/// decimals read 0.00002).
///
/// ```
/// assert_eq!(jointctl_ident::identify::format_value(2.2e-5), "2.2000e-5");
/// assert_eq!(jointctl_ident::identify::format_value(1.5), "1.50000");
/// ```
pub fn format_value(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-2 || v.abs() >= 1e6) { format!("{v:.4e}") } else { format!("{v:.5}") }
}

/// The mean of `f` over a sample's interval when the rate runs linearly from its start to the
/// sample's own rate `v` and on to its end (`edges` from `prepare::rate_edges`); `integral` is an
/// antiderivative of `f` in the rate. Halves shorter than `1e-9` rad/s take `f` at their middle.
pub(crate) fn interval_mean(f: impl Fn(f64) -> f64, integral: impl Fn(f64) -> f64, v: f64, edges: [f64; 2]) -> f64 {
    let half = |a: f64, b: f64| if (b - a).abs() < 1e-9 { f(0.5 * (a + b)) } else { (integral(b) - integral(a)) / (b - a) };
    0.5 * (half(v + edges[0], v) + half(v, v + edges[1]))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_mean_over_an_interval_where_the_rate_turns_is_not_the_value_at_its_mean() {
        // v^2 over a rate that runs -1 -> 0 -> 1: 1/3, not 0.
        let m = super::interval_mean(|v| v * v, |v| v * v * v / 3.0, 0.0, [-1.0, 1.0]);
        assert!((m - 1.0 / 3.0).abs() < 1e-12, "{m}");
        // An interval of one rate: the value there.
        assert_eq!(super::interval_mean(|v| v * v, |v| v * v * v / 3.0, 2.0, [0.0, 0.0]), 4.0);
    }

    #[test]
    fn a_lag_on_20_hz_bins_reads_the_bins_of_the_lagged_signal() {
        use super::{LagStart, lagged};
        // A 1 Hz sine through a 22.4 ms lag at 1 kHz, both binned to 20 Hz means: the lag on the
        // input's bins is the output's bins (the two commute). Along lines between the bins the
        // output was 0.0075 off (of 1), along the cubic 0.0009.
        let tau = 0.0224;
        let t: Vec<f64> = (0..10_000).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|t| (std::f64::consts::TAU * t).sin()).collect();
        let y = lagged(&t, &x, tau, 0.01, &[], LagStart::Settled);
        let bins = |v: &[f64]| -> Vec<f64> { v.chunks(50).map(|c| c.iter().sum::<f64>() / c.len() as f64).collect() };
        let (tb, xb, yb) = (bins(&t), bins(&x), bins(&y));
        let lagged_bins = lagged(&tb, &xb, tau, 0.5, &[], LagStart::Settled);
        let worst = lagged_bins.iter().zip(&yb).skip(20).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 0.002, "{worst}");
    }

    #[test]
    fn a_lag_follows_a_ramp_tau_behind_on_any_stamps_and_starts_again_after_a_gap() {
        use super::{LagStart, lagged};
        // A ramp on jittered stamps, a gap of a second in the middle: the lag's output is the
        // ramp 20 ms late from the first sample on, after the gap too.
        let mut t: Vec<f64> = (0..400).map(|i| i as f64 * 0.002 + if i % 3 == 0 { 0.0007 } else { 0.0 }).collect();
        t.iter_mut().skip(200).for_each(|x| *x += 1.0);
        let x: Vec<f64> = t.iter().map(|t| 0.5 * t).collect();
        let y = lagged(&t, &x, 0.02, 0.02, &[], LagStart::Settled);
        for i in 0..400 {
            assert!((y[i] - 0.5 * (t[i] - 0.02)).abs() < 1e-12, "{i}: {} for {}", y[i], 0.5 * (t[i] - 0.02));
        }
        // A sine through it, with a gap of 0.3 s and a start marked at 12 s: once the start's
        // transient is gone (10 tau), the output is the steady state
        // `sin(omega t - atan(omega tau)) / sqrt(1 + (omega tau)^2)`, its phase too; a zero start
        // begins at zero.
        let (tau, omega) = (0.05, std::f64::consts::TAU * 2.0);
        let t: Vec<f64> = (0..20_000).map(|i| i as f64 * 1e-3 + if i >= 8000 { 0.3 } else { 0.0 }).collect();
        let x: Vec<f64> = t.iter().map(|t| (omega * t).sin()).collect();
        let steady = |t: f64| (omega * t - (omega * tau).atan()).sin() / (1.0 + (omega * tau).powi(2)).sqrt();
        let y = lagged(&t, &x, tau, 0.01, &[12_000], LagStart::Settled);
        for start in [0, 8000, 12_000] {
            for i in start + 500..start + 4000 {
                assert!((y[i] - steady(t[i])).abs() < 1e-4, "{i}: {} for {}", y[i], steady(t[i]));
            }
        }
        let y = lagged(&t, &x, tau, 0.01, &[12_000], LagStart::Zero);
        assert!(y[0] == 0.0 && y[8000] == 0.0 && y[12_000] == 0.0);
        assert!((y[12_600] - steady(t[12_600])).abs() < 1e-4);
    }
}
