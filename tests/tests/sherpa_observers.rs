//! The reference config's observers on synthetic raw readings: every joint's state checked
//! against values computed by hand from the thesis' equations and the configured parameters.

use jointctl_modes::Mode;
use std::sync::{Arc, Mutex};

use jointctl_api::{DriveReading, FieldMask, Reading};
use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, HalIoError, SensorFrame};
use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic, WristCharacteristic};
use jointctl_runtime::{Arm, PluginLoader};

/// A HAL whose readings the test sets by device name.
#[derive(Clone)]
struct ScriptedHal {
    frame: Arc<Mutex<SensorFrame>>,
    devices: DeviceIndex,
    written: Arc<Mutex<Vec<jointctl_api::MotorSetpoint>>>,
}

impl ScriptedHal {
    fn set_encoder(&self, name: &str, r: Reading) {
        let i = self.devices.encoder(name).unwrap_or_else(|| panic!("no encoder {name}"));
        self.frame.lock().unwrap().encoders[i] = r;
    }
    fn set_drive(&self, name: &str, rad: f64) {
        let i = self.devices.drive(name).unwrap();
        self.frame.lock().unwrap().drives[i] = DriveReading::new(Reading::valid(rad), Reading::valid(0.0), true, false);
    }
    fn written(&self, name: &str) -> jointctl_api::MotorSetpoint {
        self.written.lock().unwrap()[self.devices.drive(name).unwrap()]
    }
}

impl Hal for ScriptedHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        frame.clone_from(&self.frame.lock().unwrap());
        Ok(())
    }
    fn write(&mut self, frame: &ActuatorFrame, _: f64) -> Result<(), HalIoError> {
        *self.written.lock().unwrap() = frame.drives.clone();
        Ok(())
    }
}

fn sherpa() -> (Arm, ScriptedHal, jointctl_config::LoadedConfig) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    scripted(jointctl_config::load(&path).unwrap())
}

/// An arm of `loaded` on scripted readings, every one 0 at first.
fn scripted(loaded: jointctl_config::LoadedConfig) -> (Arm, ScriptedHal, jointctl_config::LoadedConfig) {
    let devices = DeviceIndex::of(&loaded.config);
    let mut frame = SensorFrame::new(&devices);
    frame.encoders.fill(Reading::valid(0.0));
    frame.drives.fill(DriveReading::new(Reading::valid(0.0), Reading::valid(0.0), true, false));
    let hal = ScriptedHal {
        frame: Arc::new(Mutex::new(frame)),
        written: Arc::new(Mutex::new(vec![Default::default(); devices.drives.len()])),
        devices,
    };
    // Loaded from the shared libraries, as `jointctl run` does.
    let arm = Arm::build(&loaded, &PluginLoader::new([]), Box::new(hal.clone())).unwrap();
    (arm, hal, loaded)
}

fn params_characteristic(loaded: &jointctl_config::LoadedConfig, joint: &str) -> CharacteristicSpec {
    let j = loaded.config.joints.iter().find(|j| j.name == joint).unwrap();
    serde_json::from_value(j.params.0["characteristic"].clone()).unwrap()
}

fn close(a: Option<f64>, b: f64, what: &str) {
    let a = a.unwrap_or_else(|| panic!("{what} is unknown"));
    assert!((a - b).abs() < 1e-9, "{what}: {a} vs {b}");
}

#[test]
fn every_joint_of_the_sherpa_config_is_observed_from_raw_readings() {
    let (mut arm, hal, loaded) = sherpa();
    arm.activate().unwrap(); // all readings 0: every origin 0
    assert_eq!(arm.dof_names, ["q1", "q2", "q3", "q4", "q5", "q6", "q7"]);

    hal.set_encoder("enc_q1_out", Reading::valid(0.3));
    // Shoulder: q2 output 0.2, deflection 0.03, pivot encoder 0.1 rad -> 22.5 + 10 * 0.1 = 23.5 mm;
    // pulleys 0.5 / 0.1 -> q3 = (0.5 - 0.1)/2 = 0.2 (eq. 3.3, assumed differential).
    hal.set_encoder("enc_q2_out", Reading::valid(0.2));
    hal.set_encoder("enc_q2_deflection", Reading::valid(0.03));
    hal.set_encoder("enc_shoulder_pivot", Reading::valid(0.1));
    hal.set_encoder("enc_shoulder_pulley_a", Reading::valid(0.5));
    hal.set_encoder("enc_shoulder_pulley_b", Reading::valid(0.1));
    // Elbow: output 0.25, motor 0.1 -> deflection 2 * 0.1 - 0.25 = -0.05 (eq. 3.2, motor side
    // minus output), times the first-order fit the elbow's params include (section 3.3.2).
    hal.set_encoder("enc_q4_out", Reading::valid(0.25));
    hal.set_drive("elmo_q4", 0.1);
    // Wrist q5: its compliance is its drive's P gain (section 3.3.2): the deflection is the
    // drive's following error, its set-point (0, where it was activated) minus the motor
    // position 0.08 -> -0.08 rad, 70.0966 * -0.08; the output encoder gives the position.
    hal.set_encoder("enc_q5_out", Reading::valid(0.1));
    hal.set_drive("elmo_q5", 0.08);
    // Wrist q6/q7: carrier a 0.4 -> expected bevel 0.4 * 20/80 * 0.75 = 0.075 (eq. 3.8); bevel a
    // measured 0.05 -> input deflection 0.025; drivetrain b at rest -> 0. Eq. 3.7: q6 deflection
    // (0.025 + 0)/2 = 0.0125, q7 deflection (0.025 - 0)/2 = 0.0125; positions (0.05 +- 0)/2.
    hal.set_encoder("enc_wrist_carrier_a", Reading::valid(0.4));
    hal.set_encoder("enc_wrist_bevel_a", Reading::valid(0.05));
    hal.set_encoder("enc_wrist_pivot", Reading::valid(-0.2)); // 25 - 10 * 0.2 = 23 mm
    arm.step(0.025);
    let s = &arm.states;

    close(s[0].position(), 0.3, "q1 position");
    close(s[0].deflection(), 0.0, "q1 deflection");
    assert_eq!(s[0].torque(), None, "a rigid joint's torque is unknown, not zero");
    close(s[0].stiffness(), 8.3e4, "q1 stiffness");

    let shoulder = PivotCharacteristic::from_spec(&params_characteristic(&loaded, "shoulder")).unwrap();
    let e = shoulder.evaluate(23.5, 0.03);
    close(s[1].position(), 0.2, "q2 position");
    close(s[1].deflection(), 0.03, "q2 deflection");
    close(s[1].pivot(), 23.5, "q2 pivot");
    close(s[1].torque(), e.torque_nm, "q2 torque");
    close(s[1].stiffness(), e.stiffness_nm_per_rad, "q2 stiffness");
    // Between the 20 and 25 mm settings (weight 0.7 on 25 mm): a sane shoulder torque.
    assert!(e.torque_nm > 1.0 && e.torque_nm < 10.0, "{e:?}");
    close(s[2].position(), 0.2, "q3 position");
    close(s[2].stiffness(), 8.3e4, "q3 stiffness");

    close(s[3].deflection(), -0.05, "q4 deflection");
    let elbow = PivotCharacteristic::from_spec(&params_characteristic(&loaded, "q4")).unwrap();
    close(s[3].torque(), elbow.evaluate(0.0, -0.05).torque_nm, "q4 torque");
    assert!((elbow.evaluate(0.0, -0.05).stiffness_nm_per_rad - 113.78).abs() < 10.0, "the elbow's fitted stiffness is near section 3.3.2's 113.78 Nm/rad");
    close(s[4].deflection(), -0.08, "q5 deflection");
    close(s[4].torque(), 70.0966 * -0.08, "q5 torque");

    let wrist = WristCharacteristic::from_spec(&params_characteristic(&loaded, "wrist")).unwrap();
    let w = wrist.evaluate(23.0, 0.0125, 0.0125);
    close(s[5].position(), 0.025, "q6 position");
    close(s[6].position(), 0.025, "q7 position");
    close(s[5].deflection(), 0.0125, "q6 deflection");
    close(s[6].deflection(), 0.0125, "q7 deflection");
    close(s[5].torque(), w.torque_q6_nm, "q6 torque");
    close(s[6].torque(), w.torque_q7_nm, "q7 torque");
    close(s[5].pivot(), 23.0, "q6 pivot");
    // Along the 45 deg diagonal both joints carry the same torque, with the sign of the deflection.
    assert!(w.torque_q6_nm > 0.0 && (w.torque_q6_nm - w.torque_q7_nm).abs() < 1e-12);
    for (i, st) in s.iter().enumerate() {
        assert!(!st.valid.has(FieldMask::CLAMPED), "joint {i} clamped");
    }
}

#[test]
fn a_lost_reading_makes_its_joint_unknown_and_held_and_a_pivot_beyond_range_is_flagged() {
    let (mut arm, hal, _) = sherpa();
    arm.activate().unwrap();
    for i in 0..7 {
        arm.set_mode(i, position(0.1));
    }
    // Appendix A: a lost frame. The elbow's motor reading is missing this cycle.
    hal.frame.lock().unwrap().drives[hal.devices.drive("elmo_q4").unwrap()] = DriveReading::default();
    // Shoulder pivot far beyond the characterised 0-45 mm.
    hal.set_encoder("enc_shoulder_pivot", Reading::valid(10.0));
    hal.set_encoder("enc_q2_deflection", Reading::valid(0.02));
    arm.step(0.025);
    let q4 = &arm.states[3];
    assert!(q4.position().is_some(), "the output encoder still gives the position");
    assert_eq!(q4.deflection(), None, "no deflection without the motor reading");
    assert_eq!(q4.torque(), None, "never a torque from a missing reading");
    // The shoulder: clamped to 45 mm and flagged, not extrapolated.
    let q2 = &arm.states[1];
    assert!(q2.valid.has(FieldMask::CLAMPED));
    assert!(q2.torque().is_some());
    // An unusable output encoder: the joint is held, not driven.
    hal.set_encoder("enc_q1_out", Reading::invalid());
    arm.step(0.05);
    assert_eq!(arm.states[0].position(), None);
    assert!(arm.slots[0].held);
    assert_eq!(arm.slots[0].invalid_cycles, 1);
    assert_eq!(hal.written("elmo_q1"), jointctl_api::MotorSetpoint::HOLD);
}

#[test]
fn position_commands_go_through_each_plugin_transmission() {
    let (mut arm, hal, _) = sherpa();
    arm.activate().unwrap();
    // Targets within one step of the set-point rate limit (2 rad/s x 25 ms), so the set-points
    // reach the plugins unchanged: q2 = 0.04, q3 = 0.02 -> a2 = q2 + q3, a3 = q2 - q3 (eq. 3.3
    // inverse); q6 = 0.03, q7 = 0 -> both bevel inputs 0.03 -> motors 0.03 / 0.1875 (eq. 3.7
    // inverse, eq. 3.8 ratio).
    arm.set_mode(1, position(0.04));
    arm.set_mode(2, position(0.02));
    arm.set_mode(5, position(0.03));
    arm.set_mode(6, position(0.0));
    arm.step(0.0);
    // The position PI (kp 0.2, ki 0.5, joints at 0) adds kp * e + ki * e * dt to each target.
    let with_pi = |q: f64| q + 0.2 * q + 0.5 * q * 0.025;
    let a2 = hal.written("elmo_shoulder_a").position_rad;
    let a3 = hal.written("elmo_shoulder_b").position_rad;
    let (q2t, q3t) = (with_pi(0.04), with_pi(0.02));
    assert!((a2 - (q2t + q3t)).abs() < 1e-12 && (a3 - (q2t - q3t)).abs() < 1e-12, "{a2} {a3}");
    let m_a = hal.written("elmo_wrist_a").position_rad;
    let m_b = hal.written("elmo_wrist_b").position_rad;
    let q6t = with_pi(0.03);
    assert!((m_a - q6t / 0.1875).abs() < 1e-9 && (m_b - q6t / 0.1875).abs() < 1e-9, "{m_a} {m_b}");
    assert_eq!(hal.written("elmo_shoulder_pivot"), jointctl_api::MotorSetpoint::HOLD);
}

#[test]
fn the_real_arms_assumed_tables_are_the_generators_output() {
    // The real arm's config (configs/sherpa_arm_socketcan.yaml) keeps the assumed tables until
    // measurements replace them; they must be reproducible from their generator (cargo run -p
    // jointctl-models --example assumed_tables -- shoulder|wrist). The simulated arm's tables
    // are fitted to characterisations of its plant (tests/tests/characterisation.rs).
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm_socketcan.yaml");
    let loaded = jointctl_config::load(&path).unwrap();
    assert_eq!(params_characteristic(&loaded, "shoulder"), jointctl_models::assumed::shoulder_spec());
    assert_eq!(params_characteristic(&loaded, "wrist"), jointctl_models::assumed::wrist_spec());
}

#[test]
fn an_elastic_joint_with_an_input_encoder_ignores_the_drive_reading() {
    // Section 3.4.1: deflection from absolute encoders only when the motor side has one.
    let yaml = jointctl_tests::rig_yaml("x", 100.0, "  - name: b\n    plugin: elastic\n    encoders: {output: e1, input: e2}\n    drives: {motor: m1}\n    params: {stiffness_nm_per_rad: 100.0, output_per_motor: 2.0, position_pi: {kp: 0, ki: 0}}\n");
    let loaded = jointctl_config::parse_str(&yaml, "rig.yaml").unwrap();
    let devices = DeviceIndex::of(&loaded.config);
    let mut frame = SensorFrame::new(&devices);
    frame.encoders.fill(Reading::valid(0.0));
    frame.drives.fill(DriveReading::new(Reading::valid(0.0), Reading::valid(0.0), true, false));
    let hal = ScriptedHal { frame: Arc::new(Mutex::new(frame)), written: Arc::new(Mutex::new(vec![Default::default(); 4])), devices };
    let mut arm = Arm::build(&loaded, &PluginLoader::new([]), Box::new(hal.clone())).unwrap();
    arm.activate().unwrap();
    hal.set_encoder("e1", Reading::valid(0.3));
    hal.set_encoder("e2", Reading::valid(0.1));
    // A lost CAN frame on the drive (appendix A) does not matter: the input encoder is used.
    hal.frame.lock().unwrap().drives[1] = DriveReading::default();
    arm.step(0.01);
    close(arm.states[1].deflection(), 2.0 * 0.1 - 0.3, "deflection from absolute encoders");
    close(arm.states[1].torque(), 100.0 * -0.1, "torque");
}


fn position(target_rad: f64) -> Mode {
    Mode::Position { target_rad }
}

/// Issue 10: eq. 3.3 as printed gives q2 and q3 the same row; the arm's differential is an
/// assumption that must be checked on the arm before torque control is trusted. Pass:
/// `jointctl check-transmission` finds the assumed differential on the reference arm (exit 0),
/// and on an arm wired as printed (q2 = (a2 - a3)/2) it names the actuator whose sign differs
/// (exit 1).
#[test]
fn check_transmission_tells_the_assumed_differential_from_the_printed_one() {
    // The reference arm under a name of this test's own: the check takes the arm's machine-wide
    // lock, and a `jointctl run` of `sherpa` elsewhere on the machine would refuse it.
    let reference = jointctl_tests::sherpa_with("reference-eq-3-3", &jointctl_tests::arm_name("reference-eq-3-3"), &[]);
    let ok = std::process::Command::new(jointctl_tests::jointctl()).arg("check-transmission").arg(&reference).output().unwrap();
    let table = String::from_utf8_lossy(&ok.stdout);
    assert_eq!(ok.status.code(), Some(0), "{table}{}", String::from_utf8_lossy(&ok.stderr));
    assert!(table.contains("| actuator_a | +0.0100 | +0.0100 | as assumed |"), "{table}");
    let printed: serde_yaml::Value = serde_yaml::from_str("[[0.5, -0.5], [0.5, -0.5]]").unwrap();
    let path = jointctl_tests::sherpa_with("printed-eq-3-3", &jointctl_tests::arm_name("printed-eq-3-3"), &[jointctl_tests::Edit::Set("joints[shoulder].sim.matrix", printed)]);
    let wrong = std::process::Command::new(jointctl_tests::jointctl()).arg("check-transmission").arg(&path).output().unwrap();
    let table = String::from_utf8_lossy(&wrong.stdout);
    assert_eq!(wrong.status.code(), Some(1), "{table}");
    assert!(table.contains("| actuator_b | +0.0100 | -0.0100 | OPPOSITE SIGN |"), "{table}");
    assert!(table.contains("| actuator_a | +0.0100 | +0.0100 | as assumed |"), "{table}");
}

/// Issue 40: `check-transmission` commands the shoulder's drives and took no lock, so it ran
/// beside a runtime of the same arm, both commanding the drives. Pass: while the arm's
/// machine-wide lock is held, the check is refused, naming the arm and the holder, before it
/// opens the hardware; once released, it runs.
#[test]
fn check_transmission_is_refused_while_the_arm_runs() {
    let arm = jointctl_tests::arm_name("transmission-lock");
    let path = jointctl_tests::sherpa_with("transmission-lock", &arm, &[]);
    let held = jointctl_runtime::lock::MachineLock::arm(&jointctl_runtime::lock::machine_lock_dir(), &arm).unwrap();
    let refused = std::process::Command::new(jointctl_tests::jointctl()).arg("check-transmission").arg(&path).output().unwrap();
    drop(held);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("arm `{arm}` is already running on this machine (process {})", std::process::id())), "{err}");
    assert!(!err.contains("every drive holds"), "the drives were never commanded: {err}");
    let alone = std::process::Command::new(jointctl_tests::jointctl()).arg("check-transmission").arg(&path).output().unwrap();
    assert_eq!(alone.status.code(), Some(0), "{}", String::from_utf8_lossy(&alone.stderr));
}

/// Issue 10: q5 has no compliant element (section 3.3.2: its compliance is the ELMO's
/// proportional gain), and the config modelled it as a 70.0966 Nm/rad spring. Pass: with a rigid
/// element and a P-only drive, a load held on the output shows as the drive's following error,
/// and the observer's torque matches the torque sensor once the drive has settled; while the
/// drive moves to a new set-point the observer says it does not know the torque (no value),
/// rather than calling motion load.
#[test]
fn q5_observes_its_torque_from_the_drives_following_error_and_says_when_it_cannot() {
    use jointctl_modes::Mode;
    let path = jointctl_tests::sherpa_with("q5-drive-gain", &jointctl_tests::arm_name("q5-drive-gain"), &[
        // A spring contact pushes the output: a steady load of 70 Nm/rad x 0.03 rad.
        jointctl_tests::Edit::Set("joints[q5].sim.environment", serde_yaml::from_str("{kind: spring, stiffness_nm_per_rad: 70.0, rest_rad: 0.03, inertia_kgm2: 0.02, damping_nms_per_rad: 0.5}").unwrap()),
    ]);
    let loaded = jointctl_config::load(&path).unwrap();
    let sim = jointctl_sim::SharedSim::new(jointctl_sim::SimHal::load(&loaded).unwrap());
    let mut arm = jointctl_runtime::Arm::build(&loaded, &jointctl_runtime::PluginLoader::new([]), Box::new(sim.clone())).unwrap();
    arm.activate().unwrap();
    let q5 = arm.dof_names.iter().position(|n| n == "q5").unwrap();
    let mut t = 0.0;
    for _ in 0..200 {
        t += 0.025;
        arm.step(t);
    }
    let observed = arm.states[q5].torque().expect("settled: the following error is the load");
    let sensor = sim.with(|s| s.joint_torque("q5").unwrap().1);
    assert!(sensor.abs() > 0.3, "the spring loads the output: {sensor} Nm");
    assert!((observed - sensor).abs() < 0.1 * sensor.abs() + 0.05, "observed {observed} Nm, sensor {sensor} Nm");
    // A new position set-point: while the drive moves, no torque is claimed.
    arm.set_mode(q5, Mode::Position { target_rad: 0.2 });
    let mut unknown = 0;
    for _ in 0..10 {
        t += 0.025;
        arm.step(t);
        unknown += usize::from(arm.states[q5].torque().is_none());
    }
    assert!(unknown >= 5, "torque claimed during the move in {} of 10 cycles", 10 - unknown);
}

/// Issue 10 ("the observer's filtering" as a factor): the shoulder's `torque_filter_s` low-passes
/// q2's observed torque, `alpha = 1 - exp(-dt / tau)` per cycle, from the first known torque.
#[test]
fn the_shoulder_torque_filter_is_a_first_order_low_pass() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let mut loaded = jointctl_config::load(&path).unwrap();
    let shoulder = loaded.config.joints.iter_mut().find(|j| j.name == "shoulder").unwrap();
    shoulder.params.0.as_object_mut().unwrap().insert("torque_filter_s".into(), 0.1.into());
    let (mut arm, hal, loaded) = scripted(loaded);
    arm.activate().unwrap();
    hal.set_encoder("enc_q2_deflection", Reading::valid(0.03));
    let table = PivotCharacteristic::from_spec(&params_characteristic(&loaded, "shoulder")).unwrap();
    let alpha = 1.0 - (-0.025f64 / 0.1).exp();
    arm.step(0.025);
    let first = arm.states[1].torque().unwrap();
    let target = table.evaluate(arm.states[1].pivot().unwrap(), 0.03).torque_nm;
    // The first known torque starts the filter (no lag behind an arbitrary zero)...
    assert!((first - target).abs() < 1e-9, "{first} vs {target}");
    // ... and a change then arrives at alpha a cycle.
    hal.set_encoder("enc_q2_deflection", Reading::valid(0.06));
    arm.step(0.05);
    let second = arm.states[1].torque().unwrap();
    let target2 = table.evaluate(arm.states[1].pivot().unwrap(), 0.06).torque_nm;
    assert!((second - (first + alpha * (target2 - first))).abs() < 1e-9, "{second} vs {}", first + alpha * (target2 - first));
    // A negative time constant is refused at creation, by name.
    let mut bad = jointctl_config::load(&path).unwrap();
    bad.config.joints.iter_mut().find(|j| j.name == "shoulder").unwrap().params.0.as_object_mut().unwrap().insert("torque_filter_s".into(), (-1.0).into());
    let err = match Arm::build(&bad, &PluginLoader::new([]), Box::new(jointctl_hal::NullHal)) {
        Ok(_) => panic!("a negative filter time was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("torque_filter_s"), "{err}");
}
