//! # VSA wrist plugin (q6 + q7)
//!
//! Thesis sections 3.5, 4.2 and appendix B. Each joint motor drives a planetary differential's
//! sun; the VSA lever sits on the ring; the carrier drives a 30:40 belt to one input of a bevel
//! differential whose outputs are q6 and q7.
//!
//! Observer (figure 4.3):
//! - per drivetrain, eq. 3.8: the bevel input the carrier-input encoder predicts,
//!   `theta_a~ = Ns/(Ns+Nr) * Dp/Db * theta_pc`, minus the measured bevel input is the
//!   deflection of that input, both relative to the activation pose (initial angle subtracted);
//! - eq. 3.7 turns the two input deflections into the Cartesian deflection and the two measured
//!   bevel inputs into the joint positions. **Assumption**: theta_x is q6 and theta_y is q7;
//! - the torque: deflection → polar (atan2 with its quadrant; eq. B.2's tanh is a typo), torque
//!   along the two nearest measured directions at the two nearest pivot settings, interpolated,
//!   back to q6/q7 (eq. B.3); the stiffness of each joint is the interpolated first-order fit
//!   along its own axis (q7: 0 deg, q6: 90 deg).
//!
//! Controller: joint set-points → bevel inputs (eq. 3.7 inverse) → carrier inputs (eq. 3.8
//! ratio) → motor set-points, with section 4.3's position PI per DOF when asked for; a requested
//! stiffness sets the pivot drive through the inverse of the axis' stiffness table.

use jointctl_api::{
    Controller, ControlMode, JointCommand, JointFault, JointPlugin, JointState, MotorSetpoint,
    Observer, PluginError, RawJointView, export_joint_plugin, params,
};
use jointctl_control::{PiGains, PositionLoop, VelocityEstimator};
use jointctl_models::extension::{ExtensionSpec, ModelExtension};
use jointctl_models::characteristic::{CharacteristicSpec, WristCharacteristic, invert_table};
use jointctl_models::transmission::{eq_3_7_bevel, eq_3_7_bevel_inverse, eq_3_8_deflection, eq_3_8_expected_bevel_input};
use serde::Deserialize;

const CARRIER_A: usize = 0;
const CARRIER_B: usize = 1;
const BEVEL_A: usize = 2;
const BEVEL_B: usize = 3;
const PIVOT: usize = 4;
const MOTOR_A: usize = 0;
const MOTOR_B: usize = 1;
const PIVOT_DRIVE: usize = 2;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Torque-deflection curves per pivot setting and direction (the form `jointctl fit` writes).
    characteristic: CharacteristicSpec,
    /// Sun gear teeth Ns. Assumption (the thesis does not give the tooth counts).
    teeth_sun: f64,
    /// Ring gear teeth Nr. Assumption.
    teeth_ring: f64,
    /// Belt ratio Dp/Db between planetary carrier and bevel input (section 3.5.1: 30:40).
    #[serde(default = "belt")]
    belt_ratio: f64,
    /// Pivot travel per pivot-encoder radian [mm/rad]. Assumption.
    pivot_mm_per_rad: f64,
    /// Pivot position at encoder angle 0 [mm]. Assumption.
    #[serde(default)]
    pivot_offset_mm: f64,
    /// Section 4.3's position PI per DOF [rad -> rad].
    position_pi: PiGains,
    /// Oldest stale reading still used [s] (default: `jointctl_control::default_max_age_s`).
    #[serde(default = "jointctl_control::default_max_age_s")]
    max_age_s: f64,
    /// What `jointctl identify` found beyond the table, per DOF (`[q6, q7]`, either may be
    /// `null`), observed online (section 6.2); none by default.
    #[serde(default)]
    model_extension: Vec<Option<ExtensionSpec>>,
    /// The calibrated zero (`jointctl calibrate`): the two planet-carrier and the two
    /// bevel-input encoders' readings where both elements carry no torque. With it, the
    /// deflections at activation are measured, not taken as zero, and one outside the table's
    /// deflection range refuses activation. Without it, the readings at activation are the zero.
    #[serde(default)]
    zero: Option<WristZero>,
}

/// The wrist's calibrated zero.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WristZero {
    /// Planet-carrier encoders a and b at zero deflection [rad].
    carrier_rad: [f64; 2],
    /// Bevel-input encoders a and b at zero deflection [rad].
    bevel_rad: [f64; 2],
}

fn belt() -> f64 {
    30.0 / 40.0
}

/// The wrist: q6 and q7 with one shared VSA.
pub struct VsaWrist {
    p: Params,
    /// q6's and q7's model extensions, if configured.
    extension: [Option<ModelExtension>; 2],
    characteristic: WristCharacteristic,
    carrier_origin: [f64; 2],
    bevel_origin: [f64; 2],
    motor_origin: [f64; 2],
    joint_origin: [f64; 2],
    velocity: [VelocityEstimator; 2],
    position: [PositionLoop; 2],
    axis_stiffness: [Vec<f64>; 2],
    pivot_target: Option<MotorSetpoint>,
}

impl VsaWrist {
    /// Eq. 3.8's ratio: bevel input per carrier-input radian.
    fn ratio(&self) -> f64 {
        eq_3_8_expected_bevel_input(1.0, self.p.teeth_sun, self.p.teeth_ring, self.p.belt_ratio)
    }

    fn read(&self, raw: &RawJointView, i: usize) -> Option<f64> {
        raw.encoder(i).usable(self.p.max_age_s)
    }

    /// (q6, q7) positions from the measured bevel inputs, eq. 3.7.
    fn positions(&self, raw: &RawJointView) -> Option<(f64, f64)> {
        Some(eq_3_7_bevel(self.read(raw, BEVEL_A)?, self.read(raw, BEVEL_B)?))
    }

    /// (q6, q7) deflections, eq. 3.8 per drivetrain then eq. 3.7.
    fn deflections(&self, raw: &RawJointView) -> Option<(f64, f64)> {
        let mut d = [0.0; 2];
        for (i, (c, b)) in [(CARRIER_A, BEVEL_A), (CARRIER_B, BEVEL_B)].into_iter().enumerate() {
            let expected = eq_3_8_expected_bevel_input(self.read(raw, c)? - self.carrier_origin[i], self.p.teeth_sun, self.p.teeth_ring, self.p.belt_ratio);
            d[i] = eq_3_8_deflection(expected, self.read(raw, b)? - self.bevel_origin[i]);
        }
        Some(eq_3_7_bevel(d[0], d[1]))
    }
}

impl JointPlugin for VsaWrist {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        let p: Params = params::parse(params_json)?;
        let characteristic = WristCharacteristic::from_spec(&p.characteristic)
            .map_err(|e| PluginError::at(format!("characteristic.{}", e.field), e.message))?;
        params::positive("teeth_sun", p.teeth_sun)?;
        params::positive("teeth_ring", p.teeth_ring)?;
        params::positive("belt_ratio", p.belt_ratio)?;
        params::positive("max_age_s", p.max_age_s)?;
        params::nonzero("pivot_mm_per_rad", p.pivot_mm_per_rad)?;
        if p.zero.is_some_and(|z| !z.carrier_rad.iter().chain(&z.bevel_rad).all(|x| x.is_finite())) {
            return Err(PluginError::at("zero", "carrier_rad and bevel_rad must be finite"));
        }
        let position = PositionLoop::from_params(p.position_pi)?;
        if !matches!(p.model_extension.len(), 0 | 2) {
            return Err(PluginError::at("model_extension", format!("give one entry per DOF, [q6, q7] (null for none), got {}", p.model_extension.len())));
        }
        let mut extension: [Option<ModelExtension>; 2] = [None, None];
        for (i, spec) in p.model_extension.iter().enumerate() {
            if let Some(spec) = spec {
                extension[i] = Some(ModelExtension::new(spec.clone()).map_err(|e| PluginError::at(format!("model_extension[{i}].{}", e.field), e.message))?);
            }
        }
        Ok(VsaWrist {
            extension,
            characteristic: characteristic.clone(),
            carrier_origin: [0.0; 2],
            bevel_origin: [0.0; 2],
            motor_origin: [0.0; 2],
            joint_origin: [0.0; 2],
            velocity: [VelocityEstimator::new(0.5); 2],
            position: [position; 2],
            axis_stiffness: [characteristic.axis_stiffness_table(true), characteristic.axis_stiffness_table(false)],
            pivot_target: None,
            p,
        })
    }


    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        let need = |r: Option<f64>, what: &str| r.ok_or_else(|| PluginError::new(format!("cannot activate: {what} is not readable")));
        for (i, (c, b, m)) in [(CARRIER_A, BEVEL_A, MOTOR_A), (CARRIER_B, BEVEL_B, MOTOR_B)].into_iter().enumerate() {
            self.carrier_origin[i] = need(self.read(raw, c), "a planet-carrier encoder")?;
            self.bevel_origin[i] = need(self.read(raw, b), "a bevel-input encoder")?;
            self.motor_origin[i] = need(raw.drive(m).position_rad.usable(self.p.max_age_s), "a wrist motor")?;
        }
        if let Some(z) = self.p.zero {
            (self.carrier_origin, self.bevel_origin) = (z.carrier_rad, z.bevel_rad);
            // The table's deflection range over every curve.
            let range = self.p.characteristic.curves.iter().filter_map(|c| c.range_rad).reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])]);
            let (d6, d7) = self.deflections(raw).ok_or_else(|| PluginError::new("cannot activate: a wrist encoder is not readable"))?;
            if let Some([lo, hi]) = range
                && let Some((dof, d)) = [("q6", d6), ("q7", d7)].into_iter().find(|(_, d)| !(lo..=hi).contains(d))
            {
                return Err(PluginError::at(
                    "zero",
                    format!("the {dof} deflection at activation is {d:.5} rad with the calibrated zero, outside the table's range [{lo}, {hi}] rad: recalibrate (jointctl calibrate) or check the element"),
                ));
            }
        }
        let (q6, q7) = self.positions(raw).ok_or_else(|| PluginError::new("cannot activate: the bevel inputs are not readable"))?;
        self.joint_origin = [q6, q7];
        self.position[0].hold_at(q6);
        self.position[1].hold_at(q7);
        for e in self.extension.iter_mut().flatten() {
            e.reset();
        }
        Ok(())
    }
}

impl Observer for VsaWrist {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let mut s = [JointState::UNKNOWN; 2];
        let positions = self.positions(raw);
        if let Some((q6, q7)) = positions {
            s[0].set_position(q6);
            s[1].set_position(q7);
        }
        let pivot = self.read(raw, PIVOT).map(|a| self.p.pivot_offset_mm + self.p.pivot_mm_per_rad * a);
        if let Some(p) = pivot {
            let deflection = self.deflections(raw);
            let (d6, d7) = deflection.unwrap_or((0.0, 0.0));
            let e = self.characteristic.evaluate(p, d6, d7);
            for (st, k) in s.iter_mut().zip([e.stiffness_q6_nm_per_rad, e.stiffness_q7_nm_per_rad]) {
                st.set_pivot(p);
                st.set_stiffness(k);
                if e.clamped {
                    st.mark_clamped();
                }
            }
            if deflection.is_some() {
                s[0].set_deflection(d6);
                s[1].set_deflection(d7);
                let torque = if self.extension.iter().any(Option::is_some) {
                    // The table at the elements' deflections (after each DOF's play), each
                    // DOF's terms (weighted at this pivot setting when given per setting) added.
                    for x in self.extension.iter_mut().flatten() {
                        x.at_pivot(p);
                    }
                    let elastic = |x: &Option<ModelExtension>, d: f64| x.as_ref().map_or(d, |x| x.elastic_deflection(d));
                    let at = self.characteristic.evaluate(p, elastic(&self.extension[0], d6), elastic(&self.extension[1], d7));
                    let mut out = [at.torque_q6_nm, at.torque_q7_nm];
                    for (i, (x, d)) in self.extension.iter_mut().zip([d6, d7]).enumerate() {
                        if let Some(x) = x {
                            out[i] = x.torque(raw.stamp_s, d, out[i]);
                        }
                    }
                    out
                } else {
                    [e.torque_q6_nm, e.torque_q7_nm]
                };
                s[0].set_torque(torque[0]);
                s[1].set_torque(torque[1]);
            }
        }
        for (i, st) in s.iter_mut().enumerate() {
            let q = positions.map(|p| if i == 0 { p.0 } else { p.1 });
            if let Some(v) = self.velocity[i].update(q, raw.dt_s) {
                st.set_velocity(v);
            }
        }
        // A gap in the deflections or the pivot is no motion: each extension's state starts
        // afresh after it, as the offline scoring does (issue 37, finding 6).
        for (x, st) in self.extension.iter_mut().zip(&s) {
            if let Some(x) = x
                && st.torque().is_none()
            {
                x.reset();
            }
        }
        out[..2].copy_from_slice(&s);
        Ok(())
    }
}

impl Controller for VsaWrist {
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
        // One pivot sets both joints' stiffness: a request for q6 (along its axis) wins over one
        // for q7 in the same cycle. The pivot stays until the next request.
        for (i, cmd) in command.iter().enumerate().take(2) {
            if let Some(k) = cmd.stiffness()
                && let Some(pivot_mm) = invert_table(self.characteristic.pivots_mm(), &self.axis_stiffness[i], k)
            {
                self.pivot_target = Some(MotorSetpoint::move_to((pivot_mm - self.p.pivot_offset_mm) / self.p.pivot_mm_per_rad));
                break;
            }
        }
        out[PIVOT_DRIVE] = self.pivot_target.unwrap_or(MotorSetpoint::HOLD);
        let (true, [Some(t0), Some(t1)]) = (any_moving, target) else {
            out[MOTOR_A] = MotorSetpoint::HOLD;
            out[MOTOR_B] = MotorSetpoint::HOLD;
            return Ok(());
        };
        // Eq. 3.7 inverse to the bevel inputs, then eq. 3.8's ratio back to the carrier inputs
        // (the motors' gearbox outputs), anchored at the activation pose.
        let (b1, b2) = eq_3_7_bevel_inverse(t0 - self.joint_origin[0], t1 - self.joint_origin[1]);
        let k = self.ratio();
        out[MOTOR_A] = MotorSetpoint::move_to(self.motor_origin[0] + b1 / k);
        out[MOTOR_B] = MotorSetpoint::move_to(self.motor_origin[1] + b2 / k);
        Ok(())
    }
}

export_joint_plugin!(
    name: vsa_wrist,
    plugin: VsaWrist,
    dof: 2,
    encoders: "carrier_a,carrier_b,bevel_a,bevel_b,pivot",
    drives: "motor_a,motor_b,pivot",
    // One pivot sets the stiffness of both DOFs (section 3.5).
    torque_dofs: 0b11,
    stiffness_dofs: 0b11,
);
