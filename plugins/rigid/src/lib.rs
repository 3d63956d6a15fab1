//! # Rigid joint plugin
//!
//! SHERPA q1 and q3 (thesis section 3.1): an actuator with a harmonic drive CSD-32-100 whose
//! stiffness, 8.3e4 Nm/rad, is high enough to treat the joint as rigid. Position comes from the
//! output absolute encoder; deflection is 0; torque is not observed (reported unknown, not zero).

use jointctl_api::{
    Controller, JointCommand, JointFault, JointPlugin, JointState, MotorSetpoint,
    Observer, PluginError, RawJointView, export_joint_plugin, params,
};
use jointctl_control::{LinearTransmission, PiGains, PositionLoop, VelocityEstimator};
use serde::Deserialize;

/// Encoder role 0: the absolute encoder on the joint output.
const OUTPUT_ENCODER: usize = 0;
/// Drive role 0: the joint motor.
const MOTOR: usize = 0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Joint rad per motor rad of what the drive reports. Assumption: 1.0 (the drive reports the
    /// harmonic drive's output; the thesis gives no ratio for q1/q3).
    #[serde(default = "one")]
    joint_per_motor: f64,
    /// Section 3.1: CSD-32-100 stiffness, 8.3e4 Nm/rad.
    #[serde(default = "harmonic_drive_stiffness")]
    stiffness_nm_per_rad: f64,
    /// Section 4.3's position feedback PI on the joint position error [rad -> rad].
    position_pi: PiGains,
    /// Oldest stale reading still used [s] (default: `jointctl_control::default_max_age_s`).
    #[serde(default = "jointctl_control::default_max_age_s")]
    max_age_s: f64,
}

fn one() -> f64 {
    1.0
}
fn harmonic_drive_stiffness() -> f64 {
    8.3e4
}

/// A joint treated as rigid.
pub struct RigidJoint {
    params: Params,
    transmission: LinearTransmission,
    velocity: VelocityEstimator,
    position: PositionLoop,
}

impl JointPlugin for RigidJoint {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        let p: Params = params::parse(params_json)?;
        params::nonzero("joint_per_motor", p.joint_per_motor)?;
        params::positive("stiffness_nm_per_rad", p.stiffness_nm_per_rad)?;
        params::positive("max_age_s", p.max_age_s)?;
        let position = PositionLoop::from_params(p.position_pi)?;
        Ok(RigidJoint {
            transmission: LinearTransmission::new(p.joint_per_motor),
            velocity: VelocityEstimator::new(0.5),
            position,
            params: p,
        })
    }


    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        let q = raw.encoder(OUTPUT_ENCODER).usable(self.params.max_age_s);
        let m = raw.drive(MOTOR).position_rad.usable(self.params.max_age_s);
        match (q, m) {
            (Some(q), Some(m)) => {
                self.transmission = self.transmission.anchored(q, m);
                Ok(())
            }
            _ => Err(PluginError::new(
                "cannot activate: the output encoder and the motor position must both be readable",
            )),
        }
    }
}

impl Observer for RigidJoint {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let mut s = JointState::UNKNOWN;
        let q = raw.encoder(OUTPUT_ENCODER).usable(self.params.max_age_s);
        if let Some(q) = q {
            s.set_position(q);
            s.set_deflection(0.0);
            s.set_stiffness(self.params.stiffness_nm_per_rad);
        }
        if let Some(v) = self.velocity.update(q, raw.dt_s) {
            s.set_velocity(v);
        }
        out[0] = s;
        Ok(())
    }
}

impl Controller for RigidJoint {
    fn control(
        &mut self,
        state: &[JointState],
        command: &[JointCommand],
        raw: &RawJointView,
        out: &mut [MotorSetpoint],
    ) -> Result<(), JointFault> {
        out[MOTOR] = self.position.motor_setpoint(&command[0], state[0].position(), raw.dt_s, &self.transmission);
        Ok(())
    }
}

export_joint_plugin!(name: rigid, plugin: RigidJoint, dof: 1, encoders: "output", drives: "motor");
