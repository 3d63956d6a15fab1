//! The one error a building block's settings can have: a number outside its field's range.

use std::fmt;

/// A number outside the range its field allows; `field` is the YAML key, `rule` the range in
/// words.
///
/// ```
/// use jointctl_control::InvalidNumber;
/// let e = InvalidNumber { field: "kp", value: -1.0, rule: "finite and >= 0" };
/// assert_eq!(e.to_string(), "kp must be finite and >= 0, got -1");
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InvalidNumber {
    /// The field (YAML key) that holds the number.
    pub field: &'static str,
    /// The value found.
    pub value: f64,
    /// What the value must be, in words.
    pub rule: &'static str,
}

impl InvalidNumber {
    /// `Ok(value)` when `ok`, the error otherwise.
    ///
    /// ```
    /// use jointctl_control::InvalidNumber;
    /// assert!(InvalidNumber::check("ki", f64::NAN, "finite", false).is_err());
    /// ```
    pub fn check(field: &'static str, value: f64, rule: &'static str, ok: bool) -> Result<f64, InvalidNumber> {
        if ok { Ok(value) } else { Err(InvalidNumber { field, value, rule }) }
    }
}

impl fmt::Display for InvalidNumber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} must be {}, got {}", self.field, self.rule, self.value)
    }
}

impl std::error::Error for InvalidNumber {}
