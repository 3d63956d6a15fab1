//! An arm's joint samples as the shared-memory services carry them, filled from the loop's own
//! state: by the publisher's record after control and by the latest-state blackboard before it.

use jointctl_ipc::{ArmState, JointMode, JointSample};
use jointctl_modes::Mode;

use crate::arm::Arm;

/// `s`'s joints from `arm`'s observed states, references and modes (names kept).
pub(crate) fn fill_joints(s: &mut ArmState, arm: &Arm) {
    for slot in &arm.slots {
        for i in slot.dofs() {
            let st = &arm.states[i];
            s.joints[i] = JointSample {
                name: s.joints[i].name,
                reference_torque_nm: arm.torque_references[i],
                sensor_torque_nm: arm.sensor_torque(i).unwrap_or(f64::NAN),
                gravity_nm: arm.gravity_torques[i],
                mode: published_mode(arm.controllers[i].mode()),
                enabled: arm.enabled[i] as u32,
                position_rad: st.position_rad,
                velocity_rad_s: st.velocity_rad_s,
                deflection_rad: st.deflection_rad,
                torque_nm: st.torque_nm,
                stiffness_nm_per_rad: st.stiffness_nm_per_rad,
                pivot_mm: st.pivot_mm,
                valid_mask: st.valid.0,
                fault_code: slot.fault,
            };
        }
    }
}

/// The mode published in [`jointctl_ipc::JointSample::mode`].
pub fn published_mode(mode: &Mode) -> JointMode {
    match mode {
        Mode::Hold => JointMode::HOLD,
        Mode::Position { .. } => JointMode::POSITION,
        Mode::Manual { .. } => JointMode::MANUAL,
        Mode::Trajectory { .. } => JointMode::TRAJECTORY,
        Mode::Torque { .. } => JointMode::TORQUE,
        Mode::Impedance { .. } => JointMode::IMPEDANCE,
    }
}
