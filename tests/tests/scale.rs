//! Arms beyond the SHERPA arm's size: a generated arm of hundreds of DOFs runs its loop
//! allocation-free; an arm bigger than the shared-memory samples is refused as a publisher with
//! the reason (never published with joints or devices left out) and runs without publishing.

use std::process::Command;

use jointctl_modes::Mode;
use jointctl_runtime::{ArmPublisher, ControlLoop, PluginLoader, RunError};
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
fn an_arm_bigger_than_the_shared_memory_samples_is_refused_as_a_publisher_with_the_reason() {
    let dofs = jointctl_api::MAX_ARM_DOF + 1;
    let arm = build(&arm_yaml(&arm_name("scale-17"), dofs, JointKind::Rigid, 1000.0));
    let e = ArmPublisher::new(&arm, None).err().expect("17 DOFs do not fit the samples");
    assert!(matches!(e, RunError::TooLargeToPublish { what: "DOFs", count: 17, max: 16, .. }), "{e:?}");
    assert!(e.to_string().contains("--no-ipc"), "{e}");
}

#[test]
fn an_arm_whose_devices_overflow_the_diagnostics_is_refused_as_a_publisher() {
    // 16 DOFs fit, and so do their 16 drives and 16 encoders; one force/torque sensor more makes
    // 33 devices, one more than a diagnostics sample carries: it was published without it.
    let yaml = arm_yaml(&arm_name("scale-devices"), jointctl_api::MAX_ARM_DOF, JointKind::Rigid, 1000.0)
        .replacen("joints:\n", "  force_torque:\n    - {name: ft0, range_nm: 40.0, sim: {dof: j0}}\njoints:\n", 1);
    let arm = build(&yaml);
    let e = ArmPublisher::new(&arm, None).err().expect("33 devices do not fit the diagnostics");
    assert!(matches!(e, RunError::TooLargeToPublish { count: 33, max: 32, .. }), "{e:?}");
    assert!(e.to_string().contains("devices"), "{e}");
}

#[test]
fn a_big_arm_is_checked_with_a_warning_refused_by_run_and_runs_without_publishing() {
    let arm = arm_name("scale-run");
    let yaml = scratch("scale-run").join("big.yaml");
    std::fs::write(&yaml, arm_yaml(&arm, 40, JointKind::Elastic, 200.0)).unwrap();
    let check = Command::new(jointctl()).arg("check").arg(&yaml).output().unwrap();
    let out = String::from_utf8_lossy(&check.stdout);
    assert!(check.status.success(), "{out}{}", String::from_utf8_lossy(&check.stderr));
    assert!(out.contains("40 joint(s)") && out.contains("warning: arm") && out.contains("has 40 DOFs"), "{out}");
    let run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "20"]).output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && err.contains("carry at most 16") && err.contains("--no-ipc"), "{err}");
    let run = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "20", "--no-ipc"]).output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success() && err.contains("20 cycles"), "{err}");
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
