//! # jointctl-control
//!
//! Small, allocation-free building blocks that joint plugins share: the PI with anti-windup,
//! the velocity estimate, the linear transmission. Everything here runs inside one control
//! cycle, so nothing allocates, blocks or does I/O. The host's mode logic (hold, position,
//! torque, impedance, ...) lives in `jointctl-modes`, so a plugin built on these blocks pulls in
//! neither it nor a schema generator.

#![forbid(unsafe_code)]

mod invalid;
mod pi;
mod transmission;
mod velocity;

pub use invalid::InvalidNumber;
pub use pi::{Pi, PiGains};
pub use transmission::LinearTransmission;
pub use velocity::VelocityEstimator;
