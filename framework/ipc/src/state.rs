//! The joint-state sample: every joint of the arm, once per cycle (`<arm>/joint_state`).

use iceoryx2::prelude::*;

use crate::{JointMode, MAX_JOINTS, NAME_LEN};

/// One joint DOF's observed state in SI units. A field whose bit in `valid_mask` is clear is
/// unknown (its value is NaN).
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
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

/// Every joint of the arm, once per cycle.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.ArmState.v4")]
pub struct ArmState {
    /// Cycle counter, from 0 at start.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// Number of valid entries in `joints`.
    pub joint_count: u32,
    /// 1 in the final sample published at shutdown.
    pub final_sample: u32,
    /// The joints, in YAML order.
    pub joints: [JointSample; MAX_JOINTS],
}

impl ArmState {
    /// An empty sample.
    pub const EMPTY: ArmState =
        ArmState { cycle: 0, stamp_ns: 0, joint_count: 0, final_sample: 0, joints: [JointSample::EMPTY; MAX_JOINTS] };

    /// The valid joints.
    pub fn joints(&self) -> &[JointSample] {
        &self.joints[..(self.joint_count as usize).min(MAX_JOINTS)]
    }
}
