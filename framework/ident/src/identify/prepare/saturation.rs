//! A torque sensor driven past its range reads its limit: the samples there are not the torque,
//! and a fit that takes them as values bends every cause to the flat tops (a sine clipped at
//! 1.5 Nm of its 2.4 Nm got a cubic, a 50 ms lead and a dead zone named, and a noise floor of
//! 0.0003 Nm from the flat stretches). Found, so that they are left out and counted, never used.

/// The least share of the samples a limit holds (an assumption: a sensor clipped once, for a
/// sample or two, changes no fit; a range exceeded at every cycle's peak is a share of them).
pub(super) const SATURATED_MIN_SHARE: f64 = 0.005;

/// ... and the least count of them (an assumption, for short records).
pub(super) const SATURATED_MIN_SAMPLES: usize = 10;

/// How many times as many samples the limit holds as the next value inside it (an assumption:
/// a reading quantised by its converter holds the code at a sine's peak at most 1 / (sqrt 2 - 1)
/// = 2.4 times as often as the code below it, noise aside; a clipped reading piles every sample
/// beyond the range onto one code, while a noisy reading below it rarely repeats a value).
pub(super) const SATURATED_OVER_NEXT: usize = 4;

/// The least span of the deflection over the samples at the limit, as a share of the deflection's
/// whole span (an assumption: a clip is a flat torque under a deflection that goes on moving,
/// from where the torque reached the range to the stroke's end and back; a torque held while
/// the joint holds, a step-and-hold test read by a converter quieter than its step, is no clip).
pub(super) const SATURATED_MIN_DEFLECTION_SHARE: f64 = 0.05;

/// The samples of `torque` at its own maximum or minimum when that value is a limit (see the
/// constants): exactly at it, at least [`SATURATED_MIN_SAMPLES`] and [`SATURATED_MIN_SHARE`] of
/// the samples, [`SATURATED_OVER_NEXT`] times as many as the next value inside, and the
/// deflection moving under it ([`SATURATED_MIN_DEFLECTION_SHARE`]). Samples already `lost`
/// (dropouts) take no part: a lost frame's zero or a spike beyond the limit would hide it.
pub(super) fn saturated(torque: &[f64], deflection: &[f64], lost: &[bool]) -> Vec<bool> {
    let n = torque.len();
    let mut out = vec![false; n];
    let kept = || torque.iter().zip(lost).filter(|(_, l)| !**l).map(|(x, _)| *x);
    let least = SATURATED_MIN_SAMPLES.max((SATURATED_MIN_SHARE * kept().count() as f64).ceil() as usize);
    let span = |d: &mut dyn Iterator<Item = f64>| d.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
    let (lo, hi) = span(&mut deflection.iter().zip(lost).filter(|(_, l)| !**l).map(|(x, _)| *x));
    for sign in [1.0, -1.0] {
        // The limit, and the next value inside it, in the direction `sign`.
        let limit = kept().map(|x| sign * x).fold(f64::NEG_INFINITY, f64::max);
        let next = kept().map(|x| sign * x).filter(|x| *x < limit).fold(f64::NEG_INFINITY, f64::max);
        let at_limit = |i: usize| !lost[i] && sign * torque[i] == limit;
        let at = (0..n).filter(|i| at_limit(*i)).count();
        let at_next = kept().filter(|x| sign * x == next).count();
        let (a, b) = span(&mut (0..n).filter(|i| at_limit(*i)).map(|i| deflection[i]));
        let moving = b - a >= SATURATED_MIN_DEFLECTION_SHARE * (hi - lo);
        if at >= least && at >= SATURATED_OVER_NEXT * at_next.max(1) && at < n && moving {
            (0..n).filter(|i| at_limit(*i)).for_each(|i| out[i] = true);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy_sine(n: usize, amplitude: f64) -> Vec<f64> {
        let mut rng = jointctl_test_support::XorShift64::new(7);
        (0..n).map(|i| amplitude * (i as f64 * 0.01).sin() + 0.02 * rng.normal()).collect()
    }

    /// The deflection under [`noisy_sine`]'s torque (a spring of 100 Nm/rad).
    fn deflection(torque: &[f64]) -> Vec<f64> {
        (0..torque.len()).map(|i| 0.024 * (i as f64 * 0.01).sin()).collect()
    }

    fn saturated_alone(torque: &[f64], deflection: &[f64]) -> Vec<bool> {
        saturated(torque, deflection, &vec![false; torque.len()])
    }

    #[test]
    fn a_clipped_reading_is_found_at_both_limits_and_nowhere_else() {
        let clipped: Vec<f64> = noisy_sine(6000, 2.4).iter().map(|x| x.clamp(-1.5, 1.5)).collect();
        let found = saturated_alone(&clipped, &deflection(&clipped));
        assert_eq!(found.iter().filter(|f| **f).count(), clipped.iter().filter(|x| x.abs() == 1.5).count());
        assert!(found.iter().zip(&clipped).all(|(f, x)| *f == (x.abs() == 1.5)));
    }

    #[test]
    fn an_unclipped_reading_quantised_or_not_has_no_limit() {
        let sine = noisy_sine(6000, 2.4);
        let d = deflection(&sine);
        assert!(!saturated_alone(&sine, &d).iter().any(|f| *f));
        // A coarse converter (0.05 Nm codes, below the noise's scale at the peaks as well).
        let coarse: Vec<f64> = sine.iter().map(|x| (x / 0.05).round() * 0.05).collect();
        assert!(!saturated_alone(&coarse, &d).iter().any(|f| *f));
        // Clipped once, for two samples: no limit.
        let mut once = sine.clone();
        once[100] = 9.0;
        once[101] = 9.0;
        assert!(!saturated_alone(&once, &d).iter().any(|f| *f));
    }

    /// From the review: a step-and-hold read by a converter quieter than its step holds one code
    /// at the top for the whole hold, under a deflection that holds too: no clip.
    #[test]
    fn a_held_torque_under_a_held_deflection_is_no_limit() {
        // Ramps of 500 samples up to 0.01 rad and down, each end held for 1000 samples; the
        // torque 100 Nm/rad of it, read in codes of 0.005 Nm.
        let d: Vec<f64> = (0..6000)
            .map(|i| match i % 3000 {
                k if k < 500 => 0.01 * k as f64 / 500.0,
                k if k < 1500 => 0.01,
                k if k < 2000 => 0.01 * (2000 - k) as f64 / 500.0,
                _ => 0.0,
            })
            .collect();
        let torque: Vec<f64> = d.iter().map(|x| (100.0 * x / 0.005).round() * 0.005).collect();
        assert!(!saturated_alone(&torque, &d).iter().any(|f| *f));
    }

    /// From the review: a lost frame's spike beyond the limit hid it (the limit is the kept
    /// samples' extreme).
    #[test]
    fn a_spike_beyond_the_limit_that_is_already_lost_does_not_hide_it() {
        let mut clipped: Vec<f64> = noisy_sine(6000, 2.4).iter().map(|x| x.clamp(-1.5, 1.5)).collect();
        clipped[10] = 40.0;
        let mut lost = vec![false; clipped.len()];
        lost[10] = true;
        let found = saturated(&clipped, &deflection(&clipped), &lost);
        assert!(found.iter().zip(&clipped).enumerate().all(|(i, (f, x))| *f == (i != 10 && x.abs() == 1.5)));
    }
}
