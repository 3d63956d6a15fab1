//! # jointctl-runtime
//!
//! The host runtime: loads joint plugins ([`loader`]), wires them to the hardware from YAML
//! ([`arm::Arm::build`]) and runs the fixed-rate observe → publish → control → actuate loop
//! ([`runner::run`]) with its state in iceoryx2 shared memory.

pub mod arm;
pub mod commands;
pub mod joint;
pub mod loader;
pub mod runner;
pub mod timing;

pub use arm::{ActivateError, Arm, JointSlot};
pub use loader::{LoadPluginError, PluginLoader, PluginSource};
pub use runner::{ArmPublisher, ControlLoop, RunError, RunOptions, RunReport, run};

use jointctl_config::{ConfigErrors, HalBackend, LoadedConfig};
use jointctl_hal::Hal;

/// The HAL backend a config asks for.
pub fn build_hal(loaded: &LoadedConfig) -> Result<Box<dyn Hal>, ConfigErrors> {
    match loaded.config.hal.backend {
        HalBackend::Sim => jointctl_hal::sim::SimHal::new(&loaded.config)
            .map(|h| Box::new(h) as Box<dyn Hal>)
            .map_err(|e| setup_error(loaded, e)),
        HalBackend::Socketcan => {
            for b in jointctl_hal::budget::budgets(&loaded.config) {
                if b.load_percent > 100.0 {
                    return Err(loaded.source.error("rate_hz", format!("the CAN bus cannot carry this rate: {b}")).into());
                }
            }
            jointctl_hal::hardware::HardwareHal::new(&loaded.config).map(|h| Box::new(h) as Box<dyn Hal>).map_err(|e| setup_error(loaded, e))
        }
    }
}

fn setup_error(loaded: &LoadedConfig, e: jointctl_hal::HalSetupError) -> ConfigErrors {
    match e {
        jointctl_hal::HalSetupError::Config { field, message } => loaded.source.error(&field, message).into(),
    }
}

/// A plugin loader with the config's `plugin_dirs` (relative to the config file) searched first.
pub fn loader_for(loaded: &LoadedConfig) -> PluginLoader {
    PluginLoader::new(loaded.config.plugin_dirs.iter().map(|d| loaded.source.resolve(d)))
}

/// Loads the plugins of a config and builds its arm on the configured HAL.
pub fn build_arm(loaded: &LoadedConfig, loader: &PluginLoader) -> Result<Arm, ConfigErrors> {
    let hal = build_hal(loaded)?;
    Arm::build(loaded, loader, hal)
}
