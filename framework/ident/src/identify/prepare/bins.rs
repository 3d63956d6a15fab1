//! A slow log may hold bin averages: a logger that lowers the rate averages the readings of
//! each interval (the blind generator's 20 Hz records are 50 ms means of a 500-2000 Hz
//! record; issue 36's rig records were binned so for the maintainers). A rate-dependent term
//! that is not a straight line in the rate (eq. 3.5's arctan) then averages over the interval
//! too, and the arctan of the interval's mean rate is not the mean of the arctan: where the
//! rate turns within an interval the average is flatter. Evaluated at the mean rate, the
//! baseline left six times the noise on a clean 20 Hz record and took k_b at half its value
//! (blind device B: 16.3 for 34.3 s/rad), and a Dahl loop stood in for the difference. This
//! module gives each sample the rate at its interval's start and end; whether a record is read
//! so is the data's to say (see `identify::extend`).

use crate::identify::numeric::segment_ranges;

/// Logs at 100 Hz and slower, a median step of this or longer [s], may be read as bin averages
/// (an assumption: loggers average to lower the rate, and faster than 100 Hz the rate of the
/// thesis' hand-driven characterisation (section 3.3.1, motions up to a few Hz) changes by
/// little within one step; faster logs are read as point samples, as before). See
/// [`tried_as_bins`] for the rounding of the step.
pub const BIN_READING_MIN_STEP_S: f64 = 0.01;

/// Whether a log whose median step is `median_step_s` [s] is tried as bin averages: at
/// [`BIN_READING_MIN_STEP_S`] or longer, within 5 % (a 100 Hz log's time stamps `i * 0.01` or
/// rounded to 10 ms in text give a median step a few ulps either side of 0.01 s).
///
/// ```
/// use jointctl_ident::identify::prepare::tried_as_bins;
/// assert!(tried_as_bins(0.0099999999999998) && tried_as_bins(0.010000000000000009) && tried_as_bins(0.05));
/// assert!(!tried_as_bins(0.005));
/// ```
pub fn tried_as_bins(median_step_s: f64) -> bool {
    median_step_s >= 0.95 * BIN_READING_MIN_STEP_S
}

/// Per sample, the rate at the start and at the end of its interval less its own rate
/// [rad/s]: each the mean of its rate and its neighbour's in the same segment of contiguous
/// logging (`starts` from [`super::segment_starts`]); zero at a segment's ends (no neighbour
/// to read the turn from).
///
/// ```
/// use jointctl_ident::identify::prepare::rate_edges;
/// let edges = rate_edges(&[0.0, 1.0, 3.0, 3.0], &[0, 3]);
/// assert_eq!(edges, vec![[0.0, 0.5], [-0.5, 1.0], [-1.0, 0.0], [0.0, 0.0]]);
/// ```
pub fn rate_edges(v_rad_per_s: &[f64], starts: &[usize]) -> Vec<[f64; 2]> {
    let n = v_rad_per_s.len();
    let mut edges = vec![[0.0, 0.0]; n];
    for std::ops::Range { start: a, end: b } in segment_ranges(starts, n) {
        for i in a..b {
            let v = v_rad_per_s[i];
            let before = if i > a { 0.5 * (v_rad_per_s[i - 1] - v) } else { 0.0 };
            let after = if i + 1 < b { 0.5 * (v_rad_per_s[i + 1] - v) } else { 0.0 };
            edges[i] = [before, after];
        }
    }
    edges
}

impl super::Prepared {
    /// Whether a slow log carries its intervals' rates, to be read as bin averages if the data
    /// says so.
    pub fn may_hold_bins(&self) -> bool {
        !self.train.rate_edges.is_empty()
    }

    /// The same data read as point samples.
    pub fn as_points(&self) -> super::Prepared {
        let mut p = self.clone();
        p.excitation.bin_width_s = 0.0;
        for part in [&mut p.train, &mut p.test, &mut p.coarse, &mut p.stretch] {
            part.rate_edges = Vec::new();
        }
        p
    }
}
