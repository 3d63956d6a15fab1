//! A part of the prepared data (training or held out): its samples, the history before it and
//! the pieces that start again inside it.

use super::causes::Restart;

/// Prepared samples of one part of the data (training or held out).
#[derive(Clone, Debug)]
pub(crate) struct Part {
    /// Deflections before this part (a stateful effect carries over).
    pub warm: Vec<f64>,
    /// The record's samples before this part, over its history (see [`Lead`]).
    pub lead: Lead,
    /// Pieces inside the part that do not follow on from the samples before them, each with
    /// its own history (see [`Samples::restarts`](super::causes::Samples::restarts)).
    pub restarts: Vec<Restart>,
    pub t: Vec<f64>,
    pub d: Vec<f64>,
    pub v: Vec<f64>,
    pub tau: Vec<f64>,
    pub pivot: Vec<f64>,
    /// Which repetition of the record each sample belongs to; empty for a record of one (see
    /// [`Samples::repetition`](super::causes::Samples::repetition)).
    pub rep: Vec<u32>,
    /// For a record read as bin averages, each sample's rate at its interval's start and end
    /// less its own [rad/s] (see `prepare::rate_edges`); empty for point samples.
    pub rate_edges: Vec<[f64; 2]>,
    /// For a record read as bin averages, the interval each sample averages over [s]: the log's
    /// own step, whatever the part's stride (a decimated part's samples are bins apart).
    pub bin_width_s: f64,
    /// Sample period [s].
    pub dt: f64,
}

/// The times [s] and rates [rad/s] of the record's samples before a part, at its stride: the
/// part's history, whose deflections are `Part::warm`. The transforms read the history ahead of
/// the part's own samples (see `Model::design`): a delay's first samples are the deflection
/// before the part, which the part alone does not hold, and a loop's history is delayed with
/// the part. Held at the part's first value instead, a delay of 1.4 samples at 20 Hz put the
/// first two samples of a held-out window where the joint had been 50-120 ms before (the blind
/// device D of seed 46 at 20 Hz: its first held-out sample 1.57 Nm off, the held-out error 7.6
/// times the noise floor). Empty where a part has no such samples (a test's part, say): the
/// transforms then read the part alone.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lead {
    pub t: Vec<f64>,
    pub v: Vec<f64>,
}

impl Part {
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// This part's samples followed by `next`'s (training samples either side of a held-out
    /// window, the searches' pieces); the history before it is this part's, and `next` starts
    /// again from its own (a restart at its first sample).
    pub fn then(&self, next: &Part) -> Part {
        if next.len() == 0 {
            return self.clone();
        }
        if self.len() == 0 {
            return next.clone();
        }
        let join = |a: &Vec<f64>, b: &Vec<f64>| a.iter().chain(b).copied().collect();
        // Repetitions are both parts' or none (a record of one repetition has none).
        let rep = if self.rep.is_empty() || next.rep.is_empty() { Vec::new() } else { self.rep.iter().chain(&next.rep).copied().collect() };
        let rate_edges = if self.rate_edges.is_empty() || next.rate_edges.is_empty() { Vec::new() } else { self.rate_edges.iter().chain(&next.rate_edges).copied().collect() };
        // `next` starts from its own history, not from where this part ended.
        let restarts = self.restarts.iter().cloned().chain(std::iter::once(Restart { at: self.len(), history_rad: next.warm.clone() })).chain(next.restarts.iter().map(|r| Restart { at: r.at + self.len(), history_rad: r.history_rad.clone() })).collect();
        Part { warm: self.warm.clone(), lead: self.lead.clone(), restarts, t: join(&self.t, &next.t), d: join(&self.d, &next.d), v: join(&self.v, &next.v), tau: join(&self.tau, &next.tau), pivot: join(&self.pivot, &next.pivot), rep, rate_edges, bin_width_s: self.bin_width_s, dt: self.dt }
    }
}
