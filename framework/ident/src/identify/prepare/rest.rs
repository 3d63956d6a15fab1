//! A friction record's stick phases. Where a joint is at rest its friction is static: any torque
//! up to the breakaway holds, set by whatever holds the joint (a drive's last command, a brake,
//! the gravity model's error), and it decays or jumps as that changes, with no motion to say
//! why (Karnopp's stick phase; Armstrong-Helouvry et al. 1994). No sliding friction model
//! predicts it. In a record whose deflection column is a joint position (no spring), the samples
//! at rest are therefore left out of the fit and of the held-out judgement; the report counts
//! them and gives the error over every held-out sample as well. Beside a spring a hold is no
//! stick phase: the spring's torque still follows the deflection there.
//!
//! Finding (the blind generator's friction-position records, LuGre and Stribeck friction): at
//! each stop the torque held up to 4.8 Nm for about 0.3 s and then decayed to the sensor's offset
//! over another 0.3 s, with the joint's reading unchanged. Those stops left 12 times the noise
//! over the held-out part with the offset or viscous friction that was hidden there unnamed
//! (seed 6's 065: an offset of 0.22 Nm refused at t = -0.2).

use super::{GAP_STEPS, Prepared};
use crate::identify::design::Part;

/// A joint is at rest where its rate stays below one count of its encoder per this time, for at
/// least this time [s] (an assumption: a joint that moves less than a count in 0.1 s moves
/// slower than its rate can be read, 3.8e-3 rad/s on a 14-bit encoder; the stops of the blind
/// generator's friction records and of an arm's test motions last 0.3 s and more).
pub const REST_S: f64 = 0.1;

/// The samples at rest and what they held, over the whole record.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AtRest {
    /// Training and held-out samples at rest, left out of the fit and the judgement.
    pub samples: usize,
    /// Of them, in the held-out part.
    pub held_out_samples: usize,
    /// The time at rest in the training and held-out parts [s].
    pub seconds: f64,
    /// The smallest and the largest torque held at rest [Nm].
    pub torque_range_nm: [f64; 2],
    /// The baseline's held-out RMSE over every held-out sample, those at rest included [Nm]
    /// (`rmse_before` is over the samples that slide).
    pub rmse_before_all_nm: Option<f64>,
    /// The extended model's, likewise [Nm].
    pub rmse_after_all_nm: Option<f64>,
}

/// Which samples of `part` are at rest: runs whose rate stays below `rate_floor` [rad/s] for
/// at least [`REST_S`] and over enough samples that leaving them out parts the record there
/// (more than [`GAP_STEPS`] sample periods: the fit's states and delays restart after a stop, as
/// after a logger's gap).
fn at_rest(part: &Part, rate_floor: f64) -> Vec<bool> {
    let n = part.len();
    let mut rest = vec![false; n];
    let mut i = 0;
    while i < n {
        if part.v[i].abs() >= rate_floor {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < n && part.v[j].abs() < rate_floor {
            j += 1;
        }
        if part.t[j - 1] - part.t[i] >= REST_S && (j - i) as f64 >= GAP_STEPS + 2.0 {
            rest[i..j].iter_mut().for_each(|r| *r = true);
        }
        i = j;
    }
    rest
}

/// `part` without the samples flagged in `drop`.
fn without(part: &Part, drop: &[bool]) -> Part {
    let keep = |x: &Vec<f64>| -> Vec<f64> { x.iter().zip(drop).filter(|(_, d)| !**d).map(|(x, _)| *x).collect() };
    Part {
        warm: part.warm.clone(),
        t: keep(&part.t),
        d: keep(&part.d),
        v: keep(&part.v),
        tau: keep(&part.tau),
        pivot: if part.pivot.len() == part.len() { keep(&part.pivot) } else { part.pivot.clone() },
        rep: if part.rep.len() == part.len() { part.rep.iter().zip(drop).filter(|(_, d)| !**d).map(|(r, _)| *r).collect() } else { part.rep.clone() },
        rate_edges: if part.rate_edges.len() == part.len() { part.rate_edges.iter().zip(drop).filter(|(_, d)| !**d).map(|(r, _)| *r).collect() } else { part.rate_edges.clone() },
        dt: part.dt,
    }
}

/// Samples a part must keep once its stops are out (an assumption: fewer than this say little
/// of a friction's shape; a record mostly at rest is then judged whole, as before).
const MIN_SLIDING: usize = 200;

impl Prepared {
    /// The record without its samples at rest (see the module), and what they were; `None` when
    /// it has none, or when too little would be left to judge on.
    pub(crate) fn sliding_only(&self) -> Option<(Prepared, AtRest)> {
        // A rate below one count per REST_S: the encoder's count, the data's smallest step.
        let floor = self.resolution_rad / REST_S;
        let flags = |part: &Part| at_rest(part, floor);
        let (train, test) = (flags(&self.train), flags(&self.test));
        let count = |f: &[bool]| f.iter().filter(|r| **r).count();
        let (rest_train, rest_test) = (count(&train), count(&test));
        if rest_train + rest_test == 0 || self.train.len() - rest_train < MIN_SLIDING || self.test.len() - rest_test < MIN_SLIDING {
            return None;
        }
        let mut p = self.clone();
        p.train = without(&self.train, &train);
        p.test = without(&self.test, &test);
        let coarse = flags(&self.coarse);
        p.coarse = without(&self.coarse, &coarse);
        let stretch = flags(&self.stretch);
        p.stretch = without(&self.stretch, &stretch);
        if p.coarse.len() < MIN_SLIDING || p.stretch.len() < MIN_SLIDING {
            return None;
        }
        let held = self.train.tau.iter().zip(&train).chain(self.test.tau.iter().zip(&test)).filter(|(_, r)| **r).map(|(x, _)| *x);
        let torque_range_nm = held.fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], x| [lo.min(x), hi.max(x)]);
        let seconds = |part: &Part, f: &[bool]| part.dt * count(f) as f64;
        let reading = AtRest { samples: rest_train + rest_test, held_out_samples: rest_test, seconds: seconds(&self.train, &train) + seconds(&self.test, &test), torque_range_nm, rmse_before_all_nm: None, rmse_after_all_nm: None };
        Some((p, reading))
    }
}

/// `sliding` (the record without its stops) with `whole`'s held-out part, stops included: a
/// model fitted on the samples that slide, scored over every held-out sample.
pub(crate) fn scored_on_every_sample(sliding: &Prepared, whole: &Prepared) -> Prepared {
    let mut test = whole.test.clone();
    if sliding.test.rate_edges.is_empty() {
        test.rate_edges = Vec::new();
    }
    Prepared { test, ..sliding.clone() }
}
