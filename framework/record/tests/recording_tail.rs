//! A recording ends on a whole cycle: every joint state in the file has its cycle's raw readings
//! and diagnostics, even when they are published after the state (the runtime's order).

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use iceoryx2::port::update_connections::UpdateConnections as _;
use iceoryx2::service::port_factory::PortFactory as _;
use jointctl_ipc::raw::{RawDescriptor, RawFrame};
use jointctl_ipc::{ArmState, Diagnostics, IpcScope, PortLimits, ServiceNames};
use jointctl_record::recorder::{RecordOptions, record};

/// Finding: the recorder stopped as soon as a joint state reached the duration; that cycle's
/// raw readings, published after the state, were left out, and the elbow's motor position read
/// as lost in the file's last cycle (the recording test failed on a loaded machine). Here the
/// fake arm publishes each cycle's raw readings and diagnostics 20 ms after its state, so the
/// old recorder always lost the last cycle's.
#[test]
fn the_last_joint_state_comes_with_its_raw_readings_and_diagnostics() {
    // The default domain, an arm of this process's own: a domain of its own would leave its
    // management segment in /dev/shm.
    let scope = IpcScope::default();
    let arm = format!("tail_arm_{}", std::process::id());
    let arm = arm.as_str();
    let names = ServiceNames::for_arm(arm);
    let node = jointctl_ipc::create_node_in(&scope, "fake-arm").unwrap();
    let limits = PortLimits::default();
    let state = jointctl_ipc::create_joint_state_service(&node, &names.joint_state, limits).unwrap();
    let state_pub = state.publisher_builder().create().unwrap();
    let diag_pub = jointctl_ipc::create_diagnostics_service(&node, &names.diagnostics, limits).unwrap().publisher_builder().create().unwrap();
    let raw_pub = jointctl_ipc::create_raw_service(&node, &names.raw, limits).unwrap().publisher_builder().create().unwrap();
    // Samples of no joints and no devices: empty payloads.
    let _commands = jointctl_ipc::create_commands_service(&node, &names.commands, limits).unwrap().publisher_builder().create().unwrap();
    let descriptor = jointctl_ipc::create_raw_descriptor_service(&node, &names.raw_descriptor, limits).unwrap();
    let descriptor_pub = descriptor.publisher_builder().create().unwrap();
    jointctl_ipc::wire::send_record(&descriptor_pub, &RawDescriptor::of(100.0, &[], &[], &[], None)).unwrap();

    let out = std::env::temp_dir().join(format!("jointctl-test-{}-tail.mcap", std::process::id()));
    let opts = RecordOptions { arm: arm.into(), scope: scope.clone(), out: out.clone(), duration_s: Some(0.1), timeout_s: 5.0, profile: Default::default() };
    let recorder = std::thread::spawn(move || record(&opts, &AtomicBool::new(false)));
    let started = std::time::Instant::now();
    // The recorder subscribes to the descriptor last; it reaches it from the service's history
    // once the publisher has seen the subscriber.
    while descriptor.dynamic_config().number_of_subscribers() == 0 {
        assert!(started.elapsed() < Duration::from_secs(10), "the recorder subscribed");
        std::thread::sleep(Duration::from_millis(2));
    }
    descriptor_pub.update_connections().unwrap();
    assert_eq!(state.dynamic_config().number_of_subscribers(), 1);
    std::thread::sleep(Duration::from_millis(50));
    // 10 ms cycles; the recorder's duration (0.1 s) is reached at cycle 10.
    for cycle in 0..20u64 {
        let stamp_ns = 1_000_000_000 + cycle * 10_000_000;
        let state = ArmState { cycle, stamp_ns, ..ArmState::EMPTY };
        jointctl_ipc::send_sliced(&state_pub, state.header(), state.joints()).unwrap();
        std::thread::sleep(Duration::from_millis(20));
        let (mut diagnostics, mut raw) = (Diagnostics::EMPTY, RawFrame::EMPTY);
        (diagnostics.cycle, diagnostics.stamp_ns, raw.cycle, raw.stamp_ns) = (cycle, stamp_ns, cycle, stamp_ns);
        jointctl_ipc::wire::send_record(&diag_pub, &diagnostics).unwrap();
        jointctl_ipc::wire::send_record(&raw_pub, &raw).unwrap();
        if recorder.is_finished() {
            break;
        }
    }
    let summary = recorder.join().unwrap().unwrap();
    let (states, raws, diags) = (summary.messages["joint_state"], summary.messages["raw"], summary.messages["diagnostics"]);
    assert!(states >= 11, "{summary:?}");
    assert_eq!((raws, diags), (states, states), "every joint state's cycle has its raw readings and diagnostics: {summary:?}");
    let last_raw = jointctl_record::reader::raw_samples(&out).unwrap().last().map(|r| r.cycle);
    assert_eq!(last_raw, Some(10), "the recording ends with the cycle that reached its duration");
    assert_eq!(summary.lost(), 0, "{summary:?}");
    let _ = std::fs::remove_file(&out);
}
