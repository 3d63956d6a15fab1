//! Appendix C's validation: figure C.1's pose and masses, eq. C.3's hand values and figure C.2's
//! solver values, in this project's joint numbering (figure C.2 counts from q0: its q_i is q(i+1)
//! here; see `configs/sherpa_arm.urdf`).
//!
//! ```
//! use jointctl_kinematics::{Chain, Gravity, appendix_c};
//! let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
//! let mut gravity = Gravity::new(appendix_c::masses(&chain));
//! let q = appendix_c::pose(gravity.chain().dof_names()).unwrap();
//! let mut tau = vec![0.0; q.len()];
//! gravity.torques(&q, &mut tau).unwrap();
//! for (dof, solver) in appendix_c::FIGURE_C2_NM {
//!     let k = gravity.chain().dof_names().iter().position(|d| d == dof).unwrap();
//!     assert!((tau[k] - solver).abs() <= 0.01 * solver.abs(), "{dof}: {} vs {solver}", tau[k]);
//! }
//! ```

use crate::Chain;

/// Figure C.1: "the arm is set in a angle of 45 degrees", stretched: q2 (the shoulder's pitch,
/// figure C.2's q1) at 45 degrees, every other joint at zero.
pub const SHOULDER_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Figure C.1: "all masses of the joints are set to 1 [Kg]" (the camera and gripper, 0 kg, are
/// not in the URDF).
pub const BODY_MASS_KG: f64 = 1.0;

/// Figure C.2's solver values [Nm] (MoveIt!'s kinematic solver on the thesis' URDF), by this
/// project's joint names. The joints it does not print are zero there.
pub const FIGURE_C2_NM: [(&str, f64); 4] = [("q2", -28.4263), ("q4", -10.5619), ("q5", -7.06608), ("q7", -0.692195)];

/// Eq. C.3's hand values [Nm] (magnitudes: "a change of sign is required"), by this project's
/// joint names: eq. C.3's Shoulder, Elbow, "Upperarm" and Wrist.
pub const EQ_C3_NM: [(&str, f64); 4] = [("q2", 28.48), ("q4", 10.58), ("q5", 7.08), ("q7", 0.693)];

/// Figure C.1's pose for the movable joints `dofs` (q2 at 45 degrees, the rest zero); `None`
/// when the arm has no `q2`.
pub fn pose(dofs: &[String]) -> Option<Vec<f64>> {
    dofs.iter().any(|d| d == "q2").then(|| dofs.iter().map(|d| if d == "q2" { SHOULDER_ANGLE_RAD } else { 0.0 }).collect())
}

/// The arm with figure C.1's masses: every body 1 kg.
pub fn masses(chain: &Chain) -> Chain {
    chain.with_masses(|_, _| BODY_MASS_KG)
}
