//! The fault-injection suite: each case injects one fault into a running arm and states its
//! pass criterion in its doc comment. Cases that need processes, signals or the CAN VM live in
//! `processes/`, `frame_loss.rs` and `socketcan_vcan/`; this file holds the in-process ones.

use jointctl_api::{JointFault, MotorSetpoint};
use jointctl_modes::Mode;
use jointctl_runtime::{PluginLoader, RunOptions};
use jointctl_tests::rig_yaml;

/// The cases run one at a time: two of them pace a loop in real time (a plugin's stall is
/// measured against a 10 ms cycle), and a case computing beside them on this 2-core machine
/// cost that loop a second overrun (12 ms of jitter) where the stall alone costs one.
fn alone() -> std::sync::MutexGuard<'static, ()> {
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner())
}

/// Steps an arm through cycles `cycles` at 100 Hz (unpaced).
fn step_100hz(arm: &mut jointctl_runtime::Arm, cycles: std::ops::Range<usize>) {
    for i in cycles {
        arm.step(i as f64 * 0.01);
    }
}

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

/// The rig of `rig_yaml` with joint `b` on the `faulty` test plugin and these edits to the YAML.
fn arm_with_faulty_and(rate_hz: f64, params: &str, edits: &[jointctl_tests::Edit]) -> jointctl_runtime::Arm {
    let extra = format!("  - name: b\n    plugin: faulty\n    encoders: {{output: e1}}\n    drives: {{motor: m1}}\n    params: {params}\n");
    let yaml = jointctl_tests::yaml_with(&rig_yaml("fault-injection", rate_hz, &extra), edits);
    let loaded = jointctl_config::parse_str(&yaml, "rig.yaml").unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    arm
}

/// Issue 37, finding 1: a plugin's motor set-points went to the drives as computed (the DOF's
/// limits bound the joint-level command only), so a plugin bug drove a motor wherever it said.
/// Pass: a plugin that writes 2 rad to a drive whose window is [-1.5, 1.5], or a step of 0.5 rad
/// in a cycle to a drive allowed 5 rad/s (0.05 rad a cycle at 100 Hz), is held in that same
/// cycle (its set-point is a hold, the drive never moves there), faulted with SETPOINT_REJECTED,
/// named in the fault's reason with the drive and the value, and counted once; the other joint
/// goes on. With the check off (`safety.check_setpoints: false`) the set-point reaches the drive,
/// and the simulated drive, told the window as its software position limits, stops at 1.5 rad.
#[test]
fn a_set_point_outside_its_drives_window_or_rate_is_held_and_named_in_the_same_cycle() {
    let _alone = alone();
    use jointctl_tests::Edit;
    let window = Edit::Set("buses.can[0].drives[m1].setpoint_window_rad", serde_yaml::from_str("[-1.5, 1.5]").unwrap());
    let rate = Edit::Set("buses.can[0].drives[m1].max_setpoint_rate_rad_s", 5.0.into());
    for (edits, wild, reason) in [
        (vec![window], 2.0, "plugin `faulty` wrote 2 rad to drive `m1`, outside its setpoint_window_rad [-1.5, 1.5]"),
        (vec![rate], 0.8, "plugin `faulty` moved drive `m1` from 0.3 to 0.8 rad in one cycle, more than 0.05 rad"),
    ] {
        let mut arm = arm_with_faulty_and(100.0, &format!("{{wild_setpoint_at: 150, wild_setpoint_rad: {wild}}}"), &edits);
        arm.set_mode(0, position(0.3));
        arm.set_mode(1, position(0.3));
        step_100hz(&mut arm, 0..150);
        assert_eq!(arm.slots[1].fault, 0, "{reason}: no fault before the wild set-point");
        step_100hz(&mut arm, 150..151);
        let b = &arm.slots[1];
        assert_eq!(b.fault, JointFault::SETPOINT_REJECTED.code(), "{reason}");
        assert_eq!(arm.last_setpoints()[1], MotorSetpoint::HOLD, "held in the same cycle");
        assert!(b.fault_reason().contains(reason), "{}", b.fault_reason());
        step_100hz(&mut arm, 151..200);
        let b = &arm.slots[1];
        assert_eq!((b.setpoint_rejections, b.fault_count), (1, 1));
        assert!((arm.last_readings().drives[1].position_rad.value - 0.3).abs() < 0.01, "the drive stayed: {:?}", arm.last_readings().drives[1]);
        assert!((arm.states[0].position().unwrap() - 0.3).abs() < 5e-3, "the other joint went on: {:?}", arm.states[0]);
    }
    // The host's check off: the set-point of 2 rad reaches the drive, and the drive (told the
    // same window as its software position limits, 0x607D) stops at 1.5 rad (issue 37, finding
    // 2: with nothing below the host, it went to 2).
    let off = [
        Edit::Set("buses.can[0].drives[m1].setpoint_window_rad", serde_yaml::from_str("[-1.5, 1.5]").unwrap()),
        Edit::Set("safety", serde_yaml::from_str("{check_setpoints: false}").unwrap()),
    ];
    let mut arm = arm_with_faulty_and(100.0, "{wild_setpoint_at: 150, wild_setpoint_rad: 2.0}", &off);
    arm.set_mode(1, position(0.3));
    step_100hz(&mut arm, 0..151);
    assert_eq!((arm.slots[1].fault, arm.last_setpoints()[1]), (0, MotorSetpoint::move_to(2.0)));
    step_100hz(&mut arm, 151..400);
    let reached = arm.last_readings().drives[1].position_rad.value;
    assert!((reached - 1.5).abs() < 0.01, "the drive stopped at its limit: {reached} rad");
}

/// Finding: a plugin that stalls froze every joint and was never faulted (30 ms stalls gave
/// overruns forever; one that blocks 2 s every 80 cycles missed every deadline). Pass: at
/// 100 Hz (budget 0.5 x 10 ms, stall limit 10 ms), a plugin that stalls 30 ms every 20 cycles,
/// spinning or blocked in a sleep, causes exactly one overrun, is then faulted with OVER_BUDGET
/// and never called again, and the other joint goes on to its set-point.
#[test]
fn a_stalling_plugin_costs_one_overrun_then_is_faulted_and_the_loop_goes_on() {
    let _alone = alone();
    for sleeps in [false, true] {
        a_stall_costs_one_overrun(&format!("{{stall_us: 30000, stall_every: 20, stall_sleeps: {sleeps}}}"));
    }
}

/// Runs of the arm one stall may take before the overrun count is judged (an assumption: the
/// machine's own stalls are rare, three in a row far rarer). The loop's statistics do not say
/// which plugin a cycle overran in, and this shared machine stalls a thread by itself at times:
/// one run counted 2 overruns (its wake-up 12.2 ms late at most) with the joint faulted once. A
/// plugin that is never faulted overruns every 20 cycles of each run, 7 times in 150, and fails
/// every attempt.
const STALL_ATTEMPTS: usize = 3;

fn a_stall_costs_one_overrun(params: &str) {
    let mut attempt = 0;
    let (arm, report) = loop {
        attempt += 1;
        let mut arm = arm_with_faulty(100.0, params);
        arm.set_mode(0, position(0.3));
        arm.set_mode(1, position(0.3));
        let report = jointctl_runtime::run(&mut arm, &Default::default(), None, &RunOptions { cycles: Some(150), ..Default::default() }).unwrap();
        if report.stats.overruns == 1 || attempt == STALL_ATTEMPTS {
            break (arm, report);
        }
        eprintln!("{params}: attempt {attempt} counted {} overruns (max lateness {} ns): again", report.stats.overruns, report.stats.max_jitter_ns);
    };
    let b = &arm.slots[1];
    assert_eq!(b.fault, JointFault::OVER_BUDGET.code(), "{params}: the stalling joint is faulted");
    assert_eq!(b.fault_count, 1, "faulted once, then never called again");
    assert!(b.max_used_ns >= 30_000_000, "the stall was measured: {} ns", b.max_used_ns);
    assert_eq!(report.stats.overruns, 1, "one overrun, then the joint faulted: {:?}", report.stats);
    assert!(b.held && arm.states[1].position().is_none());
    assert_eq!(arm.last_setpoints()[1], MotorSetpoint::HOLD);
    assert_eq!(arm.slots[0].fault, 0);
    assert!((arm.states[0].position().unwrap() - 0.3).abs() < 5e-3, "the other joint went on: {:?}", arm.states[0]);
}

/// A per-joint `budget_us` in the YAML overrides the fraction: 2 ms stalls pass the default
/// budget at 100 Hz (5 ms) and fault a joint whose budget is 1 ms on the third (strikes). A
/// lone excess below the stall limit (max(period, 5 ms)) is counted, not faulted, because the
/// platform stalls threads too: a 10-minute soak at 1 kHz faulted healthy joints otherwise.
#[test]
fn a_joints_own_budget_overrides_the_default() {
    let _alone = alone();
    let stall = "{stall_us: 2000, stall_every: 3}";
    // A 2 ms stall is a 2 ms spin, which a loaded machine can stretch past 5 ms three times in a
    // row (a CI run beside two identify jobs faulted it): tried again, as the stalls above are.
    let within = (0..STALL_ATTEMPTS).any(|_| {
        let mut arm = arm_with_faulty(100.0, stall);
        step_100hz(&mut arm, 0..9);
        arm.slots[1].fault == 0
    });
    assert!(within, "2 ms is within 5 ms in none of {STALL_ATTEMPTS} attempts");
    let extra = format!("  - name: b\n    plugin: faulty\n    budget_us: 1000\n    encoders: {{output: e1}}\n    drives: {{motor: m1}}\n    params: {stall}\n");
    let loaded = jointctl_config::parse_str(&rig_yaml("fault-injection", 100.0, &extra), "rig.yaml").unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    step_100hz(&mut arm, 0..9);
    assert_eq!(arm.slots[1].fault, JointFault::OVER_BUDGET.code());
    // Over budget but under the stall limit: counted, and faulted only on the third time without
    // a second in budget between. The stall limit is raised to 50 ms here (by its floor): at the
    // 10 ms period a 6 ms sleep left 4 ms for the scheduler, and on a loaded CI machine one
    // sleep overshot it and faulted the joint at its first excess (the stall limit's own rule,
    // tested with a stalling plugin above), which is not what this part is about.
    let floor = [jointctl_tests::Edit::Set("timing.joint_stall_floor_us", 50_000.into())];
    let mut arm = arm_with_faulty_and(100.0, "{stall_us: 6000, stall_every: 3, stall_sleeps: true}", &floor);
    step_100hz(&mut arm, 0..6);
    assert_eq!((arm.slots[1].fault, arm.slots[1].over_budget_cycles), (0, 2));
    step_100hz(&mut arm, 6..9);
    assert_eq!(arm.slots[1].fault, JointFault::OVER_BUDGET.code());
    // A second in budget between excesses forgives them: four excesses, 1.2 s apart, no fault.
    let mut arm = arm_with_faulty_and(100.0, "{stall_us: 6000, stall_every: 120, stall_sleeps: true}", &floor);
    step_100hz(&mut arm, 0..500);
    assert_eq!((arm.slots[1].fault, arm.slots[1].over_budget_cycles), (0, 4));
}

/// Finding: a velocity limit documented as enforced was never read. Pass: with
/// `limits.velocity_rad_s: 0.5` at 100 Hz, a 0.5 rad position step moves the set-point by at
/// most 5 mrad per cycle (the controller's own rate limit, 2 rad/s, would allow 20), and the
/// clamping is counted.
#[test]
fn the_velocity_limit_bounds_the_set_point_rate() {
    let _alone = alone();
    let yaml = rig_yaml("velocity-limit", 100.0, "").replace("limits: {position_rad: [-1.0, 1.0]}", "limits: {position_rad: [-1.0, 1.0], velocity_rad_s: 0.5}");
    let loaded = jointctl_config::parse_str(&yaml, "rig.yaml").unwrap();
    assert_eq!(loaded.config.joints[0].limits.unwrap().velocity_rad_s, Some(0.5), "the edit took");
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    arm.step(0.0);
    arm.set_mode(0, position(0.5));
    let mut last = arm.states[0].position().unwrap();
    for i in 1..20 {
        arm.step(i as f64 * 0.01);
        let sp = arm.commands[0].position_rad;
        assert!((sp - last).abs() <= 0.005 + 1e-12, "cycle {i}: set-point moved {} rad", sp - last);
        last = sp;
    }
    assert!(last > 0.08, "it moves at the limit: {last}");
    assert!(arm.controllers[0].events.rate_limited >= 19);
}

/// Finding: diagnostics cut device names to 15 bytes, so `enc_shoulder_pulley_a` and
/// `enc_shoulder_pulley_b` both read `enc_shoulder_pu`. Pass: every device of the SHERPA config
/// is published whole and the names are distinct.
#[test]
fn diagnostics_carry_whole_device_names() {
    let _alone = alone();
    let arm_id = jointctl_tests::arm_name("device-names");
    let path = jointctl_tests::sherpa_with("device-names", &arm_id, &[]);
    let loaded = jointctl_config::load(&path).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &jointctl_runtime::loader_for(&loaded)).unwrap();
    arm.activate().unwrap();
    let expected: Vec<String> = arm.device_names().map(str::to_string).collect();
    assert!(expected.iter().any(|n| n == "enc_shoulder_pulley_a") && expected.iter().any(|n| n == "enc_shoulder_pulley_b"));
    let mut publisher = jointctl_runtime::ArmPublisher::new(&arm, None).unwrap();
    let node = jointctl_ipc::create_node(None, "device-names-test").unwrap();
    let names = jointctl_ipc::ServiceNames::for_arm(&arm_id);
    let sub = jointctl_ipc::diagnostics_service(&node, &names.diagnostics).unwrap().subscriber_builder().create().unwrap();
    let mut lp = jointctl_runtime::ControlLoop::new(&mut arm, Some(&mut publisher), 0);
    let t = std::time::Instant::now();
    let d = loop {
        let now = jointctl_runtime::timing::monotonic_ns();
        lp.step(now, now, None);
        if let Some(s) = sub.receive().unwrap() {
            break jointctl_ipc::Diagnostics::try_from(&s).unwrap();
        }
        assert!(t.elapsed() < std::time::Duration::from_secs(5), "no diagnostics");
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let published: Vec<&str> = d.devices.iter().map(|dev| jointctl_ipc::decode_name(&dev.name)).collect();
    assert_eq!(published, expected);
    let _ = lp.finish();
}

/// The rig at 100 Hz on a shared simulator, so that a test can inject faults into it.
fn rig_on_shared_sim(name: &str) -> (jointctl_runtime::Arm, jointctl_sim::SharedSim) {
    let loaded = jointctl_config::parse_str(&rig_yaml(name, 100.0, ""), "rig.yaml").unwrap();
    let sim = jointctl_sim::SharedSim::new(jointctl_sim::SimHal::load(&loaded).unwrap());
    let mut arm = jointctl_runtime::Arm::build(&loaded, &PluginLoader::new([]), Box::new(sim.clone())).unwrap();
    arm.activate().unwrap();
    (arm, sim)
}

fn inject(sim: &jointctl_sim::SharedSim, fault: Option<jointctl_sim::EncoderFault>) {
    sim.0.lock().unwrap().inject_encoder_fault(0, fault);
}

/// Fault suite: a silent or corrupt encoder. Pass: the joint's reading is never used as a value
/// once unusable: within its maximum age (0.1 s, 10 cycles at 100 Hz) plus one cycle the joint
/// is held (hold set-points, `held` published, invalid cycles counted), its drive stays within
/// 1 mrad while held, and it resumes to its target when the encoder answers again.
#[test]
fn a_silent_or_corrupt_encoder_holds_its_joint_within_its_maximum_age() {
    let _alone = alone();
    for fault in [jointctl_sim::EncoderFault::Silent, jointctl_sim::EncoderFault::Corrupt] {
        let (mut arm, sim) = rig_on_shared_sim("silent-encoder");
        arm.set_mode(0, position(0.3));
        for i in 0..20 {
            arm.step(i as f64 * 0.01);
        }
        inject(&sim, Some(fault));
        let mut held_after = None;
        for i in 20..60 {
            arm.step(i as f64 * 0.01);
            if arm.slots[0].held && held_after.is_none() {
                held_after = Some(i - 20);
                assert_eq!(arm.last_setpoints()[0], jointctl_api::MotorSetpoint::HOLD);
            }
        }
        let held_after = held_after.unwrap_or_else(|| panic!("{fault:?}: the joint was never held"));
        assert!(held_after <= 11, "{fault:?}: held only after {held_after} cycles");
        let drive_before = sim.with(|s| s.drives()[0].position);
        for i in 60..80 {
            arm.step(i as f64 * 0.01);
        }
        let moved = sim.with(|s| s.drives()[0].position) - drive_before;
        // The drive holds its last target; its own position loop still settles (43 urad seen).
        assert!(moved.abs() < 1e-3, "{fault:?}: the held drive moved {moved} rad");
        assert!(arm.slots[0].invalid_cycles >= 20);
        inject(&sim, None);
        for i in 80..400 {
            arm.step(i as f64 * 0.01);
        }
        assert!(!arm.slots[0].held && (arm.states[0].position().unwrap() - 0.3).abs() < 2e-3, "{fault:?}: resumed: {:?}", arm.states[0]);
    }
}

/// Fault suite: an implausible encoder (a 1 rad jump). Pass: the jump never reaches the
/// observed position (it stays within 5 mrad of the truth), the device's implausible counter
/// counts it, and a jump that persists holds the joint within its maximum age plus one cycle.
#[test]
fn an_implausible_encoder_jump_never_reaches_the_state() {
    let _alone = alone();
    let (mut arm, sim) = rig_on_shared_sim("jumping-encoder");
    arm.set_mode(0, position(0.3));
    for i in 0..50 {
        arm.step(i as f64 * 0.01);
    }
    inject(&sim, Some(jointctl_sim::EncoderFault::Offset(1.0)));
    let mut held_after = None;
    for i in 50..80 {
        arm.step(i as f64 * 0.01);
        let truth = sim.with(|s| s.drives()[0].position);
        if let Some(q) = arm.states[0].position() {
            assert!((q - truth).abs() < 5e-3, "cycle {i}: observed {q}, truth {truth}");
        }
        if arm.slots[0].held && held_after.is_none() {
            held_after = Some(i - 50);
        }
    }
    assert!(held_after.is_some_and(|c| c <= 11), "held after {held_after:?} cycles");
    let mut health = vec![jointctl_hal::DeviceHealth::default(); 32];
    arm.device_health(&mut health);
    let e0 = arm.device_names().position(|n| n == "e0").unwrap();
    assert!(health[e0].implausible >= 10, "{:?}", health[e0]);
}

/// A simulated arm that records what the runtime asks its HAL to stop with, and can panic in a
/// write (a bug of the runtime's own, unwinding through the loop).
struct StopRecorder {
    inner: jointctl_sim::SimHal,
    stops: std::sync::Arc<std::sync::Mutex<Vec<Vec<jointctl_config::StopStep>>>>,
    panic_at_write: Option<u64>,
    writes: u64,
}

impl jointctl_hal::Hal for StopRecorder {
    fn read(&mut self, frame: &mut jointctl_hal::SensorFrame) -> Result<(), jointctl_hal::HalIoError> {
        self.inner.read(frame)
    }
    fn write(&mut self, frame: &jointctl_hal::ActuatorFrame, dt_s: f64) -> Result<(), jointctl_hal::HalIoError> {
        self.writes += 1;
        if self.panic_at_write == Some(self.writes) {
            panic!("deliberate panic in the HAL's write {}", self.writes);
        }
        self.inner.write(frame, dt_s)
    }
    fn stop(&mut self, sequence: &[jointctl_config::StopStep], _: f64) -> Vec<jointctl_hal::StopStepReport> {
        self.stops.lock().unwrap().push(sequence.to_vec());
        Vec::new()
    }
}

/// Issue 37, finding 4: stop and shutdown wrote a hold and returned; nothing took the drives
/// through a stop sequence, and a panic of the runtime itself skipped even the hold. Pass: the
/// configured `safety.stop_sequence` goes to the HAL exactly once on every path: the loop's end
/// (here its cycles; a duration ends it the same way), a stop request (a signal or `cmd stop` set it), and a panic unwinding
/// through the loop; the default is `[quick_stop, pre_operational]`.
#[test]
fn the_stop_sequence_runs_once_on_every_path_that_ends_the_runtime() {
    let _alone = alone();
    use jointctl_config::StopStep;
    let run_with = |yaml_extra: &str, panic_at_write: Option<u64>, stop_first: bool| {
        let yaml = rig_yaml("stop-sequence", 100.0, "").replace("timing: {spin_us: 100}", &format!("timing: {{spin_us: 100}}\n{yaml_extra}"));
        let loaded = jointctl_config::parse_str(&yaml, "rig.yaml").unwrap();
        let stops = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let hal = StopRecorder { inner: jointctl_sim::SimHal::load(&loaded).unwrap(), stops: stops.clone(), panic_at_write, writes: 0 };
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut arm = jointctl_runtime::Arm::build(&loaded, &PluginLoader::new([]), Box::new(hal)).unwrap();
            arm.activate().unwrap();
            let stop = jointctl_runtime::signals::StopRequest::manual();
            if stop_first {
                stop.request();
            }
            let opts = RunOptions { cycles: Some(20), stop: Some(stop), ..Default::default() };
            jointctl_runtime::run(&mut arm, &Default::default(), None, &opts).unwrap();
        }));
        let stops = stops.lock().unwrap().clone();
        (outcome.is_ok(), stops)
    };
    let default = vec![StopStep::QuickStop, StopStep::PreOperational];
    assert_eq!(run_with("", None, false), (true, vec![default.clone()]), "the loop's end");
    assert_eq!(run_with("", None, true), (true, vec![default.clone()]), "a stop request");
    assert_eq!(run_with("", Some(10), false), (false, vec![default]), "a panic of the runtime");
    let configured = run_with("safety: {stop_sequence: [quick_stop, disable_voltage, pre_operational]}", None, false);
    assert_eq!(configured.1, vec![vec![StopStep::QuickStop, StopStep::DisableVoltage, StopStep::PreOperational]]);
}
