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
use super::spectrum::{forward_fft, projection, uniform};

/// Runs at rest scanned are at least this long [s] (an assumption: a second holds
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

/// A step this many times the run's median parts it (an assumption: a jittering log's steps
/// stay within it, a piece's end or a logger's pause does not).
const GAP_STEPS: f64 = 4.0;

/// A line found at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RestLine {
    /// Its frequency [Hz].
    pub frequency_hz: f64,
    /// How many frequencies the scan resolves (the look-elsewhere count it adds).
    pub resolvable: f64,
}

/// The strongest line of the residual `r` over samples at rest (time stamps `t` [s], increasing,
/// in runs: a step of more than [`GAP_STEPS`] times a run's median parts it), when it stands out
/// of the noise: each run less its mean (a stop holds whatever torque its friction holds), each
/// run's periodogram normalised by its own variance and summed over the runs (no phase is
/// assumed between runs: a record of repetitions restarts its time), the peak tested against
/// the sum's tail under white noise over every frequency resolved, and refined on the exact
/// projections. `None` without a run of [`REST_LINE_MIN_STOP_S`], or without a line that
/// stands out.
pub(crate) fn line_at_rest(t: &[f64], r: &[f64]) -> Option<RestLine> {
    // The runs: evenly sampled, so a run's periodogram needs no more slots than samples.
    let mut pieces: Vec<(usize, usize)> = Vec::new();
    if t.len() >= 2 {
        let gap = GAP_STEPS * median_step(t);
        let mut start = 0;
        for m in 1..=t.len() {
            if m == t.len() || !(t[m] - t[m - 1] <= gap) {
                pieces.push((start, m));
                start = m;
            }
        }
    }
    pieces.retain(|(i, j)| j - i >= 16 && t[j - 1] - t[*i] >= REST_LINE_MIN_STOP_S);
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
    // Each run on the grid of that step (its nearest slot), less its mean; its variance.
    let demeaned: Vec<(Vec<f64>, Vec<f64>, f64, bool)> = pieces
        .iter()
        .map(|(i, j)| {
            let mean = r[*i..*j].iter().sum::<f64>() / (j - i) as f64;
            let y: Vec<f64> = r[*i..*j].iter().map(|x| x - mean).collect();
            let var = y.iter().map(|x| x * x).sum::<f64>() / y.len() as f64;
            (t[*i..*j].to_vec(), y, var, uniform(&t[*i..*j]))
        })
        .filter(|(_, _, var, _)| *var > 0.0)
        .collect();
    if demeaned.is_empty() {
        return None;
    }
    let slots = (longest / dt).round() as usize + 1;
    let size = (4 * slots).next_power_of_two();
    let fft = forward_fft(size);
    let mut power = vec![0.0; size / 2 + 1];
    for (ts, y, var, _) in &demeaned {
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
    // Under white noise each run's normalised ordinate is about exponential with mean 1, their
    // sum over the runs a gamma of that many; its tail over the frequencies resolved.
    let resolvable = ((hi - lo) * longest).max(1.0);
    if resolvable * gamma_tail(demeaned.len(), power[peak]) > REST_LINE_FALSE_ALARM {
        return None;
    }
    let exact = |f: f64| {
        let w = std::f64::consts::TAU * f;
        demeaned.iter().map(|(ts, y, var, even)| {
            let (s, c) = projection(ts, y, w, *even);
            (s * s + c * c) / (y.len() as f64 * var)
        }).sum::<f64>()
    };
    let centre = peak as f64 * bin_hz;
    let frequency_hz = refine_log(|f| -exact(f), (centre - bin_hz).max(0.5 * lo), centre + bin_hz, 30);
    Some(RestLine { frequency_hz, resolvable })
}

/// Whether the line at `frequency_hz` stands out of the residual `r` (time stamps `t`) over
/// the neighbouring frequencies: its power above [`STANDS_OUT`] times their mean, the
/// neighbours those from 3 to 30 resolutions either side. A steady vibration found at rest runs
/// through the motion too; a "stop" that is a motion slower than one encoder count per 0.1 s
/// moves the torque within a count and makes lines at rest that the moving record does not
/// carry (blind seed 3's 010, a hysteresis record: a line of 3.5 Hz at rest, none beside the
/// motion's errors).
pub(crate) fn stands_out(t: &[f64], r: &[f64], frequency_hz: f64) -> bool {
    if t.len() < 16 {
        return false;
    }
    let even = uniform(t);
    let resolution = 1.0 / (t[t.len() - 1] - t[0]);
    let power = |f: f64| {
        let (s, c) = projection(t, r, std::f64::consts::TAU * f, even);
        s * s + c * c
    };
    let neighbours: Vec<f64> = (3..=30).flat_map(|k| [frequency_hz - k as f64 * resolution, frequency_hz + k as f64 * resolution]).filter(|f| *f > 0.0).map(power).collect();
    let mean = neighbours.iter().sum::<f64>() / neighbours.len().max(1) as f64;
    power(frequency_hz) > STANDS_OUT * mean
}

/// How far above its neighbours' mean a line's power must be (an assumption: an exponential
/// ordinate exceeds its mean this many times with a probability of 0.1 %, `ln 1000`).
const STANDS_OUT: f64 = 6.9;

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

    /// A 5 s stop at 500 Hz that holds 0.3 Nm with an 11.7 Hz line beside noise.
    fn record(line_nm: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut state = seed;
        let mut noise = move || {
            // Sum of uniforms: near Gaussian, unit variance.
            (0..12).map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            }).sum::<f64>() - 6.0
        };
        let tau = std::f64::consts::TAU;
        let t: Vec<f64> = (4000..6500).map(|i| i as f64 * 0.002).collect();
        let r = t.iter().map(|t| 0.3 + line_nm * (tau * 11.7 * t + 0.4).sin() + 0.1 * noise()).collect();
        (t, r)
    }

    #[test]
    fn a_line_at_rest_is_found_and_noise_at_rest_gives_none() {
        for seed in 1..=5 {
            let (t, r) = record(0.1, seed);
            let found = line_at_rest(&t, &r).expect("a line at rest");
            assert!((found.frequency_hz - 11.7).abs() < 0.02, "seed {seed}: {found:?}");
            let (t, r) = record(0.0, seed);
            assert_eq!(line_at_rest(&t, &r), None, "seed {seed}");
        }
    }

    #[test]
    fn a_stop_seen_in_pieces_is_scanned_run_by_run() {
        // The stop's samples in two runs 100 s apart (two stops, or a restart): each is read on
        // its own, and the line found as in one run.
        let (t, r) = record(0.1, 2);
        let (mut t2, mut r2) = (t[..1250].to_vec(), r[..1250].to_vec());
        t2.extend(t[1250..].iter().map(|x| x + 100.0));
        r2.extend(&r[1250..]);
        let found = line_at_rest(&t2, &r2).expect("a line at rest");
        assert!((found.frequency_hz - 11.7).abs() < 0.05, "{found:?}");
    }

    #[test]
    fn runs_shorter_than_a_second_are_not_scanned() {
        let (t, r) = record(0.1, 1);
        // Runs of 0.8 s, 100 s apart.
        let t2: Vec<f64> = t.iter().enumerate().map(|(i, x)| x + 100.0 * (i / 400) as f64).collect();
        assert_eq!(line_at_rest(&t2, &r), None);
        assert_eq!(line_at_rest(&[], &[]), None);
    }

    #[test]
    fn a_line_stands_out_of_its_neighbours_and_noise_does_not() {
        let (t, r) = record(0.1, 3);
        assert!(super::stands_out(&t, &r, 11.7));
        let (t, r) = record(0.0, 3);
        assert!(!super::stands_out(&t, &r, 11.7));
    }

    #[test]
    fn the_gamma_tail_is_the_exponential_for_one_stop() {
        assert!((gamma_tail(1, 3.0) - (-3.0f64).exp()).abs() < 1e-15);
        // Shape 2: exp(-x) (1 + x).
        assert!((gamma_tail(2, 3.0) - 4.0 * (-3.0f64).exp()).abs() < 1e-15);
    }
}
