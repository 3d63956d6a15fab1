//! # jointctl-control
//!
//! Small, allocation-free building blocks that joint plugins share: the PI with anti-windup,
//! section 4.3's position loop ([`PositionLoop`]), the velocity estimate, the linear
//! transmission, a reading carried to another reading's instant ([`ReadingTrack`]). Everything
//! here runs inside one control cycle, so nothing allocates, blocks or does I/O. The host's mode
//! logic (hold, position, torque, impedance, ...) lives in `jointctl-modes`, so a plugin built on
//! these blocks pulls in neither it nor a schema generator.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

mod reading_track;
mod invalid;
mod pi;
mod position_loop;
mod transmission;
mod velocity;

pub use reading_track::ReadingTrack;
pub use invalid::InvalidNumber;
pub use pi::{Pi, PiGains};
pub use position_loop::{PositionLoop, default_max_age_s};
pub use transmission::LinearTransmission;
pub use velocity::VelocityEstimator;
