//! # jointctl-ipc
//!
//! The shared-memory contract of a running arm, used by the runtime (publisher) and by every
//! inspector (subscribers), so that both sides always agree on types, names and QoS.
//!
//! Services per arm (`<arm>` is the YAML `arm:` name):
//! - `<arm>/joint_state`: one [`ArmState`] per cycle, on the wire a slice of [`JointSample`]s
//!   sized by the arm, with an [`ArmStateHeader`];
//! - `<arm>/diagnostics`: one [`Diagnostics`] per cycle;
//!
//! Every per-cycle sample is sized by the arm: a slice of joints, or a byte payload of several
//! arrays ([`wire`]), with the cycle's fields in an iceoryx2 user header.
//! - `<arm>/raw`, `<arm>/raw_descriptor`, `<arm>/commands`: what the loop read and wrote, and the
//!   commands it accepted ([`raw`]);
//! - `<arm>/command`: requests (request-response).
//!
//! Payloads are `#[repr(C)]` with a versioned iceoryx2 type name (`jointctl.JointSample.v1`), so that
//! iceoryx2 clients in other languages (its Python package) can open them: iceoryx2 compares type
//! name, size and alignment but not field order, hence the version in the name. Every process of
//! one arm builds its iceoryx2 config with [`iceoryx2_config_in`] rather than looking for a config
//! file relative to its working directory, so that all of them meet in one domain.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod access;
mod command;
mod descriptor;
mod diagnostics;
mod latest;
mod open;
mod services;
mod state;
pub mod wire;

pub use command::*;
pub use descriptor::*;
pub use diagnostics::*;
pub use latest::*;
pub use open::*;
pub use services::*;
pub use state::*;
pub use wire::{SliceSendError, send_sliced};

use iceoryx2::prelude::*;

pub use jointctl_api::FieldMask;

/// Bytes of a joint name in a sample (NUL-padded).
pub const NAME_LEN: usize = 16;

// A joint name the config accepts always fits its field with the NUL.
const _: () = assert!(jointctl_api::MAX_JOINT_NAME < NAME_LEN);

/// Bytes of a device name field (NUL-padded).
pub const DEVICE_NAME_LEN: usize = 48;

// A device name the config accepts always fits its field with the NUL.
const _: () = assert!(jointctl_api::MAX_DEVICE_NAME < DEVICE_NAME_LEN);

/// Declares a `#[repr(C)]` `u32` newtype with named values, `ALL` (every value with its name,
/// for clients in other languages too), `name()` and `from_name()`.
///
/// Newtypes rather than Rust `enum`s: a subscriber reads them from memory another process
/// wrote, and an `enum` holding a value outside its variants would be undefined behaviour;
/// here an unknown value is just named `"unknown"`.
macro_rules! named_codes {
    ($(#[$doc:meta])* $ty:ident { $($(#[$vdoc:meta])* $konst:ident = $value:literal, $name:literal;)+ }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, ZeroCopySend, zerocopy::FromBytes, zerocopy::IntoBytes, zerocopy::Immutable, zerocopy::KnownLayout)]
        #[repr(C)]
        pub struct $ty(pub u32);

        impl $ty {
            $($(#[$vdoc])* pub const $konst: $ty = $ty($value);)+
            /// Every value with its name, in code order.
            pub const ALL: &'static [($ty, &'static str)] = &[$(($ty::$konst, $name)),+];

            /// The value's lower-case name, `"unknown"` for a value outside `ALL`.
            pub fn name(self) -> &'static str {
                Self::ALL.iter().find(|(m, _)| *m == self).map_or("unknown", |(_, n)| n)
            }

            /// The value with this name.
            pub fn from_name(name: &str) -> Option<$ty> {
                Self::ALL.iter().find(|(_, n)| *n == name).map(|(m, _)| *m)
            }
        }
    };
}

pub mod raw;

named_codes! {
    /// A joint DOF's control mode, as published in [`JointSample::mode`].
    ///
    /// ```
    /// use jointctl_ipc::JointMode;
    /// assert_eq!(JointMode::TORQUE.name(), "torque");
    /// assert_eq!(JointMode::from_name("impedance"), Some(JointMode::IMPEDANCE));
    /// assert_eq!(JointMode(99).name(), "unknown");
    /// ```
    JointMode {
        /// Holding the drives where they are.
        HOLD = 0, "hold";
        /// Position control with the feedback PI (section 4.3).
        POSITION = 1, "position";
        /// A direct joint set-point.
        MANUAL = 2, "manual";
        /// Following a time-stamped trajectory.
        TRAJECTORY = 3, "trajectory";
        /// Torque control (figure 4.6).
        TORQUE = 4, "torque";
        /// Impedance control through the torque mode.
        IMPEDANCE = 5, "impedance";
    }
}

named_codes! {
    /// The waveform of a torque reference in a [`CommandRequest`] (chapter 5's step, sine and
    /// cosine).
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::TorqueWaveform::COSINE.name(), "cosine");
    /// ```
    TorqueWaveform {
        /// A step of `amplitude` at the start time.
        STEP = 0, "step";
        /// `amplitude * sin(2 pi f t)`.
        SINE = 1, "sine";
        /// `amplitude * cos(2 pi f t)`.
        COSINE = 2, "cosine";
    }
}

named_codes! {
    /// What a [`CommandRequest`] asks for.
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::CommandKind::STIFFNESS.name(), "stiffness");
    /// ```
    CommandKind {
        /// Hold one joint (`joint` set) or all joints (`joint` empty).
        HOLD = 1, "hold";
        /// Position control to `values[0]` [rad], with the position feedback PI.
        POSITION = 2, "position";
        /// Direct joint set-point `values[0]` [rad] (no feedback PI).
        MANUAL = 3, "manual";
        /// Follow `points[..point_count]` = (time [s], position [rad], velocity [rad/s] or NaN).
        TRAJECTORY = 4, "trajectory";
        /// Torque reference of [`CommandRequest::waveform`]: `values` = [amplitude [Nm],
        /// frequency [Hz], offset [Nm], start delay [s]].
        TORQUE = 5, "torque";
        /// Impedance: `values` = [K [Nm/rad], D [Nms/rad], target [rad] or NaN for "where it is"].
        IMPEDANCE = 6, "impedance";
        /// Requested stiffness `values[0]` [Nm/rad] (variable stiffness joints).
        STIFFNESS = 7, "stiffness";
        /// Enable a joint (it accepts commands again, starting in hold).
        ENABLE = 8, "enable";
        /// Disable a joint: it holds and refuses commands until enabled.
        DISABLE = 9, "disable";
        /// Stop the runtime (as SIGINT: joints held, final state published).
        STOP = 10, "stop";
    }
}

/// Upper bounds [us] of the cycle-jitter histogram buckets in [`Diagnostics`].
pub const JITTER_BUCKET_UPPER_US: [u64; 16] =
    [1, 2, 5, 10, 20, 50, 100, 200, 500, 1_000, 2_000, 5_000, 10_000, 20_000, 50_000, u64::MAX];

/// A name in a fixed-size, NUL-padded field of `N` bytes ([`NAME_LEN`] for joints,
/// [`DEVICE_NAME_LEN`] for devices); at most `N - 1` bytes are kept.
///
/// ```
/// let n: [u8; jointctl_ipc::NAME_LEN] = jointctl_ipc::encode_name("q2");
/// assert_eq!(jointctl_ipc::decode_name(&n), "q2");
/// let d: [u8; jointctl_ipc::DEVICE_NAME_LEN] = jointctl_ipc::encode_name("enc_shoulder_pulley_a");
/// assert_eq!(jointctl_ipc::decode_name(&d), "enc_shoulder_pulley_a");
/// ```
pub fn encode_name<const N: usize>(name: &str) -> [u8; N] {
    let mut out = [0u8; N];
    // The last byte stays NUL: readers may treat the field as a C string.
    jointctl_api::abi::copy_utf8_prefix(&mut out[..N - 1], name);
    out
}

/// The text of a fixed-size name field.
pub fn decode_name<const N: usize>(bytes: &[u8; N]) -> &str {
    let end = bytes.iter().position(|b| *b == 0).unwrap_or(N);
    core::str::from_utf8(&bytes[..end]).unwrap_or("?")
}
