//! Deflection readings that leap away and come back within a few samples: an encoder's glitch
//! (a bit misread, a sample from another axis), found so that it is left out, never used as a
//! value. Read as it stood, one such leap of six counts for three samples of a 30 s record of a
//! viscous friction made its rate reading a spike that outweighed the record: identify named a
//! loop and a cubic in the viscous friction's place.

use crate::identify::numeric::segment_ranges;

/// The most samples a glitch lasts (an assumption: a misread is one or a few samples; a leap
/// that stays longer is a motion, or a fault the record shows as it is).
pub const MAX_GLITCH_SAMPLES: usize = 3;

/// The readings of `series` (one segment of contiguous logging) that leap from the reading before
/// them and are back within [`MAX_GLITCH_SAMPLES`], each farther from the line between the
/// readings either side of the run than its reading can be wrong and the signal can move: three
/// times the resolution `resolution`, six times the reading's noise `noise` (a normal noise goes
/// that far once in 10^9 samples), plus twice the motion's largest step: the largest rate
/// between two readings among the [`STEP_SAMPLES`] on each side times the run's longest step in
/// time (a peak of the motion itself, however coarsely sampled, lies within a step or two of its
/// neighbours' line; a first rule, the signal's mean step times the run's length, took the peaks
/// of 20 Hz bin averages for glitches, and one without time a reading between two gaps of
/// 0.2 s). All on one side of the line: a vibration's swing crosses it. `t`: the readings' times [s].
pub(super) fn glitches(series: &[f64], t: &[f64], resolution: f64, noise: f64) -> Vec<bool> {
    let n = series.len();
    let mut glitch = vec![false; n];
    // A run's first reading lies beyond the line by more than the reach (at least `least`), and
    // the line there from `before` by at most half the reach (the run is back within the reach,
    // over two steps or more): so it leaps from `before` by more than half of `least`. A reading
    // that does not is no run's start, and is passed over without the run's test (most of this
    // search's time on a smooth record: the test reads the rates on either side for each length).
    // A fifth of `least` below that, so that rounding in the test's line cannot matter.
    let least = 3.0 * resolution + 6.0 * noise;
    let leap = 0.4 * least;
    let mut i = 1;
    while i + 1 < n {
        if (series[i] - series[i - 1]).abs() <= leap {
            i += 1;
            continue;
        }
        if let Some(j) = run_back_from(series, t, i, resolution, noise) {
            glitch[i..j].iter_mut().for_each(|g| *g = true);
            i = j;
        } else {
            i += 1;
        }
    }
    glitch
}

/// The steps between readings looked at on each side of a run for the motion's largest (an
/// assumption: a few, the motion's own around the run).
const STEP_SAMPLES: usize = 5;

/// Where the readings from `i` on come back, `i + 1..=i + MAX_GLITCH_SAMPLES`, when they are a
/// glitch; `None` otherwise.
fn run_back_from(x: &[f64], t: &[f64], i: usize, resolution: f64, noise: f64) -> Option<usize> {
    let n = x.len();
    let before = x[i - 1];
    // The largest rate between two readings among the STEP_SAMPLES before the run, and after it.
    let largest_rate = |from: usize, to: usize| (from..to).map(|k| (x[k + 1] - x[k]).abs() / (t[k + 1] - t[k])).fold(0.0f64, f64::max);
    let rate_before = largest_rate((i - 1).saturating_sub(STEP_SAMPLES), i - 1);
    for j in i + 1..=(i + MAX_GLITCH_SAMPLES).min(n - 1) {
        let after = x[j];
        // The motion's largest step over the run's longest step in time: on regular samples the
        // largest step around it; over a gap, as far as the motion could go in it.
        let longest = (i - 1..j).map(|k| t[k + 1] - t[k]).fold(0.0f64, f64::max);
        let step = rate_before.max(largest_rate(j, (j + STEP_SAMPLES).min(n - 1))) * longest;
        let reach = 3.0 * resolution + 6.0 * noise + 2.0 * step;
        let span = (j - i + 1) as f64;
        // Each reading of the run against the line from `before` to `after`, all on one side.
        let beyond = |side: f64| (i..j).all(|k| side * (x[k] - (before + (after - before) * (k - i + 1) as f64 / span)) > reach);
        let one_side = beyond(1.0) || beyond(-1.0);
        // Back: `after` on the signal's line from `before`, not a level the signal moved to.
        if one_side && (after - before).abs() <= reach {
            return Some(j);
        }
    }
    None
}

/// [`glitches`] in each segment of contiguous logging apart (`starts` from
/// [`super::segment_starts`]): the reading before a gap is no neighbour of the one after it.
pub(super) fn glitches_by_segment(series: &[f64], t: &[f64], starts: &[usize], resolution: f64, noise: f64) -> Vec<bool> {
    segment_ranges(starts, series.len().min(t.len())).flat_map(|r| glitches(&series[r.clone()], &t[r], resolution, noise)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Times 1 ms apart.
    fn ms(n: usize) -> Vec<f64> {
        (0..n).map(|i| i as f64 * 1e-3).collect()
    }

    /// A slow ramp read by a 14-bit encoder, with readings 1000-1002 six counts up.
    fn ramp_with_leap(leap_counts: f64, run: usize) -> Vec<f64> {
        let q = std::f64::consts::TAU / 16384.0;
        let mut x: Vec<f64> = (0..3000).map(|i| ((1e-5 * i as f64) / q).round() * q).collect();
        x[1000..1000 + run].iter_mut().for_each(|v| *v += leap_counts * q);
        x
    }

    #[test]
    fn a_leap_that_comes_back_within_three_samples_is_a_glitch() {
        let q = std::f64::consts::TAU / 16384.0;
        for run in 1..=3 {
            let g = glitches(&ramp_with_leap(6.0, run), &ms(3000), q, 0.0);
            assert_eq!(g.iter().filter(|g| **g).count(), run, "run of {run}");
            assert!(g[1000..1000 + run].iter().all(|g| *g));
        }
        // Down as well as up.
        assert_eq!(glitches(&ramp_with_leap(-6.0, 2), &ms(3000), q, 0.0).iter().filter(|g| **g).count(), 2);
    }

    /// The readings passed over without the run's test are none that it would take for a run's
    /// start: on random walks with leaps of every size, steps in time with gaps, noise and
    /// resolutions, the glitches are those of the test tried at every reading.
    #[test]
    fn passing_over_small_steps_finds_what_the_test_at_every_reading_finds() {
        let at_every_reading = |x: &[f64], t: &[f64], resolution: f64, noise: f64| {
            let mut glitch = vec![false; x.len()];
            let mut i = 1;
            while i + 1 < x.len() {
                match run_back_from(x, t, i, resolution, noise) {
                    Some(j) => {
                        glitch[i..j].iter_mut().for_each(|g| *g = true);
                        i = j;
                    }
                    None => i += 1,
                }
            }
            glitch
        };
        let mut rng = jointctl_test_support::XorShift64::new(11);
        let mut found = 0;
        for _ in 0..200 {
            let resolution: f64 = [0.0, 2e-6, 3.8e-4][(rng.uniform() * 3.0) as usize % 3];
            let noise: f64 = [0.0, 1e-5, 1e-3][(rng.uniform() * 3.0) as usize % 3];
            let (mut x, mut t) = (vec![0.0], vec![0.0]);
            for _ in 1..2000 {
                let gap = if rng.uniform() < 0.01 { rng.range(0.01, 0.3) } else { 1e-3 };
                t.push(t[t.len() - 1] + gap);
                x.push(x[x.len() - 1] + rng.range(-1.0, 1.0) * 4.0 * (resolution + noise).max(1e-6));
            }
            for _ in 0..20 {
                let (at, run) = ((rng.uniform() * 1990.0) as usize + 2, (rng.uniform() * 4.0) as usize + 1);
                let leap = rng.range(-1.0, 1.0) * 30.0 * (resolution + noise).max(1e-6);
                x[at..at + run].iter_mut().for_each(|v| *v += leap);
            }
            let g = glitches(&x, &t, resolution, noise);
            assert_eq!(g, at_every_reading(&x, &t, resolution, noise));
            found += g.iter().filter(|g| **g).count();
        }
        // Glitches were there to find.
        assert!(found > 500, "{found}");
    }

    #[test]
    fn a_level_the_signal_moves_to_a_small_leap_and_a_swing_are_not() {
        let q = std::f64::consts::TAU / 16384.0;
        // Four samples up is a step the signal took (or a fault), not a misread.
        assert!(!glitches(&ramp_with_leap(6.0, 4), &ms(3000), q, 0.0).contains(&true));
        // Within three counts: a flicker between counts is data.
        assert!(!glitches(&ramp_with_leap(2.0, 1), &ms(3000), q, 0.0).contains(&true));
        // A 100 Hz vibration at 1 kHz swings both ways through its line.
        let x: Vec<f64> = (0..3000).map(|i| 0.01 * (std::f64::consts::TAU * 100.0 * i as f64 / 1000.0).sin()).collect();
        assert!(!glitches(&x, &ms(3000), q, 0.0).contains(&true));
        // Within six times a noisy reading's noise.
        let mut rng = jointctl_test_support::XorShift64::new(7);
        let noisy: Vec<f64> = (0..20_000).map(|_| 1e-4 * rng.normal()).collect();
        assert!(!glitches(&noisy, &ms(20_000), 2e-6, 1e-4).contains(&true));
        // A reading between two gaps: the motion went that far in them (blind seed 3's 040, a
        // 0.5 Hz swing of 0.06 rad binned to 20 Hz with gaps of 0.21 and 0.16 s around one bin).
        let t = [0.0, 0.05, 0.10, 0.15, 0.20, 0.41, 0.57, 0.62, 0.67, 0.72, 0.77];
        let x = [0.055, 0.033, -0.001, -0.035, -0.057, 0.061, -0.042, -0.057, -0.057, -0.030, 0.010];
        assert!(!glitches(&x, &t, q, 0.0).contains(&true));
        // The same readings 50 ms apart throughout would be one.
        let even: Vec<f64> = (0..x.len()).map(|k| k as f64 * 0.05).collect();
        assert!(glitches(&x, &even, q, 0.0)[5]);
    }
}
