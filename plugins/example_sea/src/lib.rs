//! # example_sea: a series-elastic joint with a torque sensor
//!
//! A template for a new joint type. The joint is a motor behind a spring of known stiffness,
//! with an output encoder and a torque sensor. The observer prefers the sensor's torque and
//! falls back to the spring model (`K * deflection`) when the sensor reading is not usable;
//! the controller moves the motor to the joint set-point plus the spring's deflection.
//!
//! Build: `cargo build --manifest-path plugins/example_sea/Cargo.toml`; load:
//! `plugin: {name: example_sea, path: ../plugins/example_sea/target/debug/libexample_sea.so}`.

use jointctl_api::*;
use serde::Deserialize;

// Roles, in the order of `encoders:` and `drives:` in export_joint_plugin! below.
const OUTPUT: usize = 0;
const TORQUE_SENSOR: usize = 1;
const MOTOR: usize = 0;

/// The joint's YAML `params`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Spring stiffness [Nm/rad].
    spring_nm_per_rad: f64,
    /// Oldest stale reading still used [s].
    #[serde(default = "default_max_age")]
    max_age_s: f64,
}

fn default_max_age() -> f64 {
    0.1
}

/// A series-elastic joint.
pub struct SeaJoint {
    p: Params,
    motor_origin: f64,
    output_origin: f64,
}

impl JointPlugin for SeaJoint {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        let p: Params = params::parse(params_json)?;
        params::positive("spring_nm_per_rad", p.spring_nm_per_rad)?;
        params::positive("max_age_s", p.max_age_s)?;
        Ok(SeaJoint { p, motor_origin: 0.0, output_origin: 0.0 })
    }

    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        let q = raw.encoder(OUTPUT).usable(self.p.max_age_s);
        let m = raw.drive(MOTOR).position_rad.usable(self.p.max_age_s);
        let (Some(q), Some(m)) = (q, m) else {
            return Err(PluginError::new("cannot activate: output encoder and motor must be readable"));
        };
        (self.output_origin, self.motor_origin) = (q, m);
        Ok(())
    }
}

impl Observer for SeaJoint {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let mut s = JointState::UNKNOWN;
        let q = raw.encoder(OUTPUT).usable(self.p.max_age_s);
        let m = raw.drive(MOTOR).position_rad.usable(self.p.max_age_s);
        s.set_stiffness(self.p.spring_nm_per_rad);
        if let Some(q) = q {
            s.set_position(q);
        }
        if let (Some(q), Some(m)) = (q, m) {
            // Motor side minus output: a positive deflection pushes the output positive.
            let deflection = (m - self.motor_origin) - (q - self.output_origin);
            s.set_deflection(deflection);
            s.set_torque(self.p.spring_nm_per_rad * deflection);
        }
        // A usable sensor reading beats the spring model; a missing one is never read as zero.
        if let Some(t) = raw.encoder(TORQUE_SENSOR).usable(self.p.max_age_s) {
            s.set_torque(t);
        }
        out[0] = s;
        Ok(())
    }
}

impl Controller for SeaJoint {
    fn control(&mut self, state: &[JointState], cmd: &[JointCommand], _: &RawJointView, out: &mut [MotorSetpoint]) -> Result<(), JointFault> {
        out[MOTOR] = match (cmd[0].mode, state[0].deflection()) {
            (ControlMode::POSITION, Some(d)) => {
                MotorSetpoint::move_to(self.motor_origin + (cmd[0].position_rad - self.output_origin) + d)
            }
            _ => MotorSetpoint::HOLD,
        };
        Ok(())
    }
}

export_joint_plugin!(name: example_sea, plugin: SeaJoint, dof: 1, encoders: "output,torque_sensor?", drives: "motor", torque_dofs: 0b1);
