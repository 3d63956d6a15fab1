//! ATI Net F/T's Raw Data Transfer (RDT) protocol over UDP, the usual interface of the Mini40
//! the thesis validated against (chapter 5): an 8-byte request starts the stream, each 36-byte
//! record carries the six force/torque counts. Big-endian throughout (ATI's Net F/T manual,
//! "RDT interface").
//!
//! ```
//! use jointctl_hal::codec::netft::{RdtRecord, decode, encode};
//! let r = RdtRecord { rdt_sequence: 7, ft_sequence: 9, status: 0, counts: [0, 0, 0, 0, 0, 1_500_000] };
//! assert_eq!(decode(&encode(&r)), Ok(r));
//! ```

/// The RDT port of a Net F/T box.
pub const RDT_PORT: u16 = 49152;
/// The request header.
pub const HEADER: u16 = 0x1234;
/// Command: stop streaming.
pub const STOP_STREAMING: u16 = 0x0000;
/// Command: start high-speed real-time streaming.
pub const START_REALTIME: u16 = 0x0002;
/// Bytes of a record.
pub const RECORD_LEN: usize = 36;
/// Status bit that flags an error in the box (saturation, a broken gauge, a failed
/// self-test); the lower bits are details and warnings.
pub const STATUS_ERROR: u32 = 0x8000_0000;

/// A request: `command` for `samples` records (0: without end).
///
/// ```
/// let r = jointctl_hal::codec::netft::request(jointctl_hal::codec::netft::START_REALTIME, 0);
/// assert_eq!(r, [0x12, 0x34, 0, 2, 0, 0, 0, 0]);
/// ```
pub fn request(command: u16, samples: u32) -> [u8; 8] {
    let mut out = [0u8; 8];
    out[0..2].copy_from_slice(&HEADER.to_be_bytes());
    out[2..4].copy_from_slice(&command.to_be_bytes());
    out[4..8].copy_from_slice(&samples.to_be_bytes());
    out
}

/// A request read back (what a box, or a test's box, receives): `(command, samples)`.
pub fn decode_request(bytes: &[u8]) -> Option<(u16, u32)> {
    let b: &[u8; 8] = bytes.try_into().ok()?;
    (u16::from_be_bytes([b[0], b[1]]) == HEADER).then(|| (u16::from_be_bytes([b[2], b[3]]), u32::from_be_bytes([b[4], b[5], b[6], b[7]])))
}

/// One RDT record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RdtRecord {
    /// Records sent since streaming started (a gap is a lost datagram).
    pub rdt_sequence: u32,
    /// The box's internal sample counter.
    pub ft_sequence: u32,
    /// Status word ([`STATUS_ERROR`]).
    pub status: u32,
    /// Fx, Fy, Fz, Tx, Ty, Tz in counts.
    pub counts: [i32; 6],
}

/// Why bytes are not a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RdtError {
    /// Not 36 bytes.
    #[error("an RDT record has 36 bytes, got {0}")]
    Length(usize),
}

/// A record from a datagram.
pub fn decode(bytes: &[u8]) -> Result<RdtRecord, RdtError> {
    let b: &[u8; RECORD_LEN] = bytes.try_into().map_err(|_| RdtError::Length(bytes.len()))?;
    let word = |i: usize| [b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]];
    let mut counts = [0i32; 6];
    for (k, c) in counts.iter_mut().enumerate() {
        *c = i32::from_be_bytes(word(3 + k));
    }
    Ok(RdtRecord { rdt_sequence: u32::from_be_bytes(word(0)), ft_sequence: u32::from_be_bytes(word(1)), status: u32::from_be_bytes(word(2)), counts })
}

/// A record as a box sends it (for simulated and test boxes).
pub fn encode(r: &RdtRecord) -> [u8; RECORD_LEN] {
    let mut out = [0u8; RECORD_LEN];
    for (i, w) in [r.rdt_sequence, r.ft_sequence, r.status].iter().enumerate() {
        out[4 * i..4 * i + 4].copy_from_slice(&w.to_be_bytes());
    }
    for (k, c) in r.counts.iter().enumerate() {
        out[12 + 4 * k..16 + 4 * k].copy_from_slice(&c.to_be_bytes());
    }
    out
}

/// The torque about a joint axis [Nm]: `a . (T - p x F)`, `a` the unit axis and `p` a point of
/// it [m], both in the sensor frame, from a record's counts.
///
/// ```
/// use jointctl_hal::codec::netft::{RdtRecord, torque_about_axis};
/// // 1.5 Nm about z; 10 N along x acting 0.1 m off the axis along y adds -(p x F).z = 1 Nm.
/// let r = RdtRecord { rdt_sequence: 0, ft_sequence: 0, status: 0, counts: [10_000_000, 0, 0, 0, 0, 1_500_000] };
/// let t = torque_about_axis(&r, 1e6, 1e6, [0.0, 0.0, 1.0], [0.0, 0.1, 0.0]);
/// assert!((t - 2.5).abs() < 1e-12);
/// ```
pub fn torque_about_axis(r: &RdtRecord, counts_per_force: f64, counts_per_torque: f64, axis: [f64; 3], point_m: [f64; 3]) -> f64 {
    let f = [0, 1, 2].map(|k| f64::from(r.counts[k]) / counts_per_force);
    let t = [3, 4, 5].map(|k| f64::from(r.counts[k]) / counts_per_torque);
    let p = point_m;
    let p_cross_f = [p[1] * f[2] - p[2] * f[1], p[2] * f[0] - p[0] * f[2], p[0] * f[1] - p[1] * f[0]];
    let norm = axis.iter().map(|a| a * a).sum::<f64>().sqrt();
    (0..3).map(|k| axis[k] / norm * (t[k] - p_cross_f[k])).sum()
}
