//! Breaks in a log: gaps in which the motion turned unseen, after which a stateful cause's state
//! is not the data's to know (see [`unseen_turns`]).

use crate::identify::numeric::median;

/// The travel after a break, in ranges of the motion, over which the samples are left out (see
/// [`unseen_turns`]): a Dahl state forgets its start as `exp(-travel / scale)`, and the search
/// keeps the scale below a third of the amplitude (a sixth of the range), so that after one range
/// of travel what is left of the start is below `exp(-6)`, a quarter of a percent of the loop.
pub const SETTLE_RANGES: f64 = 1.0;

/// Where the record's samples do not follow on from those before them for a stateful cause:
/// after a gap longer than `period_s`, a period of the motion (twice the median time between its
/// turns, see [`motion_period_s`]), in which the motion turned at least once unseen (a
/// repetition logged on an epoch clock, seconds to minutes after the one before, the rig
/// re-homed meanwhile; a logger's long stall). A loop's state there is what the unseen motion
/// left, which the data does not say: the samples after such a break are left out of every part
/// (fitted and held out, for every model alike) until the motion has travelled
/// [`SETTLE_RANGES`] of its range, and a loop's state, a delay's history and a sensor's lag
/// start again from the break (as at a repetition whose time restarts, `Part::then`), so that
/// the samples kept read a state their own motion set. Across a shorter gap the state runs on,
/// the jump taken as one step of the motion.
///
/// Carried over a pause of 36 s, the state at the start of the rig generator's third repetition
/// (seed 5, device d2, three repetitions) was the second's last, on the other side of its loop:
/// identify's loop of 0.50 Nm left 0.60 Nm RMS over the held-out part's first eighth (0.18 with
/// the state started afresh) and was refused. Started afresh at zero with every sample kept (the
/// plain reference's way), 13 of the 192 rig records' reports moved, 8 of them worse against the
/// reference (two records from 0.64-0.65 times its error to 0.96-0.99): neither start is the
/// data's, and the samples whose state depends on it are not judged.
///
/// ```
/// // A 1 Hz motion logged at 100 Hz, with a 0.3 s stall and a 40 s break.
/// let mut t: Vec<f64> = (0..300).map(|i| i as f64 * 0.01).collect();
/// t.push(3.3);
/// t.extend((0..300).map(|i| 43.3 + i as f64 * 0.01));
/// assert_eq!(jointctl_ident::identify::prepare::unseen_turns(&t, 1.0), vec![301]);
/// ```
pub fn unseen_turns(t_s: &[f64], period_s: f64) -> Vec<usize> {
    (1..t_s.len()).filter(|i| t_s[*i] - t_s[i - 1] > period_s).collect()
}

/// A period of the motion [s]: twice the median time between its turns (`turning`, indices into
/// `t_s`), or `1 / frequency_hz` with fewer than three turns. Not the fundamental's slope over
/// the whole record: that counts the pauses between repetitions as motion (the rig generator's
/// seed 5, device d2, three repetitions: turns 1.9 s apart, 3.9 s a period, read over pauses of
/// 8.5 and 36 s as 10.2 s, so that the shorter pause was not a break).
///
/// ```
/// let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
/// assert_eq!(jointctl_ident::identify::prepare::motion_period_s(&t, &[1, 3, 5, 9], 0.1), 4.0);
/// assert_eq!(jointctl_ident::identify::prepare::motion_period_s(&t, &[1, 3], 0.1), 10.0);
/// ```
pub fn motion_period_s(t_s: &[f64], turning: &[usize], frequency_hz: f64) -> f64 {
    if turning.len() < 3 {
        return 1.0 / frequency_hz.max(1e-9);
    }
    let mut between: Vec<f64> = turning.windows(2).map(|w| t_s[w[1]] - t_s[w[0]]).collect();
    2.0 * median(&mut between).unwrap_or(0.0)
}

/// The breaks of a record and where each one's settling ends (see [`unseen_turns`]).
pub(crate) struct Breaks {
    /// Each break's first sample, in order.
    at: Vec<usize>,
    /// Each break's first sample after its settling (the record's length if it never settles).
    settled: Vec<usize>,
}

impl Breaks {
    /// The breaks of the record `(t_s, d)` whose motion turns at `turning` and whose
    /// excitation's fundamental is `frequency_hz` (see [`motion_period_s`]).
    pub(crate) fn of(t_s: &[f64], d: &[f64], turning: &[usize], frequency_hz: f64) -> Self {
        let at = unseen_turns(t_s, motion_period_s(t_s, turning, frequency_hz));
        let (lowest, highest) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
        let settle_rad = SETTLE_RANGES * (highest - lowest);
        let settled = at
            .iter()
            .map(|&b| {
                let mut travel = 0.0;
                (b + 1..d.len())
                    .find(|&i| {
                        travel += (d[i] - d[i - 1]).abs();
                        travel >= settle_rad
                    })
                    .unwrap_or(d.len())
            })
            .collect();
        Breaks { at, settled }
    }

    /// The last break at or before sample `i` (0 without one): a history stops there.
    pub(crate) fn last_at_or_before(&self, i: usize) -> usize {
        self.at[..self.at.partition_point(|b| *b <= i)].last().copied().unwrap_or(0)
    }

    /// Is sample `i` left out, settling after a break?
    pub(crate) fn settling(&self, i: usize) -> bool {
        let k = self.at.partition_point(|b| *b <= i);
        k > 0 && i < self.settled[k - 1]
    }

    /// The breaks after the first sample of `r` and before its end.
    pub(crate) fn inside(&self, r: std::ops::Range<usize>) -> &[usize] {
        &self.at[self.at.partition_point(|b| *b <= r.start)..self.at.partition_point(|b| *b < r.end)]
    }

    /// What the report says of them: `None` without a break.
    pub(crate) fn said(&self, t_s: &[f64]) -> Option<AfterBreaks> {
        let left_out_s: Vec<[f64; 2]> = self.at.iter().zip(&self.settled).map(|(b, e)| [t_s[*b], t_s[(e - 1).max(*b)]]).collect();
        (!self.at.is_empty()).then(|| AfterBreaks { breaks: self.at.len(), samples: self.at.iter().zip(&self.settled).map(|(b, e)| e - b).sum(), left_out_s })
    }
}

/// What a record's breaks left out (see [`unseen_turns`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AfterBreaks {
    /// Gaps longer than a period of the motion.
    pub breaks: usize,
    /// Samples left out after them, of the whole record, fitted and held out alike.
    pub samples: usize,
    /// Each break's samples left out, from its first to its last, in time from the record's
    /// first sample [s].
    pub left_out_s: Vec<[f64; 2]>,
}

#[cfg(test)]
mod tests {
    use super::Breaks;

    #[test]
    fn the_samples_after_a_break_are_left_out_until_the_motion_travelled_its_range() {
        // A 1 Hz triangle of range 2 at 100 Hz, a 40 s break after 3 s.
        let t: Vec<f64> = (0..600).map(|i| i as f64 * 0.01 + if i >= 300 { 40.0 } else { 0.0 }).collect();
        let d: Vec<f64> = t.iter().map(|x| 1.0 - 4.0 * ((x + 0.25).rem_euclid(1.0) - 0.5).abs()).collect();
        let b = Breaks::of(&t, &d, &[], 1.0);
        assert_eq!(b.at, vec![300]);
        // Half a period, 50 samples, travels the range.
        assert!((349..=351).contains(&b.settled[0]), "{}", b.settled[0]);
        assert!(!b.settling(299) && b.settling(300) && b.settling(340) && !b.settling(360));
        assert_eq!((b.last_at_or_before(299), b.last_at_or_before(300), b.last_at_or_before(500)), (0, 300, 300));
        assert_eq!((b.inside(0..600), b.inside(300..600)), (&[300][..], &[][..]));
        let said = b.said(&t).unwrap();
        assert_eq!((said.breaks, said.samples), (1, b.settled[0] - 300));
        assert_eq!(said.left_out_s[0][0], t[300]);
        assert!(Breaks::of(&t[..300], &d[..300], &[], 1.0).said(&t[..300]).is_none());
    }
}
