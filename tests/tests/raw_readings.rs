//! Issue "record the live arm": the raw readings and set-points leave the loop. Pass: a
//! subscriber of `<arm>/raw` gets one frame per cycle with every device's reading exactly as the
//! HAL gave it (status and age included, a lost frame as missing with no value) and every
//! set-point written; `<arm>/raw_descriptor` names the devices, their kinds and units for a
//! late subscriber; `<arm>/commands` carries each accepted command, numbered.

use jointctl_ipc::raw::{DeviceKind, RawStatus};
use jointctl_ipc::{ServiceNames, decode_name};
use jointctl_runtime::timing::monotonic_ns;
use jointctl_runtime::{ArmPublisher, ControlLoop, PluginLoader};
use jointctl_tests::{Edit, arm_name, sherpa_with};

#[test]
fn every_reading_and_set_point_of_every_cycle_is_published_with_its_status() {
    let arm_id = arm_name("raw");
    // Appendix A's lost CAN frames (20 %, nothing arrives), so that missing readings show.
    let path = sherpa_with("raw", &arm_id, &[Edit::Set("hal.sim.can_loss_rate", 0.2.into())]);
    let loaded = jointctl_config::load(&path).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    let mut publisher = ArmPublisher::new(&arm, None).unwrap();
    let node = jointctl_ipc::create_node(None, "raw-readings-test").unwrap();
    let names = ServiceNames::for_arm(&arm_id);
    let raw = jointctl_ipc::raw_service(&node, &names.raw).unwrap().subscriber_builder().create().unwrap();
    arm.set_mode(0, jointctl_modes::Mode::Position { target_rad: 0.3 });
    let mut lp = ControlLoop::new(&mut arm, Some(&mut publisher), 0);
    let mut seen = Vec::new();
    for _ in 0..40 {
        let t = monotonic_ns();
        lp.step(t, t, None);
        let readings = lp.arm.last_readings().clone();
        seen.push((readings, lp.arm.last_setpoints().to_vec()));
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    // A subscriber that comes late still learns what the frames carry.
    let descriptor = jointctl_ipc::raw_descriptor_service(&node, &names.raw_descriptor).unwrap().subscriber_builder().create().unwrap();
    let mut kept = None;
    for _ in 0..100 {
        if let Some(sample) = descriptor.receive().unwrap() {
            kept = Some(jointctl_ipc::raw::RawDescriptor::try_from(&sample).unwrap());
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let (_, refused) = lp.finish();
    assert_eq!(refused, 0);

    let d = kept.expect("the descriptor is kept for late subscribers");
    assert_eq!((d.encoders.len(), d.drives.len()), (13, 9), "section 2.2: 13 encoders, 9 drives");
    assert_eq!(decode_name(&d.encoders[0].name), "enc_q1_out");
    assert_eq!(d.encoders[0].kind, DeviceKind::ABSOLUTE_ENCODER);
    assert_eq!(decode_name(&d.encoders[0].unit), "rad");
    assert_eq!(decode_name(&d.drives[8].name), "elmo_wrist_pivot");
    assert_eq!(d.drives[8].kind, DeviceKind::DRIVE);
    assert!(d.config_path().is_some_and(|p| p.is_absolute() && p.exists()), "{:?}", d.config_path());
    assert_eq!(d.rate_hz, 40.0);

    let mut frames = Vec::new();
    while let Some(sample) = raw.receive().unwrap() {
        frames.push(jointctl_ipc::raw::RawFrame::try_from(&sample).unwrap());
    }
    // The final frame is the shutdown's; the 40 cycles come first.
    assert!(frames.len() >= 40, "{} frames", frames.len());
    let (mut missing, mut moves) = (0, 0);
    for (k, f) in frames[..40].iter().enumerate() {
        assert_eq!(f.cycle, k as u64, "one frame per cycle, in order");
        let (readings, setpoints) = &seen[k];
        assert_eq!(f.encoders().len(), 13);
        for (got, had) in f.encoders().iter().zip(&readings.encoders) {
            assert_eq!(got.status.0, u32::from(had.status.0));
            assert!(got.value == had.value || (got.value.is_nan() && got.status != RawStatus::VALID && got.status != RawStatus::STALE));
        }
        for ((got, had), sp) in f.drives().iter().zip(&readings.drives).zip(setpoints) {
            assert_eq!(got.position_rad.status.0, u32::from(had.position_rad.status.0));
            match got.position_rad.status {
                RawStatus::VALID | RawStatus::STALE => assert_eq!((got.position_rad.value, got.position_rad.age_s), (had.position_rad.value, had.position_rad.age_s)),
                _ => {
                    assert!(got.position_rad.value.is_nan(), "a lost frame is not a value: {got:?}");
                    missing += 1;
                }
            }
            assert_eq!(got.action.0, u32::from(sp.action.0));
            if got.action == jointctl_ipc::raw::RawAction::MOVE {
                assert_eq!(got.setpoint_rad, sp.position_rad);
                moves += 1;
            }
        }
    }
    assert!(missing > 0, "20 % of the drives' frames were lost: some readings are missing");
    assert!(moves > 0, "q1 moves to 0.3 rad: its drive was sent set-points");
}

#[test]
fn accepted_commands_are_published_numbered_and_refused_ones_are_not() {
    let arm_id = arm_name("raw-commands");
    let path = sherpa_with("raw-commands", &arm_id, &[]);
    let loaded = jointctl_config::load(&path).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().unwrap();
    let mut publisher = ArmPublisher::new(&arm, None).unwrap();
    let node = jointctl_ipc::create_node(None, "raw-commands-test").unwrap();
    let names = ServiceNames::for_arm(&arm_id);
    let accepted = jointctl_ipc::commands_service(&node, &names.commands).unwrap().subscriber_builder().create().unwrap();
    let raw = jointctl_ipc::raw_service(&node, &names.raw).unwrap().subscriber_builder().create().unwrap();
    let state = jointctl_ipc::joint_state_service(&node, &names.joint_state).unwrap().subscriber_builder().create().unwrap();
    let client = jointctl_ipc::command_service(&node, &jointctl_ipc::command_service_name(&arm_id), None).unwrap().client_builder().create().unwrap();
    let mut lp = ControlLoop::new(&mut arm, Some(&mut publisher), 0);
    let mut answers = Vec::new();
    for request in [
        jointctl_ipc::CommandRequest::new(jointctl_ipc::CommandKind::POSITION, "q1", &[0.2]),
        jointctl_ipc::CommandRequest::new(jointctl_ipc::CommandKind::POSITION, "q9", &[0.2]),
        jointctl_ipc::CommandRequest::torque("q2", jointctl_ipc::TorqueWaveform::SINE, &[2.0, 0.1, 0.0, 0.0]),
    ] {
        let pending = client.send_copy(request).unwrap();
        let answer = loop {
            let t = monotonic_ns();
            lp.step(t, t, None);
            std::thread::sleep(std::time::Duration::from_millis(2));
            if let Some(r) = pending.receive().unwrap() {
                break *r.payload();
            }
        };
        answers.push(answer.accepted);
    }
    assert_eq!(answers, [1, 0, 1], "q9 does not exist");
    // The last one is applied at the next cycle.
    for _ in 0..3 {
        let t = monotonic_ns();
        lp.step(t, t, None);
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    std::thread::sleep(std::time::Duration::from_millis(20));
    let mut records = Vec::new();
    while let Some(sample) = accepted.receive().unwrap() {
        records.push(*sample.payload());
    }
    lp.finish();
    // Each frame says how many accepted commands the loop had applied by then: the cycle where
    // the count reaches 1 is the first with q1 in position mode (a replay applies them there;
    // the answer's stamp alone leaves a cycle's doubt).
    let mut frames = Vec::new();
    while let Some(f) = raw.receive().unwrap() {
        frames.push((f.user_header().cycle, f.user_header().commands_applied));
    }
    let mut modes = std::collections::HashMap::new();
    while let Some(st) = state.receive().unwrap() {
        modes.insert(st.user_header().cycle, st.payload()[0].mode);
    }
    assert!(frames.windows(2).all(|w| w[0].1 <= w[1].1), "{frames:?}");
    assert_eq!(frames.last().unwrap().1, 2, "two accepted commands applied");
    let first = frames.iter().find(|f| f.1 >= 1).unwrap().0;
    assert_eq!(modes[&first], jointctl_ipc::JointMode::POSITION);
    assert_ne!(modes[&(first - 1)], jointctl_ipc::JointMode::POSITION);
    let seen: Vec<(u64, &str, u32)> = records.iter().map(|r| (r.sequence, decode_name(&r.request.joint), r.request.kind.0)).collect();
    assert_eq!(seen, [(1, "q1", jointctl_ipc::CommandKind::POSITION.0), (2, "q2", jointctl_ipc::CommandKind::TORQUE.0)]);
    assert!(records.iter().all(|r| r.response.accepted == 1 && r.stamp_ns > 0));
    assert_eq!(records[1].request.waveform, jointctl_ipc::TorqueWaveform::SINE);
}
