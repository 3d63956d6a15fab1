//! # jointctl-experiments
//!
//! The thesis' experiments, closed around the simulated arm and run faster than real time:
//! - [`model_loop`]: what `identify` found, written as an extended observer and simulation,
//!   with the gain of each on the data's held-out part;
//! - [`record`]: characterisation (sections 3.3.1, 3.4.1, 3.5.1): the output moved by a flow
//!   source while the drives hold, deflection from the observer, torque from the torque sensor;
//!   written as the CSV `jointctl fit` and `jointctl identify` read;
//! - [`characterise`]: a variable-stiffness joint recorded over its pivot settings (section
//!   3.4.2), the data its observer's table is fitted to;
//! - [`sensitivity`]: the thesis scenario's tracking with one factor changed at a time (what
//!   limited the thesis' arm, section 6.2);
//! - [`tracking`]: torque tracking (chapter 5): references (step, sine, cosine, a frequency
//!   sweep) at several stiffness settings, with NRMSE and phase lag, in two scenarios.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod characterise;
pub mod gravity_hold;
pub mod loop_causes;
pub mod model_loop;
pub mod plot;
pub mod record;
pub mod replay;
pub mod sensitivity;
pub mod tracking;

use jointctl_config::{EnvironmentConfig, LoadedConfig};

/// Why an experiment cannot run.
#[derive(Debug)]
pub struct ExperimentError(pub String);

impl std::fmt::Display for ExperimentError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ExperimentError {}

impl From<jointctl_config::ConfigErrors> for ExperimentError {
    fn from(e: jointctl_config::ConfigErrors) -> Self {
        ExperimentError(e.to_string())
    }
}

/// The joint entry and DOF index of a DOF name, with its simulated hardware.
pub(crate) fn locate(loaded: &LoadedConfig, dof: &str) -> Result<(usize, usize), ExperimentError> {
    for (j, joint) in loaded.config.joints.iter().enumerate() {
        if let Some(i) = joint.dof_names().iter().position(|n| *n == dof) {
            if joint.sim.is_none() {
                return Err(ExperimentError(format!("joint `{}` has no `sim:` section: the experiment needs its simulated hardware", joint.name)));
            }
            return Ok((j, i));
        }
    }
    Err(ExperimentError(format!("no joint `{dof}` in {}", loaded.source.file.display())))
}

/// Sets the environment of every DOF of joint entry `j`: `target` for DOF `i`, `others` for the rest.
pub(crate) fn set_environment(loaded: &mut LoadedConfig, j: usize, i: usize, target: EnvironmentConfig, others: EnvironmentConfig) {
    let joint = &mut loaded.config.joints[j];
    let n = joint.dof_names().len();
    if let Some(sim) = joint.sim.as_mut() {
        sim.environment = None;
        sim.environments = (0..n).map(|k| if k == i { target.clone() } else { others.clone() }).collect();
    }
}

/// The DOF index within the whole arm.
pub(crate) fn arm_dof(arm: &jointctl_runtime::Arm, name: &str) -> usize {
    arm.dof_names.iter().position(|n| n == name).unwrap_or(0)
}
