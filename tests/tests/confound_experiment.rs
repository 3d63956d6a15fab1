//! Confounds as a result (issue 32, item 4): when one record cannot tell two causes apart,
//! `identify` proposes an experiment (`experiment.yaml`), `sim record --experiment` runs it, and
//! identify on the new record names what the plant has.

use std::process::Command;

use jointctl_experiments::record::{RecordOptions, record};
use jointctl_runtime::PluginLoader;
use jointctl_tests::{jointctl, scratch};

fn config() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml")
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{cmd:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn causes(json: &serde_json::Value) -> Vec<String> {
    json["causes"].as_array().unwrap().iter().map(|c| c["effect"].as_str().unwrap().to_string()).collect()
}

#[test]
fn the_elbows_play_that_stands_for_its_curve_is_gone_after_the_proposed_experiment() {
    // docs/model-loop.md's walkthrough: the elbow's plant stiffens as a cubic (and is 3 % softer
    // than its observer's line near zero); on one 0.25 Hz sine identify names a 1.3 mrad dead
    // zone for it, a play the plant does not have.
    let work = scratch("confound-experiment");
    let first = work.join("q4.csv");
    run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(config()).args(["--joint", "q4", "--out"]).arg(&first).args(["--amplitude", "0.1", "--frequency", "0.25", "--duration", "80", "--rate", "200"]));
    let report = work.join("report");
    let json: serde_json::Value = serde_json::from_str(&run_ok(
        Command::new(jointctl()).args(["identify", "--data"]).arg(&first).arg("--config").arg(config()).args(["--joint", "q4", "--json", "--report"]).arg(&report),
    ))
    .unwrap();
    assert!(!json["confounded"].as_array().unwrap().is_empty(), "no confound reported: causes {:?}", causes(&json));
    let segments = json["experiment"]["segments"].as_array().unwrap();
    assert!(!segments.is_empty());
    // Never beyond what the arm already did: the recorded amplitude and peak rate.
    for s in segments {
        let (a, f) = (s["amplitude_rad"].as_f64().unwrap(), s["frequency_hz"].as_f64().unwrap());
        assert!(a <= 0.1 + 1e-9 && a * f <= 0.1 * 0.25 + 1e-9, "{s}");
    }
    let experiment = report.join("experiment.yaml");
    assert!(experiment.is_file(), "identify did not write {}", experiment.display());
    // The experiment on the same plant, and identify again.
    let second = work.join("q4-experiment.csv");
    run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(config()).args(["--joint", "q4", "--out"]).arg(&second).arg("--experiment").arg(&experiment).args(["--rate", "200"]));
    let json: serde_json::Value =
        serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&second).arg("--config").arg(config()).args(["--joint", "q4", "--json"]))).unwrap();
    // The play is gone: neither named nor confounded, and what is named explains the new record
    // to within three times its noise. (The cubic itself, 0.15 Nm at 0.1 rad, 1.4 % of the
    // torque, is not named: the hysteresis and the scale error take it.)
    let named = causes(&json);
    assert!(!named.iter().any(|c| c == "dead_zone" || c == "dropout"), "{named:?}");
    assert!(json["confounded"].as_array().unwrap().iter().all(|c| c["effect"] != "dead_zone" && c["alternative"] != "dead_zone"), "{}", json["confounded"]);
    let times_noise = json["unexplained"]["times_noise"].as_f64().unwrap();
    assert!(times_noise < 3.0, "held-out RMSE {times_noise} times the noise after the experiment: {named:?}");
}

#[test]
fn a_recordings_first_torque_is_a_reading_not_zero() {
    // Finding (issue 32, the experiment's sines recorded one after the other): the torque
    // sensor's reading from before the simulation started (the encoders' age back from t = 0)
    // read exactly 0.0 in the first 4 samples of every record, and identify dropped them as lost
    // frames. The plant's sensor has 0.01 Nm of noise: an exact zero is no reading of it.
    let loaded = jointctl_config::load(config()).unwrap();
    let opts = RecordOptions { joint: "q4".into(), amplitude_rad: 0.1, frequency_hz: 0.25, duration_s: 2.0, pivot_mm: None, angle_deg: 0.0, rate_hz: 200.0 };
    let samples = record(&loaded, &PluginLoader::new([]), &opts).unwrap();
    assert!(samples.len() > 390, "{} samples", samples.len());
    let zeros: Vec<f64> = samples.iter().filter(|s| s.torque == 0.0).map(|s| s.t).collect();
    assert!(zeros.is_empty(), "torque exactly 0.0 at t = {zeros:?}");
}

#[test]
fn a_bad_experiment_file_is_an_error_that_says_where() {
    let work = scratch("confound-experiment-bad");
    let cases = [
        ("segments:\n  - {amplitude_rad: 0.1, frequency_hz: 0.25}\n", "segments[0]: missing field `duration_s`"),
        ("segments:\n  - {amplitude_rad: 0.1, frequency_hz: -1, duration_s: 20}\n", "segments[0].frequency_hz: -1 must be in (0, 100] Hz"),
        ("segments: []\n", "segments: none to run"),
        ("segments:\n  - {amplitude_rad: .nan, frequency_hz: 1, duration_s: 20}\n", "segments[0].amplitude_rad: NaN must be in (0, pi] rad"),
    ];
    for (i, (yaml, expected)) in cases.iter().enumerate() {
        let file = work.join(format!("bad{i}.yaml"));
        std::fs::write(&file, yaml).unwrap();
        let out = Command::new(jointctl()).args(["sim", "record"]).arg(config()).args(["--joint", "q4", "--out"]).arg(work.join("x.csv")).arg("--experiment").arg(&file).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(&*file.display().to_string()) && err.contains(expected), "{yaml}: {err}");
    }
}
