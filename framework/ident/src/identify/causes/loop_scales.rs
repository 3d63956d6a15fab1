//! The deflection scales a loop is searched at: from a thousandth of the amplitude (or a
//! reading's step) to a third of it, and on a friction's pre-sliding below that thousandth.

use super::{SearchContext, log_grid};

/// The counts of the reading's coarsest quantiser a loop's turn (three scales, 95 % of its
/// limit) spans at least where a shape must be told from its quantisation: `prepare::MIN_SPAN_LSB`,
/// the levels a curve's shape needs (`prepare` reads the causes, so the value is repeated here).
pub(super) const LOOP_TURN_COUNTS: f64 = 16.0;

/// The smallest deflection scale tried: a thousandth of the amplitude, and no less than one
/// step of the deflection reading nor than a quarter of the log's first step away from a turn
/// ([`crate::identify::Excitation::turn_step_rad`]) (at most a tenth of the largest scale: below
/// one step on a stroke of fewer than 30 steps). A loop whose state turns within one step turns
/// at every step the reading reverses: a friction on the sign of the last step, which the data
/// cannot tell from a loop. Searched freely, that took a 20 Hz record's filtered torque lag
/// beside its time delay (the shared real-like l3-case018: a loop of 0.05 Nm at 0.3 of a step).
/// Likewise a loop that has closed before a slow log's first sample after each turn: on 20 Hz
/// bin means, eq. 3.5's friction averaged over the bin at the turn (a step in the rate's sign,
/// smoothed by the bin) took loops of 0.06 Nm over a hundredth to a twentieth of that sample's
/// step, on three of the blind devices' 20 Hz records of devices without hysteresis, whose
/// full-rate variants named none. Loops named on hysteresis records span at least that step
/// (1.0-1.1 of it on the closest), and a friction record's pre-sliding 0.6 of it (blind seed 2's
/// 065, a LuGre friction at 200 Hz): the floor is [`TURN_STEP_IN_SCALES`] below the step. With
/// it one of the three names none; on the other two the floor is beyond the cap (a/30) and a
/// loop at the cap is named instead (not solved here).
fn smallest_scale(c: &SearchContext) -> f64 {
    (c.excitation.amplitude_rad * 1e-3).max(reading_floor(c))
}

/// One step of the reading or a quarter of the log's first step after a turn, the coarser, at
/// most a thirtieth of the amplitude (see [`smallest_scale`]).
fn reading_floor(c: &SearchContext) -> f64 {
    c.excitation.resolution_rad.max(c.excitation.turn_step_rad / TURN_STEP_IN_SCALES).min(c.excitation.amplitude_rad / 30.0)
}

/// The deflection scales searched: 16 from [`smallest_scale`] to a third of the amplitude and,
/// at the same spacing, on below it down to [`finest_presliding_scale`]. Up to a third of the
/// amplitude: an assumption, a loop that has not reached its limit within a third of the stroke
/// is, on a sine, a phase lag that viscous friction explains as well; such a fit names the
/// wrong cause.
pub(super) fn scale_grid(c: &SearchContext) -> Vec<f64> {
    let mut grid = log_grid(smallest_scale(c), c.excitation.amplitude_rad / 3.0, 16);
    let ratio = grid[1] / grid[0];
    let floor = finest_presliding_scale(c);
    let mut below = Vec::new();
    let mut scale = grid[0] / ratio;
    while ratio > 1.0 && scale >= floor * (1.0 - 1e-12) {
        below.push(scale);
        scale /= ratio;
    }
    below.reverse();
    below.append(&mut grid);
    below
}

/// The narrowest pre-sliding a friction's loop is searched at [rad] (an assumption: this
/// project's friction records and generators pre-slide over 0.28-0.7 mrad, the blind
/// generator's seed 4's `067` the narrowest, `tests/arm_joint_friction.rs` 0.4, the rig
/// generator's arm joints 0.7; a bit over a third of the narrowest). The grid's last value
/// at or above it is 0.10-0.15 mrad (its ratio is 1.47).
pub(crate) const PRESLIDING_SCALE_RAD: f64 = 1e-4;

/// The grid's floor below [`smallest_scale`]'s thousandth of the amplitude: a friction's
/// pre-sliding (a Dahl loop's scale is the Coulomb level over the bristles' stiffness) is the
/// contact's, not the stroke's. On a joint's position over a range of 1-1.7 rad a thousandth of
/// it is 1-1.7 mrad, and the loop took a coarser scale or a time delay stood in for it (the rig
/// generator's seed 3, `a2-sine-v2`, a sine over 1.7 rad: an offset and a delay of 173 ms named,
/// 0.120 Nm held out, 1.46 times the plain least-squares reference's, whose Dahl state at
/// 0.58 mrad, the offset beside it, left 0.062).
/// So the grid goes on down towards [`PRESLIDING_SCALE_RAD`] where a thousandth of the amplitude
/// (the largest deflection's size, on a friction record the largest position's) is coarser:
/// from amplitudes of about 0.15 rad on, the first value below a thousandth being 1.47 times
/// finer. A spring's deflection up to that keeps its grid (the rig generator's springs); one
/// deflected further gets the finer values too (no spring record of the blind suites moved). It stops at no less than
/// the floors of [`smallest_scale`] (a step of the reading, a quarter of the first step after
/// a turn) nor than a quarter of a sample's typical travel ([`typical_travel_rad`]): a loop
/// that closes between two samples is, to the data, a friction on the sign of the last step,
/// which the baseline's friction is already (on the shared real-like l3-case008, 20 Hz bins of a
/// LuGre friction, a loop of 0.5 mrad was taken beside the friction and its viscous part read as
/// eq. 3.5's arctan: the damping was no longer named). Nor where its turn (three scales, 95 % of
/// its limit) spans fewer than [`LOOP_TURN_COUNTS`] counts of the reading's coarsest quantiser
/// (`Excitation::quantum_rad`), the project's rule for a shape told from its quantisation: on
/// the blind generator's seed 4's `067` (a clean LuGre friction at 500 Hz, 0.38 mrad counts), a
/// loop of about one count was taken where a thousandth of the amplitude gave one of 0.8 mrad,
/// and was then refused on the held-out part (block t = 0.8), the pre-sliding lost with it
/// (held out 0.389 -> 0.480 Nm, noise 0.349).
fn finest_presliding_scale(c: &SearchContext) -> f64 {
    let told_from_quantisation = LOOP_TURN_COUNTS * c.excitation.quantum_rad / 3.0;
    (c.excitation.amplitude_rad * 1e-3).min(PRESLIDING_SCALE_RAD).max(reading_floor(c)).max(typical_travel_rad(c) / TURN_STEP_IN_SCALES).max(told_from_quantisation)
}

/// The median deflection a sample moves over [rad]: the rate's size times the step, over the
/// full-rate stretch; infinite where there is none.
fn typical_travel_rad(c: &SearchContext) -> f64 {
    let f = &c.full_rate;
    let mut travel: Vec<f64> = f.t_s.windows(2).zip(f.velocity_rad_per_s).map(|(t, v)| (t[1] - t[0]).abs() * v.abs()).filter(|x| x.is_finite()).collect();
    if travel.is_empty() {
        return f64::INFINITY;
    }
    let middle = travel.len() / 2;
    *travel.select_nth_unstable_by(middle, f64::total_cmp).1
}

/// A Dahl state is within `exp(-4)`, 2 %, of its limit four deflection scales after a turn: a
/// loop of a quarter of the log's first step after a turn has closed at that sample, a step in
/// the sign of the motion to the data (an assumption on the closeness: the false loops lay at
/// 0.01-0.06 of the step, the narrowest real ones at 0.6 and more).
const TURN_STEP_IN_SCALES: f64 = 4.0;
