//! # jointctl-backends
//!
//! The one place that knows every HAL backend: it reads `hal.backend` from an arm description
//! and builds the simulated arm (`jointctl-sim`) or the real buses (`jointctl-hal-socketcan`),
//! then the arm on it. The runtime itself knows only the `Hal` trait, so a deployment that links
//! the runtime does not link the simulator through it, and adding a backend touches this crate
//! and the config's `HalBackend` only.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

use jointctl_config::{ConfigErrors, HalBackend, LoadedConfig};
use jointctl_hal::Hal;
use jointctl_runtime::{Arm, PluginLoader};

/// The HAL backend a config asks for.
///
/// ```
/// let loaded = jointctl_config::parse_str(
///     "arm: a\nhal: {backend: sim}\nbuses: {can: [{interface: can0, drives: [{name: m, node_id: 1}]}]}\njoints: [{name: q, plugin: rigid}]\n",
///     "a.yaml").unwrap();
/// assert!(jointctl_backends::build_hal(&loaded).is_ok());
/// ```
pub fn build_hal(loaded: &LoadedConfig) -> Result<Box<dyn Hal>, ConfigErrors> {
    match loaded.config.hal.backend {
        HalBackend::Sim => jointctl_sim::SimHal::load(loaded)
            .map(|h| Box::new(h) as Box<dyn Hal>)
            .map_err(|e| setup_error(loaded, e)),
        HalBackend::Socketcan => {
            check_bus_budget(loaded)?;
            jointctl_hal_socketcan::HardwareHal::new(&loaded.config)
                .map(|h| Box::new(h) as Box<dyn Hal>)
                .map_err(|e| setup_error(loaded, e))
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
///
/// ```
/// let loaded = jointctl_config::parse_str(
///     "arm: a\nrate_hz: 40\nhal: {backend: sim}\nbuses: {can: [{interface: can0, drives: [{name: m, node_id: 1}]}]}\njoints: [{name: q, plugin: rigid}]\n",
///     "a.yaml").unwrap();
/// assert!(jointctl_backends::check_bus_budget(&loaded).unwrap().is_empty());
/// ```
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

/// Loads the plugins of a config and builds its arm on the configured HAL.
///
/// ```no_run
/// let loaded = jointctl_config::load(std::path::Path::new("configs/sherpa_arm.yaml")).unwrap();
/// let arm = jointctl_backends::build_arm(&loaded, &jointctl_runtime::loader_for(&loaded)).unwrap();
/// assert_eq!(arm.dof_names.len(), 7);
/// ```
pub fn build_arm(loaded: &LoadedConfig, loader: &PluginLoader) -> Result<Arm, ConfigErrors> {
    let hal = build_hal(loaded)?;
    Arm::build(loaded, loader, hal)
}

/// Builds the arm exactly as [`build_arm`] does, except that nothing is opened: the simulated
/// backend is built whole (it touches no hardware), the real buses are checked as far as their
/// description goes (bus budget) and replaced by a HAL with nothing behind it. `jointctl check`
/// runs this, so that it refuses what `jointctl run` would.
///
/// ```
/// let loaded = jointctl_config::parse_str(
///     "arm: a\nhal: {backend: sim}\nbuses: {can: [{interface: can0, drives: [{name: m, node_id: 1}]}]}\njoints: [{name: q, plugin: rigid, drives: {motor: m}, sim: {drives: [m], matrix: [[1.0, 2.0]]}}]\n",
///     "a.yaml").unwrap();
/// let err = jointctl_backends::build_arm_for_check(&loaded, &jointctl_runtime::PluginLoader::new([])).map(|_| ()).unwrap_err();
/// assert!(err.0[0].field.contains("sim"), "{err}");
/// ```
pub fn build_arm_for_check(loaded: &LoadedConfig, loader: &PluginLoader) -> Result<Arm, ConfigErrors> {
    let hal: Box<dyn Hal> = match loaded.config.hal.backend {
        HalBackend::Sim => build_hal(loaded)?,
        HalBackend::Socketcan => {
            check_bus_budget(loaded)?;
            Box::new(jointctl_hal::NullHal)
        }
    };
    Arm::build(loaded, loader, hal)
}
