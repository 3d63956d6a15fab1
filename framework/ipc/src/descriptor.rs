//! The arm's plugin instances, published once and kept for late subscribers (`<arm>/joints`).

use iceoryx2::prelude::*;

use crate::{NAME_LEN, raw};

/// Longest plugin name or version in a [`JointDescriptor`] [bytes, NUL included].
pub const LABEL_LEN: usize = 64;

/// One plugin instance of the arm: what `ros2 control list_controllers` would list.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.JointDescriptor.v1")]
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

/// The user header of the plugin-instance sample; the instances are its payload, a slice
/// with one [`JointDescriptor`] per instance in YAML order.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.JointsDescriptorHeader.v1")]
pub struct JointsDescriptorHeader {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
}

/// The arm's plugin instances, published once at start and kept for late readers.
///
/// ```
/// use jointctl_ipc::{JointDescriptor, JointsDescriptor, decode_name, encode_name};
/// let mut d = JointsDescriptor { rate_hz: 1000.0, joints: Vec::new() };
/// d.joints.push(JointDescriptor { name: encode_name("q4"), plugin: encode_name("elastic"), dof_count: 1, ..JointDescriptor::EMPTY });
/// assert_eq!(decode_name(&d.joints()[0].plugin), "elastic");
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointsDescriptor {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
    /// The plugin instances, in YAML order (at most one per DOF).
    pub joints: Vec<JointDescriptor>,
}

impl JointsDescriptor {
    /// An empty descriptor.
    pub const EMPTY: JointsDescriptor = JointsDescriptor { rate_hz: 0.0, joints: Vec::new() };

    /// The instances.
    pub fn joints(&self) -> &[JointDescriptor] {
        &self.joints
    }

    /// The sample's header.
    pub fn header(&self) -> JointsDescriptorHeader {
        JointsDescriptorHeader { rate_hz: self.rate_hz }
    }

    /// A descriptor from a received sample's header and instances.
    pub fn from_parts(header: &JointsDescriptorHeader, joints: &[JointDescriptor]) -> Self {
        JointsDescriptor { rate_hz: header.rate_hz, joints: joints.to_vec() }
    }
}

/// A received plugin-instance sample.
pub type JointsDescriptorSample = iceoryx2::sample::Sample<ipc::Service, [JointDescriptor], JointsDescriptorHeader>;

impl From<&JointsDescriptorSample> for JointsDescriptor {
    fn from(sample: &JointsDescriptorSample) -> Self {
        JointsDescriptor::from_parts(sample.user_header(), sample.payload())
    }
}
