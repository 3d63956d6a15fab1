//! Turning what a bus delivered into a [`Reading`] that can be trusted, per device.
//!
//! Thesis appendix A: lost CAN frames were read as zero, the observed deflection spiked and the
//! arm dropped. Here nothing a bus delivers becomes a value unchecked:
//! - nothing arrived this cycle → the last good value, marked stale with its age (or missing);
//! - a frame that failed its checks (parity, error flag) → counted, last good value stale;
//! - a value that jumps further than the joint can move in the elapsed time, or an exact zero
//!   after readings away from zero (an all-zero frame passes the parity check) → implausible:
//!   counted, last good value stale. Time counts only up to the first rejected value: a jump
//!   that persists (a slipped magnet) is never accepted later merely because enough time passed
//!   for the joint to have moved that far; the reading stays stale (the joint is held) until a
//!   value consistent with the last good one arrives.
//!
//! Allocation-free; runs inside the control cycle.

use jointctl_api::{Reading, ReadingStatus};

/// What a bus delivered for one device this cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sample {
    /// A decoded value (rad), received `age_s` ago.
    Value {
        /// The value [rad].
        value: f64,
        /// Time since it was received [s].
        age_s: f64,
    },
    /// Nothing arrived.
    Missing,
    /// A frame arrived but failed its checks.
    Invalid,
}

/// Plausibility limits of one device (from YAML; defaults are assumptions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plausibility {
    /// Fastest the measured angle can change [rad/s].
    pub max_rate_rad_s: f64,
    /// Allowed extra jump for quantisation and noise [rad].
    pub tolerance_rad: f64,
    /// The value wraps at this span (2 pi for an absolute encoder); jumps across the wrap are
    /// unwrapped, not rejected.
    pub wrap_rad: Option<f64>,
    /// Reject an exact zero after a last good value farther than this from zero [rad]
    /// (`None`: a zero is always plausible).
    pub zero_band_rad: Option<f64>,
}

impl Plausibility {
    /// Limits for a 14-bit absolute encoder on a joint moving at most `max_rate_rad_s`.
    pub fn absolute_encoder(max_rate_rad_s: f64) -> Self {
        let count = std::f64::consts::TAU / 16384.0;
        Plausibility {
            max_rate_rad_s,
            tolerance_rad: 4.0 * count,
            wrap_rad: Some(std::f64::consts::TAU),
            zero_band_rad: Some(4.0 * count),
        }
    }

    /// Limits for a force/torque sensor's torque [Nm]: any change is plausible (a contact can
    /// change it at once); the range check is the sensor's own, before the conditioner.
    pub fn torque_sensor() -> Self {
        Plausibility { max_rate_rad_s: 0.0, tolerance_rad: f64::INFINITY, wrap_rad: None, zero_band_rad: None }
    }

    /// Limits for a drive position reported over CAN.
    pub fn drive_position(max_rate_rad_s: f64) -> Self {
        Plausibility { max_rate_rad_s, tolerance_rad: 1e-3, wrap_rad: None, zero_band_rad: Some(1e-3) }
    }
}

/// Counters of what was not used, per device; published in diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LossCounters {
    /// Cycles in which nothing arrived.
    pub missing: u64,
    /// Frames that failed their checks.
    pub invalid: u64,
    /// Values rejected as implausible (jumps, zeros).
    pub implausible: u64,
}

/// The conditioner of one device.
///
/// ```
/// use jointctl_api::ReadingStatus;
/// use jointctl_hal::condition::{Conditioner, Plausibility, Sample};
/// let mut c = Conditioner::new(Plausibility::drive_position(2.0));
/// let v = |value| Sample::Value { value, age_s: 0.0 };
/// assert_eq!(c.update(v(0.50), 0.000).status, ReadingStatus::VALID);
/// assert_eq!(c.update(v(0.51), 0.025).status, ReadingStatus::VALID);
/// // Appendix A: a lost frame read as zero is not a value.
/// let r = c.update(v(0.0), 0.050);
/// assert_eq!((r.status, r.value), (ReadingStatus::STALE, 0.51));
/// assert_eq!(c.counters().implausible, 1);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Conditioner {
    limits: Plausibility,
    last_good: Option<(f64, f64)>,
    /// The good value before the last one (value, time), for the direction of motion.
    before_last: Option<(f64, f64)>,
    /// When the first value after the last good one was rejected as a jump [s].
    rejected_at: Option<f64>,
    counters: LossCounters,
}

impl Conditioner {
    /// A conditioner that has seen nothing yet.
    pub const fn new(limits: Plausibility) -> Self {
        Conditioner { limits, last_good: None, before_last: None, rejected_at: None, counters: LossCounters { missing: 0, invalid: 0, implausible: 0 } }
    }

    /// The last value that passed every check [rad].
    pub fn last_good(&self) -> Option<f64> {
        self.last_good.map(|(v, _)| v)
    }

    /// What was not used so far.
    pub fn counters(&self) -> LossCounters {
        self.counters
    }

    fn hold(&self, now_s: f64) -> Reading {
        match self.last_good {
            Some((v, t)) => Reading::stale(v, (now_s - t).max(0.0)),
            None => Reading::invalid(),
        }
    }

    /// Conditions this cycle's sample at time `now_s` [s].
    pub fn update(&mut self, sample: Sample, now_s: f64) -> Reading {
        match sample {
            Sample::Missing => {
                self.counters.missing += 1;
                match self.hold(now_s) {
                    r if r.status == ReadingStatus::INVALID => Reading::MISSING,
                    r => r,
                }
            }
            Sample::Invalid => {
                self.counters.invalid += 1;
                self.hold(now_s)
            }
            Sample::Value { value, age_s } => {
                if !value.is_finite() {
                    self.counters.invalid += 1;
                    return self.hold(now_s);
                }
                let received = now_s - age_s.max(0.0);
                let Some((last, t)) = self.last_good else {
                    // An absolute encoder's first reading is taken in (-span/2, span/2]: a joint
                    // just below its zero reads slightly negative, not almost a full turn.
                    let first = match self.limits.wrap_rad {
                        Some(span) => value - span * (value / span).round(),
                        None => value,
                    };
                    self.last_good = Some((first, received));
                    return Reading::valid_aged(first, age_s.max(0.0));
                };
                let l = self.limits;
                // Appendix A: a zero from far off zero is a lost frame, not a value, unless the
                // motion so far was carrying the joint through zero by now (a deflection that
                // springs back to exactly zero counts within one cycle; rejecting that zero held
                // the joint stale for as long as it rested there).
                let arriving = self.before_last.is_some_and(|(pv, pt)| {
                    let predicted = last + (last - pv) / (t - pt).max(1e-9) * (received - t);
                    predicted.signum() != last.signum() || l.zero_band_rad.is_some_and(|band| predicted.abs() <= band)
                });
                if value == 0.0 && !arriving && l.zero_band_rad.is_some_and(|band| last.abs() > band) {
                    self.counters.implausible += 1;
                    return self.hold(now_s);
                }
                // Unwrap across the encoder's zero: take the representation nearest the last value.
                let v = match l.wrap_rad {
                    Some(span) => value + span * ((last - value) / span).round(),
                    None => value,
                };
                // After a rejected jump, the clock stops at the rejection (see the module docs).
                let horizon = self.rejected_at.unwrap_or(received).min(received);
                let allowed = l.max_rate_rad_s * (horizon - t).max(0.0) + l.tolerance_rad;
                if (v - last).abs() > allowed {
                    self.counters.implausible += 1;
                    self.rejected_at.get_or_insert(received);
                    return self.hold(now_s);
                }
                self.rejected_at = None;
                self.before_last = self.last_good;
                self.last_good = Some((v, received));
                Reading::valid_aged(v, age_s.max(0.0))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Finding (issue 10, checking the shoulder's transmission): a deflection encoder that sprang
    /// back from 9 counts to exactly 0 within one 40 Hz cycle read as appendix A's lost-frame
    /// zero, and every later 0 too: the joint's deflection stayed stale for as long as it rested
    /// at zero. Pass: a zero that the motion so far reaches by now is a value; a zero from a
    /// joint at rest, or moving but far from zero, is still a lost frame.
    #[test]
    fn a_zero_the_motion_reaches_is_a_value_and_a_zero_from_rest_is_not() {
        let v = |value| Sample::Value { value, age_s: 0.0 };
        let mut back = Conditioner::new(Plausibility::absolute_encoder(10.0));
        back.update(v(0.00997), 0.000);
        back.update(v(0.00345), 0.025);
        for k in 2..40 {
            let r = back.update(v(0.0), k as f64 * 0.025);
            assert_eq!((r.status, r.value), (ReadingStatus::VALID, 0.0), "cycle {k}");
        }
        assert_eq!(back.counters().implausible, 0);
        for (a, b) in [(0.1, 0.1), (0.5, 0.49)] {
            let mut c = Conditioner::new(Plausibility::absolute_encoder(10.0));
            c.update(v(a), 0.000);
            c.update(v(b), 0.025);
            let r = c.update(v(0.0), 0.050);
            assert_eq!((r.status, r.value), (ReadingStatus::STALE, b), "{a} -> {b} -> 0");
        }
    }

    /// Finding (fault suite): a persistent 1 rad jump was accepted after 0.09 s, once the
    /// elapsed time allowed the joint to have moved that far, and became the joint's position.
    #[test]
    fn a_persistent_jump_is_never_accepted_by_waiting() {
        let mut c = Conditioner::new(Plausibility::absolute_encoder(10.0));
        let v = |value| Sample::Value { value, age_s: 0.0 };
        assert_eq!(c.update(v(0.3), 0.0).status, ReadingStatus::VALID);
        for k in 1..=100 {
            let r = c.update(v(1.3), k as f64 * 0.01);
            assert_eq!((r.status, r.value), (ReadingStatus::STALE, 0.3), "cycle {k}");
        }
        assert_eq!(c.counters().implausible, 100);
        // The encoder comes back: a value consistent with the last good one is taken again.
        assert_eq!(c.update(v(0.301), 1.01).status, ReadingStatus::VALID);
        // Missing frames alone still widen the allowance (the joint may have moved meanwhile).
        for k in 0..10 {
            c.update(Sample::Missing, 1.02 + k as f64 * 0.01);
        }
        assert_eq!(c.update(v(1.0), 1.12).status, ReadingStatus::VALID);
    }
}
