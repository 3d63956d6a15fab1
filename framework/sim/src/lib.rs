//! # jointctl-sim
//!
//! The simulated arm, replacing the thesis' 20-sim bond-graph models (sections 3.2-3.5), as a
//! HAL backend (`hal: {backend: sim}`): [`elmo`] drives (profile + PID + inertia + friction),
//! [`unit`]s (a joint's transmission, elastic element with plant effects, and environment), and
//! the buses: absolute encoders through the AS5048A codec (14-bit quantisation, noise), drive
//! positions through TPDO1 frames (frame loss, appendix A's zero mode), SPI and CAN latency
//! (section 2.3), all through the same conditioner as the robot. Seeded and stepped by the
//! runtime, so a run is repeatable and can go faster than real time.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod effect_checks;
pub mod elmo;
pub mod free_arm;
pub mod pivot_effects;
pub mod rng;
pub mod unit;

mod latency;
mod shared;
mod sim_hal;

pub use crate::shared::SharedSim;
pub use crate::sim_hal::{EncoderFault, SimHal};
