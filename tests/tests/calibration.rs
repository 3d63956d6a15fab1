//! Calibrated zeros (issue 37, finding 5): the elastic plugin took the readings at activation as
//! zero deflection, so an arm that started loaded read 0 Nm while it carried its load.

use std::process::Command;

use jointctl_runtime::PluginLoader;
use jointctl_tests::{Edit, arm_name, jointctl, sherpa_with};

/// Every DOF's state in the first cycle of the simulated SHERPA arm with `edits`, or why it
/// did not activate.
fn states_at_activation(test: &str, edits: &[Edit]) -> Result<Vec<jointctl_api::JointState>, jointctl_runtime::ActivateError> {
    let loaded = jointctl_config::load(sherpa_with(test, &arm_name(test), edits)).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &PluginLoader::new([])).unwrap();
    arm.activate().map(|()| {
        arm.step(0.0);
        arm.states.clone()
    })
}

/// `jointctl calibrate` on the simulated SHERPA arm (under a name of its own: each runtime of an
/// arm takes its lock), as parsed YAML.
fn calibrated(test: &str) -> serde_yaml::Value {
    let config = sherpa_with(test, &arm_name(test), &[]);
    let out = Command::new(jointctl()).arg("calibrate").arg(&config).args(["--cycles", "20"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_yaml::from_slice(&out.stdout).unwrap()
}

/// Pass: `jointctl calibrate` writes each elastic joint's zero (q4, q5) in a file of this format;
/// q4 given a zero whose motor side is 0.01 rad from where the drive starts reads that
/// deflection (eq. 3.1's 2:1, 0.02 rad, 2.3 Nm on the fitted line) at activation, where
/// without a zero it read 0; a zero 0.5 rad off puts the deflection outside the spring's range
/// (the characteristic's range_rad) and activation is refused naming it.
#[test]
fn a_calibrated_joint_reads_its_deflection_at_start_and_refuses_one_outside_its_range() {
    let written = calibrated("calibrate-elastic");
    assert_eq!(written["version"].as_u64(), Some(jointctl_config::FORMAT_VERSION));
    for joint in ["q4", "q5"] {
        assert!(written["joints"][joint]["zero"]["input_rad"].as_f64().is_some(), "{joint}: {written:?}");
    }
    let (input, output) = (written["joints"]["q4"]["zero"]["input_rad"].as_f64().unwrap(), written["joints"]["q4"]["zero"]["output_rad"].as_f64().unwrap());
    let q4_torque_at_start = |test: &str, zero: Option<&str>| -> Result<f64, jointctl_runtime::ActivateError> {
        let edits: Vec<Edit> = zero.map(|z| Edit::Set("joints[q4].params.zero", serde_yaml::from_str(z).unwrap())).into_iter().collect();
        states_at_activation(test, &edits).map(|s| s[3].torque().unwrap())
    };
    assert!(q4_torque_at_start("zero-none", None).unwrap().abs() < 1e-6);
    // The calibrated zero itself reads no torque; its motor side moved by -0.01 rad, 0.02 rad.
    assert!(q4_torque_at_start("zero-calibrated", Some(&format!("{{input_rad: {input}, output_rad: {output}}}"))).unwrap().abs() < 1e-6);
    let loaded_start = q4_torque_at_start("zero-offset", Some(&format!("{{input_rad: {}, output_rad: {output}}}", input - 0.01))).unwrap();
    println!("q4 at activation with the motor side 0.01 rad from its zero: {loaded_start:.3} Nm");
    assert!((loaded_start - 0.02 * 117.47).abs() < 0.1, "{loaded_start} Nm");
    let refused = q4_torque_at_start("zero-wrong", Some(&format!("{{input_rad: {}, output_rad: {output}}}", input - 0.5))).unwrap_err().to_string();
    assert!(refused.contains("the deflection at activation is 1.00000 rad with the calibrated zero, outside the spring's range"), "{refused}");
}

/// The same for the shoulder's q2 (its deflection encoder, section 3.4.1). Pass: `calibrate`
/// writes the shoulder's zero; a zero 0.01 rad below the encoder's reading at start makes q2 read
/// 0.01 rad of deflection at activation (0 without a zero); one 1 rad off, beyond the table's
/// range at every pivot setting, is refused naming it.
#[test]
fn a_calibrated_shoulder_reads_its_deflection_at_start_and_refuses_one_outside_its_table() {
    let written = calibrated("calibrate-shoulder");
    let zero = written["joints"]["shoulder"]["zero"]["deflection_rad"].as_f64().expect("the shoulder's zero");
    let q2_deflection_at_start = |test: &str, zero: Option<f64>| {
        let edits: Vec<Edit> = zero.map(|z| Edit::Set("joints[shoulder].params.zero", serde_yaml::from_str(&format!("{{deflection_rad: {z}}}")).unwrap())).into_iter().collect();
        states_at_activation(test, &edits).map(|s| s[1].deflection().unwrap())
    };
    assert!(q2_deflection_at_start("q2-zero-none", None).unwrap().abs() < 1e-6);
    let offset = q2_deflection_at_start("q2-zero-offset", Some(zero - 0.01)).unwrap();
    assert!((offset - 0.01).abs() < 1e-3, "{offset} rad");
    let refused = q2_deflection_at_start("q2-zero-wrong", Some(zero - 1.0)).unwrap_err().to_string();
    assert!(refused.contains("the q2 deflection at activation is 1.00000 rad with the calibrated zero, outside the table's range"), "{refused}");
}

/// The same for the wrist (its planet-carrier and bevel-input encoders, section 3.5.1). Pass:
/// `calibrate` writes the wrist's zero; that zero reads no deflection at activation; a bevel-a
/// zero 0.01 rad off reads a deflection on both DOFs (eq. 3.7 shares it); one 1 rad off is
/// refused naming the DOF.
#[test]
fn a_calibrated_wrist_reads_its_deflections_at_start_and_refuses_one_outside_its_table() {
    let written = calibrated("calibrate-wrist");
    let z = &written["joints"]["wrist"]["zero"];
    let (carrier, bevel): (Vec<f64>, Vec<f64>) = (serde_yaml::from_value(z["carrier_rad"].clone()).unwrap(), serde_yaml::from_value(z["bevel_rad"].clone()).unwrap());
    let deflections_at_start = |test: &str, bevel_a_offset: f64| -> Result<(f64, f64), jointctl_runtime::ActivateError> {
        let zero = format!("{{carrier_rad: [{}, {}], bevel_rad: [{}, {}]}}", carrier[0], carrier[1], bevel[0] + bevel_a_offset, bevel[1]);
        let edits = [Edit::Set("joints[wrist].params.zero", serde_yaml::from_str(&zero).unwrap())];
        states_at_activation(test, &edits).map(|s| (s[5].deflection().unwrap(), s[6].deflection().unwrap()))
    };
    let (d6, d7) = deflections_at_start("wrist-zero", 0.0).unwrap();
    assert!(d6.abs() < 1e-6 && d7.abs() < 1e-6, "{d6} {d7}");
    let (d6, d7) = deflections_at_start("wrist-zero-offset", -0.01).unwrap();
    println!("wrist at activation with bevel a 0.01 rad from its zero: q6 {d6:.5} rad, q7 {d7:.5} rad");
    assert!(d6.abs() > 1e-3 && d7.abs() > 1e-3, "{d6} {d7}");
    let refused = deflections_at_start("wrist-zero-wrong", -1.0).unwrap_err().to_string();
    assert!(refused.contains("deflection at activation is") && refused.contains("with the calibrated zero, outside the table's range"), "{refused}");
}
