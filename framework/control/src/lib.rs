//! # jointctl-control
//!
//! Small, allocation-free building blocks that joint plugins share. Everything here runs inside
//! one control cycle, so nothing allocates, blocks or does I/O.

#![forbid(unsafe_code)]

mod joint_controller;
mod pi;
mod reference;
mod trajectory;
mod velocity;

pub use joint_controller::{ControllerConfig, ControllerEvents, DofLimits, GainPoint, JointController, Mode, Observed, Output, StartupMode};
pub use pi::{Pi, PiGains};
pub use reference::{Reference, Waveform};
pub use trajectory::{MAX_TRAJECTORY_POINTS, Trajectory, TrajectoryPoint};
pub use velocity::VelocityEstimator;

mod transmission;
pub use transmission::LinearTransmission;
