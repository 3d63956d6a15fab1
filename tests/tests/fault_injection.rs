//! The fault-injection suite: each case injects one fault into a running arm and states its
//! pass criterion in its doc comment. Cases that need processes, signals or the CAN VM live in
//! `processes.rs`, `frame_loss.rs` and `socketcan_vcan.rs`; this file holds the in-process ones.

use jointctl_api::{JointFault, MotorSetpoint};
use jointctl_modes::Mode;
use jointctl_runtime::{PluginLoader, RunOptions};
use jointctl_tests::rig_yaml;

fn position(target_rad: f64) -> Mode {
    Mode::Position { target_rad }
}

/// The rig of `rig_yaml` with joint `b` on the `faulty` test plugin.
fn arm_with_faulty(rate_hz: f64, params: &str) -> jointctl_runtime::Arm {
    let extra = format!("  - name: b\n    plugin: faulty\n    encoders: {{output: e1}}\n    drives: {{motor: m1}}\n    params: {params}\n");
    let loaded = jointctl_config::parse_str(&rig_yaml("fault-injection", rate_hz, &extra), "rig.yaml").unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    arm
}

/// Finding: a plugin that stalls froze every joint and was never faulted (30 ms stalls gave
/// overruns forever). Pass: at 100 Hz (budget 0.5 x 10 ms), a plugin that stalls 30 ms every
/// 20 cycles causes exactly one overrun, is then faulted with OVER_BUDGET and never called again,
/// and the other joint goes on to its set-point.
#[test]
fn a_stalling_plugin_costs_one_overrun_then_is_faulted_and_the_loop_goes_on() {
    let mut arm = arm_with_faulty(100.0, "{stall_us: 30000, stall_every: 20}");
    arm.set_mode(0, position(0.3));
    arm.set_mode(1, position(0.3));
    let report = jointctl_runtime::run(&mut arm, &Default::default(), None, &RunOptions { cycles: Some(150), ..Default::default() }).unwrap();
    let b = &arm.slots[1];
    assert_eq!(b.fault, JointFault::OVER_BUDGET.code(), "the stalling joint is faulted");
    assert_eq!(b.fault_count, 1, "faulted once, then never called again");
    assert!(b.max_used_ns >= 30_000_000, "the stall was measured: {} ns", b.max_used_ns);
    assert_eq!(report.stats.overruns, 1, "one overrun, then the joint faulted: {:?}", report.stats);
    assert!(b.held && arm.states[1].position().is_none());
    assert_eq!(arm.last_setpoints()[1], MotorSetpoint::HOLD);
    assert_eq!(arm.slots[0].fault, 0);
    assert!((arm.states[0].position().unwrap() - 0.3).abs() < 5e-3, "the other joint went on: {:?}", arm.states[0]);
}

/// A per-joint `budget_us` in the YAML overrides the fraction: 2 ms stalls pass the default
/// budget at 100 Hz (5 ms) and fault a joint whose budget is 1 ms.
#[test]
fn a_joints_own_budget_overrides_the_default() {
    let stall = "{stall_us: 2000, stall_every: 3}";
    let mut arm = arm_with_faulty(100.0, stall);
    for i in 0..9 {
        arm.step(i as f64 * 0.01);
    }
    assert_eq!(arm.slots[1].fault, 0, "2 ms is within 5 ms");
    let extra = format!("  - name: b\n    plugin: faulty\n    budget_us: 1000\n    encoders: {{output: e1}}\n    drives: {{motor: m1}}\n    params: {stall}\n");
    let loaded = jointctl_config::parse_str(&rig_yaml("fault-injection", 100.0, &extra), "rig.yaml").unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    for i in 0..9 {
        arm.step(i as f64 * 0.01);
    }
    assert_eq!(arm.slots[1].fault, JointFault::OVER_BUDGET.code());
}
