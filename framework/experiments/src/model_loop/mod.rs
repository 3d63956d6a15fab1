//! The model loop's last step (section 6.2's first recommendation): what `jointctl identify`
//! found in measured data, written as an extended observer (the joint's params with a
//! `model_extension`) and an extended simulation (the joint's `sim.effects`, or
//! `sim.effects_by_pivot` from a record of several pivot settings), with the gain of
//! each measured on the data's held-out part.
//!
//! - **Observer**: the recorded deflections through the joint's observer model (its
//!   characteristic and, when it has one, its `model_extension`: the functions the plugins call
//!   online), before and after, against the F/T sensor. `identify` compares the data with the
//!   characteristic alone, so the causes' observer terms together *are* the new extension; an
//!   extension already configured is replaced, never added to.
//! - **Simulation**: the simulated joint's element and effects replayed along the recorded
//!   motion ([`jointctl_sim::unit::Unit::replay`]), before and after, against the F/T sensor. The
//!   causes were named against the observer's model, which need not be the plant's (the
//!   reference arm's plant already holds the hysteresis its observer lacks): a cause's plant
//!   terms go into the simulation only when they make its replay of the *training* part
//!   significantly better (the block t-test of [`jointctl_ident::identify::significance`]); the
//!   held-out part only measures.

use crate::ExperimentError;

mod extension;
mod found;
mod gain;
mod observer;
mod plant_choice;
mod simulation;
mod wrist_offsets;
mod write;

pub use self::extension::{DofEffects, Extension, SettingGain, extend, extend_by_pivot};
pub use self::found::{Found, SettingFound};
pub use self::gain::{Gain, Split, Trace, observer_gain_along};
pub use self::observer::{configured_torque, configured_torque_along, observer_torque, observer_torque_along, observer_torque_of};
pub use self::simulation::{PlantEffects, REPLAY_RATE_WINDOW_S, simulated_torque};
pub use self::wrist_offsets::{DiagonalPart, extend_wrist_offsets};
pub use self::write::{Written, write};

fn err(m: impl Into<String>) -> ExperimentError {
    ExperimentError(m.into())
}

#[cfg(test)]
mod tests;
