//! The observed state of one joint degree of freedom.

/// Which fields of a [`JointState`] hold an observed value. A field whose bit is clear is
/// *unknown* (published as `null`), never zero.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct FieldMask(pub u32);

impl FieldMask {
    /// Joint position is observed.
    pub const POSITION: u32 = 1 << 0;
    /// Joint velocity is observed.
    pub const VELOCITY: u32 = 1 << 1;
    /// Deflection of the elastic element is observed.
    pub const DEFLECTION: u32 = 1 << 2;
    /// Joint torque is observed.
    pub const TORQUE: u32 = 1 << 3;
    /// Joint stiffness is observed.
    pub const STIFFNESS: u32 = 1 << 4;
    /// VSA pivot position is observed.
    pub const PIVOT: u32 = 1 << 5;
    /// Set by the observer when a value was clamped to a characterised range (e.g. a pivot
    /// position beyond the measured settings) instead of extrapolated.
    pub const CLAMPED: u32 = 1 << 16;

    /// True when every bit of `bits` is set.
    pub const fn has(self, bits: u32) -> bool {
        self.0 & bits == bits
    }
}

/// The observed state of one joint DOF in SI units.
///
/// Write through the setters so that a non-finite value is never marked valid:
/// ```
/// use jointctl_api::JointState;
/// let mut s = JointState::UNKNOWN;
/// s.set_position(0.5);
/// s.set_torque(f64::NAN); // rejected: stays unknown
/// assert_eq!(s.position(), Some(0.5));
/// assert_eq!(s.torque(), None);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointState {
    /// Joint (link side) position [rad].
    pub position_rad: f64,
    /// Joint velocity [rad/s].
    pub velocity_rad_s: f64,
    /// Deflection of the elastic element [rad].
    pub deflection_rad: f64,
    /// Joint torque [Nm].
    pub torque_nm: f64,
    /// Joint stiffness [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// VSA pivot position [mm] (thesis section 2.4 gives pivot positions in mm).
    pub pivot_mm: f64,
    /// Which of the above are observed.
    pub valid: FieldMask,
    _reserved: u32,
}

macro_rules! field_access {
    ($get:ident, $set:ident, $field:ident, $bit:ident) => {
        #[doc = concat!("The observed `", stringify!($field), "`, or `None` when unknown.")]
        pub fn $get(&self) -> Option<f64> {
            self.valid.has(FieldMask::$bit).then_some(self.$field)
        }
        #[doc = concat!("Sets `", stringify!($field), "` and marks it valid if it is finite; otherwise marks it unknown.")]
        pub fn $set(&mut self, value: f64) {
            if value.is_finite() {
                self.$field = value;
                self.valid.0 |= FieldMask::$bit;
            } else {
                self.$field = f64::NAN;
                self.valid.0 &= !FieldMask::$bit;
            }
        }
    };
}

impl JointState {
    /// Nothing observed.
    pub const UNKNOWN: JointState = JointState {
        position_rad: f64::NAN,
        velocity_rad_s: f64::NAN,
        deflection_rad: f64::NAN,
        torque_nm: f64::NAN,
        stiffness_nm_per_rad: f64::NAN,
        pivot_mm: f64::NAN,
        valid: FieldMask(0),
        _reserved: 0,
    };

    field_access!(position, set_position, position_rad, POSITION);
    field_access!(velocity, set_velocity, velocity_rad_s, VELOCITY);
    field_access!(deflection, set_deflection, deflection_rad, DEFLECTION);
    field_access!(torque, set_torque, torque_nm, TORQUE);
    field_access!(stiffness, set_stiffness, stiffness_nm_per_rad, STIFFNESS);
    field_access!(pivot, set_pivot, pivot_mm, PIVOT);

    /// Marks the state as clamped to a characterised range.
    pub fn mark_clamped(&mut self) {
        self.valid.0 |= FieldMask::CLAMPED;
    }
}

impl Default for JointState {
    fn default() -> Self {
        JointState::UNKNOWN
    }
}
