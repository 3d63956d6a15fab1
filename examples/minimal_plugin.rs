//! A joint type in a few dozen lines, run on the simulated arm.
//!
//! `cargo run --example minimal_plugin`
//!
//! The joint: a motor that drives its output 1:1 through a stiff transmission, with an encoder on
//! the output. The observer reads the output's position; the controller moves the motor so that
//! the output reaches the host's set-point. Built as a `cdylib` (as `plugins/example_sea` is), the
//! same code is a plugin the host loads by path; here it is linked in and registered statically.

use jointctl_api::*;
use serde::Deserialize;

// Roles, in the order of `encoders:` and `drives:` in `export_joint_plugin!` below.
const OUTPUT: usize = 0;
const MOTOR: usize = 0;

/// The YAML `params:` of a joint of this type.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Readings older than this are not used [s].
    max_age_s: f64,
}

/// One joint's state between cycles.
pub struct StiffJoint {
    params: Params,
    /// Motor and output positions at activation [rad]: the transmission's zero.
    motor_origin_rad: f64,
    output_origin_rad: f64,
}

impl JointPlugin for StiffJoint {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        // A bad parameter is reported at its YAML line.
        let params: Params = params::parse(params_json)?;
        params::positive("max_age_s", params.max_age_s)?;
        Ok(StiffJoint { params, motor_origin_rad: 0.0, output_origin_rad: 0.0 })
    }

    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        let output = raw.encoder(OUTPUT).usable(self.params.max_age_s);
        let motor = raw.drive(MOTOR).position_rad.usable(self.params.max_age_s);
        let (Some(output), Some(motor)) = (output, motor) else {
            return Err(PluginError::new("cannot activate: the output encoder and the motor must be readable"));
        };
        (self.output_origin_rad, self.motor_origin_rad) = (output, motor);
        Ok(())
    }
}

impl Observer for StiffJoint {
    // Called every cycle: no allocation, no blocking, no I/O; a reading that `usable` does not
    // return is never used (the field stays unknown and the host holds the joint).
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let mut state = JointState::UNKNOWN;
        if let Some(q) = raw.encoder(OUTPUT).usable(self.params.max_age_s) {
            state.set_position(q);
        }
        out[0] = state;
        Ok(())
    }
}

impl Controller for StiffJoint {
    fn control(&mut self, _state: &[JointState], cmd: &[JointCommand], _raw: &RawJointView, out: &mut [MotorSetpoint]) -> Result<(), JointFault> {
        out[MOTOR] = match cmd[0].mode {
            ControlMode::POSITION => MotorSetpoint::move_to(self.motor_origin_rad + (cmd[0].position_rad - self.output_origin_rad)),
            _ => MotorSetpoint::HOLD,
        };
        Ok(())
    }
}

export_joint_plugin!(name: stiff_joint, plugin: StiffJoint, dof: 1, encoders: "output", drives: "motor");

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let yaml = jointctl_examples::one_joint_arm("minimal-plugin", "stiff_joint", 500.0, "{max_age_s: 0.05}");
    let loaded = jointctl_config::parse_str(&yaml, "minimal_plugin.yaml")?;
    let mut loader = jointctl_runtime::PluginLoader::new([]);
    loader.register_static(plugin_descriptor())?;
    let mut arm = jointctl_backends::build_arm(&loaded, &loader)?;
    arm.activate()?;
    arm.set_mode(0, jointctl_modes::Mode::Position { target_rad: 0.3 });
    // Two simulated seconds, stepped as fast as the machine goes (`jointctl_runtime::run` paces it).
    for cycle in 0..1000 {
        arm.step(f64::from(cycle) / loaded.config.rate_hz);
    }
    let q = arm.states[0].position().ok_or("the joint's position is unknown")?;
    println!("joint q of plugin `stiff_joint` at {q:.4} rad after 2 s (target 0.3 rad)");
    if (q - 0.3).abs() > 0.01 {
        return Err(format!("the joint did not reach its target: {q} rad").into());
    }
    arm.shutdown();
    Ok(())
}
