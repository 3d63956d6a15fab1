//! The joint-state sample: every joint of the arm, once per cycle (`<arm>/joint_state`).
//!
//! On the wire a sample is an iceoryx2 slice of [`JointSample`]s, one per DOF, sized by the arm,
//! with an [`ArmStateHeader`] as its user header; in a process it is an [`ArmState`].

use iceoryx2::prelude::*;

use crate::{JointMode, NAME_LEN};

/// One joint DOF's observed state in SI units. A field whose bit in `valid_mask` is clear is
/// unknown (its value is NaN).
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.JointSample.v1")]
pub struct JointSample {
    /// NUL-padded joint name.
    pub name: [u8; NAME_LEN],
    /// Joint position [rad].
    pub position_rad: f64,
    /// Joint velocity [rad/s].
    pub velocity_rad_s: f64,
    /// Deflection of the elastic element [rad].
    pub deflection_rad: f64,
    /// Joint torque [Nm].
    pub torque_nm: f64,
    /// Joint stiffness [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// VSA pivot position [mm].
    pub pivot_mm: f64,
    /// The torque reference in use [Nm] (torque and impedance modes), NaN otherwise.
    pub reference_torque_nm: f64,
    /// The torque its force/torque sensor measures [Nm] (the joint's `torque_sensor`; for
    /// validation and recording, never used by the observer), NaN when it has none or the
    /// reading is not usable this cycle.
    pub sensor_torque_nm: f64,
    /// The torque that holds the arm against gravity at the observed pose [Nm] (the arm's URDF,
    /// `kinematics`; appendix C), NaN when the arm has none or a position of the chain is
    /// unknown. Torque and impedance references are beyond it when the DOF's controller has
    /// `gravity_feedforward`.
    pub gravity_nm: f64,
    /// [`FieldMask`] bits of the observed fields.
    pub valid_mask: u32,
    /// 0, or the fault that holds this joint (1 = its plugin panicked; >= 16 plugin codes).
    pub fault_code: u32,
    /// Control mode.
    pub mode: JointMode,
    /// 1 when the joint accepts commands (not disabled).
    pub enabled: u32,
}

impl JointSample {
    /// An unnamed, unobserved joint.
    pub const EMPTY: JointSample = JointSample {
        name: [0; NAME_LEN],
        position_rad: f64::NAN,
        velocity_rad_s: f64::NAN,
        deflection_rad: f64::NAN,
        torque_nm: f64::NAN,
        stiffness_nm_per_rad: f64::NAN,
        pivot_mm: f64::NAN,
        reference_torque_nm: f64::NAN,
        sensor_torque_nm: f64::NAN,
        gravity_nm: f64::NAN,
        valid_mask: 0,
        fault_code: 0,
        mode: JointMode::HOLD,
        enabled: 1,
    };

    /// An unobserved joint with this name.
    ///
    /// ```
    /// let s = jointctl_ipc::JointSample::named("q4");
    /// assert_eq!(jointctl_ipc::decode_name(&s.name), "q4");
    /// assert!(s.torque_nm.is_nan());
    /// ```
    pub fn named(name: &str) -> Self {
        JointSample { name: crate::encode_name(name), ..JointSample::EMPTY }
    }

    /// The value of a field if its bit is set in `valid_mask`.
    ///
    /// ```
    /// use jointctl_ipc::{FieldMask, JointSample};
    /// let mut s = JointSample::EMPTY;
    /// s.torque_nm = 2.0;
    /// assert_eq!(s.get(FieldMask::TORQUE, s.torque_nm), None);
    /// s.valid_mask = FieldMask::TORQUE;
    /// assert_eq!(s.get(FieldMask::TORQUE, s.torque_nm), Some(2.0));
    /// ```
    pub fn get(&self, bit: u32, value: f64) -> Option<f64> {
        (self.valid_mask & bit != 0).then_some(value)
    }
}

/// The user header of a joint-state sample: what is the cycle's, not a joint's. The joints are
/// the sample's payload, a slice with one [`JointSample`] per DOF in YAML order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.ArmStateHeader.v1")]
pub struct ArmStateHeader {
    /// Cycle counter, from 0 at start.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// 1 in the final sample published at shutdown.
    pub final_sample: u32,
    /// Joints in the payload: its slice length, said again for clients that read the payload
    /// as bytes (iceoryx2's Python package 0.10 reports a slice's length in bytes).
    pub joint_count: u32,
}

/// Every joint of the arm in one cycle, as a process holds it: the header's fields and the
/// joints, as many as the arm has DOFs.
///
/// ```
/// let mut s = jointctl_ipc::ArmState::named(["q1", "q2"]);
/// s.cycle = 7;
/// s.joints[1].torque_nm = 1.5;
/// let copy = jointctl_ipc::ArmState::from_parts(&s.header(), s.joints());
/// assert_eq!((copy.cycle, copy.joints().len(), copy.joints()[1].torque_nm), (7, 2, 1.5));
/// assert_eq!(jointctl_ipc::decode_name(&copy.joints()[1].name), "q2");
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ArmState {
    /// Cycle counter, from 0 at start.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// 1 in the final sample published at shutdown.
    pub final_sample: u32,
    /// The joints, in YAML order.
    pub joints: Vec<JointSample>,
}

impl ArmState {
    /// A state with no joints.
    pub const EMPTY: ArmState = ArmState { cycle: 0, stamp_ns: 0, final_sample: 0, joints: Vec::new() };

    /// A state of unobserved joints with these names (cycle 0).
    pub fn named<'a>(names: impl IntoIterator<Item = &'a str>) -> Self {
        ArmState { joints: names.into_iter().map(JointSample::named).collect(), ..ArmState::EMPTY }
    }

    /// The joints.
    pub fn joints(&self) -> &[JointSample] {
        &self.joints
    }

    /// The sample's header.
    pub fn header(&self) -> ArmStateHeader {
        ArmStateHeader { cycle: self.cycle, stamp_ns: self.stamp_ns, final_sample: self.final_sample, joint_count: self.joints.len() as u32 }
    }

    /// A state from a received sample's header and joints.
    pub fn from_parts(header: &ArmStateHeader, joints: &[JointSample]) -> Self {
        let mut s = ArmState::EMPTY;
        s.copy_from_parts(header, joints);
        s
    }

    /// This state overwritten by a received sample's header and joints; allocation-free when it
    /// holds as many joints already.
    pub fn copy_from_parts(&mut self, header: &ArmStateHeader, joints: &[JointSample]) {
        (self.cycle, self.stamp_ns, self.final_sample) = (header.cycle, header.stamp_ns, header.final_sample);
        self.joints.clear();
        self.joints.extend_from_slice(joints);
    }

    /// This state overwritten by `other`; allocation-free when it holds as many joints already
    /// (the runtime's copy of a cycle's record).
    pub fn copy_from(&mut self, other: &ArmState) {
        self.copy_from_parts(&other.header(), &other.joints);
    }
}

/// A received joint-state sample.
pub type ArmStateSample = iceoryx2::sample::Sample<ipc::Service, [JointSample], ArmStateHeader>;

impl From<&ArmStateSample> for ArmState {
    fn from(sample: &ArmStateSample) -> Self {
        ArmState::from_parts(sample.user_header(), sample.payload())
    }
}
