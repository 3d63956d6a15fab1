//! A friction record's turns. Where the joint turns within one count of its encoder, the
//! reading stays on that count while the motion slows, stops and goes back: the encoder cannot
//! say which way the joint moves there, and the friction's sign, the whole of a friction record's
//! torque, flips somewhere inside with no reading to say when. Every sliding model reads the
//! direction from the rate, and the rate over those samples is a guess (a window's slope that
//! reaches into the motion either side). In a record whose deflection column is a joint position
//! (no spring), such runs are left out of the fit and the judgement as the stops are (see
//! `rest`); the report counts them. Beside a spring the torque turns with the deflection, and
//! nothing is left out.
//!
//! Finding (the blind generator's friction-position records, Stribeck and LuGre friction, a
//! 14-bit encoder at 200 Hz-2 kHz): at each turn the torque flipped between the static levels,
//! +-6.7 Nm, over readings of one count whose rates read up to 0.006 rad/s either way. On seed
//! 8's 063, 2 % of the held-out samples (those below 0.01 rad/s) carried 90 % of the held-out
//! squared error, 6.7 times the noise in all, and the viscous friction hidden there was refused
//! as a negative damping.

/// A run of equal readings is a turn when it holds at least this many samples (a reading held
/// is an encoder's count; a noisy reading without counts never repeats, and its extremes are no
/// turns).
pub const HELD_SAMPLES: usize = 2;

/// The time intervals `(start, end)` [s] where the reading `d` [rad], logged at `t` [s], stays
/// on the count at which the motion turned: runs of at least [`HELD_SAMPLES`] equal readings
/// whose readings before and after lie on the same side of them (a peak or a trough). In time
/// order, apart. Over the whole record, across its gaps: the joint unwatched in a logger's pause
/// between two equal readings turned there, or went and came back, and either way the reading
/// cannot say which way it moved (kept within each segment of contiguous logging, the blind
/// generator's seed 11's 064, an irregular log, kept turns whose flips took its held-out error
/// over the samples that slide from 0.090 to 0.165 Nm).
pub(super) fn turns(t: &[f64], d: &[f64]) -> Vec<(f64, f64)> {
    let n = t.len().min(d.len());
    let mut found = Vec::new();
    // Each run of equal readings [i, j) with a reading before and after it.
    let mut i = 1;
    while i < n {
        let mut j = i + 1;
        while j < n && d[j] == d[i] {
            j += 1;
        }
        if j < n && j - i >= HELD_SAMPLES && (d[i - 1] - d[i]) * (d[j] - d[i]) > 0.0 {
            found.push((t[i], t[j - 1]));
        }
        i = j;
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_peak_and_a_trough_held_on_a_count_are_turns_and_a_climb_is_not() {
        // Counts: a climb with a step held, a peak held 3 samples, down, a trough held twice,
        // a single-sample peak, and the record's last run (no reading after it).
        let d = [0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 3.0, 2.0, 1.0, 1.0, 2.0, 3.0, 2.0, 2.0];
        let t: Vec<f64> = (0..d.len()).map(|i| i as f64).collect();
        assert_eq!(turns(&t, &d), vec![(4.0, 6.0), (8.0, 9.0)]);
    }

    #[test]
    fn a_reading_without_counts_has_no_turns() {
        let d: Vec<f64> = (0..200).map(|i| (i as f64 * 0.1).sin() + 1e-3 * ((i * 7919 % 13) as f64)).collect();
        let t: Vec<f64> = (0..d.len()).map(|i| i as f64).collect();
        assert!(turns(&t, &d).is_empty());
    }
}
