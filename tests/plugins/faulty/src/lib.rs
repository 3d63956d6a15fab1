//! Test fixture: a 1-DOF joint that misbehaves on request, to test that the host contains it.
//! Position from encoder role `output`; drive role `motor` held or moved to the position set-point.

use jointctl_api::*;
use serde::Deserialize;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Panic in `create`.
    #[serde(default)]
    panic_in_create: bool,
    /// Panic in `observe` on this cycle (from 0).
    #[serde(default)]
    panic_in_observe_at: Option<u64>,
    /// Panic in `control` on this cycle.
    #[serde(default)]
    panic_in_control_at: Option<u64>,
    /// Return fault code 42 from `observe` on this cycle.
    #[serde(default)]
    fault_at: Option<u64>,
    /// Busy-wait this long in `observe` [us] ...
    #[serde(default)]
    stall_us: u64,
    /// ... every this many cycles (0 = never).
    #[serde(default)]
    stall_every: u64,
    /// Stall by sleeping (blocking) instead of spinning.
    #[serde(default)]
    stall_sleeps: bool,
    /// Write a move to `wild_setpoint_rad` from this cycle on, whatever the command (a plugin
    /// bug that drives a motor somewhere the joint's limits never allowed).
    #[serde(default)]
    wild_setpoint_at: Option<u64>,
    /// Where the wild set-point goes [rad].
    #[serde(default)]
    wild_setpoint_rad: f64,
    /// Create this file in `deactivate`, so a test can see whether the host called it.
    #[serde(default)]
    deactivate_marker: Option<std::path::PathBuf>,
}

/// A joint that panics, faults or stalls when told to.
pub struct Faulty {
    p: Params,
    cycle: u64,
}

impl Observer for Faulty {
    fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
        let c = self.cycle;
        self.cycle += 1;
        if self.p.panic_in_observe_at == Some(c) {
            panic!("faulty joint: deliberate panic in observe at cycle {c}");
        }
        if self.p.fault_at == Some(c) {
            return Err(JointFault::new(42));
        }
        if self.p.stall_every > 0 && c % self.p.stall_every == self.p.stall_every - 1 && self.p.stall_sleeps {
            std::thread::sleep(std::time::Duration::from_micros(self.p.stall_us));
        } else if self.p.stall_every > 0 && c % self.p.stall_every == self.p.stall_every - 1 {
            let t = std::time::Instant::now();
            while t.elapsed().as_micros() < self.p.stall_us as u128 {
                core::hint::spin_loop();
            }
        }
        let mut s = JointState::UNKNOWN;
        if let Some(q) = raw.encoder(0).usable(0.1) {
            s.set_position(q);
        }
        out[0] = s;
        Ok(())
    }
}

impl Controller for Faulty {
    fn control(&mut self, _: &[JointState], cmd: &[JointCommand], _: &RawJointView, out: &mut [MotorSetpoint]) -> Result<(), JointFault> {
        if self.p.panic_in_control_at == Some(self.cycle.saturating_sub(1)) {
            panic!("faulty joint: deliberate panic in control");
        }
        if self.p.wild_setpoint_at.is_some_and(|at| self.cycle.saturating_sub(1) >= at) {
            out[0] = MotorSetpoint::move_to(self.p.wild_setpoint_rad);
            return Ok(());
        }
        out[0] = if cmd[0].mode == ControlMode::POSITION { MotorSetpoint::move_to(cmd[0].position_rad) } else { MotorSetpoint::HOLD };
        Ok(())
    }
}

impl JointPlugin for Faulty {
    fn create(params_json: &str) -> Result<Self, PluginError> {
        let p: Params = params::parse(params_json)?;
        if p.panic_in_create {
            panic!("faulty joint: deliberate panic in create");
        }
        Ok(Faulty { p, cycle: 0 })
    }

    fn deactivate(&mut self) {
        if let Some(marker) = &self.p.deactivate_marker {
            let _ = std::fs::write(marker, b"deactivated");
        }
    }
}

export_joint_plugin!(name: faulty, plugin: Faulty, dof: 1, encoders: "output", drives: "motor");
