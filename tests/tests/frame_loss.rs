//! Thesis appendix A in the simulated arm: lost CAN frames that read as zero must not reach the
//! observer. The elbow (q4) computes its deflection from the drive's position over CAN; a zero
//! taken as a value shows as a torque spike of about 113.78 Nm/rad x 0.5 rad = 57 Nm. The bound
//! is against the simulated torque sensor (the elbow's torque is real while its link
//! accelerates), sample by sample.

use jointctl_modes::Mode;
use jointctl_tests::{Edit, sherpa_with};

fn run(loss_rate: f64, mode: &str) -> (f64, f64, u64) {
    let test = format!("loss-{mode}-{loss_rate}");
    let arm = jointctl_tests::arm_name(&format!("loss-{mode}-{}pct", (loss_rate * 100.0).round()));
    let path = sherpa_with(&test, &arm, &[
        Edit::Set("hal.sim.can_loss_rate", loss_rate.into()),
        Edit::Set("hal.sim.can_loss_mode", mode.into()),
    ]);
    let loaded = jointctl_config::load(&path).unwrap();
    let sim = jointctl_sim::SharedSim::new(jointctl_sim::SimHal::new(&loaded.config).unwrap());
    let mut arm = jointctl_runtime::Arm::build(&loaded, &jointctl_runtime::PluginLoader::new([]), Box::new(sim.clone())).unwrap();
    arm.activate().unwrap();
    arm.set_mode(3, Mode::Position { target_rad: 0.5 });
    let mut worst_torque: f64 = 0.0;
    let mut settled = Vec::new();
    for i in 1..=2000 {
        // The sensor at the instant the observer reads (before this cycle's physics step).
        let (_, sensor) = sim.with(|s| s.joint_torque("q4").unwrap());
        arm.step(i as f64 / 40.0);
        if let Some(t) = arm.states[3].torque() {
            worst_torque = worst_torque.max((t - sensor).abs());
        }
        if i > 400 {
            settled.push(arm.states[3].position().unwrap_or(f64::NAN));
        }
    }
    let drift = settled.iter().map(|q| (q - 0.5).abs()).fold(0.0, f64::max);
    let mut health = vec![jointctl_hal::DeviceHealth::default(); 32];
    arm.device_health(&mut health);
    let elbow = arm.device_names().position(|n| n == "elmo_q4").unwrap();
    (worst_torque, drift, health[elbow].implausible + health[elbow].missing)
}

#[test]
fn five_percent_zeroed_frames_cause_no_torque_spike_and_no_motion() {
    let (torque, drift, rejected) = run(0.05, "zero");
    // Quantisation alone gives ~113.78 x 2 counts = 0.09 Nm; a zero taken as a value gives ~57 Nm.
    assert!(torque < 0.2, "largest |observed - sensor torque| {torque} Nm: a lost frame reached the observer");
    assert!(drift < 1e-3, "the held elbow moved {drift} rad");
    // About 5 % of 2000 frames were zeroed and every one rejected.
    assert!((50..=160).contains(&rejected), "{rejected} frames rejected");
}

#[test]
fn twenty_percent_lost_frames_hold_too() {
    let (torque, drift, rejected) = run(0.2, "missing");
    assert!(torque < 0.2 && drift < 1e-3, "torque {torque}, drift {drift}");
    assert!((300..=500).contains(&rejected), "{rejected}");
}
