//! The buses' latency: set-points in flight to a drive over the CAN bus, and a device's past
//! values, read as they were a latency ago.

/// Set-points on their way to one drive over the CAN bus: each is applied when its latency has
/// passed. A fixed ring, so that the control cycle never allocates; when it is full the oldest
/// pending set-point is dropped (a newer absolute target supersedes it anyway).
#[derive(Clone, Debug)]
pub(crate) struct InFlight {
    /// (time due [s], target [rad]).
    ring: [(f64, f64); InFlight::CAPACITY],
    head: usize,
    len: usize,
}

impl InFlight {
    /// 30 ms of set-points at 8 kHz.
    const CAPACITY: usize = 256;

    pub(crate) fn new() -> Self {
        InFlight { ring: [(0.0, 0.0); Self::CAPACITY], head: 0, len: 0 }
    }

    pub(crate) fn push(&mut self, due_s: f64, target: f64) {
        if self.len == Self::CAPACITY {
            self.head = (self.head + 1) % Self::CAPACITY;
            self.len -= 1;
        }
        self.ring[(self.head + self.len) % Self::CAPACITY] = (due_s, target);
        self.len += 1;
    }

    /// The newest set-point due by `now_s`, taking it and every older one off the ring.
    pub(crate) fn arrived(&mut self, now_s: f64) -> Option<f64> {
        let mut target = None;
        while self.len > 0 && self.ring[self.head].0 <= now_s + 1e-12 {
            target = Some(self.ring[self.head].1);
            self.head = (self.head + 1) % Self::CAPACITY;
            self.len -= 1;
        }
        target
    }
}

/// Past values of one device, one per physics step, to read them with a bus latency.
#[derive(Clone, Debug)]
pub(crate) struct DelayLine {
    samples: Vec<(f64, f64)>,
    next: usize,
    filled: bool,
}

impl DelayLine {
    const CAPACITY: usize = 512;

    pub(crate) fn new() -> Self {
        DelayLine { samples: vec![(f64::NEG_INFINITY, 0.0); Self::CAPACITY], next: 0, filled: false }
    }

    pub(crate) fn push(&mut self, t: f64, v: f64) {
        self.samples[self.next] = (t, v);
        self.next = (self.next + 1) % Self::CAPACITY;
        self.filled |= self.next == 0;
    }

    /// The newest value no newer than `t` (the oldest kept if all are newer). Walks back from
    /// the newest sample: a latency of L costs L / substep steps.
    pub(crate) fn at(&self, t: f64) -> f64 {
        let n = if self.filled { Self::CAPACITY } else { self.next };
        let mut oldest = 0.0;
        for back in 1..=n {
            let k = (self.next + Self::CAPACITY - back) % Self::CAPACITY;
            let (ts, v) = self.samples[k];
            if ts <= t + 1e-12 {
                return v;
            }
            oldest = v;
        }
        oldest
    }

    /// [`Self::at`], but `None` when nothing was kept at or before `t` and nothing older was
    /// dropped: a reading from before the simulation started, which no sensor gave.
    pub(crate) fn reading_at(&self, t: f64) -> Option<f64> {
        let n = if self.filled { Self::CAPACITY } else { self.next };
        let newest_kept_before = (1..=n).map(|back| self.samples[(self.next + Self::CAPACITY - back) % Self::CAPACITY]).find(|(ts, _)| *ts <= t + 1e-12);
        match newest_kept_before {
            Some((_, v)) => Some(v),
            None if self.filled => Some(self.at(t)),
            None => None,
        }
    }
}
