//! AS5048A-style 14-bit absolute magnetic encoder frames on SPI (thesis section 2.2: 13 such
//! encoders). A 16-bit answer: bit 15 even parity over the whole word, bit 14 error flag,
//! bits 13..0 the angle. Reads are pipelined: the answer to a command arrives with the next
//! transfer.

/// Counts per revolution of a 14-bit encoder.
pub const COUNTS: u32 = 1 << 14;

/// The command word that reads the angle register (0x3FFF, read bit, even parity): 0xFFFF.
pub const READ_ANGLE: u16 = 0xFFFF;

/// Why an encoder frame is not a reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The word's parity is odd.
    Parity,
    /// The encoder set its error flag (e.g. magnet out of range, framing error).
    ErrorFlag,
}

/// Decodes an answer word into counts (0..16383).
///
/// ```
/// use jointctl_hal::codec::as5048::{decode, encode, FrameError};
/// assert_eq!(decode(encode(8192)), Ok(8192));
/// assert_eq!(decode(encode(8192) ^ 0x0001), Err(FrameError::Parity));
/// assert_eq!(decode(0x4000 | 0x8000), Err(FrameError::ErrorFlag)); // flag set, parity even
/// // An all-zero word passes parity: plausibility checks must catch it (see `condition`).
/// assert_eq!(decode(0x0000), Ok(0));
/// ```
pub fn decode(word: u16) -> Result<u16, FrameError> {
    if !word.count_ones().is_multiple_of(2) {
        return Err(FrameError::Parity);
    }
    if word & 0x4000 != 0 {
        return Err(FrameError::ErrorFlag);
    }
    Ok(word & 0x3FFF)
}

/// Encodes counts as an answer word with even parity and no error flag (for the simulated bus
/// and tests).
pub fn encode(counts: u16) -> u16 {
    let w = counts & 0x3FFF;
    if w.count_ones().is_multiple_of(2) { w } else { w | 0x8000 }
}

/// Counts → angle in [0, 2 pi) [rad].
pub fn counts_to_rad(counts: u16) -> f64 {
    counts as f64 * std::f64::consts::TAU / COUNTS as f64
}

/// The joint's angle from an encoder's counts [rad]: negated when the encoder is mounted to count
/// against the joint's positive direction (`reversed`), then its `offset_rad` subtracted (the
/// calibrated position zero).
///
/// ```
/// use jointctl_hal::codec::as5048::{COUNTS, joint_angle_rad};
/// let quarter = (COUNTS / 4) as u16;
/// assert!((joint_angle_rad(quarter, 0.5, false) - (std::f64::consts::FRAC_PI_2 - 0.5)).abs() < 1e-12);
/// assert!((joint_angle_rad(quarter, 0.5, true) - (-std::f64::consts::FRAC_PI_2 - 0.5)).abs() < 1e-12);
/// ```
pub fn joint_angle_rad(counts: u16, offset_rad: f64, reversed: bool) -> f64 {
    let raw = counts_to_rad(counts);
    (if reversed { -raw } else { raw }) - offset_rad
}

/// Angle → nearest counts (wrapped into one revolution): the 14-bit quantisation.
pub fn rad_to_counts(rad: f64) -> u16 {
    let c = (rad / std::f64::consts::TAU * COUNTS as f64).round().rem_euclid(COUNTS as f64);
    (c as u32 % COUNTS) as u16
}
