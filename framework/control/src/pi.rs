use serde::Deserialize;

use crate::InvalidNumber;

/// Gains and limits of a [`Pi`] loop, as written in a joint's YAML `params`.
///
/// The thesis tuned its PI gains experimentally and does not print them (sections 4.3, 5):
/// every default here is an assumption.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PiGains {
    /// Proportional gain [output unit / input unit].
    pub kp: f64,
    /// Integral gain [output unit / (input unit * s)].
    pub ki: f64,
    /// Symmetric output limit (|output| <= limit). Assumption when not given: unlimited.
    #[serde(default = "unlimited")]
    pub output_limit: f64,
}

fn unlimited() -> f64 {
    f64::INFINITY
}

impl PiGains {
    /// Checks the gains are finite and non-negative and the limit positive.
    ///
    /// ```
    /// use jointctl_control::PiGains;
    /// assert!(PiGains { kp: 1.0, ki: 0.5, output_limit: 0.1 }.validate().is_ok());
    /// assert!(PiGains { kp: -1.0, ki: 0.5, output_limit: 0.1 }.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), InvalidNumber> {
        InvalidNumber::check("kp", self.kp, "finite and >= 0", self.kp.is_finite() && self.kp >= 0.0)?;
        InvalidNumber::check("ki", self.ki, "finite and >= 0", self.ki.is_finite() && self.ki >= 0.0)?;
        InvalidNumber::check("output_limit", self.output_limit, "> 0", self.output_limit > 0.0)?;
        Ok(())
    }
}

/// A PI controller with anti-windup: while the output saturates in the direction of the error,
/// the integrator grows no further than the output limit.
///
/// ```
/// use jointctl_control::{Pi, PiGains};
/// let mut pi = Pi::new(PiGains { kp: 2.0, ki: 10.0, output_limit: 1.0 });
/// assert_eq!(pi.update(0.1, 0.01), 0.2 + 10.0 * 0.1 * 0.01);
/// // A large error saturates, and the integrator stops growing.
/// for _ in 0..1000 { assert!(pi.update(5.0, 0.01) <= 1.0); }
/// assert!(pi.integral() <= 1.0);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Pi {
    gains: PiGains,
    integral: f64,
}

impl Pi {
    /// A PI loop with a zero integrator.
    pub const fn new(gains: PiGains) -> Self {
        Pi { gains, integral: 0.0 }
    }

    /// One step: `error` in the input unit, `dt_s` the step [s]. Returns the limited output.
    pub fn update(&mut self, error: f64, dt_s: f64) -> f64 {
        let limit = self.gains.output_limit;
        let p = self.gains.kp * error;
        let candidate = self.integral + self.gains.ki * error * dt_s;
        // Anti-windup: while the output saturates in the direction of the error, the integrator
        // may grow only until the output reaches the limit, never past it (and never shrinks
        // because of the saturation).
        self.integral = if p + candidate > limit && error > 0.0 {
            self.integral.max((limit - p).min(candidate))
        } else if p + candidate < -limit && error < 0.0 {
            self.integral.min((-limit - p).max(candidate))
        } else {
            candidate
        }
        .clamp(-limit, limit);
        (p + self.integral).clamp(-limit, limit)
    }

    /// The integrator state.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Clears the integrator (on mode changes).
    pub fn reset(&mut self) {
        self.integral = 0.0;
    }

    /// Replaces the gains, keeping the integrator (gain scheduling).
    pub fn set_gains(&mut self, gains: PiGains) {
        self.gains = gains;
        self.integral = self.integral.clamp(-gains.output_limit, gains.output_limit);
    }
}
