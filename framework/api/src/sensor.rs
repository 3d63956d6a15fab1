//! The raw sensor view a joint plugin reads: one [`Reading`] per wired encoder and one
//! [`DriveReading`] per wired drive, in the order of the plugin's declared roles.
//!
//! A reading carries its status and age so that a lost or late frame is never mistaken for a
//! value (thesis appendix A: lost CAN frames read as zero and made the arm drop).

/// How trustworthy a [`Reading`] is. A `#[repr(transparent)]` byte rather than an enum, so that a
/// value written by another library can never be an invalid enum discriminant.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ReadingStatus(pub u8);

impl ReadingStatus {
    /// Never received (or the role is not wired). The value must not be used.
    pub const MISSING: Self = Self(0);
    /// Received this cycle and passed the bus' checks.
    pub const VALID: Self = Self(1);
    /// The last good value; nothing new arrived this cycle. `age_s` says how old it is.
    pub const STALE: Self = Self(2);
    /// Received but failed a check (parity, error flag, plausibility). Must not be used.
    pub const INVALID: Self = Self(3);
}

/// One scalar sensor reading in SI units (rad for encoders).
///
/// ```
/// use jointctl_api::Reading;
/// let r = Reading::valid(0.25);
/// assert_eq!(r.usable(0.1), Some(0.25));
/// assert_eq!(Reading::stale(0.25, 0.5).usable(0.1), None); // too old
/// assert_eq!(Reading::MISSING.usable(1.0), None);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// The value, meaningful only when [`Reading::usable`] returns it.
    pub value: f64,
    /// Age of the value [s]: 0 when it arrived this cycle.
    pub age_s: f64,
    /// Status of the value.
    pub status: ReadingStatus,
    _reserved: [u8; 7],
}

impl Reading {
    /// A reading that never arrived.
    pub const MISSING: Reading = Reading {
        value: f64::NAN,
        age_s: f64::INFINITY,
        status: ReadingStatus::MISSING,
        _reserved: [0; 7],
    };

    /// A fresh, checked value.
    pub const fn valid(value: f64) -> Self {
        Reading { value, age_s: 0.0, status: ReadingStatus::VALID, _reserved: [0; 7] }
    }

    /// A checked value received `age_s` ago (bus latency).
    pub const fn valid_aged(value: f64, age_s: f64) -> Self {
        Reading { value, age_s, status: ReadingStatus::VALID, _reserved: [0; 7] }
    }

    /// The last good value, `age_s` seconds old.
    pub const fn stale(value: f64, age_s: f64) -> Self {
        Reading { value, age_s, status: ReadingStatus::STALE, _reserved: [0; 7] }
    }

    /// A frame that arrived but failed its checks.
    pub const fn invalid() -> Self {
        Reading { status: ReadingStatus::INVALID, ..Reading::MISSING }
    }

    /// The value if it may be used: valid, or stale but no older than `max_age_s`, and finite.
    pub fn usable(&self, max_age_s: f64) -> Option<f64> {
        let fresh_enough = match self.status {
            ReadingStatus::VALID => true,
            ReadingStatus::STALE => self.age_s <= max_age_s,
            _ => false,
        };
        (fresh_enough && self.value.is_finite()).then_some(self.value)
    }
}

impl Default for Reading {
    fn default() -> Self {
        Reading::MISSING
    }
}

/// What a motor drive reports each cycle (ELMO: motor-side position from its incremental encoder,
/// and the torque its current loop applies).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct DriveReading {
    /// Motor (gearbox output) position [rad].
    pub position_rad: Reading,
    /// Motor (gearbox output) velocity [rad/s].
    pub velocity_rad_s: Reading,
    /// The motor's torque at the gearbox output [Nm]: the drive's current reading (CiA 402
    /// torque actual value 0x6077, per mille of the rated torque). What the drive's position
    /// loop applies, its load and inertia included; missing where the drive does not report it.
    pub torque_nm: Reading,
    /// 1 when the drive reports it is enabled and following set-points.
    pub enabled: u8,
    /// 1 when the drive reports a fault.
    pub fault: u8,
    _reserved: [u8; 6],
}

impl DriveReading {
    /// A drive reading from its parts.
    ///
    /// ```
    /// use jointctl_api::{DriveReading, Reading};
    /// let d = DriveReading::new(Reading::valid(1.0), Reading::valid(0.0), true, false);
    /// assert_eq!(d.enabled, 1);
    /// ```
    pub const fn new(position_rad: Reading, velocity_rad_s: Reading, enabled: bool, fault: bool) -> Self {
        DriveReading {
            position_rad,
            velocity_rad_s,
            torque_nm: Reading::MISSING,
            enabled: enabled as u8,
            fault: fault as u8,
            _reserved: [0; 6],
        }
    }

    /// The reading with the motor's torque [Nm] (the drive's current reading).
    ///
    /// ```
    /// use jointctl_api::{DriveReading, Reading};
    /// let d = DriveReading::new(Reading::valid(1.0), Reading::MISSING, true, false);
    /// assert_eq!(d.torque_nm.usable(0.0), None, "not reported unless given");
    /// assert_eq!(d.with_torque(Reading::valid(2.5)).torque_nm.usable(0.0), Some(2.5));
    /// ```
    pub const fn with_torque(self, torque_nm: Reading) -> Self {
        DriveReading { torque_nm, ..self }
    }
}

/// Most encoders one joint plugin instance can be wired to (the wrist uses 4 for deflection
/// plus output and pivot encoders, thesis section 3.5.1).
pub const MAX_ENCODERS: usize = 8;
/// Most drives one joint plugin instance can be wired to (wrist: two joint motors + pivot).
pub const MAX_DRIVES: usize = 4;

/// Everything one joint plugin instance sees of the hardware in one cycle.
///
/// `encoders[i]` is the device wired to the plugin's i-th encoder role, `drives[i]` to its i-th
/// drive role; roles not wired (optional ones) read [`Reading::MISSING`].
///
/// ```
/// use jointctl_api::{RawJointView, Reading};
/// let mut raw = RawJointView::default();
/// raw.encoders[0] = Reading::valid(0.1);
/// assert_eq!(raw.encoder(0).usable(0.0), Some(0.1));
/// assert_eq!(raw.encoder(7).usable(1.0), None);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawJointView {
    /// Monotonic time of this cycle [s] since the runtime started.
    pub stamp_s: f64,
    /// Nominal cycle period [s].
    pub dt_s: f64,
    /// Encoders by role.
    pub encoders: [Reading; MAX_ENCODERS],
    /// Drives by role.
    pub drives: [DriveReading; MAX_DRIVES],
}

impl Default for RawJointView {
    fn default() -> Self {
        RawJointView {
            stamp_s: 0.0,
            dt_s: 0.0,
            encoders: [Reading::MISSING; MAX_ENCODERS],
            drives: [DriveReading::default(); MAX_DRIVES],
        }
    }
}

impl RawJointView {
    /// The encoder wired to role `index` ([`Reading::MISSING`] past the array).
    pub fn encoder(&self, index: usize) -> &Reading {
        self.encoders.get(index).unwrap_or(&Reading::MISSING)
    }

    /// The drive wired to role `index`.
    pub fn drive(&self, index: usize) -> DriveReading {
        self.drives.get(index).copied().unwrap_or_default()
    }
}
