/// A reading carried to the instant another reading was taken.
///
/// A deflection is the difference of two readings, and the two need not be equally old: on the
/// thesis' arm the drive's motor position crossed the CAN bus about 30 ms late and the output
/// encoder the SPI bus about 15 ms late (section 2.3). While the joint moves, subtracting them as
/// they are reads a deflection that is off by the motor's motion in between. On the simulated
/// elbow that read the element 0.08 % stiffer at 0.25 Hz and about 0.45 % at 1 Hz, which `jointctl
/// identify` named as a `stiffness_error` (t = 5.5) on a plant that had none.
///
/// The track keeps the last distinct reading with the instant it was taken (`stamp - age`) and
/// the rate between the last two; [`Self::at`] extrapolates the newest reading linearly to
/// another instant. A rate needs two readings at most [`Self::MAX_SPAN_S`] apart, and the
/// reading is carried at most that far: beyond it (a gap, a stale bus) the reading is returned
/// as it is, never a guess from old motion. The instants come from the ages the HAL reports
/// with each reading; a reading whose age is not known is not carried (see the elastic plugin).
///
/// ```
/// use jointctl_control::ReadingTrack;
/// let mut track = ReadingTrack::new();
/// track.update(0.0, 0.000);
/// track.update(0.010, 0.025); // 0.4 rad/s
/// // The same reading, carried 15 ms forward (to an encoder read 15 ms after it).
/// assert!((track.at(0.040).unwrap() - 0.016).abs() < 1e-12);
/// // Too far from the reading to carry it: as it is.
/// assert_eq!(track.at(1.0), Some(0.010));
/// ```
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadingTrack {
    /// The newest reading [rad] and when it was taken [s].
    last: Option<(f64, f64)>,
    /// The rate between the last two readings [rad/s].
    rate: Option<f64>,
}

impl ReadingTrack {
    /// Longest interval over which a rate is formed and a reading carried [s]. Assumption: 0.1 s,
    /// four cycles of the thesis' 40 Hz loop (section 4.1): motion older than that says little
    /// of the motion now (and with its default `max_deflection_age_s` the elastic plugin forms
    /// no deflection from a stale reading at all).
    pub const MAX_SPAN_S: f64 = 0.1;

    /// An empty track: [`Self::at`] gives nothing until a reading arrives.
    pub const fn new() -> Self {
        ReadingTrack { last: None, rate: None }
    }

    /// Forgets every reading (a gap, a reactivation).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Feeds a reading `value` taken at `taken_s` (the cycle's stamp less the reading's age). A
    /// reading taken at the instant of the last one is the same reading (a stale bus) and changes
    /// nothing; one taken earlier than the last starts the track afresh.
    pub fn update(&mut self, value: f64, taken_s: f64) {
        if !(value.is_finite() && taken_s.is_finite()) {
            self.reset();
            return;
        }
        match self.last {
            Some((_, t0)) if (taken_s - t0).abs() <= 1e-9 => {}
            Some((v0, t0)) if taken_s > t0 => {
                let dt = taken_s - t0;
                self.rate = (dt <= Self::MAX_SPAN_S).then(|| (value - v0) / dt);
                self.last = Some((value, taken_s));
            }
            _ => {
                self.rate = None;
                self.last = Some((value, taken_s));
            }
        }
    }

    /// The newest reading carried to the instant `t_s` along the last rate; as it is when there
    /// is no rate or `t_s` lies more than [`Self::MAX_SPAN_S`] from it; `None` before any reading.
    pub fn at(&self, t_s: f64) -> Option<f64> {
        let (v, t0) = self.last?;
        let span = t_s - t0;
        Some(match self.rate {
            Some(r) if span.abs() <= Self::MAX_SPAN_S => v + r * span,
            _ => v,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::ReadingTrack;

    #[test]
    fn a_stale_reading_keeps_the_rate_and_a_gap_drops_it() {
        let mut t = ReadingTrack::new();
        assert_eq!(t.at(0.0), None);
        t.update(1.0, 0.0);
        assert_eq!(t.at(0.01), Some(1.0), "one reading has no rate");
        t.update(1.1, 0.025);
        t.update(1.1, 0.025); // the same frame again
        assert!((t.at(0.035).unwrap() - 1.14).abs() < 1e-12);
        t.update(2.0, 0.5); // after a gap: no rate across it
        assert_eq!(t.at(0.51), Some(2.0));
        t.update(f64::NAN, 0.525);
        assert_eq!(t.at(0.525), None);
        t.update(0.0, 0.6);
        t.update(0.0, 0.3); // time ran backwards: afresh
        assert_eq!(t.at(0.31), Some(0.0));
    }
}
