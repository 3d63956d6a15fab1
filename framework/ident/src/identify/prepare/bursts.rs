//! Samples a logger wrote in a burst after it stalled. A logger that stalls (a full buffer, a
//! busy bus) and then writes what it buffered stamps those samples when it writes them, tens of
//! microseconds apart, although they were taken at its usual step during the stall: the rig
//! generator's logger (`tools/ident_reference/rig_generator`: ~1.8 ms steps, stalls, bursts) put
//! four to six samples within 30 us after each stall of 15-20 ms, the deflection moving its usual
//! step between them. Read at their stamps, the deflection leaps at each burst and its rate
//! with it: on that generator's seed 5 device d2 (three repetitions) the rate read 0.74 rad/s
//! RMS on the training part where the motion's is 0.09, correlated with it at 0.16, and a loop
//! that the plain reference's fit took (held out 0.313 -> 0.199 Nm) gained nothing beside a
//! friction of that rate. The samples of a stall and its burst are laid evenly over the time
//! from the sample before the stall to the burst's last, where that spacing is the log's usual
//! step: what a logger that buffers does.

use crate::identify::numeric::median_step;

/// A step longer than this many median steps is a stall, one shorter than this share of the
/// median a burst's, and the burst runs on while the steps stay below the catch-up share
/// (assumptions: a jittered log's steps stay within half and twice its median; the rig
/// generator's bursts are 1-2 % of it and its catch-up steps about a fortieth).
const STALL_STEPS: f64 = 2.0;
const BURST_SHARE: f64 = 0.25;
const CATCH_UP_SHARE: f64 = 0.5;
/// The stall and burst laid evenly must come to within this factor of the median step either
/// way (else the burst does not hold the stall's samples: a pause between repetitions, a log
/// that lost samples).
const SPACING_FACTOR: f64 = 2.0;

/// `t` with the samples of each stall and its burst laid evenly (see the module).
pub(super) fn laid_evenly(mut t: Vec<f64>) -> Vec<f64> {
    let n = t.len();
    if n < 11 {
        return t;
    }
    let median = median_step(&t);
    let mut i = 1;
    while i + 1 < n {
        let (stall, next) = (t[i] - t[i - 1], t[i + 1] - t[i]);
        if !(stall > STALL_STEPS * median && next > 0.0 && next < BURST_SHARE * median) {
            i += 1;
            continue;
        }
        let mut end = i + 1;
        while end + 1 < n && t[end + 1] - t[end] > 0.0 && t[end + 1] - t[end] < CATCH_UP_SHARE * median {
            end += 1;
        }
        let from = i - 1;
        let spacing = (t[end] - t[from]) / (end - from) as f64;
        if spacing < SPACING_FACTOR * median && spacing * SPACING_FACTOR > median {
            for k in from + 1..end {
                t[k] = t[from] + (k - from) as f64 * spacing;
            }
        }
        i = end + 1;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::laid_evenly;

    /// A 1.8 ms log that stalls for 16.2 ms and writes its eight buffered samples 10 us apart:
    /// they are laid back at 1.8 ms; the steps around are untouched, and a pause of a second
    /// before a few close samples is left alone.
    #[test]
    fn a_burst_after_a_stall_is_laid_over_the_stall() {
        let mut t: Vec<f64> = (0..20).map(|i| i as f64 * 1.8e-3).collect();
        let stalled = t[19] + 16.2e-3;
        t.extend((0..9).map(|k| stalled + k as f64 * 1e-5));
        let last = t[t.len() - 1];
        t.extend((1..20).map(|i| last + i as f64 * 1.8e-3));
        let even = laid_evenly(t.clone());
        let moved = t.iter().zip(&even).filter(|(a, b)| a != b).count();
        assert_eq!(moved, 8);
        for w in even.windows(2) {
            assert!((w[1] - w[0] - 1.8e-3).abs() < 1.1e-4, "{even:?}");
        }
        let mut paused: Vec<f64> = (0..20).map(|i| i as f64 * 1.8e-3).collect();
        paused.extend((0..5).map(|k| 1.0 + k as f64 * 1e-5));
        paused.extend((1..20).map(|i| 1.0 + 4e-5 + i as f64 * 1.8e-3));
        assert_eq!(laid_evenly(paused.clone()), paused);
    }
}
