//! The arm's plugin instances, published once and kept for late subscribers (`<arm>/joints`).

use iceoryx2::prelude::*;

use crate::{MAX_JOINTS, NAME_LEN, raw};

/// Longest plugin name or version in a [`JointDescriptor`] [bytes, NUL included].
pub const LABEL_LEN: usize = 64;

/// One plugin instance of the arm: what `ros2 control list_controllers` would list.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct JointDescriptor {
    /// NUL-padded instance name (the YAML's `joints[].name`).
    pub name: [u8; NAME_LEN],
    /// NUL-padded plugin name.
    pub plugin: [u8; LABEL_LEN],
    /// NUL-padded plugin crate version.
    pub version: [u8; LABEL_LEN],
    /// NUL-padded path of the plugin's library; empty when it is linked into the host.
    pub library: [u8; raw::PATH_LEN],
    /// Index of its first DOF in [`ArmState::joints`].
    pub first_dof: u32,
    /// Number of DOFs it serves.
    pub dof_count: u32,
    /// Time its plugin may take per cycle, observe and control together [ns].
    pub budget_ns: u64,
}

impl JointDescriptor {
    /// An unnamed entry.
    pub const EMPTY: JointDescriptor =
        JointDescriptor { name: [0; NAME_LEN], plugin: [0; LABEL_LEN], version: [0; LABEL_LEN], library: [0; raw::PATH_LEN], first_dof: 0, dof_count: 0, budget_ns: 0 };
}

/// The arm's plugin instances, published once at start and kept for late readers.
///
/// ```
/// use jointctl_ipc::{JointDescriptor, JointsDescriptor, decode_name, encode_name};
/// let mut d = JointsDescriptor::EMPTY;
/// d.joints[0] = JointDescriptor { name: encode_name("q4"), plugin: encode_name("elastic"), dof_count: 1, ..JointDescriptor::EMPTY };
/// d.joint_count = 1;
/// assert_eq!(decode_name(&d.joints()[0].plugin), "elastic");
/// ```
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.JointsDescriptor.v1")]
pub struct JointsDescriptor {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
    /// Number of valid entries in `joints`.
    pub joint_count: u32,
    _reserved: u32,
    /// The plugin instances, in YAML order (at most one per DOF).
    pub joints: [JointDescriptor; MAX_JOINTS],
}

impl JointsDescriptor {
    /// An empty descriptor.
    pub const EMPTY: JointsDescriptor = JointsDescriptor { rate_hz: 0.0, joint_count: 0, _reserved: 0, joints: [JointDescriptor::EMPTY; MAX_JOINTS] };

    /// The valid entries.
    pub fn joints(&self) -> &[JointDescriptor] {
        &self.joints[..(self.joint_count as usize).min(MAX_JOINTS)]
    }
}
