/// Velocity from successive positions by finite difference, with a first-order low-pass.
///
/// A missing position resets the estimator: the next velocity is unknown, not computed across
/// the gap (a gap read as a value is what made the thesis' arm jump, appendix A).
///
/// ```
/// use jointctl_control::VelocityEstimator;
/// let mut v = VelocityEstimator::new(1.0); // no filtering
/// assert_eq!(v.update(Some(0.0), 0.01), None);
/// assert!((v.update(Some(0.01), 0.01).unwrap() - 1.0).abs() < 1e-12);
/// assert_eq!(v.update(None, 0.01), None);
/// assert_eq!(v.update(Some(0.02), 0.01), None); // restarts after a gap
/// ```
#[derive(Clone, Copy, Debug)]
pub struct VelocityEstimator {
    alpha: f64,
    last_position: Option<f64>,
    filtered: Option<f64>,
}

impl VelocityEstimator {
    /// `alpha` in (0, 1]: weight of the newest difference (1 = no filtering).
    pub const fn new(alpha: f64) -> Self {
        VelocityEstimator { alpha, last_position: None, filtered: None }
    }

    /// Feeds one position [rad] taken `dt_s` after the previous one; returns the velocity [rad/s].
    pub fn update(&mut self, position: Option<f64>, dt_s: f64) -> Option<f64> {
        let Some(q) = position else {
            self.last_position = None;
            self.filtered = None;
            return None;
        };
        let raw = self.last_position.filter(|_| dt_s > 0.0).map(|q0| (q - q0) / dt_s);
        self.last_position = Some(q);
        self.filtered = match (raw, self.filtered) {
            (Some(r), Some(f)) => Some(f + self.alpha * (r - f)),
            (Some(r), None) => Some(r),
            (None, _) => None,
        };
        self.filtered
    }
}
