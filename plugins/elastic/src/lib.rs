//! # Elastic joint plugin
//!
//! SHERPA q4 (elbow) and q5 (wrist), thesis section 3.3: a joint whose transmission is compliant,
//! characterised by a first-order (linear) torque-deflection fit (section 3.3.2: elbow
//! 113.78 Nm/rad, wrist q5 70.0966 Nm/rad).
//!
//! Kinematics, eq. 3.1/3.2: `theta_out = theta_motor + theta_RC`, ideally `theta_RC = theta_motor`
//! so `theta_out = 2 * theta_motor` for the elbow. With `r` the ideal output-per-motor ratio the
//! deflection is how far the motor side leads the output:
//! `deflection = r * (theta_motor - theta_motor0) - (theta_out - theta_out0)`, with the initial
//! angles subtracted (section 3.4.1) so that the joint may start anywhere. A positive deflection
//! is a positive torque on the output, the convention of figure 4.6 (set-point = position +
//! feed-forward deflection) and of eq. 3.8 (expected minus measured).
//!
//! q5 has no compliant element: its compliance is its ELMO's proportional gain (section 3.3.2).
//! With `compliance: drive_gain` the "deflection" is the drive's following error seen from the
//! joint, `r * (set-point - motor position)`, and the torque `K` times it. What that cannot
//! know, the observer does not claim: while the drive is still moving to a new set-point (its
//! profile, the bus latency; `settle_s` after the last change) the following error is motion,
//! not load, and the torque is unknown; a drive with integral action hides a steady load (the
//! simulated q5 drive has none, an assumption the config states).

use jointctl_api::{
    Controller, JointCommand, JointFault, JointPlugin, JointState, MotorSetpoint,
    Observer, PluginError, RawJointView, export_joint_plugin, params,
};
use jointctl_control::{LinearTransmission, PiGains, PositionLoop, ReadingTrack, VelocityEstimator};
use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic};
use jointctl_models::extension::{ExtensionSpec, ModelExtension};
use serde::Deserialize;

/// Encoder role 0: the absolute encoder on the joint output.
const OUTPUT_ENCODER: usize = 0;
/// Encoder role 1 (optional): an absolute encoder on the motor side of the elastic element. When
/// wired, the deflection comes from absolute encoders only (section 3.4.1 preferred them to the
/// motor encoders read over CAN, appendix A); otherwise from the drive's motor position.
const INPUT_ENCODER: usize = 1;
/// Drive role 0: the joint motor.
const MOTOR: usize = 0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    /// First-order fit of the torque-deflection characteristic [Nm/rad] (section 3.3.2).
    #[serde(default)]
    stiffness_nm_per_rad: Option<f64>,
    /// A fitted characteristic (`jointctl fit`, one curve) instead of the linear stiffness: the
    /// torque from the curve, the stiffness from its first-order fit (section 4.2).
    #[serde(default)]
    characteristic: Option<CharacteristicSpec>,
    /// Ideal output rad per motor rad: 2 for the elbow (eq. 3.1), 1 for q5 (assumption: the
    /// drive reports the belt output; the thesis gives no ratio).
    output_per_motor: f64,
    /// Section 4.3's position feedback PI [rad -> rad].
    position_pi: PiGains,
    /// Oldest stale reading still used for the position [s] (default: `jointctl_control::default_max_age_s`).
    #[serde(default = "jointctl_control::default_max_age_s")]
    max_age_s: f64,
    /// Oldest motor-side reading combined with the output encoder into a deflection [s]. A stale
    /// motor position next to a fresh output position is a false deflection while the joint
    /// moves (a lost frame during motion), so by default only readings of this cycle are used
    /// and the torque is unknown otherwise.
    #[serde(default)]
    max_deflection_age_s: f64,
    /// Whether the motor side's reading is carried to the instant the output encoder was read
    /// before the two are subtracted (default true): the drive's position comes over CAN and the
    /// output encoder over SPI, with different latencies (section 2.3: about 30 and 15 ms), and
    /// while the joint moves a difference of readings of different ages is not the deflection
    /// (`jointctl_control::ReadingTrack`). It uses the ages the HAL reports: the simulated HAL
    /// reports its configured latencies; the SocketCAN HAL dates a drive's position at the SYNC
    /// that sampled it and an SPI reading as it is read. `false`: subtracted as they are.
    #[serde(default = "default_align_reading_ages")]
    align_reading_ages: bool,
    /// Where the compliance is: `element` (an elastic element between motor and output, the
    /// default) or `drive_gain` (the drive's position loop, q5).
    #[serde(default)]
    compliance: Compliance,
    /// `drive_gain`: how long after a set-point change the following error is load, not motion
    /// [s]. Assumption: 0.25 s, a small move of the simulated ELMO's profile plus the thesis' CAN
    /// latency both ways (section 2.3).
    #[serde(default = "default_settle_s")]
    settle_s: f64,
    /// What `jointctl identify` found beyond the characteristic (hysteresis, friction, play,
    /// cubic stiffness, offset, scale), observed online (section 6.2); none by default.
    #[serde(default)]
    model_extension: Option<ExtensionSpec>,
    /// The calibrated zero (`jointctl calibrate`): the readings of the motor side (the input
    /// encoder, or the drive) and of the output encoder where the element carries no torque.
    /// With it, the deflection at activation is measured, not taken as zero: an arm that starts
    /// loaded (under gravity) reads its load. Without it, the element is taken as relaxed at
    /// activation (what the thesis' set-up did, section 3.4.1).
    #[serde(default)]
    zero: Option<Zero>,
    /// The spring's deflection range [rad], `[low, high]`: a calibrated joint whose deflection at
    /// activation lies outside refuses to activate (a wrong zero, a broken element). Default: the
    /// characteristic's `range_rad`; none for a linear stiffness without it.
    #[serde(default)]
    deflection_range_rad: Option<[f64; 2]>,
}

/// A calibrated zero of the deflection.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Zero {
    /// The motor side's reading at zero deflection [rad].
    input_rad: f64,
    /// The output encoder's reading at zero deflection [rad].
    output_rad: f64,
}

fn default_align_reading_ages() -> bool {
    true
}

fn default_settle_s() -> f64 {
    0.25
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Compliance {
    #[default]
    Element,
    DriveGain,
}


/// A joint with a linear elastic element.
pub struct ElasticJoint {
    params: Params,
    stiffness_nm_per_rad: f64,
    curve: Option<PivotCharacteristic>,
    transmission: LinearTransmission,
    velocity: VelocityEstimator,
    /// The motor side's readings, to carry them to the output encoder's instant.
    input_track: ReadingTrack,
    position: PositionLoop,
    input_wired: bool,
    input_origin: f64,
    output_origin: f64,
    /// `drive_gain`: the last motor set-point sent [rad] and the time since it changed [s].
    setpoint_rad: f64,
    since_change_s: f64,
    extension: Option<ModelExtension>,
}

impl ElasticJoint {
    /// The observed torque at deflection `phi` [Nm]: the characteristic (`k` for a line),
    /// through the model extension when there is one (the characteristic then at the element's
    /// deflection, after the play).
    fn torque(&mut self, t_s: f64, phi: f64, k: f64) -> f64 {
        let curve = |x: f64| match &self.curve {
            Some(c) => c.evaluate(0.0, x).torque_nm,
            None => k * x,
        };
        match &mut self.extension {
            Some(e) => {
                let phi_e = e.elastic_deflection(phi);
                let tau = curve(phi_e);
                e.torque(t_s, phi, tau)
            }
            None => curve(phi),
        }
    }

    /// Eq. 3.2 solved for the RC element's deflection, relative to the activation pose (the
    /// initial angles subtracted, section 3.4.1): motor side minus output.
    fn deflection(&self, output_rad: f64, input_rad: f64) -> f64 {
        self.transmission.ratio() * (input_rad - self.input_origin) - (output_rad - self.output_origin)
    }
}

impl JointPlugin for ElasticJoint {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        let p: Params = params::parse(params_json)?;
        let curve = match &p.characteristic {
            Some(spec) => Some(PivotCharacteristic::from_spec(spec).map_err(|e| PluginError::at(format!("characteristic.{}", e.field), e.message))?),
            None => None,
        };
        let stiffness = match (p.stiffness_nm_per_rad, &curve) {
            (Some(k), None) => params::positive("stiffness_nm_per_rad", k)?,
            (None, Some(c)) => c.stiffness(0.0),
            _ => return Err(PluginError::new("give either `stiffness_nm_per_rad` (linear) or `characteristic` (a fitted curve)")),
        };
        params::nonzero("output_per_motor", p.output_per_motor)?;
        params::positive("max_age_s", p.max_age_s)?;
        if !(p.max_deflection_age_s.is_finite() && p.max_deflection_age_s >= 0.0) {
            return Err(PluginError::at("max_deflection_age_s", "must be finite and >= 0"));
        }
        if !(p.settle_s.is_finite() && p.settle_s >= 0.0) {
            return Err(PluginError::at("settle_s", "must be finite and >= 0"));
        }
        if p.compliance == Compliance::DriveGain && curve.is_some() {
            return Err(PluginError::at("compliance", "`drive_gain` takes a linear `stiffness_nm_per_rad` (the drive's gain at the joint), not a characteristic"));
        }
        if let Some(z) = p.zero
            && !(z.input_rad.is_finite() && z.output_rad.is_finite())
        {
            return Err(PluginError::at("zero", "input_rad and output_rad must be finite"));
        }
        if let Some([lo, hi]) = p.deflection_range_rad
            && !(lo < hi && lo.is_finite() && hi.is_finite())
        {
            return Err(PluginError::at("deflection_range_rad", format!("must be [low, high] with low < high, got [{lo}, {hi}]")));
        }
        let position = PositionLoop::from_params(p.position_pi)?;
        if p.model_extension.as_ref().is_some_and(|e| !e.by_pivot.is_empty()) {
            return Err(PluginError::at("model_extension.by_pivot", "an elastic joint has one setting: give its terms flat (by_pivot is for joints with pivot settings, the shoulder and the wrist)"));
        }
        let extension = match p.model_extension.clone() {
            Some(spec) => Some(ModelExtension::new(spec).map_err(|e| PluginError::at(format!("model_extension.{}", e.field), e.message))?),
            None => None,
        };
        Ok(ElasticJoint {
            extension,
            stiffness_nm_per_rad: stiffness,
            curve,
            transmission: LinearTransmission::new(p.output_per_motor),
            velocity: VelocityEstimator::new(0.5),
            position,
            input_track: ReadingTrack::new(),
            input_wired: false,
            input_origin: 0.0,
            output_origin: 0.0,
            setpoint_rad: 0.0,
            since_change_s: 0.0,
            params: p,
        })
    }


    fn activate(&mut self, raw: &RawJointView) -> Result<(), PluginError> {
        let age = self.params.max_age_s;
        let q = raw.encoder(OUTPUT_ENCODER).usable(age);
        let m = raw.drive(MOTOR).position_rad.usable(age);
        let i = raw.encoder(INPUT_ENCODER);
        self.input_wired = i.status != jointctl_api::ReadingStatus::MISSING;
        let input = if self.input_wired { i.usable(age) } else { m };
        match (q, m, input) {
            (Some(q), Some(m), Some(input)) => {
                self.transmission = self.transmission.anchored(q, m);
                // Calibrated: the zero is the calibration's, and the deflection now is measured
                // (and must lie in the spring's range); otherwise it is taken as zero now.
                (self.input_origin, self.output_origin) = self.params.zero.map_or((input, q), |z| (z.input_rad, z.output_rad));
                let range = self.params.deflection_range_rad.or_else(|| self.params.characteristic.as_ref().and_then(|c| c.curves.first()).and_then(|c| c.range_rad));
                if self.params.zero.is_some()
                    && let Some([lo, hi]) = range
                {
                    let now = self.deflection(q, input);
                    if !(lo..=hi).contains(&now) {
                        return Err(PluginError::at(
                            "zero",
                            format!("the deflection at activation is {now:.5} rad with the calibrated zero, outside the spring's range [{lo}, {hi}] rad: recalibrate (jointctl calibrate) or check the element"),
                        ));
                    }
                }
                self.input_track.reset();
                // The drive holds where it is: its set-point is its position.
                self.setpoint_rad = m;
                self.since_change_s = self.params.settle_s;
                if let Some(e) = &mut self.extension {
                    e.reset();
                }
                Ok(())
            }
            _ => Err(PluginError::new(
                "cannot activate: the output encoder, the motor position and (if wired) the input encoder must be readable",
            )),
        }
    }
}

impl Observer for ElasticJoint {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let mut s = JointState::UNKNOWN;
        let q = raw.encoder(OUTPUT_ENCODER).usable(self.params.max_age_s);
        let age = self.params.max_deflection_age_s;
        let input_reading = if self.input_wired { *raw.encoder(INPUT_ENCODER) } else { raw.drive(MOTOR).position_rad };
        let input = input_reading.usable(age);
        let output_reading = raw.encoder(OUTPUT_ENCODER);
        let q_for_deflection = output_reading.usable(age);
        // The motor side at the instant the output encoder was read (readings of different ages
        // are not one deflection while the joint moves).
        let input = match input {
            // (An age that is not known, e.g. a reading replayed from a record without one:
            // subtracted as it is.)
            Some(i) if self.params.align_reading_ages && input_reading.age_s.is_finite() && output_reading.age_s.is_finite() => {
                self.input_track.update(i, raw.stamp_s - input_reading.age_s);
                self.input_track.at(raw.stamp_s - output_reading.age_s)
            }
            // A lost frame is no reason to forget the motion: the track forms no rate across a
            // gap longer than its span, and a reset here made the next reading's deflection jump
            // by the whole misalignment for one cycle.
            other => other,
        };
        if let Some(q) = q {
            s.set_position(q);
            s.set_stiffness(self.stiffness_nm_per_rad);
        }
        if self.params.compliance == Compliance::DriveGain {
            // The drive's following error as the joint sees it, once the drive has settled.
            let motor = raw.drive(MOTOR).position_rad.usable(age);
            if let Some(m) = motor.filter(|_| self.since_change_s >= self.params.settle_s) {
                let deflection = self.transmission.ratio() * (self.setpoint_rad - m);
                s.set_deflection(deflection);
                let k = self.stiffness_nm_per_rad;
                s.set_torque(self.torque(raw.stamp_s, deflection, k));
            }
        } else if let (Some(q), Some(input)) = (q_for_deflection, input) {
            let deflection = self.deflection(q, input);
            s.set_deflection(deflection);
            // Section 3.3.2: first-order fit, torque = K * deflection (or the fitted curve).
            let k = self.stiffness_nm_per_rad;
            s.set_torque(self.torque(raw.stamp_s, deflection, k));
        }
        if let Some(v) = self.velocity.update(q, raw.dt_s) {
            s.set_velocity(v);
        }
        // A gap in the deflection is no motion: the extension's state (the Dahl loop, the rate's
        // history) starts afresh after it, as the offline scoring does (issue 37, finding 6).
        if s.deflection().is_none()
            && let Some(e) = &mut self.extension
        {
            e.reset();
        }
        out[0] = s;
        Ok(())
    }
}

impl Controller for ElasticJoint {
    fn control(
        &mut self,
        state: &[JointState],
        command: &[JointCommand],
        raw: &RawJointView,
        out: &mut [MotorSetpoint],
    ) -> Result<(), JointFault> {
        out[MOTOR] = self.position.motor_setpoint(&command[0], state[0].position(), raw.dt_s, &self.transmission);
        self.since_change_s += raw.dt_s;
        if out[MOTOR].action == jointctl_api::DriveAction::MOVE && out[MOTOR].position_rad != self.setpoint_rad {
            // A change below one encoder count is not a move (a held PI output jitters).
            if (out[MOTOR].position_rad - self.setpoint_rad).abs() > std::f64::consts::TAU / 16384.0 {
                self.since_change_s = 0.0;
            }
            self.setpoint_rad = out[MOTOR].position_rad;
        }
        Ok(())
    }
}

export_joint_plugin!(name: elastic, plugin: ElasticJoint, dof: 1, encoders: "output,input?", drives: "motor", torque_dofs: 0b1);

#[cfg(test)]
mod tests {
    use super::*;
    use jointctl_api::{DriveReading, Reading};

    /// One cycle's readings: the motor's position `age_motor_s` old, the output's `age_out_s` old.
    fn raw(stamp_s: f64, motor_rad: f64, age_motor_s: f64, output_rad: f64, age_out_s: f64) -> RawJointView {
        let mut r = RawJointView { stamp_s, dt_s: 0.025, ..RawJointView::default() };
        r.encoders[OUTPUT_ENCODER] = Reading::valid_aged(output_rad, age_out_s);
        r.drives[MOTOR] = DriveReading::new(Reading::valid_aged(motor_rad, age_motor_s), Reading::MISSING, true, false);
        r
    }

    fn joint(align: bool) -> ElasticJoint {
        let params = format!(
            r#"{{"stiffness_nm_per_rad": 100.0, "output_per_motor": 2.0, "position_pi": {{"kp": 0, "ki": 0}}, "align_reading_ages": {align}}}"#
        );
        ElasticJoint::create(&params).unwrap()
    }

    /// The motor starts to turn at 0.4 rad/s after activation (at rest), the output following at
    /// zero deflection (output = 2 motor):
    /// the drive's position is 30 ms old, the output encoder's 15 ms (section 2.3's buses). The
    /// deflection is zero only when the motor's reading is carried to the encoder's instant.
    #[test]
    fn readings_of_different_ages_are_one_deflection_at_the_output_encoders_instant() {
        let motor = |t: f64| 0.4 * (t - 1.0).max(0.0);
        for (align, expected) in [(true, 0.0), (false, -2.0 * 0.4 * 0.015)] {
            let mut j = joint(align);
            let view = |t: f64| raw(t, motor(t - 0.030), 0.030, 2.0 * motor(t - 0.015), 0.015);
            j.activate(&view(1.0)).unwrap();
            let mut out = [JointState::UNKNOWN];
            for k in 1..=4 {
                j.observe(&view(1.0 + 0.025 * k as f64), &mut out).unwrap();
            }
            let d = out[0].deflection().unwrap();
            assert!((d - expected).abs() < 1e-9, "align {align}: deflection {d}, expected {expected}");
        }
    }

    /// One drive frame lost in the middle of the motion: no deflection that cycle (a stale
    /// reading is not combined), and the next one is aligned again at once, without a jump.
    #[test]
    fn a_lost_drive_frame_does_not_make_the_next_deflection_jump() {
        let motor = |t: f64| 0.4 * (t - 1.0).max(0.0);
        let view = |t: f64| raw(t, motor(t - 0.030), 0.030, 2.0 * motor(t - 0.015), 0.015);
        let mut j = joint(true);
        j.activate(&view(1.0)).unwrap();
        let mut out = [JointState::UNKNOWN];
        for k in 1..=8 {
            let t = 1.0 + 0.025 * k as f64;
            let mut v = view(t);
            if k == 5 {
                v.drives[MOTOR] = DriveReading::new(Reading::MISSING, Reading::MISSING, true, false);
            }
            j.observe(&v, &mut out).unwrap();
            match out[0].deflection() {
                None => assert_eq!(k, 5, "cycle {k}: no deflection"),
                Some(d) => assert!(k != 5 && (k < 3 || d.abs() < 1e-9), "cycle {k}: deflection {d}"),
            }
        }
    }
}
