//! The record as read, before its rate: the readings left out (dropouts, glitches, a torque at
//! its sensor's limit), the columns kept, the motion's period, reversals and quantisation. It
//! does not depend on how the rate is read, so a record is read once and each rate reading of
//! it ([`Read::prepare`]) starts from here: identify screens several readings of one record
//! (see `bin_reading`), and read again for each, the speed benchmark's 100 000-sample record
//! took 36 ms a preparation, 24 of them before the rate (the glitch search 10), five times.

use std::borrow::Cow;

use super::dropouts::dropouts_by_segment;
use super::glitches::glitches_by_segment;
use super::noise::scatter_rms;
use super::crossings::{crossing_rate_by_segment, holds_between_moves};
use super::cubic_rate::cubic_rate_by_segment;
use super::bursts;
use super::lattice;
use super::rate::{DeflectionNoise, coarsest_tick_rad, velocity_by_segment, velocity_half_widths, widest_rate_window};
use super::{HeldOut, HeldOutWindow, MIN_REVERSALS, MIN_SPAN_LSB, PrepareError, Prepared, RateReading, fundamental_hz, noise_floor, resolution_rad, held_out_window, saturation, segment_starts, sign, turns};
use crate::csv::Data;
use crate::identify::causes::{reversals, turn_step_rad};

/// A record as read, before its rate (see the module's doc).
pub(crate) struct Read<'a> {
    /// The record.
    pub data: &'a Data,
    /// The deflection, torque and pivot without the readings left out [rad, Nm, mm]: borrowed
    /// when none is (a long record is not copied whole).
    pub d: Cow<'a, [f64]>,
    pub tau: Cow<'a, [f64]>,
    pub pivot: Cow<'a, [f64]>,
    /// Each kept sample's repetition (see `Data::repetition`); empty for a record of one.
    pub rep: Vec<u32>,
    /// The kept samples' times from the first sample's, `t0` [s] (Unix-epoch stamps, 1.7e9 s,
    /// would leave a sine of the time a few digits only).
    pub t: Vec<f64>,
    pub t0: f64,
    /// Where each segment of contiguous logging starts, in the kept samples.
    pub starts: Vec<usize>,
    /// The motion's fundamental [Hz] and its period [samples].
    pub frequency_hz: f64,
    pub period_samples: f64,
    /// The samples where the motion turns (see `causes::reversals`).
    pub turning: Vec<usize>,
    /// The median time step [s] (irregular logs jitter around it; gaps are not steps).
    pub spacing_s: f64,
    /// The deflection's resolution, its coarsest quantiser's step and its scatter about a line
    /// from sample to sample [rad] (see `resolution_rad`, `rate::coarsest_tick_rad`,
    /// `noise::scatter_rms`).
    pub resolution_rad: f64,
    pub quantum_rad: f64,
    /// The count of the coarsest lattice its steps lie on [rad] (see `lattice`).
    pub lattice_rad: f64,
    pub scatter_rad: f64,
    /// Readings left out: dropouts, glitches besides them, and torques at the sensor's limit
    /// besides both.
    pub dropouts: usize,
    pub glitches: usize,
    pub saturated: usize,
    /// What `Prepared` reports of the whole record: the deflection's step at its turns [rad],
    /// why the torque reads against the deflection if it does (see `sign`), and the turns'
    /// spans of held readings [s] (see `turns`).
    pub turn_step_rad: f64,
    pub reversed_sign: Option<String>,
    pub turn_runs: Vec<(f64, f64)>,
    /// The share of the record's time the training part takes, and the held-out window chosen
    /// on the record as read (dropouts in: a lost reading's zero adds travel and range, accepted
    /// so that the model loop's gains, which see the same columns, choose the same window).
    pub train_fraction: f64,
    pub held_out: HeldOutWindow,
}

impl<'a> Read<'a> {
    /// `data` read, to be split `train_fraction` for training, the held-out part chosen as
    /// `how` says: its refusals are those of identify's preparation that do not depend on the
    /// rate (too few samples, uneven columns, a saturated sensor, too little excitation, a
    /// constant torque).
    pub(crate) fn of(data: &'a Data, train_fraction: f64, how: HeldOut) -> Result<Self, PrepareError> {
        let n_all = data.len();
        if n_all < 50 {
            return Err(PrepareError::TooFewSamples { samples: n_all, needed: 50 });
        }
        if let Some((column, len)) = data.uneven_column() {
            return Err(PrepareError::UnevenColumn { column, len, samples: n_all });
        }
        let resolution = resolution_rad(&data.deflection);
        // Each segment of contiguous logging apart: a record that starts from rest (a
        // repetition, an experiment's next sine) reads exactly zero after a gap, and the reading
        // before the gap is no neighbour of it.
        let raw_starts = segment_starts(&data.t);
        let mut lost = dropouts_by_segment(&data.deflection, &raw_starts, resolution);
        // A torque reading is uncertain by its sensor's noise (a noisy torque near zero may read
        // exactly zero between two readings either side of it: a quantised F/T sensor of 1/640
        // Nm with 0.03 Nm of noise did), measured on the raw series as the floor is.
        let torque_noise = noise_floor(&data.torque, &raw_starts);
        lost.iter_mut().zip(dropouts_by_segment(&data.torque, &raw_starts, torque_noise)).for_each(|(a, b)| *a |= b);
        let dropouts = lost.iter().filter(|l| **l).count();
        // Deflection readings that leap and come back (see `glitches`), besides the dropouts;
        // its noise measured on the raw series, as the torque's is.
        let deflection_noise = noise_floor(&data.deflection, &raw_starts);
        let leaps = glitches_by_segment(&data.deflection, &data.t, &raw_starts, resolution, deflection_noise);
        let mut glitches = 0;
        for (l, leap) in lost.iter_mut().zip(leaps) {
            if leap && !*l {
                *l = true;
                glitches += 1;
            }
        }
        let at_limit = saturation::saturated(&data.torque, &data.deflection, &lost);
        lost.iter_mut().zip(at_limit).for_each(|(a, b)| *a |= b);
        let dropped = lost.iter().filter(|l| **l).count();
        let saturated = dropped - dropouts - glitches;
        if n_all - dropped < 50 && saturated > 0 {
            return Err(PrepareError::Saturated { saturated, samples: n_all, left: n_all - dropped, needed: 50 });
        }
        let kept = |column: &'a [f64]| -> Cow<'a, [f64]> {
            if dropped == 0 { Cow::Borrowed(column) } else { Cow::Owned(column.iter().zip(&lost).filter(|(_, l)| !**l).map(|(x, _)| *x).collect()) }
        };
        let (d, tau, pivot) = (kept(&data.deflection), kept(&data.torque), kept(&data.pivot_mm));
        // Each sample's repetition: the count of restarts at or before it; none for a record of
        // one repetition, so that every part of a record says the same (a part inside the first
        // repetition of a restarted record still fits per repetition what the others do).
        let rep: Vec<u32> = if data.restarts.is_empty() { Vec::new() } else { (0..n_all).filter(|i| !lost[*i]).map(|i| data.repetition(i)).collect() };
        let t0 = data.t[0];
        let t = bursts::laid_evenly(kept(&data.t).iter().map(|x| x - t0).collect());
        let starts = segment_starts(&t);
        let frequency_hz = fundamental_hz(&t, &d);
        let period_samples = {
            let duration = t[t.len() - 1] - t[0];
            (d.len() as f64 / (frequency_hz * duration).max(1.0)).max(1.0)
        };
        let turning = reversals(&d);
        let (lo, hi) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
        let span = hi - lo;
        if span < MIN_SPAN_LSB * resolution || turning.len() < MIN_REVERSALS {
            return Err(PrepareError::TooLittleExcitation { span_rad: span, lsb: span / resolution, reversals: turning.len() });
        }
        // A constant torque under a deflection that moves was reported as too little
        // excitation, with counts and reversals that met the bounds it quoted (issue 40,
        // finding 10).
        if tau.iter().all(|x| *x == tau[0]) {
            return Err(PrepareError::ConstantTorque { value_nm: tau[0] });
        }
        let spacing_s = crate::identify::numeric::median_step(&t);
        // The deflection's noise: its quantisation (at most half a step, see
        // `rate::DeflectionNoise`) and its scatter about a line from sample to sample.
        let scatter_rad = scatter_rms(&d, &starts);
        let quantum_rad = coarsest_tick_rad(&d, &starts, resolution);
        let lattice_rad = lattice::coarse_lattice_rad(&d, &starts, resolution);
        let (turn_step, reversed_sign, turn_runs) = (turn_step_rad(&d, &starts), sign::reversed_sign(&d, &tau), turns::turns(&t, &d));
        let held_out = held_out_window(&data.t, &data.deflection, train_fraction, how);
        Ok(Read { data, d, tau, pivot, rep, t, t0, starts, frequency_hz, period_samples, turning, spacing_s, resolution_rad: resolution, quantum_rad, lattice_rad, scatter_rad, dropouts, glitches, saturated, turn_step_rad: turn_step, reversed_sign, turn_runs, train_fraction, held_out })
    }
}

impl Read<'_> {
    /// Whether the deflection is a staircase of holds between moves, whose rate may be read
    /// through its crossings over `reach_s` either side (see `crossings::holds_between_moves`),
    /// logged faster than a log tried as bin averages (see `bins::tried_as_bins`): a crossing is
    /// an instant between two samples, and a slow log's sample may be a bin's mean, which holds
    /// its value at rest and moves by no count (the blind device D of seed 2 at 20 Hz, read so,
    /// named a Dahl loop beside its delay).
    pub(crate) fn holds_between_moves(&self, reach_s: f64) -> bool {
        !super::tried_as_bins(self.spacing_s) && holds_between_moves(&self.t, &self.d, &self.starts, reach_s)
    }

    /// The deflection's rate read as `rate` says [rad/s], at each kept sample.
    pub(crate) fn rate(&self, rate: RateReading) -> Vec<f64> {
        self.rates(&[rate]).remove(0)
    }

    /// The deflection's rate read each way of `readings` [rad/s], in their order. Adaptive
    /// readings whose windows are the same (the same narrowest window and windows per period:
    /// the usual one and the sharper ones) are read together and share the ladder's windows
    /// (see `rate::velocity_by_segment`), each bit for bit the rate read alone.
    pub(crate) fn rates(&self, readings: &[RateReading]) -> Vec<Vec<f64>> {
        let (t, d, starts) = (&self.t, &self.d, &self.starts);
        let mut rates: Vec<Option<Vec<f64>>> = vec![None; readings.len()];
        for k in 0..readings.len() {
            match readings[k] {
                _ if rates[k].is_some() => {}
                RateReading::Cubic => rates[k] = Some(cubic_rate_by_segment(t, d, starts)),
                RateReading::Crossings { reach_s } => rates[k] = Some(crossing_rate_by_segment(t, d, starts, reach_s)),
                RateReading::Adaptive { narrowest, windows_per_period, .. } => {
                    let alike = |r: &RateReading| matches!(*r, RateReading::Adaptive { narrowest: n, windows_per_period: w, .. } if n == narrowest && w == windows_per_period);
                    let together: Vec<usize> = (k..readings.len()).filter(|j| rates[*j].is_none() && alike(&readings[*j])).collect();
                    let scales: Vec<f64> = together.iter().map(|j| if let RateReading::Adaptive { reach_scale, .. } = readings[*j] { reach_scale } else { 1.0 }).collect();
                    let noise = DeflectionNoise { quantum_rad: self.quantum_rad, scatter_rad: self.scatter_rad };
                    let half = velocity_half_widths(d.len(), &self.turning, self.period_samples, windows_per_period, [narrowest, widest_rate_window(self.spacing_s)]);
                    for (j, rate) in together.into_iter().zip(velocity_by_segment(t, d, starts, noise, &scales, &half)) {
                        rates[j] = Some(rate);
                    }
                }
            }
        }
        rates.into_iter().flatten().collect()
    }
}

/// The most samples a record may have for [`ReadAhead`] to read its readings ahead (an
/// assumption: four readings of 8 bytes a sample held together, 16 MB here; on the 2 million
/// samples of issue 13's bound, 64 MB of its 150). A longer record's readings are read when
/// each is prepared, one at a time, as before.
pub const READ_AHEAD_SAMPLES: usize = 500_000;

/// A record as read with rate readings read ahead, together where they can be (see
/// [`Read::rates`]): identify prepares the usual reading, screens the sharper and wider ones
/// beside it, and prepares the usual one again for the searches. Read one at a time, the usual
/// reading was read twice and each sharper one walked the ladder's windows again (the rate was
/// a third of identify's time on the speed benchmark's 100 000 samples).
pub(crate) struct ReadAhead<'r, 'a> {
    /// The record as read.
    read: &'r Read<'a>,
    /// The readings read ahead and their rates [rad/s].
    ahead: Vec<(RateReading, Vec<f64>)>,
}

impl<'r, 'a> ReadAhead<'r, 'a> {
    /// `readings` of `read` read ahead, when it has at most [`READ_AHEAD_SAMPLES`] samples;
    /// none otherwise.
    pub(crate) fn new(read: &'r Read<'a>, readings: &[RateReading]) -> Self {
        let ahead = if read.d.len() <= READ_AHEAD_SAMPLES { readings.iter().copied().zip(read.rates(readings)).collect() } else { Vec::new() };
        ReadAhead { read, ahead }
    }

    /// Whether the readings were read ahead (the record has at most [`READ_AHEAD_SAMPLES`]).
    pub(crate) fn has_read_ahead(&self) -> bool {
        !self.ahead.is_empty()
    }

    /// Whether `rate` was read ahead with a rate equal, sample for sample, to that of a reading
    /// read ahead before it (the usual one first): prepared, it is that reading.
    pub(crate) fn repeats(&self, rate: RateReading) -> bool {
        self.ahead.iter().position(|(r, _)| *r == rate).is_some_and(|k| self.ahead[..k].iter().any(|(_, v)| *v == self.ahead[k].1))
    }

    /// The record prepared with its rate read as `rate` says: read ahead or read now.
    pub(crate) fn prepare(&self, rate: RateReading) -> Result<Prepared, PrepareError> {
        match self.ahead.iter().find(|(r, _)| *r == rate) {
            Some((_, v)) => self.read.prepare_with_rate(v),
            None => self.read.prepare(rate),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{NARROWEST_RATE_WINDOW, SHARPER_REACH_SCALES, VELOCITY_WINDOWS_PER_PERIOD};
    use super::*;

    /// A 14-bit record of 0.1 rad at 0.2 Hz, 200 Hz (the speed benchmark's motion): a sine, or a
    /// triangle whose rate turns in a sample.
    fn record(triangle: bool) -> Data {
        let q = std::f64::consts::TAU / 16384.0;
        let t: Vec<f64> = (0..20_000).map(|i| i as f64 / 200.0).collect();
        let wave = |t: f64| if triangle { 0.1 * (4.0 * (0.2 * t).fract() - 2.0).abs() - 0.1 } else { 0.1 * (std::f64::consts::TAU * 0.2 * t).sin() };
        let d: Vec<f64> = t.iter().map(|t| (wave(*t) / q).round() * q).collect();
        let tau = d.iter().enumerate().map(|(i, d)| 100.0 * d + 0.01 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)).collect();
        Data::from_columns(t, d, tau)
    }

    /// A sharper reading whose intervals never bind reads the usual rate, and its screening is
    /// passed over; where the rate turns in a sample, it does not.
    #[test]
    fn a_reading_that_reads_an_earlier_ones_rate_repeats_it() {
        let readings = |data: &Data| {
            let read = Read::of(data, 0.7, HeldOut::Last).expect("read");
            let usual = RateReading::usual(NARROWEST_RATE_WINDOW);
            let sharper = |reach_scale| RateReading::Adaptive { narrowest: NARROWEST_RATE_WINDOW, reach_scale, windows_per_period: VELOCITY_WINDOWS_PER_PERIOD };
            let all = [usual, sharper(SHARPER_REACH_SCALES[0]), sharper(SHARPER_REACH_SCALES[1])];
            let ahead = ReadAhead::new(&read, &all);
            all.map(|r| ahead.repeats(r))
        };
        let (sine, triangle) = (readings(&record(false)), readings(&record(true)));
        // The usual reading repeats nothing; on the sine the half reach repeats it.
        assert_eq!(sine[..2], [false, true], "{sine:?}");
        assert_eq!(triangle, [false, false, false], "{triangle:?}");
    }
}
