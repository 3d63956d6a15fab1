//! Confounds as a result (issue 32, item 4): when one record cannot tell two causes apart,
//! `identify` proposes an experiment (`experiment.yaml`), `sim record --experiment` runs it, and
//! identify on the new record names what the plant has.

use std::process::Command;

use jointctl_experiments::record::{RecordOptions, record};
use jointctl_runtime::PluginLoader;
use jointctl_tests::{jointctl, run_ok, scratch};

fn config() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml")
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

/// Finding (issue 32, item 4): eq. 3.5's arctan nearly straight over a slow record's rates and a
/// viscous friction in its place were reported as confounded with "no experiment is proposed
/// for them (the proposals stay within what the arm did)" (on the blind generator's seeds 1-16,
/// its devices of seeds 1-10 and the third generator's seeds 1-6, 27 hidden viscous frictions
/// were left so, the held-out part undecided). They part only where the arctan
/// saturates; the experiment now goes there, and the pair resolves both ways on the simulated
/// elbow: a viscous friction beside a small sharp arctan is named, a straight arctan of the
/// plant's own is left to the baseline.
#[test]
fn a_straight_arctan_against_a_viscous_friction_is_resolved_by_a_faster_experiment() {
    let plants = [
        ("visc", "viscous_nms_per_rad: 3.0, arctan_friction: {k_a_nm: 0.03, k_b_s_per_rad: 34.0}", Some(3.0)),
        ("atan", "arctan_friction: {k_a_nm: 0.5, k_b_s_per_rad: 10.0}", None),
    ];
    for (label, effects, viscous) in plants {
        let name = format!("cf-straight-{label}");
        let effects: serde_yaml::Value = serde_yaml::from_str(&format!("{{torque_noise_nm: 0.1, {effects}}}")).unwrap();
        let plant = jointctl_tests::sherpa_with(&format!("{name}-p"), &jointctl_tests::arm_name(&name), &[jointctl_tests::Edit::Set("joints[q4].sim.effects", effects)]);
        let work = scratch(&format!("{name}-w"));
        // 0.05 rad at 0.25 Hz: 0.079 rad/s at the peak, where an arctan of k_b = 10 s/rad is
        // still nearly a line.
        let first = work.join("first.csv");
        run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&first).args(["--amplitude", "0.05", "--frequency", "0.25", "--duration", "80", "--rate", "200"]));
        let report = work.join("report");
        let json: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&first).args(["--json", "--report"]).arg(&report))).unwrap();
        let pair = |json: &serde_json::Value| json["confounded"].as_array().unwrap().iter().any(|c| c["effect"] == "coulomb_friction" && c["alternative"] == "viscous_friction");
        assert!(pair(&json), "{label}: the pair is not reported: causes {:?}, confounds {}", causes(&json), json["confounded"]);
        let experiment = report.join("experiment.yaml");
        assert!(experiment.is_file(), "{label}: no experiment for the pair: {}", json["confounded"]);
        // Faster than the record, to where the arctan saturates (3 / k_b) and beyond.
        let peak = |s: &serde_json::Value| 2.0 * std::f64::consts::PI * s["amplitude_rad"].as_f64().unwrap() * s["frequency_hz"].as_f64().unwrap();
        let fastest = json["experiment"]["segments"].as_array().unwrap().iter().map(peak).fold(0.0, f64::max);
        assert!(fastest > 2.0 * 0.079, "{label}: the experiment's fastest segment peaks at {fastest} rad/s");
        let second = work.join("experiment.csv");
        run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&second).arg("--experiment").arg(&experiment).args(["--rate", "200"]));
        let again: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&second).arg("--json"))).unwrap();
        assert!(!pair(&again), "{label}: still confounded after the experiment: {}", again["confounded"]);
        let damping = again["causes"].as_array().unwrap().iter().find(|c| c["effect"] == "viscous_friction").map(|c| c["params"]["damping_nms_per_rad"].as_f64().unwrap());
        match (viscous, damping) {
            (Some(truth), Some(found)) => assert!((found / truth - 1.0).abs() < 0.25, "{label}: {found} Nm s/rad for {truth}"),
            (None, None) => {}
            _ => panic!("{label}: the plant's viscous friction {viscous:?}, named {damping:?}: causes {:?}", causes(&again)),
        }
        let _ = std::fs::remove_dir_all(&work);
    }
}

/// Finding (issue 32, item 4): against a config without eq. 3.5's friction (the elbow's line
/// alone), a small viscous friction on a noisy record was named with `coulomb_friction` reported
/// beside it as confounded, the arctan fitted in its place nearly straight (k_b = 1 / the peak
/// rate, 79 % of its tangent's line at the peak); the experiment proposed for a rate-driven pair
/// ran the same sine slower (0.25, 0.5, 1 times the frequency), where the two stay one line and
/// the viscous torque falls, and identify on it named nothing (the viscous friction significant
/// but negligible: a held-out gain of 3.8e-4 Nm^2 against 5.1e-4). Such a pair parts only where
/// the arctan saturates, as the baseline's nearly straight arctan does: the experiment now goes
/// faster, and the pair resolves both ways. (With the arctan at 0.15 Nm a time delay is named
/// instead, reported as confounded with both: on a linear spring over one sine, the torque
/// leading the encoder by `tau` is `k tau` times the rate, a third straight line; left so.)
#[test]
fn a_straight_arctan_named_as_a_cause_against_a_viscous_friction_is_resolved_by_a_faster_experiment() {
    let plants = [("visc", "viscous_nms_per_rad: 0.37", "viscous_friction", "coulomb_friction"), ("atan", "arctan_friction: {k_a_nm: 0.2, k_b_s_per_rad: 5.0}", "coulomb_friction", "viscous_friction")];
    for (label, effects, hidden, other) in plants {
        let name = format!("cf-cause-{label}");
        let arm = jointctl_tests::arm_name(&name);
        let edits = |effects: &str| {
            let effects: serde_yaml::Value = serde_yaml::from_str(&format!("{{torque_noise_nm: 0.1, {effects}}}")).unwrap();
            vec![
                jointctl_tests::Edit::Set("joints[q4].sim.effects", effects),
                jointctl_tests::Edit::Remove("joints[q4].params.include"),
                jointctl_tests::Edit::Set("joints[q4].params.stiffness_nm_per_rad", 113.78.into()),
            ]
        };
        let config = jointctl_tests::sherpa_with(&format!("{name}-c"), &arm, &edits(""));
        let plant = jointctl_tests::sherpa_with(&format!("{name}-p"), &arm, &edits(effects));
        let work = scratch(&format!("{name}-w"));
        let identify = |csv: &std::path::Path, report: Option<&std::path::Path>| -> serde_json::Value {
            let mut cmd = Command::new(jointctl());
            cmd.args(["identify", "--data"]).arg(csv).arg("--config").arg(&config).args(["--joint", "q4", "--json"]);
            if let Some(dir) = report {
                cmd.arg("--report").arg(dir);
            }
            serde_json::from_str(&run_ok(&mut cmd)).unwrap()
        };
        // model_loop.rs's characterisation: 0.0967 rad at 0.25 Hz, 0.152 rad/s at the peak.
        let first = work.join("first.csv");
        run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&first).args(["--amplitude", "0.0967", "--frequency", "0.25", "--duration", "80", "--rate", "200"]));
        let report = work.join("report");
        let json = identify(&first, Some(&report));
        let pair = |json: &serde_json::Value| json["confounded"].as_array().unwrap().iter().any(|c| [&c["effect"], &c["alternative"]].iter().all(|e| *e == hidden || *e == other));
        assert!(pair(&json), "{label}: the pair is not reported: causes {:?}, confounds {}", causes(&json), json["confounded"]);
        let peak = |s: &serde_json::Value| 2.0 * std::f64::consts::PI * s["amplitude_rad"].as_f64().unwrap() * s["frequency_hz"].as_f64().unwrap();
        let fastest = json["experiment"]["segments"].as_array().unwrap().iter().map(peak).fold(0.0, f64::max);
        assert!(fastest > 2.0 * 0.152, "{label}: the experiment's fastest segment peaks at {fastest} rad/s: {}", json["experiment"]);
        let second = work.join("experiment.csv");
        run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&second).arg("--experiment").arg(report.join("experiment.yaml")).args(["--rate", "200"]));
        let again = identify(&second, None);
        let named = causes(&again);
        assert!(named.iter().any(|c| c == hidden) && !named.iter().any(|c| c == other), "{label}: named {named:?} after the experiment, confounds {}", again["confounded"]);
        let _ = std::fs::remove_dir_all(&work);
    }
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
        ("segments:\n  - {amplitude_rad: 0.1, frequency_hz: -1, duration_s: 20}\n", "segments[0].frequency_hz: -1 must be in [0.001, 100] Hz"),
        ("segments:\n  - {amplitude_rad: 0.1, frequency_hz: 0.0001, duration_s: 20}\n", "segments[0].frequency_hz: 0.0001 must be in [0.001, 100] Hz"),
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
    // A 2.5 MB CSV given by mistake: serde_yaml quoted all of it, and so did the error.
    let csv = work.join("not-an-experiment.csv");
    std::fs::write(&csv, format!("t,deflection,torque\n{}", "0.001000,0.0000000,0.06019\n".repeat(100_000))).unwrap();
    let out = Command::new(jointctl()).args(["sim", "record"]).arg(config()).args(["--joint", "q4", "--out"]).arg(work.join("x.csv")).arg("--experiment").arg(&csv).output().unwrap();
    assert!(out.status.code() == Some(1) && out.stderr.len() < 3000, "{} bytes of error", out.stderr.len());
}

/// `sim record`'s own options, checked as an experiment file's segments are: a duration of
/// `inf` or 1e300 panicked (a capacity overflow), a rate of NaN panicked in the drives' profile,
/// 1e9 aborted on a 960 GB allocation, 0 never ended; a zero duration, a NaN direction or an
/// amplitude beyond the joint's travel wrote a header and no sample with exit 0, a pivot beyond
/// the shoulder's travel recorded where the travel ends (47.7 mm for 1000), a 1 MHz sine at
/// 100 Hz its alias. Each is now an error naming the option, and no file is written.
#[test]
fn sim_record_refuses_options_it_cannot_record() {
    let work = scratch("sim-record-options");
    let cases: [(&[&str], &str); 10] = [
        (&["--duration", "inf"], "--duration"),
        (&["--duration", "1e300"], "--duration: 1.000e300 must be in (0, 86400] s"),
        (&["--duration", "0"], "--duration: 0 must be in (0, 86400] s"),
        (&["--rate", "nan"], "--rate"),
        (&["--rate", "1e9"], "--rate: 1.000e9 must be in [1, 10000] Hz"),
        (&["--rate", "0"], "--rate: 0 must be in [1, 10000] Hz"),
        (&["--angle-deg", "nan"], "--angle-deg"),
        (&["--amplitude", "100"], "--amplitude: 100 must be in (0, pi] rad"),
        (&["--frequency", "60"], "--frequency: 60 Hz is not below half the sample rate (--rate 100 Hz)"),
        (&["--joint", "q2", "--pivot-mm", "1000", "--duration", "1"], "--pivot-mm 1000: the pivot settled at"),
    ];
    for (i, (args, expected)) in cases.iter().enumerate() {
        let out_file = work.join(format!("x{i}.csv"));
        let joint = if args.contains(&"--joint") { &[][..] } else { &["--joint", "q4"][..] };
        let out = Command::new(jointctl()).args(["sim", "record"]).arg(config()).args(joint).args(*args).arg("--out").arg(&out_file).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(if expected.contains(':') { 1 } else { 2 }), "{args:?}: {err}");
        assert!(err.contains(expected) && !err.contains("panicked"), "{args:?}: {err}");
        assert!(!out_file.exists(), "{args:?}: a file was written");
    }
}

/// The proposed experiment run on a running arm (issue 32, item 4: a file that `cmd` and
/// `record` run on the arm, not only `sim record`): `cmd experiment` turns each segment into a
/// torque sine of the joint's published stiffness times its deflection amplitude, for whole
/// periods from rest, with a second at zero torque after each; on the simulated arm's clamped
/// shoulder (q2) the recording holds those commands and the deflections they asked for.
#[test]
fn an_experiment_file_runs_on_the_running_arm_in_torque_control() {
    use jointctl_tests::{Running, arm_name, sherpa_with};
    use std::process::Stdio;
    let test = "experiment-on-arm";
    let arm = arm_name(test);
    let config = sherpa_with(test, &arm, &[]);
    let work = scratch(&format!("{test}-out"));
    let file = work.join("experiment.yaml");
    std::fs::write(&file, "segments:\n  - {amplitude_rad: 0.01, frequency_hz: 0.5, duration_s: 3.5}\n  - {amplitude_rad: 0.02, frequency_hz: 1.0, duration_s: 3.0}\n").unwrap();
    let _run = Running(Command::new(jointctl()).arg("run").arg(&config).args(["--duration", "60"]).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap());
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the runtime is up: {}", String::from_utf8_lossy(&up.stderr));
    let experiment = |extra: &[&str]| Command::new(jointctl()).args(["cmd", "--arm", &arm, "experiment"]).args(extra).output().unwrap();
    let refused = experiment(&["q9", file.to_str().unwrap()]);
    assert!(!refused.status.success() && String::from_utf8_lossy(&refused.stderr).contains("has no joint `q9` (it has q1, q2"), "{}", String::from_utf8_lossy(&refused.stderr));
    let plan = experiment(&["q2", file.to_str().unwrap(), "--dry-run", "--stiffness", "100"]);
    assert!(plan.status.success() && String::from_utf8_lossy(&plan.stderr).contains("1: torque sine 1.0000 Nm at 0.5000 Hz for 4.00 s"), "whole periods: {}", String::from_utf8_lossy(&plan.stderr));
    // Each segment's peak rate, to check against the joint's before a run (2 pi x 0.01 rad x 0.5 Hz).
    assert!(String::from_utf8_lossy(&plan.stderr).contains("(deflection 0.01000 rad, peak rate 0.031 rad/s)"), "{}", String::from_utf8_lossy(&plan.stderr));

    let recording = work.join("r.mcap");
    let mut record = Running(Command::new(jointctl()).args(["record", "--arm", &arm, "--duration", "15", "--out"]).arg(&recording).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap());
    // The recorder subscribes before the first command (it says nothing when it has: a margin
    // that a loaded machine has kept in the recording tests).
    std::thread::sleep(std::time::Duration::from_millis(2000));
    let ran = experiment(&["q2", file.to_str().unwrap()]);
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    assert!(record.0.wait().unwrap().success());

    let commands = jointctl_record::reader::commands(&recording).unwrap();
    let sent: Vec<(String, Vec<f64>)> = commands.iter().map(|c| (c.request.waveform.name().to_string(), c.request.values[..2].to_vec())).collect();
    assert_eq!(sent.len(), 4, "{sent:?}");
    let q2 = jointctl_record::reader::joint_series(&recording, "q2").unwrap();
    let k = q2.stiffness_nm_per_rad[0];
    let expected = [("sine", 0.01 * k, 0.5), ("step", 0.0, 0.0), ("sine", 0.02 * k, 1.0), ("step", 0.0, 0.0)];
    for ((waveform, values), (w, a, f)) in sent.iter().zip(expected) {
        assert_eq!(waveform, w, "{sent:?}");
        assert!((values[0] - a).abs() < 1e-9 * k && values[1] == f, "{sent:?} for {k} Nm/rad");
    }
    // Each sine's run in the recording: its deflection's half range against the one asked for
    // (the published stiffness is the slope at rest; the shoulder's play and lever make it read
    // 1.2-1.3 times as much), and its length in whole periods.
    let mut runs: Vec<(f64, f64, f64, f64)> = Vec::new(); // (start s, end s, min, max deflection)
    for i in 0..q2.len() {
        let (t, r, d) = (q2.t_s[i], q2.reference_torque_nm[i], q2.deflection_rad[i]);
        if r.is_finite() && r != 0.0 {
            match runs.last_mut() {
                Some(run) if t - run.1 < 0.5 => *run = (run.0, t, run.2.min(d), run.3.max(d)),
                _ => runs.push((t, t, d, d)),
            }
        }
    }
    assert_eq!(runs.len(), 2, "{runs:?}");
    for ((start, end, lo, hi), (asked, seconds)) in runs.iter().zip([(0.01, 4.0), (0.02, 3.0)]) {
        let half = (hi - lo) / 2.0;
        assert!(half > 0.8 * asked && half < 1.6 * asked, "deflection half range {half} for {asked}: {runs:?}");
        // Whole periods (4 s, not the file's 3.5), give or take the loop's cycles (25 ms) and
        // the command's scheduling on a loaded machine.
        assert!((end - start - seconds).abs() < 0.35, "{} s for {seconds}: {runs:?}", end - start);
    }
}

/// `cmd experiment --position`: each segment a position sine of the joint about where it
/// stands, sent as trajectories; the recorded position follows each sine, and the joint ends
/// where it began.
#[test]
fn an_experiment_file_runs_on_the_running_arm_by_position() {
    use jointctl_tests::{Running, arm_name, sherpa_with};
    use std::process::Stdio;
    let test = "experiment-by-position";
    let arm = arm_name(test);
    let config = sherpa_with(test, &arm, &[]);
    let work = scratch(&format!("{test}-out"));
    let file = work.join("experiment.yaml");
    std::fs::write(&file, "segments:\n  - {amplitude_rad: 0.02, frequency_hz: 0.5, duration_s: 3.5}\n  - {amplitude_rad: 0.01, frequency_hz: 1.0, duration_s: 3.0}\n").unwrap();
    let plan = Command::new(jointctl()).args(["cmd", "--arm", &arm, "experiment", "q4"]).arg(&file).args(["--position", "--dry-run"]).output().unwrap();
    assert!(plan.status.success() && String::from_utf8_lossy(&plan.stderr).contains("1: position sine 0.02000 rad at 0.5000 Hz for 2 periods and a quarter, back in 1.00 s (5.50 s, 1 trajectory; peak rate 0.063 rad/s)"), "{}", String::from_utf8_lossy(&plan.stderr));
    // A day at 100 Hz would hold 69 million points: refused, with the segment and the bound.
    let long = work.join("long.yaml");
    std::fs::write(&long, "segments:\n  - {amplitude_rad: 0.01, frequency_hz: 1.0, duration_s: 20}\n  - {amplitude_rad: 0.01, frequency_hz: 100.0, duration_s: 86400}\n").unwrap();
    let refused = Command::new(jointctl()).args(["cmd", "--arm", &arm, "experiment", "q4"]).arg(&long).args(["--position", "--dry-run"]).output().unwrap();
    assert!(!refused.status.success() && String::from_utf8_lossy(&refused.stderr).contains("segments[1]: 8640000 periods; the position form runs at most 100000 a segment"), "{}", String::from_utf8_lossy(&refused.stderr));
    let both = Command::new(jointctl()).args(["cmd", "--arm", &arm, "experiment", "q4"]).arg(&file).args(["--position", "--stiffness", "100", "--dry-run"]).output().unwrap();
    assert!(!both.status.success() && String::from_utf8_lossy(&both.stderr).contains("cannot be used with"), "{}", String::from_utf8_lossy(&both.stderr));

    let _run = Running(Command::new(jointctl()).arg("run").arg(&config).args(["--duration", "60"]).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap());
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--json", "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the runtime is up: {}", String::from_utf8_lossy(&up.stderr));
    let recording = work.join("r.mcap");
    let mut record = Running(Command::new(jointctl()).args(["record", "--arm", &arm, "--duration", "19", "--out"]).arg(&recording).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap());
    std::thread::sleep(std::time::Duration::from_millis(2000));
    let ran = Command::new(jointctl()).args(["cmd", "--arm", &arm, "experiment", "q4"]).arg(&file).arg("--position").output().unwrap();
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    assert!(record.0.wait().unwrap().success());

    let commands = jointctl_record::reader::commands(&recording).unwrap();
    let trajectories: Vec<&jointctl_ipc::CommandRequest> = commands.iter().map(|c| &c.request).filter(|r| r.kind == jointctl_ipc::CommandKind::TRAJECTORY).collect();
    // 2 periods at 0.5 Hz and 3 at 1 Hz: 20 and 28 points, one trajectory each.
    assert_eq!(trajectories.iter().map(|r| r.point_count).collect::<Vec<_>>(), [20, 28]);
    let q4 = jointctl_record::reader::joint_series(&recording, "q4").unwrap();
    let first = (0..q4.len()).find(|&i| q4.mode[i] == "trajectory").expect("q4 followed the trajectories");
    let center = trajectories[0].points[0][1];
    assert!((q4.position_rad[first] - center).abs() < 2e-3, "it starts where it stood: {} for {center}", q4.position_rad[first]);
    // Each sine's amplitude in the recorded position: least squares on sin and cos of its
    // frequency over its whole periods (the phase left free: the tracking lag and when each
    // trajectory was applied), with the first segment's 5.5 s and the second's start after a
    // second held.
    let t0 = q4.t_s[first];
    for (start, seconds, f, asked) in [(0.0, 4.0, 0.5, 0.02), (6.6, 3.0, 1.0, 0.01)] {
        let omega = 2.0 * std::f64::consts::PI * f;
        let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in (first..q4.len()).filter(|&i| (q4.t_s[i] - t0 - start) >= 0.0 && q4.t_s[i] - t0 - start < seconds) {
            let (s, c, y) = ((omega * q4.t_s[i]).sin(), (omega * q4.t_s[i]).cos(), q4.position_rad[i] - center);
            (ss, sc, cc, ys, yc) = (ss + s * s, sc + s * c, cc + c * c, ys + y * s, yc + y * c);
        }
        let det = ss * cc - sc * sc;
        let (a, b) = ((ys * cc - yc * sc) / det, (yc * ss - ys * sc) / det);
        let amplitude = a.hypot(b);
        eprintln!("q4 at {f} Hz: {amplitude:.5} rad for {asked}");
        // The elbow's position loop passes a little more than it is asked at these frequencies
        // (1.05 and 1.12 times when this was written).
        assert!(amplitude > 0.8 * asked && amplitude < 1.3 * asked, "{amplitude} rad for a {asked} rad sine at {f} Hz");
    }
    let last = q4.position_rad[q4.len() - 1];
    eprintln!("q4 ends at {last:.5} rad, began at {center:.5}");
    assert!((last - center).abs() < 1e-3, "it ends where it began: {last} for {center}");
}
