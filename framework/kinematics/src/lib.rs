//! The arm's kinematic and inertial description and what gravity does to it.
//!
//! Appendix C of the thesis describes the SHERPA arm as a URDF (links with a mass and a centre of
//! mass, table C.1; frames a distance apart, table C.2) and validates the gravity torques of one
//! pose (figure C.1, eq. C.3, figure C.2). Here:
//!
//! - [`Chain`]: a URDF read with `urdf-rs` into a tree of bodies and joints, validated (one root,
//!   known links, revolute / continuous / fixed joints, finite numbers), each error saying which
//!   element is wrong.
//! - [`Gravity`]: the generalised gravity torque of every movable joint at a pose, the torque the
//!   joint must apply to hold the pose (the convention of Pinocchio's `computeGeneralizedGravity`
//!   and of figure C.2's solver). Allocation-free after construction, for the control cycle.
//! - [`Dynamics`]: the arm's equation of motion (inverse dynamics, mass matrix, forward
//!   dynamics with joints locked), allocation-free, for the simulated free arm.
//! - [`appendix_c`]: figure C.1's pose and masses and figure C.2's printed values.
//!
//! ```
//! use jointctl_kinematics::{Chain, Gravity};
//! // One 2 kg body 0.5 m up a pitch joint, tilted 30 degrees.
//! let urdf = r#"<robot name="pendulum">
//!   <link name="base"/>
//!   <link name="arm"><inertial><origin xyz="0 0 0.5"/><mass value="2"/>
//!     <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
//!   <joint name="q1" type="revolute"><parent link="base"/><child link="arm"/>
//!     <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="100" velocity="1"/></joint>
//! </robot>"#;
//! let chain = Chain::from_urdf_str(urdf).unwrap();
//! let mut gravity = Gravity::new(chain);
//! let mut tau = [0.0];
//! gravity.torques(&[30f64.to_radians()], &mut tau).unwrap();
//! // Holding torque: -m g l sin(q).
//! assert!((tau[0] + 2.0 * 9.81 * 0.5 * 0.5).abs() < 1e-12);
//! ```

#![warn(missing_docs)]
pub mod appendix_c;
mod chain;
mod dynamics;
mod gravity;

pub use chain::{Body, Chain, ChainError, JointFrame};
pub use dynamics::{Dynamics, DynamicsError};
pub use gravity::{Gravity, PoseError, STANDARD_GRAVITY_M_S2};
