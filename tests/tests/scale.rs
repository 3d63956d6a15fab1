//! Arms beyond the SHERPA arm's size: a generated arm of hundreds of DOFs runs its loop
//! allocation-free, and publishes every joint and device (the shared-memory samples are sized by
//! the arm).

use std::process::Command;

use jointctl_modes::Mode;
use jointctl_runtime::{ArmPublisher, ControlLoop, PluginLoader};
use jointctl_test_support::count_allocations;
use jointctl_test_support::generated_arm::{JointKind, arm_yaml};
use jointctl_tests::{arm_name, jointctl, scratch};

#[global_allocator]
static ALLOC: jointctl_test_support::CountingAlloc = jointctl_test_support::CountingAlloc;

fn build(yaml: &str) -> jointctl_runtime::Arm {
    let mut loaded = jointctl_config::parse_str(yaml, "generated.yaml").unwrap_or_else(|e| panic!("{e}"));
    // A plugin call preempted on a loaded machine outlasts its budget (half a 1 kHz period) now
    // and then, and over a million calls the stall guard then holds a joint: that is the guard
    // working (fault_injection tests it), not what these tests measure.
    loaded.config.timing.joint_stall_floor_us = 10_000_000;
    loaded.config.timing.joint_budget_strikes = u32::MAX;
    let mut loader = PluginLoader::new([]);
    loader.register_static(jointctl_plugin_rigid::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_elastic::plugin_descriptor()).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &loader).unwrap_or_else(|e| panic!("{e}"));
    arm.activate().unwrap();
    arm
}

#[test]
fn a_700_dof_arm_tracks_its_targets_and_its_cycle_allocates_nothing() {
    for kind in [JointKind::Rigid, JointKind::Elastic] {
        let mut arm = build(&arm_yaml(&arm_name("scale-700"), 700, kind, 1000.0));
        assert_eq!(arm.dof_names.len(), 700);
        for i in 0..700 {
            arm.set_mode(i, Mode::Position { target_rad: if i % 2 == 0 { 0.2 } else { -0.2 } });
        }
        let mut lp = ControlLoop::new(&mut arm, None, 0);
        let step = |lp: &mut ControlLoop| {
            let t = jointctl_runtime::timing::monotonic_ns();
            lp.step(t, t, None);
        };
        for _ in 0..1500 {
            step(&mut lp);
        }
        let ((), n) = count_allocations(|| {
            for _ in 0..200 {
                step(&mut lp);
            }
        });
        assert_eq!(n, 0, "{kind:?}: {n} allocations in 200 cycles of 700 DOFs");
        for i in [0, 1, 350, 699] {
            let q = lp.arm.states[i].position().unwrap_or(f64::NAN);
            let target = if i % 2 == 0 { 0.2 } else { -0.2 };
            assert!((q - target).abs() < 0.02, "{kind:?}: j{i} at {q} rad, target {target}");
        }
        assert!(lp.arm.slots.iter().all(|s| s.fault == 0), "{kind:?}: a joint faulted");
    }
}

#[test]
fn a_700_dof_arm_publishes_every_joint_and_device_and_its_cycle_still_allocates_nothing() {
    // The shared-memory samples were fixed at 16 DOFs and 32 devices: a bigger arm was refused
    // as a publisher. They are sized by the arm now.
    let mut arm = build(&arm_yaml(&arm_name("scale-pub-700"), 700, JointKind::Rigid, 1000.0));
    let (encoders, drives) = arm.raw_devices();
    assert_eq!((encoders.len(), drives.len()), (700, 700));
    let device_names: Vec<String> = arm.device_names().map(str::to_string).collect();
    let devices = device_names.len();
    let mut publisher = ArmPublisher::new(&arm, None).unwrap_or_else(|e| panic!("700 DOFs are published: {e}"));
    let node = jointctl_ipc::create_node(None, &format!("scale-pub-700-{}", std::process::id())).unwrap();
    let names = jointctl_ipc::ServiceNames::for_arm(&arm.name);
    let state = jointctl_ipc::joint_state_service(&node, &names.joint_state).unwrap().subscriber_builder().create().unwrap();
    let diagnostics = jointctl_ipc::diagnostics_service(&node, &names.diagnostics).unwrap().subscriber_builder().create().unwrap();
    let raw = jointctl_ipc::raw_service(&node, &names.raw).unwrap().subscriber_builder().create().unwrap();
    let latest = jointctl_ipc::LatestStateReader::open(&jointctl_ipc::IpcScope::domain(None), &arm.name).unwrap();
    let mut lp = ControlLoop::new(&mut arm, Some(&mut publisher), 0);
    let step = |lp: &mut ControlLoop| {
        let t = jointctl_runtime::timing::monotonic_ns();
        lp.step(t, t, None);
        // Paced, so that the publisher thread keeps up and no record is dropped.
        std::thread::sleep(std::time::Duration::from_millis(2));
    };
    for _ in 0..20 {
        step(&mut lp);
    }
    let ((), n) = count_allocations(|| {
        for _ in 0..20 {
            step(&mut lp);
        }
    });
    assert_eq!(n, 0, "{n} allocations in 20 published cycles of 700 DOFs");
    let (_, refused) = lp.finish();
    assert_eq!((refused, publisher.drops()), (0, 0), "every sample sent");
    let (mut states, mut last_state) = (0, None);
    while let Some(s) = state.receive().unwrap() {
        states += 1;
        last_state = Some(jointctl_ipc::ArmState::from(&s));
    }
    let s = last_state.expect("joint states");
    assert!(states >= 40, "{states} joint states for 40 cycles");
    assert_eq!(s.joints.len(), 700);
    assert_eq!(jointctl_ipc::decode_name(&s.joints[699].name), "j699");
    assert!(s.joints[699].position_rad.is_finite(), "the last joint is observed");
    let mut last_diag = None;
    while let Some(d) = diagnostics.receive().unwrap() {
        last_diag = Some(jointctl_ipc::Diagnostics::try_from(&d).unwrap());
    }
    let d = last_diag.expect("diagnostics");
    assert_eq!((d.joints.len(), d.devices.len()), (700, devices));
    assert_eq!(jointctl_ipc::decode_name(&d.devices[devices - 1].name), device_names[devices - 1]);
    let mut last_raw = None;
    while let Some(f) = raw.receive().unwrap() {
        last_raw = Some(jointctl_ipc::raw::RawFrame::try_from(&f).unwrap());
    }
    let f = last_raw.expect("raw frames");
    assert_eq!((f.encoders().len(), f.drives().len()), (700, 700));
    assert_eq!(f.encoders()[699].status, jointctl_ipc::raw::RawStatus::VALID);
    let seen = latest.latest().unwrap();
    assert_eq!((seen.joints.len(), seen.final_sample), (700, 1), "the blackboard's 44 pages");
    assert_eq!(jointctl_ipc::decode_name(&seen.joints[699].name), "j699");
}

#[test]
fn a_big_arm_runs_and_publishes_and_an_inspector_sees_all_its_joints() {
    // `check` warned and `run` refused such an arm (pointing to `--no-ipc`) while the samples
    // carried at most 16 DOFs.
    let arm = arm_name("scale-run");
    let yaml = scratch("scale-run").join("big.yaml");
    std::fs::write(&yaml, arm_yaml(&arm, 40, JointKind::Elastic, 200.0)).unwrap();
    let check = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
    let out = String::from_utf8_lossy(&check.stdout);
    assert!(check.status.success(), "{out}{}", String::from_utf8_lossy(&check.stderr));
    assert!(out.contains("40 joint(s)") && !out.contains("warning: arm"), "{out}");
    let mut run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--duration", "20"]).stderr(std::process::Stdio::piped()).spawn().unwrap();
    let echo = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "3", "--timeout", "15"]).output().unwrap();
    let diag = Command::new(jointctl()).args(["inspect", "diag", "--arm", &arm, "--json", "--timeout", "15"]).output().unwrap();
    let _ = Command::new(jointctl()).args(["cmd", "stop", "--arm", &arm]).output();
    let status = run.wait().unwrap();
    let out = String::from_utf8_lossy(&echo.stdout);
    assert!(echo.status.success(), "{out}{}", String::from_utf8_lossy(&echo.stderr));
    let last: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    assert_eq!(last["joints"].as_array().map(Vec::len), Some(40), "{last}");
    assert_eq!(last["joints"][39]["name"], "j39");
    let d: serde_json::Value = serde_json::from_slice(&diag.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&diag.stderr)));
    assert_eq!((d["joints"].as_array().map(Vec::len), d["devices"].as_array().map(Vec::len)), (Some(40), Some(80)), "{d}");
    assert!(status.success(), "the run stopped cleanly");
}

/// The scheduling policy, priority and allowed CPUs of thread `tid` of this process.
fn scheduling_of(tid: i32) -> (i32, i32, Vec<usize>) {
    // SAFETY: plain queries into valid, zeroed structs.
    unsafe {
        let policy = libc::sched_getscheduler(tid);
        let mut param: libc::sched_param = std::mem::zeroed();
        libc::sched_getparam(tid, &mut param);
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::sched_getaffinity(tid, std::mem::size_of::<libc::cpu_set_t>(), &mut set);
        let cpus = (0..libc::CPU_SETSIZE as usize).filter(|&c| libc::CPU_ISSET(c, &set)).collect();
        (policy, param.sched_priority, cpus)
    }
}

#[test]
fn the_publisher_thread_follows_the_loop_one_priority_below_on_its_cpu_and_logs_every_hop() {
    // Whether this machine grants SCHED_FIFO at the loop's priority (root, CAP_SYS_NICE or an
    // rtprio limit of 30): without it the runtime warns, the loop and its publisher stay
    // unprivileged, and only the pinning (which needs no privilege) is checked.
    let granted = std::thread::spawn(|| jointctl_runtime::timing::set_fifo(30).is_ok()).join().unwrap();
    let arm_name = arm_name("sched-follow");
    let mut loaded = jointctl_config::parse_str(&arm_yaml(&arm_name, 2, JointKind::Rigid, 1000.0), "generated.yaml").unwrap();
    // The last CPU this process may run on (a container may allow fewer than the machine has).
    let cpu = *scheduling_of(0).2.last().expect("at least one allowed CPU");
    (loaded.config.timing.realtime_priority, loaded.config.timing.cpu) = (Some(30), Some(cpu));
    let mut loader = PluginLoader::new([]);
    loader.register_static(jointctl_plugin_rigid::plugin_descriptor()).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &loader).unwrap();
    arm.activate().unwrap();
    let scope = jointctl_ipc::IpcScope::domain(None);
    let mut publisher = ArmPublisher::with_hop_log(&arm, &scope, Default::default(), 1000).unwrap();
    let timing = loaded.config.timing.clone();
    let looping = std::thread::spawn(move || {
        let opts = jointctl_runtime::RunOptions { cycles: Some(600), duration_s: None, timing_samples: 0, stop: None };
        jointctl_runtime::run(&mut arm, &timing, Some(&mut publisher), &opts).unwrap();
        publisher
    });
    let thread_name = format!("{arm_name}-publisher");
    let task_of = |name: &str| {
        std::fs::read_dir("/proc/self/task").unwrap().flatten().find_map(|t| {
            let comm = std::fs::read_to_string(t.path().join("comm")).unwrap_or_default();
            (comm.trim() == name).then(|| t.file_name().to_string_lossy().parse::<i32>().unwrap())
        })
    };
    let publisher_tid = task_of(&thread_name[..15.min(thread_name.len())]).expect("the publisher thread");
    // The settings are applied as the loop starts: wait for them (at most the run's 0.6 s).
    let start = std::time::Instant::now();
    let mut seen = scheduling_of(publisher_tid);
    while seen.2 != vec![cpu] && start.elapsed() < std::time::Duration::from_millis(500) {
        std::thread::sleep(std::time::Duration::from_millis(10));
        seen = scheduling_of(publisher_tid);
    }
    let publisher = looping.join().unwrap();
    let (policy, priority, cpus) = seen;
    assert_eq!(cpus, vec![cpu], "the publisher thread pinned beside the loop");
    if granted {
        assert_eq!((policy, priority), (libc::SCHED_FIFO, 29), "the publisher thread one below the loop");
    } else {
        assert_eq!(policy, libc::SCHED_OTHER, "refused: the publisher thread stays unprivileged");
    }
    let hops = publisher.hops();
    // A record the publisher thread could not take in time is dropped and counted, never waited for.
    assert_eq!(hops.len() as u64 + publisher.drops(), 600, "one hop per cycle (not the final sample, outside any cycle)");
    for h in hops {
        let order = [h.read_ns, h.readings_ns, h.done_ns, h.handed_ns, h.taken_ns, h.sent_ns];
        assert!(order.windows(2).all(|w| w[0] <= w[1]), "hops out of order in cycle {}: {order:?}", h.cycle);
    }
}
