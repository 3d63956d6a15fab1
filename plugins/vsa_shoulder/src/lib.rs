//! # VSA shoulder plugin (q2 + q3)
//!
//! Thesis sections 2.4 and 3.4. The shoulder's two actuators a2, a3 drive q2 and q3 through a
//! tendon differential (eq. 3.3); q2 carries the lever-arm VSA. One plugin instance therefore
//! serves both DOFs: q2 as a variable stiffness joint, q3 as rigid (harmonic drive, section 3.1).
//!
//! Observer (section 4.2, figure 4.3 red and blue blocks):
//! - pivot position [mm] from the pivot encoder;
//! - q2 deflection from the encoder that measures it directly, with the initial angle
//!   subtracted (section 3.4.1: the motor encoders over CAN lost frames, appendix A);
//! - q2 torque from the characteristic of the two nearest pivot settings, linearly weighted
//!   (section 4.2), stiffness from their first-order fits; a pivot beyond the characterised
//!   range is clamped and flagged;
//! - q2 position from its output encoder; q3 position from the two differential pulleys (eq. 3.3).
//!
//! Controller: joint position set-points → actuator set-points through the inverse of eq. 3.3,
//! with section 4.3's position PI per DOF when asked for; a requested q2 stiffness sets the pivot
//! drive through the inverse of the stiffness table (pivot encoder and drive on one shaft:
//! assumption).

use jointctl_api::{
    Controller, ControlMode, JointCommand, JointFault, JointPlugin, JointState, MotorSetpoint,
    Observer, PluginError, RawJointView, export_joint_plugin, params,
};
use jointctl_control::{PiGains, PositionLoop, VelocityEstimator};
use jointctl_models::extension::{ExtensionSpec, ModelExtension};
use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic};
use jointctl_models::transmission::{eq_3_3_shoulder_actuators, eq_3_3_shoulder_joints};
use serde::Deserialize;

const Q2_OUTPUT: usize = 0;
const Q2_DEFLECTION: usize = 1;
const PULLEY_A: usize = 2;
const PULLEY_B: usize = 3;
const PIVOT: usize = 4;
const ACTUATOR_A: usize = 0;
const ACTUATOR_B: usize = 1;
const PIVOT_DRIVE: usize = 2;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Torque-deflection characteristic per pivot setting (the form `jointctl fit` writes).
    characteristic: CharacteristicSpec,
    /// Pivot travel per pivot-encoder radian [mm/rad]. Assumption (not in the thesis).
    pivot_mm_per_rad: f64,
    /// Pivot position at encoder angle 0 [mm]. Assumption.
    #[serde(default)]
    pivot_offset_mm: f64,
    /// q3 stiffness reported (section 3.1: harmonic drive CSD-32-100, 8.3e4 Nm/rad).
    #[serde(default = "harmonic_drive")]
    q3_stiffness_nm_per_rad: f64,
    /// Section 4.3's position PI per DOF [rad -> rad].
    position_pi: PiGains,
    /// Oldest stale reading still used [s] (default: `jointctl_control::default_max_age_s`).
    #[serde(default = "jointctl_control::default_max_age_s")]
    max_age_s: f64,
    /// Time constant of a first-order low-pass on q2's observed torque [s] (0, the default: none).
    /// It smooths the deflection encoder's quantisation and structural ringing at the price of
    /// lag in the torque loop; the sensitivity study measures that price.
    #[serde(default)]
    torque_filter_s: f64,
    /// What `jointctl identify` found beyond q2's table (hysteresis, friction, play, cubic,
    /// offset, scale), observed online (section 6.2); none by default.
    #[serde(default)]
    model_extension: Option<ExtensionSpec>,
    /// The calibrated zero (`jointctl calibrate`): the q2 deflection encoder's reading where the
    /// element carries no torque. With it, the deflection at activation is measured, not taken as
    /// zero, and one outside the table's deflection range refuses activation. Without it, the
    /// shoulder's angle at activation is subtracted (section 3.4.1).
    #[serde(default)]
    zero: Option<ShoulderZero>,
}

/// The shoulder's calibrated zero.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShoulderZero {
    /// The q2 deflection encoder's reading at zero deflection [rad].
    deflection_rad: f64,
}

fn harmonic_drive() -> f64 {
    8.3e4
}

/// The shoulder: q2 (VSA) and q3 (rigid) behind the tendon differential.
pub struct VsaShoulder {
    p: Params,
    characteristic: PivotCharacteristic,
    deflection_origin_rad: f64,
    actuator_origin: (f64, f64),
    joint_origin: (f64, f64),
    velocity: [VelocityEstimator; 2],
    position: [PositionLoop; 2],
    pivot_target: Option<MotorSetpoint>,
    /// The low-passed q2 torque [Nm]; `None` until a torque is known (and after one is not).
    filtered_torque_nm: Option<f64>,
    /// q2's model extension, if configured.
    extension: Option<ModelExtension>,
}

impl VsaShoulder {
    fn pivot_mm(&self, raw: &RawJointView) -> Option<f64> {
        raw.encoder(PIVOT).usable(self.p.max_age_s).map(|a| self.p.pivot_offset_mm + self.p.pivot_mm_per_rad * a)
    }

    /// The observed torque through the configured first-order low-pass (discretised exactly
    /// for a held input: `alpha = 1 - exp(-dt / tau)`); unchanged without a filter.
    fn low_pass(&mut self, torque_nm: f64, dt_s: f64) -> f64 {
        let tau = self.p.torque_filter_s;
        let out = match self.filtered_torque_nm {
            Some(f) if tau > 0.0 => f + (1.0 - (-dt_s / tau).exp()) * (torque_nm - f),
            _ => torque_nm,
        };
        self.filtered_torque_nm = Some(out);
        out
    }

    fn q3(&self, raw: &RawJointView) -> Option<f64> {
        let a = raw.encoder(PULLEY_A).usable(self.p.max_age_s)?;
        let b = raw.encoder(PULLEY_B).usable(self.p.max_age_s)?;
        Some(eq_3_3_shoulder_joints(a, b).1)
    }
}

impl JointPlugin for VsaShoulder {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        let p: Params = params::parse(params_json)?;
        let characteristic = PivotCharacteristic::from_spec(&p.characteristic)
            .map_err(|e| PluginError::at(format!("characteristic.{}", e.field), e.message))?;
        params::nonzero("pivot_mm_per_rad", p.pivot_mm_per_rad)?;
        params::positive("q3_stiffness_nm_per_rad", p.q3_stiffness_nm_per_rad)?;
        params::positive("max_age_s", p.max_age_s)?;
        if !(p.torque_filter_s.is_finite() && p.torque_filter_s >= 0.0) {
            return Err(PluginError::at("torque_filter_s", "must be finite and >= 0"));
        }
        if p.zero.is_some_and(|z| !z.deflection_rad.is_finite()) {
            return Err(PluginError::at("zero.deflection_rad", "must be finite"));
        }
        let position = PositionLoop::from_params(p.position_pi)?;
        let extension = match p.model_extension.clone() {
            Some(spec) => Some(ModelExtension::new(spec).map_err(|e| PluginError::at(format!("model_extension.{}", e.field), e.message))?),
            None => None,
        };
        Ok(VsaShoulder {
            extension,
            filtered_torque_nm: None,
            characteristic,
            deflection_origin_rad: 0.0,
            actuator_origin: (0.0, 0.0),
            joint_origin: (0.0, 0.0),
            velocity: [VelocityEstimator::new(0.5); 2],
            position: [position; 2],
            pivot_target: None,
            p,
        })
    }

    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        let age = self.p.max_age_s;
        let need = |r: Option<f64>, what: &str| r.ok_or_else(|| PluginError::new(format!("cannot activate: {what} is not readable")));
        // Section 3.4.1: the shoulder may start at a non-zero angle; subtract it.
        let reading = need(raw.encoder(Q2_DEFLECTION).usable(age), "the q2 deflection encoder")?;
        self.deflection_origin_rad = match self.p.zero {
            Some(z) => {
                // The table's deflection range over every pivot setting.
                let range = self.p.characteristic.curves.iter().filter_map(|c| c.range_rad).reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])]);
                let now = reading - z.deflection_rad;
                if let Some([lo, hi]) = range
                    && !(lo..=hi).contains(&now)
                {
                    return Err(PluginError::at(
                        "zero",
                        format!("the q2 deflection at activation is {now:.5} rad with the calibrated zero, outside the table's range [{lo}, {hi}] rad: recalibrate (jointctl calibrate) or check the element"),
                    ));
                }
                z.deflection_rad
            }
            None => reading,
        };
        let q2 = need(raw.encoder(Q2_OUTPUT).usable(age), "the q2 output encoder")?;
        let q3 = need(self.q3(raw), "a differential pulley encoder")?;
        let a = need(raw.drive(ACTUATOR_A).position_rad.usable(age), "actuator a")?;
        let b = need(raw.drive(ACTUATOR_B).position_rad.usable(age), "actuator b")?;
        self.actuator_origin = (a, b);
        self.joint_origin = (q2, q3);
        self.position[0].hold_at(q2);
        self.position[1].hold_at(q3);
        if let Some(e) = &mut self.extension {
            e.reset();
        }
        Ok(())
    }
}

impl Observer for VsaShoulder {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let age = self.p.max_age_s;
        let (mut q2, mut q3) = (JointState::UNKNOWN, JointState::UNKNOWN);
        let pivot = self.pivot_mm(raw);
        let q2_pos = raw.encoder(Q2_OUTPUT).usable(age);
        let deflection = raw.encoder(Q2_DEFLECTION).usable(age).map(|d| d - self.deflection_origin_rad);
        if let Some(q) = q2_pos {
            q2.set_position(q);
        }
        if let Some(p) = pivot {
            q2.set_pivot(p);
            let e = self.characteristic.evaluate(p, deflection.unwrap_or(0.0));
            q2.set_stiffness(e.stiffness_nm_per_rad);
            if let Some(d) = deflection {
                q2.set_deflection(d);
                // With a model extension the table is read at the element's deflection (after
                // the play) and the extension's terms are added.
                let torque = match &mut self.extension {
                    Some(x) => {
                        // Terms identified per pivot setting are weighted at this one.
                        x.at_pivot(p);
                        let at = self.characteristic.evaluate(p, x.elastic_deflection(d)).torque_nm;
                        x.torque(raw.stamp_s, d, at)
                    }
                    None => e.torque_nm,
                };
                q2.set_torque(self.low_pass(torque, raw.dt_s));
            } else {
                self.filtered_torque_nm = None;
            }
            if e.clamped {
                q2.mark_clamped();
            }
        }
        // A gap in the deflection or the pivot is no motion: the extension's state starts
        // afresh after it, as the offline scoring does (issue 37, finding 6).
        if q2.torque().is_none()
            && let Some(x) = &mut self.extension
        {
            x.reset();
        }
        let q3_pos = self.q3(raw);
        if let Some(q) = q3_pos {
            q3.set_position(q);
            q3.set_deflection(0.0);
            q3.set_stiffness(self.p.q3_stiffness_nm_per_rad);
        }
        for (state, (v, q)) in [&mut q2, &mut q3].into_iter().zip(self.velocity.iter_mut().zip([q2_pos, q3_pos])) {
            if let Some(v) = v.update(q, raw.dt_s) {
                state.set_velocity(v);
            }
        }
        out[0] = q2;
        out[1] = q3;
        Ok(())
    }
}

impl Controller for VsaShoulder {
    fn control(
        &mut self,
        state: &[JointState],
        command: &[JointCommand],
        raw: &RawJointView,
        out: &mut [MotorSetpoint],
    ) -> Result<(), JointFault> {
        // Section 4.3 per DOF; a DOF not in position mode holds still while the other moves,
        // and an unknown target (a position not read) holds both motors.
        let target: [Option<f64>; 2] = std::array::from_fn(|i| self.position[i].target_rad(&command[i], state[i].position(), raw.dt_s));
        let any_moving = command[..2].iter().any(|c| c.mode == ControlMode::POSITION);
        // A requested q2 stiffness moves the pivot (inverse of the stiffness table, clamped to
        // the characterised settings); it stays there until the next request.
        if let Some(k) = command[0].stiffness()
            && let Some(pivot_mm) = self.characteristic.pivot_for_stiffness(k)
        {
            self.pivot_target = Some(MotorSetpoint::move_to((pivot_mm - self.p.pivot_offset_mm) / self.p.pivot_mm_per_rad));
        }
        out[PIVOT_DRIVE] = self.pivot_target.unwrap_or(MotorSetpoint::HOLD);
        let (true, [Some(t0), Some(t1)]) = (any_moving, target) else {
            out[ACTUATOR_A] = MotorSetpoint::HOLD;
            out[ACTUATOR_B] = MotorSetpoint::HOLD;
            return Ok(());
        };
        // Inverse of eq. 3.3 (assumed differential), anchored at the activation pose.
        let (da, db) = eq_3_3_shoulder_actuators(t0 - self.joint_origin.0, t1 - self.joint_origin.1);
        out[ACTUATOR_A] = MotorSetpoint::move_to(self.actuator_origin.0 + da);
        out[ACTUATOR_B] = MotorSetpoint::move_to(self.actuator_origin.1 + db);
        Ok(())
    }
}

export_joint_plugin!(
    name: vsa_shoulder,
    plugin: VsaShoulder,
    dof: 2,
    encoders: "q2_output,q2_deflection,pulley_a,pulley_b,pivot",
    drives: "actuator_a,actuator_b,pivot",
    // q2 is the VSA (torque observed, stiffness set by the pivot); q3 is rigid.
    torque_dofs: 0b01,
    stiffness_dofs: 0b01,
);
