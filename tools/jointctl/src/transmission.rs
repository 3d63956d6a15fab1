//! `jointctl check-transmission`: eq. 3.3 as printed gives q2 and q3 the same row (`(a2 - a3)/2`),
//! so the shoulder's differential is an assumption (sum and difference, see
//! `jointctl_models::transmission::eq_3_3_shoulder_joints`). Before torque control is trusted on an
//! arm, this moves each shoulder actuator alone by a small step and reads q2's motor-side angle
//! from its own encoders (output plus the deflection encoder, section 3.4.1): the sign and size
//! of each change say whether the assumed row of q2 is the arm's. q3 has no output encoder: the
//! command says which way q3 should turn, for the person watching.
//!
//! It talks to the HAL alone (no plugin, no controller): every drive holds but the one moved.

use std::path::Path;
use std::process::ExitCode;

use jointctl_api::MotorSetpoint;
use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, SensorFrame};
use jointctl_models::transmission::eq_3_3_shoulder_joints;

/// Seconds each position is held before it is read (the drive's profile and the joint settle).
/// An assumption: the simulated ELMO moves 0.02 rad in about 0.1 s.
const SETTLE_S: f64 = 1.5;

/// The measured change of q2's motor-side angle against the assumption.
struct Move {
    actuator: &'static str,
    expected_q2_rad: f64,
    expected_q3_rad: f64,
    measured_q2_rad: f64,
}

struct Rig {
    hal: Box<dyn Hal>,
    sensors: SensorFrame,
    out: ActuatorFrame,
    dt_s: f64,
    q2_output: usize,
    q2_deflection: usize,
}

impl Rig {
    /// Runs for `seconds`, the drives holding but `moved` (index, target); returns the mean of
    /// q2's motor-side angle over the last fifth, or why it could not be read.
    fn hold(&mut self, seconds: f64, moved: Option<(usize, f64)>) -> Result<f64, String> {
        let cycles = (seconds / self.dt_s).ceil() as usize;
        let (mut sum, mut n) = (0.0, 0usize);
        for k in 0..cycles {
            self.hal.read(&mut self.sensors).map_err(|e| format!("reading the buses: {e}"))?;
            self.out.drives.fill(MotorSetpoint::HOLD);
            if let Some((d, target)) = moved {
                self.out.drives[d] = MotorSetpoint::move_to(target);
            }
            self.hal.write(&self.out, self.dt_s).map_err(|e| format!("writing the drives: {e}"))?;
            if k >= cycles * 4 / 5 {
                let out = self.sensors.encoders[self.q2_output].usable(1.0);
                let defl = self.sensors.encoders[self.q2_deflection].usable(1.0);
                if let (Some(o), Some(d)) = (out, defl) {
                    sum += o + d;
                    n += 1;
                }
            }
        }
        if n == 0 {
            return Err("q2's output and deflection encoders gave no usable reading".into());
        }
        Ok(sum / n as f64)
    }

    fn drive_position(&self, d: usize) -> Result<f64, String> {
        self.sensors.drives[d].position_rad.usable(1.0).ok_or_else(|| format!("drive {d} gave no usable position"))
    }
}

pub fn run(config: &Path, step_rad: f64) -> ExitCode {
    match check(config, step_rad) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => crate::fail(e),
    }
}

fn check(config: &Path, step_rad: f64) -> Result<bool, String> {
    if !(step_rad.is_finite() && step_rad > 0.0 && step_rad <= 0.1) {
        return Err(format!("--step-rad must be in (0, 0.1] rad, got {step_rad}"));
    }
    let loaded = jointctl_config::load(config).map_err(|e| e.to_string())?;
    let joint = loaded
        .config
        .joints
        .iter()
        .find(|j| j.plugin.name == "vsa_shoulder")
        .ok_or_else(|| format!("{}: no `vsa_shoulder` joint: the check is of eq. 3.3's differential", config.display()))?;
    let devices = DeviceIndex::of(&loaded.config);
    let role = |map: &std::collections::BTreeMap<String, String>, role: &str, kind: &str, index: &dyn Fn(&str) -> Option<usize>| {
        let name = map.get(role).ok_or_else(|| format!("joint `{}`: no {kind} `{role}`", joint.name))?;
        index(name).ok_or_else(|| format!("joint `{}`: {kind} `{name}` is on no bus", joint.name))
    };
    let enc = |n: &str| devices.encoder(n);
    let drv = |n: &str| devices.drive(n);
    let (q2_output, q2_deflection) = (role(&joint.encoders, "q2_output", "encoder", &enc)?, role(&joint.encoders, "q2_deflection", "encoder", &enc)?);
    let actuators = [("actuator_a", role(&joint.drives, "actuator_a", "drive", &drv)?), ("actuator_b", role(&joint.drives, "actuator_b", "drive", &drv)?)];
    // It commands the drives: not beside a runtime of this arm, nor on a bus another drives.
    let _locks = crate::run::lock_hardware(&loaded).map_err(|e| crate::chain(&e))?;
    let hal = jointctl_backends::build_hal(&loaded).map_err(|e| e.to_string())?;
    let mut rig = Rig { hal, sensors: SensorFrame::new(&devices), out: ActuatorFrame::new(&devices), dt_s: 1.0 / loaded.config.rate_hz, q2_output, q2_deflection };
    eprintln!("check-transmission: every drive holds; each shoulder actuator moves {step_rad} rad alone and back");
    let rest = rig.hold(SETTLE_S, None)?;
    let mut moves = Vec::new();
    for (k, (actuator, d)) in actuators.iter().enumerate() {
        let start = rig.drive_position(*d)?;
        let moved = rig.hold(SETTLE_S, Some((*d, start + step_rad)))?;
        let back = rig.hold(SETTLE_S, Some((*d, start)))?;
        let (a2, a3) = if k == 0 { (step_rad, 0.0) } else { (0.0, step_rad) };
        let (expected_q2_rad, expected_q3_rad) = eq_3_3_shoulder_joints(a2, a3);
        moves.push(Move { actuator, expected_q2_rad, expected_q3_rad, measured_q2_rad: moved - 0.5 * (rest + back) });
    }
    // One encoder count of each of the two encoders, plus a tenth of the expected change.
    let count = std::f64::consts::TAU / 16384.0;
    let mut ok = true;
    outln!("| actuator moved | q2 expected [rad] | q2 measured [rad] | q2 | q3 expected [rad] (no encoder: watch it) |");
    outln!("|---|---|---|---|---|");
    for m in &moves {
        let tolerance = 2.0 * count + 0.1 * m.expected_q2_rad.abs();
        let verdict = if (m.measured_q2_rad - m.expected_q2_rad).abs() <= tolerance {
            "as assumed"
        } else if (m.measured_q2_rad + m.expected_q2_rad).abs() <= tolerance {
            ok = false;
            "OPPOSITE SIGN"
        } else {
            ok = false;
            "DIFFERENT"
        };
        outln!("| {} | {:+.4} | {:+.4} | {verdict} | {:+.4} |", m.actuator, m.expected_q2_rad, m.measured_q2_rad, m.expected_q3_rad);
    }
    if ok {
        outln!("q2's row of eq. 3.3 is the assumed one (q2 = (a2 + a3) / 2) on this arm.");
    } else {
        outln!("q2 does not move as the assumed eq. 3.3 says: fix the differential (or the drives' wiring or direction) before trusting torque control.");
    }
    Ok(ok)
}
