//! The command channel end to end: `jointctl cmd` in a second process, the runtime's answer,
//! and the published state changing accordingly; torque tracking on the SHERPA config.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use jointctl_ipc::JointMode;
use jointctl_modes::{Mode, Reference, Waveform};
use jointctl_runtime::commands::ArmCommand;
use jointctl_tests::{Edit, arm_name, jointctl, sherpa_with, stop};

fn sherpa_copy(test: &str) -> (String, std::path::PathBuf) {
    let arm = arm_name(test);
    let path = sherpa_with(test, &arm, &[]);
    (arm, path)
}

fn cmd(arm: &str, args: &[&str]) -> (i32, String) {
    let out = Command::new(jointctl()).arg("cmd").args(args).args(["--arm", arm]).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out.status.code().unwrap_or(-1), text)
}

/// The latest published state of `arm`, read in this process.
struct Watch {
    _node: iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
    sub: iceoryx2::port::subscriber::Subscriber<iceoryx2::prelude::ipc::Service, [jointctl_ipc::JointSample], jointctl_ipc::ArmStateHeader>,
}

impl Watch {
    fn new(arm: &str) -> Self {
        let node = jointctl_ipc::create_node(None, &format!("test-watch-{}", std::process::id())).unwrap();
        let t = Instant::now();
        loop {
            let names = jointctl_ipc::ServiceNames::for_arm(arm);
            if let Ok(s) = jointctl_ipc::joint_state_service(&node, &names.joint_state) {
                let sub = s.subscriber_builder().create().unwrap();
                let w = Watch { _node: node, sub };
                // The first sample means the runtime is up, its command service included.
                w.latest();
                return w;
            }
            assert!(t.elapsed() < Duration::from_secs(10), "arm never came up");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn latest(&self) -> jointctl_ipc::ArmState {
        let t = Instant::now();
        let mut last = None;
        loop {
            while let Some(s) = self.sub.receive().unwrap() {
                last = Some(jointctl_ipc::ArmState::from(&s));
            }
            if let Some(s) = last {
                return s;
            }
            assert!(t.elapsed() < Duration::from_secs(10), "no state");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn wait_for(&self, what: &str, mut ok: impl FnMut(&jointctl_ipc::ArmState) -> bool) -> jointctl_ipc::ArmState {
        let t = Instant::now();
        loop {
            let s = self.latest();
            if ok(&s) {
                return s;
            }
            assert!(t.elapsed() < Duration::from_secs(8), "timed out waiting for {what}: {:?}", s.joints()[..3].iter().map(|j| (j.position_rad, j.mode)).collect::<Vec<_>>());
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn start(path: &std::path::Path) -> Child {
    Command::new(jointctl()).arg("run").arg(path).args(["--duration", "30"]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap()
}

#[test]
fn commands_from_another_process_are_acknowledged_and_change_the_published_state() {
    let (arm, path) = sherpa_copy("cmd-e2e");
    let mut run = start(&path);
    let watch = Watch::new(&arm);

    let (code, text) = cmd(&arm, &["position", "q1", "0.4"]);
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("accepted: q1: position"), "{text}");
    watch.wait_for("q1 at 0.4", |s| s.joints[0].mode == JointMode::POSITION && (s.joints[0].position_rad - 0.4).abs() < 0.01);

    // Refusals change nothing and say why.
    let (code, text) = cmd(&arm, &["position", "q1", "7"]);
    assert_eq!(code, 1);
    assert!(text.contains("outside q1's limits"), "{text}");
    let (code, text) = cmd(&arm, &["torque", "q2", "--step", "inf"]);
    assert_eq!(code, 2, "refused where it is typed: {text}");
    assert!(text.contains("--step") && text.contains("finite"), "{text}");
    let (code, text) = cmd(&arm, &["torque", "q2", "--step", "60"]);
    assert_eq!(code, 1);
    assert!(text.contains("beyond q2's torque limit 40 Nm"), "{text}");
    let (code, text) = cmd(&arm, &["position", "nope", "0"]);
    assert_eq!(code, 1);
    assert!(text.contains("joint `nope` does not exist"), "{text}");
    assert_eq!(watch.latest().joints[0].mode, JointMode::POSITION, "q1 still in position mode");

    // Torque mode on q2 (output clamped in the simulated arm, figure 5.1): a 3 Nm step.
    let (code, text) = cmd(&arm, &["torque", "q2", "--step", "3"]);
    assert_eq!(code, 0, "{text}");
    let s = watch.wait_for("q2 torque 3 Nm", |s| s.joints[1].mode == JointMode::TORQUE && (s.joints[1].torque_nm - 3.0).abs() < 0.05);
    assert_eq!(s.joints[1].reference_torque_nm, 3.0);

    // A requested stiffness moves the pivot; the observed stiffness follows.
    let (code, text) = cmd(&arm, &["stiffness", "q2", "200"]);
    assert_eq!(code, 0, "{text}");
    watch.wait_for("q2 stiffness 200", |s| (s.joints[1].stiffness_nm_per_rad - 200.0).abs() < 1.0);

    // Disable refuses modes until enable.
    assert_eq!(cmd(&arm, &["disable", "q4"]).0, 0);
    let (code, text) = cmd(&arm, &["position", "q4", "0.2"]);
    assert_eq!(code, 1);
    assert!(text.contains("disabled"), "{text}");
    watch.wait_for("q4 disabled", |s| s.joints[3].enabled == 0);
    assert_eq!(cmd(&arm, &["enable", "q4"]).0, 0);
    assert_eq!(cmd(&arm, &["position", "q4", "0.2"]).0, 0);

    // Hold all, then stop: the runtime ends by itself, cleanly.
    assert_eq!(cmd(&arm, &["hold"]).0, 0);
    watch.wait_for("all held", |s| s.joints().iter().all(|j| j.mode == JointMode::HOLD));
    assert_eq!(cmd(&arm, &["stop"]).0, 0);
    let t = Instant::now();
    let status = loop {
        if let Some(s) = run.try_wait().unwrap() {
            break s;
        }
        assert!(t.elapsed() < Duration::from_secs(5), "the runtime did not stop");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success());
    let (code, text) = cmd(&arm, &["hold"]);
    assert_eq!(code, 1);
    assert!(text.contains("no runtime is running"), "{text}");
}

/// Finding: commands that would never run were accepted (exit 0, "accepted", nothing
/// happened): torque on a rigid joint, stiffness on a non-VSA joint, `--delay NaN`; and
/// negative numbers needed `--step=-5`. Pass: each is refused with its reason (exit 1 from the
/// runtime, exit 2 from the argument parser), and `--step -5` is a step to -5 Nm.
#[test]
fn commands_that_would_never_run_are_refused_and_negative_numbers_parse() {
    let (arm, path) = sherpa_copy("cmd-capabilities");
    let mut run = start(&path);
    let _watch = Watch::new(&arm);
    for (args, code, wants) in [
        (&["torque", "q1", "--step", "1"][..], 1, "joint `q1` does not observe its torque (plugin `rigid`), so it cannot run torque control"),
        (&["impedance", "q3", "--k", "10", "--d", "1"][..], 1, "joint `q3` does not observe its torque (plugin `vsa_shoulder`), so it cannot run impedance control"),
        (&["stiffness", "q4", "50"][..], 1, "joint `q4` has no variable stiffness (plugin `elastic`)"),
        (&["stiffness", "q3", "50"][..], 1, "joint `q3` has no variable stiffness"),
        (&["torque", "q2", "--step", "1", "--delay", "NaN"][..], 2, "must be a finite number, got NaN"),
        (&["position", "q1", "nan"][..], 2, "must be a finite number"),
        (&["torque", "q2", "--step", "1", "--delay=-1"][..], 2, "must be in [0, 1e9] s, got -1"),
        // Issue 40, finding 7: negative values reached the argument parser's "unexpected
        // argument '-1'" instead of a reason.
        (&["torque", "q2", "--step", "1", "--delay", "-1"][..], 2, "must be in [0, 1e9] s, got -1"),
        (&["torque", "q2", "--sine", "5", "--freq", "-1"][..], 1, "frequency_hz must be >= 0, got -1"),
        (&["impedance", "q4", "--k", "-1", "--d", "1"][..], 1, "K and D must be >= 0, got K = -1"),
        (&["impedance", "q4", "--k", "1", "--d", "-1"][..], 1, "K and D must be >= 0, got K = 1, D = -1"),
        (&["stiffness", "q6", "-1"][..], 1, "the stiffness must be > 0 Nm/rad, got -1"),
        (&["--timeout", "-1", "hold", "q2"][..], 2, "must be in [0, 1e9] s, got -1"),
        // Issue 40, finding 7: a 1 GHz sine was accepted, a 1e308 Nm step refused with a
        // 309-digit number cut before the reason.
        (&["torque", "q2", "--sine", "5", "--freq", "1e9"][..], 1, "above the loop's Nyquist frequency"),
        (&["torque", "q2", "--step", "1e308"][..], 1, "the reference reaches 1.000e308 Nm, beyond q2's torque limit"),
        (&["torque", "q2", "--step", "1", "--delay", "1e5"][..], 1, "the start delay must be in [0, 86400] s, got 100000 s"),
        (&["torque", "q2", "--step", "1", "--delay", "1e300"][..], 2, "must be in [0, 1e9] s, got 1.000e300"),
        (&["torque", "q2", "--step", "-5"][..], 0, "accepted: q2: torque"),
        (&["torque", "q2", "--sine", "-2", "--freq", "0.5", "--offset", "-1"][..], 0, "accepted"),
        (&["stiffness", "q6", "2.5"][..], 0, "accepted"),
    ] {
        let (got, text) = cmd(&arm, args);
        assert_eq!(got, code, "{args:?}: {text}");
        assert!(text.contains(wants), "{args:?}: {text}");
    }
    stop(&mut run);
}

/// Finding: commands for a faulted joint were accepted. Pass: once joint `b` faults (fault code
/// 42 from its plugin at cycle 5), a position command for it is refused with the code; `a` still
/// takes commands.
#[test]
fn a_faulted_joint_refuses_commands() {
    let arm = arm_name("cmd-faulted");
    let dir = jointctl_tests::scratch("cmd-faulted");
    let path = dir.join("rig.yaml");
    let faulty = "  - name: b\n    plugin: faulty\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {fault_at: 5}\n";
    std::fs::write(&path, jointctl_tests::rig_yaml(&arm, 100.0, faulty)).unwrap();
    let mut run = start(&path);
    let watch = Watch::new(&arm);
    watch.wait_for("b faulted", |s| s.joints[1].fault_code == 42);
    let (code, text) = cmd(&arm, &["position", "b", "0.1"]);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("joint `b` is faulted (code 42: reported by its plugin)"), "{text}");
    // Issue 40, finding 17: `enable` on the faulted joint answered "accepted: b enabled" and
    // the joint stayed faulted.
    let (code, text) = cmd(&arm, &["enable", "b"]);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("faulted") && !text.contains("accepted"), "{text}");
    assert_eq!(cmd(&arm, &["position", "a", "0.1"]).0, 0);
    stop(&mut run);
}

#[test]
fn a_streamed_command_that_stops_arriving_falls_back_to_hold() {
    let (arm, path) = sherpa_copy("cmd-watchdog");
    let mut run = start(&path);
    let watch = Watch::new(&arm);
    let (code, text) = cmd(&arm, &["--stream", "torque", "q2", "--step", "2"]);
    assert_eq!(code, 0, "{text}");
    watch.wait_for("torque mode", |s| s.joints[1].mode == JointMode::TORQUE);
    // Not renewed: after the watchdog time (0.5 s, assumption) q2 holds again.
    watch.wait_for("hold after the watchdog", |s| s.joints[1].mode == JointMode::HOLD);
    stop(&mut run);
}

#[test]
fn q2_observed_torque_follows_a_0_1_hz_sine() {
    // In-process and faster than real time: the SHERPA config, 40 Hz, 20 s of a 5 Nm sine.
    let (_, path) = sherpa_copy("sine");
    let loaded = jointctl_config::load(&path).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &jointctl_runtime::PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    let reference = Reference { waveform: Waveform::Sine, amplitude: 5.0, frequency_hz: 0.1, offset: 0.0, start_s: 0.0 };
    arm.observe(0.0);
    arm.apply(ArmCommand::Mode { dof: 1, mode: Mode::Torque { reference }, streamed: false });
    let mut sq = 0.0;
    let mut n = 0;
    for i in 1..=800 {
        let t = i as f64 / 40.0;
        arm.step(t);
        if t >= 1.0 {
            let e = arm.states[1].torque().unwrap() - reference.value(t);
            sq += e * e;
            n += 1;
        }
    }
    let rmse = (sq / n as f64).sqrt();
    // NRMSE (RMSE / amplitude) below 2 %: the simulated plant is the observer's own model.
    assert!(rmse / 5.0 < 0.02, "NRMSE {}", rmse / 5.0);
    assert_eq!(arm.controllers[1].events.torque_clamps, 0);
}

#[test]
fn transmission_round_trips_joint_to_motor_to_joint_for_every_plugin() {
    // Manual set-points without the feedback PI (`manual_position_feedback: false`; the thesis
    // has it on by default) go through each plugin's transmission to the motors;
    // the simulated encoders (configured from eq. 3.1, 3.3, 3.7/3.8 in the YAML) read them back
    // and the observers must return the commanded joint positions (to one encoder count): rigid q1, the shoulder
    // differential's q3, elbow q4 (ratio 2), q5, and the wrist's q6/q7 through the bevel and
    // planetary ratios. (q2's output is clamped in this configuration.)
    let no_pi = || serde_yaml::from_str::<serde_yaml::Value>("{manual_position_feedback: false}").unwrap();
    let path = sherpa_with("round-trip", &arm_name("round-trip"), &[
        Edit::Set("joints[q1].controller", no_pi()),
        Edit::Set("joints[shoulder].dofs[q3].controller", no_pi()),
        Edit::Set("joints[q4].controller", no_pi()),
        Edit::Set("joints[q5].controller", no_pi()),
        Edit::Set("joints[wrist].dofs[q6].controller", no_pi()),
        Edit::Set("joints[wrist].dofs[q7].controller", no_pi()),
        // The kinematics alone: the wrist's plant is its own table, without friction or
        // hysteresis (which move the output off a position commanded without feedback).
        Edit::Set("joints[wrist].sim.element", serde_yaml::from_str("{kind: wrist_table}").unwrap()),
        Edit::Remove("joints[wrist].sim.effects"),
    ]);
    let loaded = jointctl_config::load(&path).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &jointctl_runtime::PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    let targets = [(0, 0.3), (2, -0.2), (3, 0.25), (4, -0.4), (5, 0.15), (6, -0.1)];
    for (dof, q) in targets {
        arm.set_mode(dof, Mode::Manual { target_rad: q });
    }
    for i in 0..400 {
        arm.step(i as f64 / 40.0);
    }
    // The simulated encoders are quantised to 14 bits like the robot's (2 pi / 16384 rad).
    let count = std::f64::consts::TAU / 16384.0;
    for (dof, q) in targets {
        let observed = arm.states[dof].position().unwrap();
        assert!((observed - q).abs() <= count, "{}: commanded {q}, observed {observed}", arm.dof_names[dof]);
    }
}

#[test]
fn a_reference_configured_in_yaml_runs_from_the_start() {
    let startup = serde_yaml::from_str("{torque: {waveform: cosine, amplitude: 3.0, frequency_hz: 0.2}}").unwrap();
    let path = sherpa_with("startup", &arm_name("startup"), &[Edit::Set("joints[shoulder].dofs[q2].controller.startup", startup)]);
    let loaded = jointctl_config::load(&path).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &jointctl_runtime::PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    for i in 0..=80 {
        arm.step(i as f64 / 40.0);
    }
    assert_eq!(arm.controllers[1].mode().name(), "torque");
    // At t = 2 s the cosine reference is 3 cos(2 pi 0.2 2) = -2.427 Nm.
    let reference = 3.0 * (2.0 * std::f64::consts::PI * 0.2 * 2.0).cos();
    assert!((arm.torque_references[1] - reference).abs() < 1e-9);
    assert!((arm.states[1].torque().unwrap() - reference).abs() < 0.3, "{:?}", arm.states[1]);
}
