//! A slow log's deflection rate through a local cubic (see [`cubic_rate_by_segment`]).

use crate::identify::numeric::segment_ranges;

/// Samples either side of the cubic a slow log's rate may be read through (see
/// [`cubic_rate_by_segment`]).
const CUBIC_HALF_WIDTH: usize = 2;

/// A slow log's deflection rate read through a local cubic: at each sample, the slope of the
/// least-squares cubic through the [`CUBIC_HALF_WIDTH`] samples either side (fewer at a
/// segment's ends: a quadratic through four, a line through two or three), segment by segment.
/// On evenly spaced samples this is the fourth-order central difference
/// `(8 (d[i+1] - d[i-1]) - (d[i+2] - d[i-2])) / 12 dt`.
///
/// Why: a log of bin means (`jointctl record`'s 20 Hz, a rig's averaged channel) holds the
/// deflection's means over each interval, and a bin's viscous torque is the damping times the
/// deflection's change over the interval over its length. That change is known to fourth
/// order from the means, by the same stencil: the cumulative integral of the deflection is
/// known exactly at the interval edges, and the rate's mean is its second difference there. A
/// least-squares line through five samples reads a 2 Hz motion at 20 Hz 15 % slow, a central
/// difference 6.5 % slow, this stencil 0.5 %. On the blind devices' 20 Hz means, each viscous
/// damping came out 5-18 % above its full-rate variants and its truth.
pub(super) fn cubic_rate_by_segment(t: &[f64], d: &[f64], starts: &[usize]) -> Vec<f64> {
    let n = d.len();
    let mut v = vec![0.0; n];
    for std::ops::Range { start: a, end: b } in segment_ranges(starts, n) {
        for i in a..b {
            let (lo, hi) = (i.saturating_sub(CUBIC_HALF_WIDTH).max(a), (i + CUBIC_HALF_WIDTH + 1).min(b));
            v[i] = local_slope(&t[lo..hi], &d[lo..hi], t[i]);
        }
    }
    v
}

/// The slope at `at` of the least-squares polynomial through the points (`t`, `d`): a cubic
/// through five or more, a quadratic through four, a line through two or three; 0 for one.
fn local_slope(t: &[f64], d: &[f64], at: f64) -> f64 {
    let m = t.len();
    if m < 2 {
        return 0.0;
    }
    let degree = match m {
        2 | 3 => 1,
        4 => 2,
        _ => 3,
    };
    // Time about `at`, in units of the window's spread (a well-scaled system).
    let scale = (t[m - 1] - t[0]).max(1e-300) / 2.0;
    let x: Vec<f64> = t.iter().map(|v| (v - at) / scale).collect();
    let k = degree + 1;
    let gram = nalgebra::DMatrix::from_fn(k, k, |r, c| x.iter().map(|v| v.powi((r + c) as i32)).sum::<f64>());
    let right = nalgebra::DVector::from_fn(k, |r, _| x.iter().zip(d).map(|(v, y)| v.powi(r as i32) * y).sum::<f64>());
    gram.lu().solve(&right).map_or(0.0, |c| c[1] / scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cubic_through_five_even_samples_is_the_fourth_order_difference() {
        let t: Vec<f64> = (0..9).map(|i| i as f64 * 0.05).collect();
        let d: Vec<f64> = t.iter().map(|t| (3.0 * t).sin() + 0.2 * t * t).collect();
        let v = cubic_rate_by_segment(&t, &d, &[0]);
        for i in 2..7 {
            let stencil = (8.0 * (d[i + 1] - d[i - 1]) - (d[i + 2] - d[i - 2])) / (12.0 * 0.05);
            assert!((v[i] - stencil).abs() < 1e-9, "{i}: {} vs {stencil}", v[i]);
        }
        // A cubic's own rate, exactly, at the ends too (fewer samples, lower degree: a quadratic
        // and a line are exact on a line).
        let line: Vec<f64> = t.iter().map(|t| 0.3 - 2.0 * t).collect();
        assert!(cubic_rate_by_segment(&t, &line, &[0]).iter().all(|v| (v + 2.0).abs() < 1e-9));
    }

    /// Bin means of a 2 Hz sine at 20 Hz: the rate of their interval (the deflection's change
    /// over it, over its length) read through the cubic within 1 %, through the usual
    /// least-squares line over two samples either side 15 % slow.
    #[test]
    fn the_rate_of_bin_means_is_read_through_the_cubic_at_its_interval() {
        use std::f64::consts::TAU;
        let (f, bin) = (2.0, 0.05);
        let mean = |a: f64| (-(TAU * f * (a + bin)).cos() + (TAU * f * a).cos()) / (TAU * f * bin);
        let t: Vec<f64> = (0..200).map(|i| i as f64 * bin).collect();
        let d: Vec<f64> = t.iter().map(|a| mean(*a)).collect();
        let truth: Vec<f64> = t.iter().map(|a| ((TAU * f * (a + bin)).sin() - (TAU * f * a).sin()) / bin).collect();
        let cubic = cubic_rate_by_segment(&t, &d, &[0]);
        let line = super::super::rate::velocity(&t, &d, &vec![2; t.len()]);
        let rms = |v: &[f64]| (v[5..195].iter().zip(&truth[5..195]).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / truth[5..195].iter().map(|b| b * b).sum::<f64>()).sqrt();
        assert!(rms(&cubic) < 0.01, "cubic {}", rms(&cubic));
        assert!(rms(&line) > 0.1, "line {}", rms(&line));
    }
}
