//! # jointctl-control
//!
//! Small, allocation-free building blocks that joint plugins share. Everything here runs inside
//! one control cycle, so nothing allocates, blocks or does I/O.

mod pi;
mod velocity;

pub use pi::{Pi, PiGains};
pub use velocity::VelocityEstimator;

mod transmission;
pub use transmission::LinearTransmission;
