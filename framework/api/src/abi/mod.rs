//! The plugin ABI: what crosses the shared-library boundary.
//!
//! Only `#[repr(C)]` data and `extern "C"` functions cross it. A plugin library exports one
//! function, `jointctl_plugin_<name>`, returning a `'static` [`PluginDescriptor`]. The host checks
//! the [`DescriptorHeader`] (magic, ABI version, layout hash) before it reads anything else.
//! The shims (in `entry_points.rs`) are generated per plugin type by
//! [`export_joint_plugin!`](crate::export_joint_plugin); they catch panics so that a panic never
//! unwinds across the boundary, and each side frees only what it allocated (the plugin's
//! instance is freed by the plugin's `destroy`; error text is written into a host-owned buffer).

use core::ffi::{CStr, c_char, c_void};
use core::mem::{align_of, offset_of, size_of};

use crate::{DriveReading, JointCommand, JointContext, JointFault, JointState, MotorSetpoint, RawJointView, Reading};

#[macro_use]
mod hash;
mod descriptor;
mod entry_points;
mod error_buf;

pub use descriptor::{DescriptorHeader, PluginDescriptor};
pub use entry_points::{PluginVTable, VTABLE_SIGNATURES};
pub use error_buf::{ErrorBuf, copy_utf8_prefix};
use hash::{mix_bytes, mix_tokens, mix_usize};

/// First 8 bytes of every descriptor: "JNTCTL" + format 1.
pub const ABI_MAGIC: u64 = u64::from_le_bytes(*b"JNTCTL\x00\x01");
/// Bumped on any incompatible change of the shared types or entry points.
pub const ABI_MAJOR: u32 = 2;
/// Bumped on compatible additions; a host accepts plugins with a minor version up to its own.
pub const ABI_MINOR: u32 = 1;
/// Version of the `jointctl-api` crate the library was built against.
pub const API_VERSION: &str = env!("CARGO_PKG_VERSION");
const API_VERSION_C: &CStr = c_string(concat!(env!("CARGO_PKG_VERSION"), "\0"));

/// A `'static` C string from a literal that ends in exactly one NUL; anything else is refused
/// when the constant is evaluated (at compile time in [`export_joint_plugin!`](crate::export_joint_plugin)).
///
/// ```
/// assert_eq!(jointctl_api::abi::c_string("motor\0").to_str(), Ok("motor"));
/// ```
pub const fn c_string(text: &'static str) -> &'static CStr {
    match CStr::from_bytes_with_nul(text.as_bytes()) {
        Ok(c) => c,
        Err(_) => panic!("a descriptor string must end with one NUL and contain no other"),
    }
}

/// Return code of an entry point: success.
pub const STATUS_OK: u32 = 0;
/// Return code of an entry point: the plugin panicked; the panic was caught at the boundary.
pub const STATUS_PANICKED: u32 = 1;
/// Return code of an entry point: the plugin returned an error (see the [`ErrorBuf`]).
pub const STATUS_FAILED: u32 = 2;
// The faults a host raises for these codes carry the same numbers (the plugin module, below the
// ABI, does not import it).
const _: () = assert!(crate::JointFault::PANICKED.code() == STATUS_PANICKED && crate::JointFault::BAD_STATUS.code() == STATUS_FAILED);

/// An opaque plugin instance, owned by the plugin.
pub type Handle = *mut c_void;

/// FNV-1a over everything both sides of the boundary must agree on: the size, alignment, field
/// names, offsets and field types of every shared type, the signatures of the entry points
/// (the vtable's field types), and the constants (status codes, limits, mode, action, status
/// and mask values). Two builds agree on it only if they agree on all of these.
pub const LAYOUT_HASH: u64 = {
    use crate::{ControlMode, DriveAction, FieldMask, ReadingStatus};
    let mut hash = 0xcbf2_9ce4_8422_2325_u64;
    hash_layouts!(hash;
        Reading { value: f64, age_s: f64, status: ReadingStatus }
        DriveReading { position_rad: Reading, velocity_rad_s: Reading, torque_nm: Reading, enabled: u8, fault: u8 }
        RawJointView { stamp_s: f64, dt_s: f64, encoders: [Reading; crate::MAX_ENCODERS], drives: [DriveReading; crate::MAX_DRIVES] }
        JointState { position_rad: f64, velocity_rad_s: f64, deflection_rad: f64, torque_nm: f64, stiffness_nm_per_rad: f64, pivot_mm: f64, valid: FieldMask }
        JointCommand { mode: ControlMode, position_feedback: u8, position_rad: f64, velocity_rad_s: f64, stiffness_nm_per_rad: f64 }
        MotorSetpoint { position_rad: f64, velocity_ff_rad_s: f64, action: DriveAction }
        JointContext { dof: u32, encoder_count: u32, drive_count: u32, rate_hz: f64 }
        ErrorBuf { message_len: u32, field_len: u32, message: [u8; 1024], field: [u8; 256] }
        DescriptorHeader { magic: u64, abi_major: u32, abi_minor: u32, layout_hash: u64, api_version: *const c_char }
        PluginDescriptor {
            header: DescriptorHeader, name: *const c_char, version: *const c_char, built_with_unwind: u8,
            torque_dofs: u8, stiffness_dofs: u8, dof: u32, encoder_roles: *const c_char, drive_roles: *const c_char, vtable: PluginVTable,
        }
    );
    // The entry points: their names, parameter names and types, in order, and the table's size.
    hash = mix_tokens(hash, VTABLE_SIGNATURES);
    hash = mix_usize(hash, size_of::<PluginVTable>());
    hash_constants!(hash;
        crate::MAX_ENCODERS, crate::MAX_DRIVES, crate::MAX_DOF,
        STATUS_OK, STATUS_PANICKED, STATUS_FAILED, JointFault::FIRST_PLUGIN_CODE,
        ControlMode::HOLD.0, ControlMode::POSITION.0,
        DriveAction::HOLD.0, DriveAction::MOVE.0,
        ReadingStatus::MISSING.0, ReadingStatus::VALID.0, ReadingStatus::STALE.0, ReadingStatus::INVALID.0,
        FieldMask::POSITION, FieldMask::VELOCITY, FieldMask::DEFLECTION, FieldMask::TORQUE,
        FieldMask::STIFFNESS, FieldMask::PIVOT, FieldMask::CLAMPED,
    );
    hash
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue finding: swapping two `u32` parameters of an entry point passed the ABI check.
    /// The signatures' text (parameter names included) is part of the hash, taken from the same
    /// tokens that declare the vtable; a changed constant changes the hash too.
    #[test]
    fn the_layout_hash_covers_signatures_with_parameter_names_and_constants() {
        let compact: String = VTABLE_SIGNATURES.split_whitespace().collect();
        let order = "dof:u32,raw:*constRawJointView,out:*mutMotorSetpoint,drives:u32";
        assert!(compact.contains(order), "{compact}");
        let swapped = compact.replacen(order, "drives:u32,raw:*constRawJointView,out:*mutMotorSetpoint,dof:u32", 1);
        let h = |text: &str| mix_tokens(0xcbf2_9ce4_8422_2325, text);
        assert_eq!(h(VTABLE_SIGNATURES), h(&compact), "whitespace does not count");
        assert_ne!(h(&compact), h(&swapped));
        let (mut a, mut b) = (0xcbf2_9ce4_8422_2325_u64, 0xcbf2_9ce4_8422_2325_u64);
        hash_constants!(a; STATUS_FAILED);
        b = mix_bytes(b, b"STATUS_FAILED");
        b = mix_bytes(b, &(STATUS_FAILED as u64 + 1).to_le_bytes());
        assert_ne!(a, b, "a constant's value is hashed");
    }
}
