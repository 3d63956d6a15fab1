//! Where in the training part the grid searches look: pieces spread over all of it, not its
//! first seconds.

use std::ops::Range;

/// Pieces the searches' samples are taken in, at most (an assumption: a record's kinds of motion
/// (holds, ramps, sweeps, sines of several speeds) come a few to a record in the generators and
/// the thesis' experiments; eight pieces see each kind that lasts an eighth of the training part,
/// and each junction between pieces is one transient for a stateful effect).
pub(crate) const SEARCH_PIECES: usize = 8;

/// The full-rate index ranges the searches take their `limit` training samples from: the whole
/// training part (`0..lo` and `hi..n`, the held-out window `lo..hi` left out) when it is no longer,
/// otherwise up to [`SEARCH_PIECES`] contiguous pieces of at least `min_piece` samples (one of
/// `limit` when `min_piece` is longer), spread evenly over it (counted as one across the
/// held-out window; a piece that straddles it comes as two ranges, one of them possibly short).
///
/// Why: the first `limit` samples are the record's first seconds, and a record's first seconds
/// are often not what the rest is. The blind generator's seed 6, record 051 (a ramp, a 28 s
/// hold, then a chirp of 0.35-4.25 Hz at 200 Hz with a 27 ms delay) searched its delay on the
/// ramp and the hold alone: the delay was taken as -40 ms, made the held-out part worse, and no
/// cause was named at 4.2 times the noise floor.
pub(crate) fn spread(lo: usize, hi: usize, n: usize, limit: usize, min_piece: usize) -> Vec<Range<usize>> {
    let (lo, hi) = (lo.min(n), hi.clamp(lo.min(n), n));
    let trained = lo + (n - hi);
    // A logical training index to the full-rate one, across the held-out window.
    let physical = |r: Range<usize>| -> Vec<Range<usize>> {
        let before = r.start.min(lo)..r.end.min(lo);
        let after = (r.start.max(lo) - lo + hi)..(r.end.max(lo) - lo + hi);
        [before, after].into_iter().filter(|p| !p.is_empty()).collect()
    };
    if trained <= limit {
        return physical(0..trained);
    }
    let pieces = (limit / min_piece.max(1)).clamp(1, SEARCH_PIECES);
    let length = limit / pieces;
    if pieces == 1 {
        return physical(0..length);
    }
    (0..pieces).flat_map(|i| {
        let start = i * (trained - length) / (pieces - 1);
        physical(start..start + length)
    }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total(r: &[Range<usize>]) -> usize {
        r.iter().map(|p| p.len()).sum()
    }

    #[test]
    fn a_short_training_part_is_taken_whole_without_the_held_out_window() {
        assert_eq!(spread(70, 100, 100, 5000, 200), vec![0..70]);
        assert_eq!(spread(40, 70, 100, 5000, 200), vec![0..40, 70..100]);
    }

    #[test]
    fn a_long_one_is_taken_in_pieces_from_its_start_to_its_end() {
        let r = spread(70_000, 100_000, 100_000, 5000, 200);
        assert_eq!(r.len(), SEARCH_PIECES);
        assert_eq!(total(&r), 5000);
        assert_eq!(r[0].start, 0);
        assert_eq!(r.last().map(|p| p.end), Some(70_000));
        assert!(r.windows(2).all(|w| w[0].end <= w[1].start), "{r:?}");
    }

    #[test]
    fn pieces_skip_the_held_out_window_and_reach_past_it() {
        let r = spread(45_000, 75_000, 100_000, 5000, 200);
        assert_eq!(total(&r), 5000);
        assert!(r.iter().all(|p| p.end <= 45_000 || p.start >= 75_000), "{r:?}");
        assert_eq!(r.last().map(|p| p.end), Some(100_000));
    }

    #[test]
    fn a_slow_excitation_keeps_whole_cycles_in_fewer_pieces() {
        // 4 cycles of 1000 samples each at least: one piece of 5000.
        assert_eq!(spread(70_000, 100_000, 100_000, 5000, 4000), vec![0..5000]);
        let r = spread(70_000, 100_000, 100_000, 5000, 2000);
        assert_eq!(r.len(), 2);
        assert!(r.iter().all(|p| p.len() == 2500));
    }
}
