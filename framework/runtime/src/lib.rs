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
        HalBackend::Sim => jointctl_sim::SimHal::new(&loaded.config)
            .map(|h| Box::new(h) as Box<dyn Hal>)
            .map_err(|e| setup_error(loaded, e)),
        HalBackend::Socketcan => {
            check_bus_budget(loaded)?;
            jointctl_hal::hardware::HardwareHal::new(&loaded.config).map(|h| Box::new(h) as Box<dyn Hal>).map_err(|e| setup_error(loaded, e))
        }
    }
}

fn setup_error(loaded: &LoadedConfig, e: jointctl_hal::HalSetupError) -> ConfigErrors {
    match e {
        jointctl_hal::HalSetupError::Config { field, message } => loaded.source.error(&field, message).into(),
    }
}

/// Checks that the configured CAN buses can carry the loop rate (worst-case stuffing). Over
/// 100 % is an error for the real buses, a warning for the simulated backend (returned as text).
pub fn check_bus_budget(loaded: &LoadedConfig) -> Result<Vec<String>, ConfigErrors> {
    let mut warnings = Vec::new();
    for b in jointctl_hal::budget::budgets(&loaded.config) {
        if b.load_percent > 100.0 {
            let message = format!("the CAN bus cannot carry this rate: {b}");
            match loaded.config.hal.backend {
                HalBackend::Socketcan => return Err(loaded.source.error("rate_hz", message).into()),
                HalBackend::Sim => warnings.push(format!("warning: on real hardware {message}")),
            }
        }
    }
    Ok(warnings)
}

/// Loads the plugins of a config and builds its arm on a HAL with no hardware behind it, to
/// validate plugins, parameters and wiring without the buses (`jointctl check`).
pub fn build_arm_for_check(loaded: &LoadedConfig, loader: &PluginLoader) -> Result<Arm, ConfigErrors> {
    Arm::build(loaded, loader, Box::new(jointctl_hal::NullHal))
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
