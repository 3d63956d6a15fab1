//! The thesis' experiments on the simulated arm.

use jointctl_modes::Waveform;
use jointctl_experiments::record::{RecordOptions, record};
use jointctl_experiments::tracking::{Plan, Scenario, run};
use jointctl_runtime::PluginLoader;
use jointctl_tests::{Edit, arm_name, jointctl, scratch, sherpa_with};

fn sherpa() -> jointctl_config::LoadedConfig {
    jointctl_config::load(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml")).unwrap()
}

/// The thesis' characterisation end to end through the command line: `jointctl sim record` (the
/// output moved by a flow source, the drives holding), then `jointctl fit --order 1` (first-order
/// fit through zero, section 4.2); the stiffness is read from the YAML it writes.
fn characterise(joint: &str) -> f64 {
    let dir = scratch(&format!("characterise-{joint}"));
    let (csv, yaml) = (dir.join("rec.csv"), dir.join("fit.yaml"));
    let config = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let rec = std::process::Command::new(jointctl())
        .args(["sim", "record"])
        .arg(&config)
        .args(["--joint", joint, "--duration", "10", "--amplitude", "0.1", "--frequency", "0.2", "--out"])
        .arg(&csv)
        .output()
        .unwrap();
    assert!(rec.status.success(), "sim record: {}", String::from_utf8_lossy(&rec.stderr));
    let deflections = std::fs::read_to_string(&csv).unwrap().lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap()).fold(0.0, f64::max);
    assert!(deflections > 0.09, "the joint was deflected about 0.1 rad (largest {deflections})");
    let fit = std::process::Command::new(jointctl()).arg("fit").arg(&csv).args(["--order", "1", "--out"]).arg(&yaml).output().unwrap();
    assert!(fit.status.success(), "fit: {}", String::from_utf8_lossy(&fit.stderr));
    let written: serde_yaml::Value = serde_yaml::from_str(&std::fs::read_to_string(&yaml).unwrap()).unwrap();
    written["characteristic"]["curves"][0]["stiffness_nm_per_rad"].as_f64().expect("a fitted stiffness")
}

#[test]
fn recorded_characterisations_fit_back_to_the_configured_stiffness() {
    // Section 3.3.2: elbow 113.78 Nm/rad, wrist q5 70.0966 Nm/rad. The elbow's plant stiffens
    // (a cubic k3 delta^3): a line fitted to a sine of amplitude A takes k3 <x^4>/<x^2> =
    // 3/4 k3 A^2 of it. q5's compliance is its drive's proportional gain: moving the output also
    // moves the drive's own inertia (0.5 kg m^2 at the gearbox output, an assumption of the
    // simulated ELMO), which at the 0.2 Hz sweep takes J w^2 = 0.79 Nm/rad off what the sensor sees.
    let k3 = sherpa().config.joints[2].sim.as_ref().unwrap().effects.cubic_nm_per_rad3;
    assert!(k3 > 0.0, "the elbow's plant is not the observer's line");
    let drive_inertia = 0.5 * (std::f64::consts::TAU * 0.2f64).powi(2);
    for (joint, k) in [("q4", 113.78 + 0.75 * k3 * 0.1f64.powi(2)), ("q5", 70.0966 - drive_inertia)] {
        let fitted = characterise(joint);
        println!("{joint}: jointctl fit gives {fitted:.3} Nm/rad (configured {k})");
        assert!((fitted - k).abs() / k < 0.01, "{joint}: fitted {fitted} Nm/rad, configured {k}");
    }
}

#[test]
fn the_thesis_loop_degrades_above_0_2_hz_where_the_modern_loop_still_tracks() {
    let plan = Plan { stiffness_nm_per_rad: vec![89.0], references: vec![(Waveform::Sine, 0.2), (Waveform::Sine, 4.0)], periods: 2.0, ..Plan::default() };
    let thesis = run(&sherpa(), &PluginLoader::new([]), "q2", Scenario::Thesis, &plan, |_, _| {}).unwrap();
    let modern = run(&sherpa(), &PluginLoader::new([]), "q2", Scenario::Modern, &plan, |_, _| {}).unwrap();
    let (t02, t4) = (thesis[0].nrmse_observed, thesis[1].nrmse_sensor);
    let m4 = modern[1].nrmse_sensor;
    // Chapter 5: good at 0.1-0.2 Hz, poor above: at 4 Hz the 40 Hz loop with 15/30 ms
    // latencies is worse than no control at all (NRMSE > 1). At 0.2 Hz the loop follows the
    // torque its observer sees; the F/T sensor differs from that by the observer's offset
    // (sections 5.1, 6.1: a table fitted through the plant's hysteresis and friction band).
    assert!(t02 < 0.05, "thesis at 0.2 Hz: NRMSE of the observed torque {t02}");
    let gap = thesis[0].nrmse_observer_vs_sensor;
    assert!((0.02..0.3).contains(&gap), "thesis at 0.2 Hz: observer vs F/T sensor {gap}");
    assert!(t4 > 1.0, "thesis at 4 Hz: NRMSE {t4}");
    // The same hardware at 1 kHz with a direct bus still follows 4 Hz, if less well (the ELMO
    // profile's acceleration limit binds next).
    assert!(m4 < 0.8 && m4 < t4 / 2.0, "modern at 4 Hz: NRMSE {m4}");
    assert!(modern[1].phase_lag_deg.unwrap().abs() < 90.0 && thesis[1].phase_lag_deg.unwrap().abs() > 90.0);
}

/// The elbow's observer subtracts the drive's motor position (CAN, 30 ms old in the thesis'
/// scenario, section 2.3) from the output encoder's (SPI, 15 ms old). Subtracted as they came,
/// the observed torque at 1 Hz was 0.189 of the reference's range from the F/T sensor's; with the
/// motor's reading carried to the encoder's instant (`align_reading_ages`, the default) 0.111.
#[test]
fn the_elbows_observer_forms_its_deflection_from_readings_carried_to_one_instant() {
    let plan = Plan { references: vec![(Waveform::Sine, 1.0)], periods: 3.0, ..Plan::default() };
    let gap = |align: bool| {
        let name = format!("exp-align-{align}");
        let config = sherpa_with(&name, &arm_name(&name), &[Edit::Set("joints[q4].params.align_reading_ages", align.into())]);
        let loaded = jointctl_config::load(&config).unwrap();
        run(&loaded, &PluginLoader::new([]), "q4", Scenario::Thesis, &plan, |_, _| {}).unwrap()[0].nrmse_observer_vs_sensor
    };
    let (aligned, as_read) = (gap(true), gap(false));
    println!("q4, thesis' scenario, 1 Hz: observer vs F/T {as_read:.3} as read, {aligned:.3} aligned");
    assert!(aligned < 0.8 * as_read, "aligned {aligned} against {as_read} as read");
}

#[test]
fn the_experiment_command_prints_the_documented_json() {
    let dir = scratch("experiment-json");
    let cfg = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let out = std::process::Command::new(jointctl())
        .args(["experiment", "torque-tracking"])
        .arg(&cfg)
        .args(["--joint", "q2", "--scenario", "thesis", "--json", "--quick", "--stiffness", "89", "--report"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object on stdout");
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    for r in rows {
        let keys: Vec<&str> = r.as_object().unwrap().keys().map(String::as_str).collect();
        assert_eq!(keys, ["joint", "scenario", "reference", "frequency_hz", "pivot_mm", "amplitude_nm", "nrmse_observed", "nrmse_sensor", "nrmse_observer_vs_sensor", "offset_nm", "ripple_nm", "phase_lag_deg"]);
        // The observer-vs-sensor figures are the two torques' difference, not either's error.
        let (o, s) = (r["nrmse_observed"].as_f64().unwrap(), r["nrmse_sensor"].as_f64().unwrap());
        let gap = r["nrmse_observer_vs_sensor"].as_f64().unwrap();
        assert!(gap >= 0.0 && gap <= o + s + 1e-9, "{r}");
        assert!(r["offset_nm"].as_f64().is_some_and(f64::is_finite), "{r}");
        assert_eq!(r["joint"], "q2");
        assert_eq!(r["scenario"], "thesis");
        assert!(r["pivot_mm"].is_f64());
    }
    assert_eq!(rows[0]["reference"], "step");
    assert!(rows[0]["phase_lag_deg"].is_null());
    assert!(rows[1]["phase_lag_deg"].is_f64());
    // The report: table and one plot per run.
    assert!(dir.join("table.md").exists());
    let svgs = std::fs::read_dir(&dir).unwrap().filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "svg")).count();
    assert_eq!(svgs, 3);
}

/// The reference arm with the elbow's plant effects off: a bare 113.78 Nm/rad spring.
fn plain_elbow() -> jointctl_config::LoadedConfig {
    let mut loaded = sherpa();
    loaded.config.joints[2].sim.as_mut().unwrap().effects = Default::default();
    loaded
}

fn record_with(loaded: &jointctl_config::LoadedConfig, joint: &str, pivot_mm: Option<f64>, angle_deg: f64) -> Vec<jointctl_experiments::record::Sample> {
    let opts = RecordOptions { joint: joint.into(), amplitude_rad: 0.1, frequency_hz: 0.2, duration_s: 10.0, pivot_mm, angle_deg, rate_hz: 100.0 };
    record(loaded, &PluginLoader::new([]), &opts).unwrap()
}

/// Area enclosed by the torque-deflection loop over the last full period [Nm rad].
fn loop_area(samples: &[jointctl_experiments::record::Sample]) -> f64 {
    let last = &samples[samples.len() - 500..];
    last.windows(2).map(|w| 0.5 * (w[0].torque + w[1].torque) * (w[1].deflection - w[0].deflection)).sum::<f64>().abs()
}

#[test]
fn a_vsa_recording_reproduces_its_table_at_the_held_pivot() {
    let loaded = sherpa();
    let samples = record_with(&loaded, "q2", Some(20.0), 0.0);
    let spec: jointctl_models::characteristic::CharacteristicSpec =
        serde_json::from_value(loaded.config.joints[1].params.0["characteristic"].clone()).unwrap();
    let table = jointctl_models::characteristic::PivotCharacteristic::from_spec(&spec).unwrap();
    let mut gaps = Vec::new();
    for s in &samples[100..] {
        assert!((s.pivot_mm - 20.0).abs() < 0.01, "pivot held at 20 mm: {}", s.pivot_mm);
        gaps.push(s.torque - table.evaluate(20.0, s.deflection).torque_nm);
    }
    // The table was fitted through the middle of the plant's loop (section 3.3.2), so the
    // sensor scatters around it by the hysteresis and friction band (0.4 + 0.16 + 0.09 Nm in
    // the config) and the 12 Hz mode, with no systematic offset.
    let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let worst = gaps.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    assert!(mean.abs() < 0.05, "mean difference from the table {mean} Nm");
    assert!(worst < 1.5, "largest difference from the table {worst} Nm");
}

#[test]
fn hysteresis_and_dead_zone_in_the_plant_show_in_the_recording() {
    let base = plain_elbow();
    let plain = loop_area(&record_with(&base, "q4", None, 0.0));
    let mut with = base.clone();
    let sim = with.config.joints[2].sim.as_mut().unwrap();
    sim.effects.hysteresis = Some(jointctl_config::DahlConfig { sigma_nm_per_rad: 500.0, limit_nm: 1.5, shape: 1.0, presliding_damping_s: 0.0 });
    sim.effects.dead_zone_rad = 0.01;
    let samples = record_with(&with, "q4", None, 0.0);
    let area = loop_area(&samples);
    // Dahl hysteresis of 1.5 Nm over a +-0.1 rad sweep encloses about 4 x 1.5 x 0.1 = 0.6 Nm rad.
    assert!(plain < 0.05, "the plain elastic joint has no loop: {plain}");
    assert!(area > 0.3, "hysteresis loop area {area} Nm rad");
    // In the dead-zone, the elastic element carries no torque: only the hysteresis remains.
    let inside: Vec<f64> = samples[200..].iter().filter(|s| s.deflection.abs() < 0.005).map(|s| s.torque.abs()).collect();
    assert!(!inside.is_empty() && inside.iter().all(|t| *t <= 1.5 + 0.2), "{inside:?}");
}

/// Finding (issue 13: "find out where the +-10 ms delays on the simulated recordings come
/// from"): the recorder read the torque sensor after the cycle's control step, when the
/// simulation had advanced one period, so the torque led the deflection by 1 / rate (10 ms at
/// 100 Hz). Pass: on the plain elastic joint (a 113.78 Nm/rad spring, no plant effect), the
/// recorded torque is K x deflection to within the 14-bit quantisation, sample by sample: a
/// 10 ms shift at 0.2 Hz and 0.1 rad leaves up to 113.78 x 0.1 x 2 pi x 0.2 x 0.01 = 0.14 Nm.
///
/// Finding (issue 10, latency on the thesis' arm): with the reference config's SPI latency
/// (15 ms, section 2.3) the deflection the observer reads is 15 ms old while the torque sensor
/// was sampled now: a delay of 15 ms again. Pass: the recorder takes the sensor's reading from
/// when the encoders were read.
#[test]
fn the_recording_samples_torque_and_deflection_at_the_same_instant() {
    let elbow = plain_elbow();
    assert!(elbow.config.hal.sim.spi_latency_s >= 0.015, "the reference config reads its encoders late (section 2.3)");
    let samples = record_with(&elbow, "q4", None, 0.0);
    let count = std::f64::consts::TAU / 16384.0;
    let worst = samples[100..].iter().map(|s| (s.torque - 113.78 * s.deflection).abs()).fold(0.0, f64::max);
    assert!(worst < 113.78 * count * 1.5, "largest |torque - K deflection| {worst} Nm");
}

/// Issue 10, "what limited the thesis' arm": the sensitivity table's JSON and the findings
/// `docs/experiments/sensitivity.md` states for the middle setting: with the thesis' stated
/// latencies the loop is good to 1 Hz, not 0.2 Hz; the loop rate alone does not change the
/// bandwidth; four times the stated feedback latency, or a 100 ms filter on the observed torque,
/// brings "good" down to 0.2 Hz.
#[test]
fn the_sensitivity_table_finds_which_factor_reproduces_the_0_2_hz_limit() {
    let cfg = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let out = std::process::Command::new(jointctl()).args(["experiment", "sensitivity"]).arg(&cfg).args(["--joint", "q2", "--stiffness", "89.4", "--json"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let variants = v["variants"].as_array().unwrap();
    let keys: Vec<&str> = variants[0].as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(keys, ["factor", "value", "bandwidth_hz", "good_up_to_hz", "nrmse_sensor_at_0_2_hz", "nrmse_sensor_at_2_hz", "nrmse_observer_vs_sensor_at_0_2_hz"]);
    let find = |factor: &str, value: &str| variants.iter().find(|r| r["factor"] == factor && r["value"] == value).unwrap_or_else(|| panic!("no row {factor} = {value}"));
    let base = &variants[0];
    assert_eq!(base["factor"], "none (thesis scenario)");
    assert!(base["good_up_to_hz"].as_f64().unwrap() >= 1.0, "{base}");
    let fast = find("loop rate", "1000 Hz");
    assert_eq!(fast["bandwidth_hz"], base["bandwidth_hz"], "{fast}");
    let late = find("feedback latency (SPI)", "60 ms");
    assert!(late["good_up_to_hz"].as_f64().unwrap() <= 0.2, "{late}");
    // The observer's filtering (the shoulder plugin's torque low-pass) is a factor too.
    let filtered = find("observer filtering", "torque low-pass 100 ms");
    assert!(filtered["good_up_to_hz"].as_f64().unwrap() <= 0.2, "{filtered}");
}

/// Issue 10: the wrist had no experiment. Pass: `--joint wrist` runs q6 and q7 together (section
/// 5.2, figures 5.15-5.26), rows name their DOF, the thesis' step amplitudes hold at the low,
/// middle and high settings (1, 1.5, 2 Nm: figures 5.24, 5.20, 5.16), and a run of both DOFs
/// (two cosines) gives a row for each.
#[test]
fn the_wrist_experiment_runs_both_dofs_together_with_the_thesis_amplitudes() {
    let cfg = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let dir = scratch("wrist-experiment");
    let out = std::process::Command::new(jointctl())
        .args(["experiment", "torque-tracking"])
        .arg(&cfg)
        .args(["--joint", "wrist", "--quick", "--json", "--report"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    // Quick: two cosines (two rows), a step on q6, a 1 Hz sine on q7; at three settings.
    assert_eq!(rows.len(), 3 * 4, "{v}");
    let joints: Vec<&str> = rows[..4].iter().map(|r| r["joint"].as_str().unwrap()).collect();
    assert_eq!(joints, ["q6", "q7", "q6", "q7"]);
    assert_eq!((rows[0]["reference"].as_str(), rows[1]["reference"].as_str()), (Some("cosine"), Some("cosine")));
    // Each run's pivot is the same for both DOFs (one VSA), and differs between settings.
    assert_eq!(rows[0]["pivot_mm"], rows[1]["pivot_mm"]);
    assert_ne!(rows[0]["pivot_mm"], rows[4]["pivot_mm"]);
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("cosine (with q7 cosine 0.1 Hz)"), "{table}");
    // The steps' heights are the thesis', and the loop follows them.
    for (k, amplitude) in [(2usize, 1.0), (6, 1.5), (10, 2.0)] {
        assert_eq!(rows[k]["reference"], "step");
        assert_eq!(rows[k]["amplitude_nm"], amplitude, "{}", rows[k]);
        assert!(rows[k]["nrmse_observed"].as_f64().unwrap() < 0.5, "step of {amplitude} Nm: {}", rows[k]);
    }
}

/// The sensitivity table's 1 kHz rows came out different on a busy machine: the runtime's
/// wall-clock plugin budget (a real-time guard) faulted the joint in a simulated experiment,
/// where a cycle has no deadline. Pass: with a budget that every plugin call exceeds and one
/// strike allowed, the experiment's step still tracks, as it does on an idle machine.
#[test]
fn an_experiment_in_simulated_time_does_not_fault_a_joint_on_wall_clock_budgets() {
    let mut loaded = sherpa();
    loaded.config.timing.joint_budget_strikes = 1;
    let shoulder = loaded.config.joints.iter_mut().find(|j| j.name == "shoulder").unwrap();
    shoulder.budget_us = Some(0.001);
    let plan = Plan { stiffness_nm_per_rad: vec![89.4], references: vec![(Waveform::Step, 0.0)], ..Plan::default() };
    let rows = run(&loaded, &PluginLoader::new([]), "q2", Scenario::Modern, &plan, |_, _| {}).unwrap();
    assert!(rows[0].nrmse_sensor < 0.5, "the step was not followed (joint faulted?): sensor NRMSE {}", rows[0].nrmse_sensor);
}

/// `experiment torque-tracking` asked for what it cannot measure: a stiffness of 0 or NaN ran
/// at the default pivot, 5000 Nm/rad (q2 is configured for 25-320) at the stiffest end, with the
/// request nowhere in the output; q3, without an F/T sensor, printed NRMSE -0.000 and gain 0.00.
/// Each is now an error that says why, before anything runs.
#[test]
fn torque_tracking_refuses_settings_the_joint_cannot_take() {
    let config = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let report = scratch("tracking-refused");
    for (joint, stiffness, expected) in [
        ("q2", Some("0"), "--stiffness 0: a stiffness must be positive"),
        ("q2", Some("nan"), "must be a finite number"),
        ("q2", Some("5000"), "--stiffness 5000: `q2` is configured for 25-320 Nm/rad"),
        ("q3", None, "`q3` has no F/T sensor"),
    ] {
        let mut cmd = std::process::Command::new(jointctl());
        cmd.args(["experiment", "torque-tracking"]).arg(&config).args(["--joint", joint, "--quick", "--report"]).arg(&report);
        if let Some(k) = stiffness {
            cmd.arg(format!("--stiffness={k}"));
        }
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(expected), "{joint} {stiffness:?}: {err}");
    }
}

/// `sim characterise` on a joint it cannot characterise says why with the element the joint
/// has: the rigid q1 was told that "a `pivot_table` element is the observer's own table".
#[test]
fn characterising_a_rigid_joint_says_it_is_rigid() {
    let config = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let out = std::process::Command::new(jointctl()).args(["sim", "characterise"]).arg(&config).args(["--joint", "q1", "--out"]).arg(scratch("characterise-rigid").join("q1.csv")).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(1) && err.contains("`q1`: a characterisation needs") && err.contains("it is rigid") && !err.contains("pivot_table"), "{err}");
}
