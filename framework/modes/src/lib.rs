//! # jointctl-modes
//!
//! The host's mode logic, one [`JointController`] per DOF: hold, position (with the plugin's
//! feedback PI, thesis section 4.3), manual, trajectory, torque (figure 4.6, with section 6.2's
//! gain schedule) and impedance; their reference generators and trajectories; and the YAML
//! `controller:` settings ([`ControllerConfig`]). The runtime runs it; plugins never see it: they
//! get a joint set-point and map it onto their motors with `jointctl-control`'s blocks.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

mod controller_config;
mod joint_controller;
mod mode;
mod reference;
mod schema;
mod trajectory;

pub use controller_config::{ControllerConfig, ControllerConfigError, DofLimits, GainPoint, StartupMode};
pub use joint_controller::{ControllerEvents, JointController, Observed, Output};
pub use mode::Mode;
pub use reference::{Reference, Waveform};
pub use schema::PiGainsSchema;
pub use trajectory::{MAX_TRAJECTORY_POINTS, Trajectory, TrajectoryError, TrajectoryPoint};
