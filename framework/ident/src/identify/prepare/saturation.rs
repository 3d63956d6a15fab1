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
/// a reading quantised by its converter holds each code near a sine's peak about as often as
/// its neighbour, within twice; a clipped reading piles every sample beyond the range onto one
/// code, while a noisy reading below it rarely repeats a value).
pub(super) const SATURATED_OVER_NEXT: usize = 4;

/// The samples of `series` at its own maximum or minimum when that value is a limit (see the
/// constants): exactly at it, at least [`SATURATED_MIN_SAMPLES`] and [`SATURATED_MIN_SHARE`] of
/// the samples, and [`SATURATED_OVER_NEXT`] times as many as the next value inside.
pub(super) fn saturated(series: &[f64]) -> Vec<bool> {
    let n = series.len();
    let mut out = vec![false; n];
    let least = SATURATED_MIN_SAMPLES.max((SATURATED_MIN_SHARE * n as f64).ceil() as usize);
    for sign in [1.0, -1.0] {
        // The limit, and the next value inside it, in the direction `sign`.
        let limit = series.iter().map(|x| sign * x).fold(f64::NEG_INFINITY, f64::max);
        let next = series.iter().map(|x| sign * x).filter(|x| *x < limit).fold(f64::NEG_INFINITY, f64::max);
        let at = series.iter().filter(|x| sign * **x == limit).count();
        let at_next = series.iter().filter(|x| sign * **x == next).count();
        if at >= least && at >= SATURATED_OVER_NEXT * at_next.max(1) && at < n {
            out.iter_mut().zip(series).filter(|(_, x)| sign * **x == limit).for_each(|(o, _)| *o = true);
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

    #[test]
    fn a_clipped_reading_is_found_at_both_limits_and_nowhere_else() {
        let clipped: Vec<f64> = noisy_sine(6000, 2.4).iter().map(|x| x.clamp(-1.5, 1.5)).collect();
        let found = saturated(&clipped);
        assert_eq!(found.iter().filter(|f| **f).count(), clipped.iter().filter(|x| x.abs() == 1.5).count());
        assert!(found.iter().zip(&clipped).all(|(f, x)| *f == (x.abs() == 1.5)));
    }

    #[test]
    fn an_unclipped_reading_quantised_or_not_has_no_limit() {
        let sine = noisy_sine(6000, 2.4);
        assert!(!saturated(&sine).iter().any(|f| *f));
        // A coarse converter (0.05 Nm codes, below the noise's scale at the peaks as well).
        let coarse: Vec<f64> = sine.iter().map(|x| (x / 0.05).round() * 0.05).collect();
        assert!(!saturated(&coarse).iter().any(|f| *f));
        // Clipped once, for two samples: no limit.
        let mut once = sine.clone();
        once[100] = 9.0;
        once[101] = 9.0;
        assert!(!saturated(&once).iter().any(|f| *f));
    }
}
