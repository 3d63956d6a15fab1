//! A line in the residual while the joint is at rest: a vibration's frequency where no model
//! error of the motion can make one.
//!
//! The band a mode is looked for in over the moving record ([`super::spectrum::band`]) starts
//! at four times the excitation's fundamental: below it lie the model's periodic errors, which
//! recur with the motion and so predict the held-out part as a mode would. Under a fast
//! excitation that band leaves out real modes: on the blind generator (seed 44's 056) a steady
//! 11.7 Hz vibration of 0.49 Nm under a 4.2 Hz excitation lay below the band's 16.8 Hz, a
//! spurious 18.8 Hz line was taken instead, and no cause was named at 2.7 times the noise floor,
//! although the record ended in a 6 s hold where the vibration was alone with the noise. A joint
//! at rest makes no error of the motion: a line there is a vibration whatever its frequency.

use super::numeric::{median_step, refine_log};
use super::spectrum::{forward_fft, projection};

/// Stops scanned are at least this long on the part scanned [s] (an assumption: a second holds
/// [`REST_LINE_CYCLES`] cycles from 4 Hz up, and shorter stops are mostly the settling after a
/// move).
const REST_LINE_MIN_STOP_S: f64 = 1.0;

/// A line at rest is looked for from this many cycles within the shortest stop scanned up (an
/// assumption: fewer, and a stop's settling or drift is a slow line of its own).
const REST_LINE_CYCLES: f64 = 4.0;

/// The scan's false-alarm probability over all the frequencies it resolves (an assumption: a
/// candidate only, which must still earn its place by BIC and on the held-out part; 0.1 %, the
/// level of the project's held-out tests).
const REST_LINE_FALSE_ALARM: f64 = 1e-3;

/// A line found at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RestLine {
    /// Its frequency [Hz].
    pub frequency_hz: f64,
    /// How many frequencies the scan resolves (the look-elsewhere count it adds).
    pub resolvable: f64,
}

/// The strongest line of the residual `r` (time stamps `t` [s], increasing) over the samples
/// inside the `stops` (`(start, end)` [s], the joint at rest), when it stands out of the noise:
/// each stop's samples less their mean (a stop holds whatever torque its friction holds), each
/// stop's periodogram normalised by its own variance and summed over the stops (no phase is
/// assumed between stops: a record of repetitions restarts its time), the peak tested against
/// the sum's tail under white noise over every frequency resolved, and refined on the exact
/// projections. `None` without a stop of [`REST_LINE_MIN_STOP_S`] on these samples, or without
/// a line that stands out.
pub(crate) fn line_at_rest(t: &[f64], r: &[f64], stops: &[(f64, f64)]) -> Option<RestLine> {
    let pieces: Vec<(usize, usize)> = stops
        .iter()
        .map(|(a, b)| (t.partition_point(|x| *x < *a), t.partition_point(|x| *x <= *b)))
        .filter(|(i, j)| j > i && j - i >= 16 && t[j - 1] - t[*i] >= REST_LINE_MIN_STOP_S)
        .collect();
    if pieces.is_empty() {
        return None;
    }
    let dt = median_step(&t[pieces[0].0..pieces[0].1]);
    let shortest = pieces.iter().map(|(i, j)| t[j - 1] - t[*i]).fold(f64::INFINITY, f64::min);
    let longest = pieces.iter().map(|(i, j)| t[j - 1] - t[*i]).fold(0.0, f64::max);
    let (lo, hi) = (REST_LINE_CYCLES / shortest, (0.5 / dt).min(200.0) * 0.9);
    if !(dt > 0.0 && hi > lo) {
        return None;
    }
    // Each stop on the grid of that step (its nearest slot), less its mean; its variance.
    let demeaned: Vec<(Vec<f64>, Vec<f64>, f64)> = pieces
        .iter()
        .map(|(i, j)| {
            let mean = r[*i..*j].iter().sum::<f64>() / (j - i) as f64;
            let y: Vec<f64> = r[*i..*j].iter().map(|x| x - mean).collect();
            let var = y.iter().map(|x| x * x).sum::<f64>() / y.len() as f64;
            (t[*i..*j].to_vec(), y, var)
        })
        .filter(|(_, _, var)| *var > 0.0)
        .collect();
    if demeaned.is_empty() {
        return None;
    }
    let slots = (longest / dt).round() as usize + 1;
    let size = (4 * slots).next_power_of_two();
    let fft = forward_fft(size);
    let mut power = vec![0.0; size / 2 + 1];
    for (ts, y, var) in &demeaned {
        let mut buffer = vec![rustfft::num_complex::Complex::new(0.0, 0.0); size];
        for (x, v) in ts.iter().zip(y) {
            let slot = ((x - ts[0]) / dt).round() as usize;
            if slot < size {
                buffer[slot].re += *v;
            }
        }
        fft.process(&mut buffer);
        let scale = 1.0 / (y.len() as f64 * var);
        for (p, b) in power.iter_mut().zip(&buffer) {
            *p += b.norm_sqr() * scale;
        }
    }
    let bin_hz = 1.0 / (size as f64 * dt);
    let (first, last) = ((lo / bin_hz).ceil() as usize, ((hi / bin_hz).floor() as usize).min(size / 2));
    let peak = (first..=last).filter(|k| *k < power.len()).max_by(|a, b| power[*a].total_cmp(&power[*b]))?;
    // Under white noise each stop's normalised ordinate is about exponential with mean 1, their
    // sum over the stops a gamma of that many; its tail over the frequencies resolved.
    let resolvable = ((hi - lo) * longest).max(1.0);
    if resolvable * gamma_tail(demeaned.len(), power[peak]) > REST_LINE_FALSE_ALARM {
        return None;
    }
    let exact = |f: f64| {
        let w = std::f64::consts::TAU * f;
        demeaned.iter().map(|(ts, y, var)| {
            let (s, c) = projection(ts, y, w, false);
            (s * s + c * c) / (y.len() as f64 * var)
        }).sum::<f64>()
    };
    let centre = peak as f64 * bin_hz;
    let frequency_hz = refine_log(|f| -exact(f), (centre - bin_hz).max(0.5 * lo), centre + bin_hz, 30);
    Some(RestLine { frequency_hz, resolvable })
}

/// `P(X > x)` for `X` a sum of `k` unit exponentials (a gamma of shape `k`):
/// `exp(-x) sum_{i < k} x^i / i!`.
fn gamma_tail(k: usize, x: f64) -> f64 {
    let (mut term, mut sum) = (1.0, 1.0);
    for i in 1..k {
        term *= x / i as f64;
        sum += term;
    }
    (-x).exp() * sum
}

#[cfg(test)]
mod tests {
    use super::{gamma_tail, line_at_rest};

    /// A record at 500 Hz: 8 s of motion whose residual carries lines at 8.4 and 12.6 Hz (a
    /// model's errors at harmonics), then a 5 s stop that holds 0.3 Nm with an 11.7 Hz line
    /// beside noise.
    fn record(line_nm: f64, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<(f64, f64)>) {
        let mut state = seed;
        let mut noise = move || {
            // Sum of uniforms: near Gaussian, unit variance.
            (0..12).map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            }).sum::<f64>() - 6.0
        };
        let tau = std::f64::consts::TAU;
        let t: Vec<f64> = (0..6500).map(|i| i as f64 * 0.002).collect();
        let r = t.iter().map(|t| {
            let at_rest = *t >= 8.0;
            let motion = if at_rest { 0.3 } else { 0.4 * (tau * 8.4 * t).sin() + 0.3 * (tau * 12.6 * t).cos() };
            motion + line_nm * (tau * 11.7 * t + 0.4).sin() + 0.1 * noise()
        }).collect();
        (t, r, vec![(8.0, 13.0)])
    }

    #[test]
    fn a_line_at_rest_is_found_and_noise_at_rest_gives_none() {
        for seed in 1..=5 {
            let (t, r, stops) = record(0.1, seed);
            let found = line_at_rest(&t, &r, &stops).expect("a line at rest");
            assert!((found.frequency_hz - 11.7).abs() < 0.02, "seed {seed}: {found:?}");
            let (t, r, stops) = record(0.0, seed);
            assert_eq!(line_at_rest(&t, &r, &stops), None, "seed {seed}");
        }
    }

    #[test]
    fn stops_shorter_than_a_second_are_not_scanned() {
        let (t, r, _) = record(0.1, 1);
        assert_eq!(line_at_rest(&t, &r, &[(8.0, 8.8)]), None);
        assert_eq!(line_at_rest(&t, &r, &[]), None);
    }

    #[test]
    fn the_gamma_tail_is_the_exponential_for_one_stop() {
        assert!((gamma_tail(1, 3.0) - (-3.0f64).exp()).abs() < 1e-15);
        // Shape 2: exp(-x) (1 + x).
        assert!((gamma_tail(2, 3.0) - 4.0 * (-3.0f64).exp()).abs() < 1e-15);
    }
}
