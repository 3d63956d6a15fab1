//! The deflection rate's estimate: a causal least-squares slope over a window that grows until
//! the deflection in it spans a few resolution steps.

use super::{ModelExtension, RATE_CAPACITY};
use crate::extension::spec::RATE_STEPS;

impl ModelExtension {
    /// The deflection rate [rad/s]: the slope of a least-squares line through the last
    /// `rate_window_s` of samples, or more (up to `rate_window_max_s`) until the deflection in
    /// them spans [`RATE_STEPS`] resolution steps (causal: the observer has no future samples).
    pub fn deflection_rate(&mut self, t_s: f64, phi: f64) -> f64 {
        let tail = (self.head + self.len) % RATE_CAPACITY;
        self.ring[tail] = (t_s, phi);
        if self.len == RATE_CAPACITY {
            self.head = (self.head + 1) % RATE_CAPACITY;
        } else {
            self.len += 1;
        }
        while self.len > 2 && t_s - self.ring[self.head].0 > self.spec.rate_window_max_s {
            self.head = (self.head + 1) % RATE_CAPACITY;
            self.len -= 1;
        }
        // Newest first: how many samples the window takes.
        let span = RATE_STEPS * self.spec.rate_resolution_rad;
        let (mut lo, mut hi) = (phi, phi);
        let mut take = self.len;
        for k in 0..self.len {
            let (t, d) = self.ring[(self.head + self.len - 1 - k) % RATE_CAPACITY];
            (lo, hi) = (lo.min(d), hi.max(d));
            if k >= 1 && t_s - t >= self.spec.rate_window_s && hi - lo >= span {
                take = k + 1;
                break;
            }
        }
        if take < 2 {
            return 0.0;
        }
        let n = take as f64;
        let (mut st, mut sd, mut stt, mut std_) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..take {
            let (t, d) = self.ring[(self.head + self.len - take + k) % RATE_CAPACITY];
            let x = t - t_s;
            (st, sd, stt, std_) = (st + x, sd + d, stt + x * x, std_ + x * d);
        }
        let den = n * stt - st * st;
        if den.abs() < 1e-18 { 0.0 } else { (n * std_ - st * sd) / den }
    }
}
