//! # jointctl-runtime
//!
//! The host runtime: loads joint plugins ([`loader`]), wires them to a HAL from YAML
//! ([`arm::Arm::build`]; which backend is `jointctl-backends`' business) and runs the
//! fixed-rate observe → control → actuate loop ([`runner::run`]) with its state in iceoryx2
//! shared memory. It knows the `Hal` trait only: no simulator, no bus driver.

#![warn(missing_docs)]
pub mod arm;
pub mod command_desk;
pub mod commands;
pub mod doctor;
pub mod guard;
pub mod joint;
pub mod loader;
pub mod lock;
pub mod publisher;
mod run_error;
pub mod runner;
pub mod signals;
mod state_fill;
pub mod status;
pub mod timing;

pub use arm::{ActivateError, Arm, JointSlot};
pub use loader::{LoadPluginError, PluginLoader, PluginSource};
pub use publisher::{ArmPublisher, HopSample};
pub use run_error::RunError;
pub use runner::{ControlLoop, RunOptions, RunReport, run};

use jointctl_config::LoadedConfig;

/// A plugin loader with the config's `plugin_dirs` (relative to the config file) searched first.
pub fn loader_for(loaded: &LoadedConfig) -> PluginLoader {
    PluginLoader::new(loaded.config.plugin_dirs.iter().map(|d| loaded.source.resolve(d)))
}
