//! The model loop on the wrist (section 3.5.2, issue 32): each DOF identified along its own axis
//! and extended alone, records along the diagonals identified against the table's torque along
//! them, and a record along both diagonals whose torque offsets are split between the DOFs and
//! written as their extension.

use std::path::Path;
use std::process::Command;

use jointctl_tests::{Edit, arm_name, identify_gain as gain, jointctl, run_ok, scratch, sherpa_with};
use serde_yaml::Value;

/// The wrist's plant made its own table (`wrist_table`) with the sensor's noise, and `q7`'s
/// effects (YAML mapping entries) in q7's own set (`effects_per_dof`).
fn wrist_edits(q7: &str) -> Vec<Edit<'static>> {
    vec![
        Edit::Set("joints[wrist].sim.effects", serde_yaml::from_str("{}").unwrap()),
        Edit::Set("joints[wrist].sim.effects_per_dof", serde_yaml::from_str(&format!("[{{torque_noise_nm: 0.005}}, {{torque_noise_nm: 0.005, {q7}}}]")).unwrap()),
        Edit::Set("joints[wrist].sim.element", serde_yaml::from_str("{kind: wrist_table}").unwrap()),
    ]
}

/// The wrist (section 3.5.2, issue 32): its plant is the observer's own table (`wrist_table`)
/// plus the sensor's noise, and a hidden Dahl hysteresis in q7 alone (`effects_per_dof`). Each
/// DOF recorded along itself (0 deg for q7, 90 deg for q6) is identified against the table's
/// torque of that DOF: q7's hysteresis is named with simulation and observer gains of at least
/// 50 %, its extension written for q7 alone (`model_extension: [q6, q7]`) and its plant terms into
/// q7's own effects; q6 gets no hysteresis. The extended configs pass `check`.
#[test]
fn the_wrist_with_a_hidden_hysteresis_in_one_dof_is_named_on_that_dof() {
    let name = "ml-wrist";
    let arm = arm_name(name);
    let hidden = "hysteresis: {sigma_nm_per_rad: 60.0, limit_nm: 0.25}";
    let config = sherpa_with(&format!("{name}-c"), &arm, &wrist_edits(""));
    let plant = sherpa_with(&format!("{name}-p"), &arm, &wrist_edits(hidden));
    let work = scratch(&format!("{name}-w"));
    for (dof, angle, index) in [("q7", "0", 1), ("q6", "90", 0)] {
        let csv = work.join(format!("{dof}.csv"));
        let mut record = Command::new(jointctl());
        record.args(["sim", "record"]).arg(&plant).args(["--joint", dof, "--angle-deg", angle, "--out"]).arg(&csv);
        record.args(["--amplitude", "0.1", "--frequency", "0.25", "--duration", "80", "--rate", "200", "--pivot-mm", "20"]);
        run_ok(&mut record);
        let out = work.join(format!("{dof}-ext"));
        let json: serde_json::Value = serde_json::from_str(&run_ok(
            Command::new(jointctl()).args(["identify", "--data"]).arg(&csv).arg("--config").arg(&config).args(["--joint", dof, "--json", "--out"]).arg(&out),
        ))
        .unwrap();
        let causes: Vec<&str> = json["causes"].as_array().unwrap().iter().map(|c| c["effect"].as_str().unwrap()).collect();
        println!("{name} {dof}: hidden in q7 {{{hidden}}}: named {causes:?}; gains {}; extension {}", json["gains"], json["extension"]);
        run_ok(Command::new(jointctl()).arg("check").arg(out.join("extended.yaml")));
        if dof == "q6" {
            assert!(!causes.contains(&"hysteresis"), "q6 has no hysteresis: {causes:?}");
            continue;
        }
        assert!(causes.contains(&"hysteresis"), "q7: hysteresis not named: {causes:?}");
        let (simulation, observer) = (gain(&json, "simulation"), gain(&json, "observer"));
        assert!(simulation >= 0.5 && observer >= 0.5, "q7: gains simulation {simulation:.2}, observer {observer:.2}");
        let list = json["extension"]["observer"].as_array().unwrap_or_else(|| panic!("the wrist's extension is a list per DOF: {}", json["extension"]));
        assert!(list[1 - index].is_null() && list[index]["hysteresis"].is_object(), "the extension is q7's alone: {list:?}");
        let extended = std::fs::read_to_string(out.join("extended.yaml")).unwrap();
        assert!(extended.contains("effects_per_dof"), "q7's plant terms go to its own effects");
        // q7 at a second setting after the first, in one file: identified per setting, its
        // plant terms by setting in q7's own sets, q6's as configured.
        let other = work.join("q7-30.csv");
        let mut record = Command::new(jointctl());
        record.args(["sim", "record"]).arg(&plant).args(["--joint", "q7", "--angle-deg", "0", "--out"]).arg(&other);
        record.args(["--amplitude", "0.1", "--frequency", "0.25", "--duration", "80", "--rate", "200", "--pivot-mm", "30"]);
        run_ok(&mut record);
        let both = work.join("q7-settings.csv");
        std::fs::write(&both, std::fs::read_to_string(&csv).unwrap() + std::fs::read_to_string(&other).unwrap().split_once('\n').unwrap().1).unwrap();
        let out = work.join("q7-settings-ext");
        let json: serde_json::Value = serde_json::from_str(&run_ok(
            Command::new(jointctl()).args(["identify", "--data"]).arg(&both).arg("--config").arg(&config).args(["--joint", "q7", "--json", "--out"]).arg(&out),
        ))
        .unwrap();
        run_ok(Command::new(jointctl()).arg("check").arg(out.join("extended.yaml")));
        let settings = json["settings"].as_array().unwrap_or_else(|| panic!("{json}"));
        for s in settings {
            let named: Vec<&str> = s["causes"].as_array().unwrap().iter().map(|c| c["effect"].as_str().unwrap()).collect();
            assert!(named.contains(&"hysteresis"), "q7 at {} mm: {named:?}", s["pivot_mm"]);
            assert!(gain(s, "simulation") >= 0.5 && gain(s, "observer") >= 0.5, "q7 at {} mm: gains {}", s["pivot_mm"], s["gains"]);
        }
        let plant_yaml: Value = serde_yaml::from_str(&std::fs::read_to_string(out.join("plant.yaml")).unwrap()).unwrap();
        let entries = plant_yaml.as_sequence().unwrap_or_else(|| panic!("{plant_yaml:?}"));
        assert_eq!(entries.len(), 2);
        for e in entries {
            let sets = e["effects_per_dof"].as_sequence().unwrap_or_else(|| panic!("{e:?}"));
            assert!(sets[0].get("hysteresis").is_none() && sets[1]["hysteresis"].is_mapping(), "q7's loop in q7's set alone: {e:?}");
        }
    }
}

/// Section 3.5.2's diagonal directions (issue 32): along 45 and 135 deg both wrist DOFs deflect
/// (q6 by sin, q7 by cos of the direction), and the baseline is the table's torque along that
/// direction. A Dahl loop in q7 alone (60 Nm/rad, 0.25 Nm) shows along either diagonal as a loop
/// of `cos(45 deg)` its limit (q7's torque projected) and `cos^2` its rest stiffness (q7 deflected
/// by the deflection times `cos` of the direction): named with that limit; the clean plant along 45 deg gets no
/// cause. A diagonal's causes belong to the pair: `--out` is refused with the reason, and a
/// record along the other DOF's axis names the DOF to identify from it.
#[test]
fn the_wrist_recorded_along_its_diagonals_is_identified_against_the_tables_torque_along_them() {
    let name = "ml-wrist-diag";
    let arm = arm_name(name);
    let config = sherpa_with(&format!("{name}-c"), &arm, &wrist_edits(""));
    let plant = sherpa_with(&format!("{name}-p"), &arm, &wrist_edits("hysteresis: {sigma_nm_per_rad: 60.0, limit_nm: 0.25}"));
    let work = scratch(&format!("{name}-w"));
    let record = |plant: &Path, angle: &str| {
        let label = if plant == config.as_path() { "clean" } else { "hidden" };
        let csv = work.join(format!("{label}-{angle}.csv"));
        let mut record = Command::new(jointctl());
        record.args(["sim", "record"]).arg(plant).args(["--joint", "q6", "--angle-deg", angle, "--out"]).arg(&csv);
        record.args(["--amplitude", "0.1", "--frequency", "0.25", "--duration", "80", "--rate", "200", "--pivot-mm", "20"]);
        run_ok(&mut record);
        csv
    };
    let identify = |csv: &Path| -> serde_json::Value {
        serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(csv).arg("--config").arg(&config).args(["--joint", "q6", "--json"]))).unwrap()
    };
    let expected_limit = 0.25 * std::f64::consts::FRAC_1_SQRT_2;
    // q7's extension, identified along its own axis, explains the diagonals in the observer.
    let out = work.join("q7-ext");
    run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(record(&plant, "0")).arg("--config").arg(&config).args(["--joint", "q7", "--out"]).arg(&out));
    for angle in ["45", "135"] {
        let csv = record(&plant, angle);
        let json = identify(&csv);
        let causes: Vec<&str> = json["causes"].as_array().unwrap().iter().map(|c| c["effect"].as_str().unwrap()).collect();
        println!("{name} along {angle} deg: named {causes:?}; {}", json["causes"]);
        assert_eq!(json["direction"]["angle_deg"].as_f64(), Some(angle.parse().unwrap()), "the report says the direction");
        let hysteresis = json["causes"].as_array().unwrap().iter().find(|c| c["effect"] == "hysteresis").unwrap_or_else(|| panic!("along {angle} deg: hysteresis not named: {causes:?}"));
        let limit = hysteresis["params"]["limit_nm"].as_f64().unwrap();
        let sigma = hysteresis["params"]["sigma_nm_per_rad"].as_f64().unwrap();
        assert!((limit / expected_limit - 1.0).abs() < 0.25, "along {angle} deg: limit {limit:.4} Nm, expected {expected_limit:.4}");
        assert!((sigma / 30.0 - 1.0).abs() < 0.25, "along {angle} deg: rest stiffness {sigma:.1} Nm/rad, expected 30 (60 cos^2 45 deg)");
        let extended: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&csv).arg("--config").arg(out.join("extended.yaml")).args(["--joint", "q6", "--json"]))).unwrap();
        let observer = &extended["direction"]["observer"];
        let (table, with) = (observer["rmse_table"].as_f64().unwrap(), observer["rmse_extended"].as_f64().unwrap());
        println!("{name} along {angle} deg: the observer with q7's extension from 0 deg: held-out {table:.4} -> {with:.4} Nm");
        assert!(with <= 0.5 * table, "along {angle} deg: q7's extension leaves {with:.4} of the table's {table:.4} Nm");
    }
    let clean = record(&config, "45");
    let json = identify(&clean);
    assert!(json["causes"].as_array().unwrap().is_empty(), "the clean wrist along 45 deg: {}", json["causes"]);
    let refused = Command::new(jointctl()).args(["identify", "--data"]).arg(&clean).arg("--config").arg(&config).args(["--joint", "q6", "--out"]).arg(work.join("x")).output().unwrap();
    let why = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && why.contains("per DOF"), "--out along a diagonal: {why}");
    let along_q7 = record(&config, "0");
    let refused = Command::new(jointctl()).args(["identify", "--data"]).arg(&along_q7).arg("--config").arg(&config).args(["--joint", "q6"]).output().unwrap();
    let why = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && why.contains("identify `q7`"), "a record along q7's axis given as q6: {why}");
}

/// Issue 32's wrist, the one cause a diagonal can give each DOF: a torque offset is even in the
/// deflection, so q6's `o6` and q7's `o7` read `(o6 + o7) / sqrt 2` along 45 deg and
/// `(o6 - o7) / sqrt 2` along 135 deg (`docs/model-loop.md`). One record along both (two `sim
/// record` runs, the second's time after the first's, as a rig logs one test after another) is
/// identified per direction and the offsets split; a record of two directions was refused. With
/// `--out` the offsets are the extension, each DOF's observer entry and simulated effects, with
/// gains of at least 50 % along the diagonals (`--out` was refused for such a record); they
/// replace offsets configured in either place, go into terms by pivot setting at each setting,
/// and leave a simulation that has them already as it is; configured, they explain the record
/// along each diagonal (`directions[].observer`, which a record along both did not give). The clean
/// plant: no offset, the report says why none is split, and `--out` says it has nothing to write.
#[test]
fn a_record_along_both_wrist_diagonals_splits_a_torque_offset_between_the_dofs() {
    let name = "ml-wrist-both";
    let arm = arm_name(name);
    let config = sherpa_with(&format!("{name}-c"), &arm, &wrist_edits(""));
    let edits = |q6: &str, q7: &str| {
        let mut e = wrist_edits("");
        e[1] = Edit::Set("joints[wrist].sim.effects_per_dof", serde_yaml::from_str(&format!("[{{torque_noise_nm: 0.005{q6}}}, {{torque_noise_nm: 0.005{q7}}}]")).unwrap());
        e
    };
    let plant = sherpa_with(&format!("{name}-p"), &arm, &edits(", torque_offset_nm: 0.3", ", torque_offset_nm: -0.2"));
    let work = scratch(&format!("{name}-w"));
    let both = |plant: &Path, label: &str| {
        let mut rows = Vec::new();
        for angle in ["45", "135"] {
            let csv = work.join(format!("{label}-{angle}.csv"));
            run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(plant).args(["--joint", "q6", "--angle-deg", angle, "--out"]).arg(&csv).args(["--amplitude", "0.1", "--frequency", "0.25", "--duration", "40", "--rate", "200", "--pivot-mm", "20"]));
            let text = std::fs::read_to_string(&csv).unwrap();
            let t0 = if rows.is_empty() { 0.0 } else { 40.0 };
            rows.extend(text.lines().skip(1).map(|l| {
                let (t, rest) = l.split_once(',').unwrap();
                format!("{},{rest}", t.parse::<f64>().unwrap() + t0)
            }));
        }
        let file = work.join(format!("{label}-both.csv"));
        std::fs::write(&file, format!("t,deflection,torque,pivot_mm,angle_deg,motor_position\n{}\n", rows.join("\n"))).unwrap();
        file
    };
    let identify = |file: &Path| -> serde_json::Value { serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(file).arg("--config").arg(&config).args(["--joint", "q7", "--json"]))).unwrap() };
    let file = both(&plant, "offsets");
    let json = identify(&file);
    println!("{name}: {}", json["offsets_per_dof"]);
    let angles: Vec<f64> = json["directions"].as_array().unwrap().iter().map(|d| d["angle_deg"].as_f64().unwrap()).collect();
    assert_eq!(angles, [45.0, 135.0]);
    for (dof, hidden) in [("q6", 0.3), ("q7", -0.2)] {
        let o = json["offsets_per_dof"][dof]["offset_nm"].as_f64().unwrap_or_else(|| panic!("no offset for {dof}: {}", json["offsets_per_dof"]));
        assert!((o - hidden).abs() < 0.01, "{dof}: offset {o:.4} Nm, hidden {hidden}");
    }
    // The offsets are the extension: each DOF's observer entry and simulated effects, both
    // gains measured along the diagonals on what identify held out.
    let out = work.join("offsets-ext");
    let written: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&file).arg("--config").arg(&config).args(["--joint", "q7", "--json", "--out"]).arg(&out))).unwrap();
    run_ok(Command::new(jointctl()).arg("check").arg(out.join("extended.yaml")));
    let observer: Value = serde_yaml::from_str(&std::fs::read_to_string(out.join("observer.yaml")).unwrap()).unwrap();
    let plant_yaml: Value = serde_yaml::from_str(&std::fs::read_to_string(out.join("plant.yaml")).unwrap()).unwrap();
    for (k, hidden) in [(0, 0.3), (1, -0.2)] {
        let o = observer["model_extension"][k]["torque_offset_nm"].as_f64().unwrap_or_else(|| panic!("DOF {k}'s observer offset: {observer:?}"));
        assert!((o - hidden).abs() < 0.01, "DOF {k}: observer offset {o:.4} Nm, hidden {hidden}");
        let p = plant_yaml[k]["torque_offset_nm"].as_f64().unwrap_or_else(|| panic!("DOF {k}'s simulated offset: {plant_yaml:?}"));
        assert!((p - hidden).abs() < 0.01, "DOF {k}: simulated offset {p:.4} Nm, hidden {hidden}");
    }
    let (simulation, observer) = (gain(&written, "simulation"), gain(&written, "observer"));
    println!("{name}: gains along the diagonals: simulation {simulation:.2}, observer {observer:.2}; {}", written["gains"]);
    assert!(simulation >= 0.5 && observer >= 0.5, "gains simulation {simulation:.2}, observer {observer:.2}");
    assert_eq!((written["extension"]["plant_dof"].as_str(), written["extension"]["plant_other_dofs"][0]["dof"].as_str()), (Some("q7"), Some("q6")), "{}", written["extension"]);
    // The written extension, configured, explains the record along each diagonal (the plugin's
    // own evaluation along the direction).
    let again: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&file).arg("--config").arg(out.join("extended.yaml")).args(["--joint", "q7", "--json"]))).unwrap();
    for d in again["directions"].as_array().unwrap() {
        let (table, with) = (d["observer"]["rmse_table"].as_f64().unwrap(), d["observer"]["rmse_extended"].as_f64().unwrap());
        println!("{name} along {} deg, the written extension configured: held-out {table:.4} -> {with:.4} Nm", d["angle_deg"]);
        assert!(with <= 0.5 * table, "along {} deg: {with:.4} of the table's {table:.4} Nm", d["angle_deg"]);
    }
    // From a review: against a config whose simulation has an offset on q6 already and whose q7
    // observer terms are by pivot setting, the offsets replace what is there (they are read
    // against the table alone): q6's simulated offset was written 0.1 Nm too large, and q7's
    // entry refused ("either flat or by_pivot").
    let mut edits = edits(", torque_offset_nm: 0.1", "");
    edits.push(Edit::Set("joints[wrist].params.model_extension", serde_yaml::from_str("[null, {by_pivot: [{pivot_mm: 10.0, terms: {torque_offset_nm: 0.05}}, {pivot_mm: 30.0, terms: {torque_offset_nm: 0.05}}]}]").unwrap()));
    let configured = sherpa_with(&format!("{name}-c2"), &arm, &edits);
    let out = work.join("offsets-ext-2");
    let json: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&file).arg("--config").arg(&configured).args(["--joint", "q7", "--json", "--out"]).arg(&out))).unwrap();
    run_ok(Command::new(jointctl()).arg("check").arg(out.join("extended.yaml")));
    let plant_yaml: Value = serde_yaml::from_str(&std::fs::read_to_string(out.join("plant.yaml")).unwrap()).unwrap();
    let q6 = plant_yaml[0]["torque_offset_nm"].as_f64().unwrap();
    assert!((q6 - 0.3).abs() < 0.01, "q6's simulated offset {q6:.4} Nm, hidden 0.3 (configured 0.1)");
    let observer: Value = serde_yaml::from_str(&std::fs::read_to_string(out.join("observer.yaml")).unwrap()).unwrap();
    for setting in observer["model_extension"][1]["by_pivot"].as_sequence().unwrap() {
        let o = setting["terms"]["torque_offset_nm"].as_f64().unwrap();
        assert!((o + 0.2).abs() < 0.01, "q7 at {:?} mm: {o:.4} Nm, hidden -0.2", setting["pivot_mm"]);
    }
    let notes = json["extension"]["notes"].to_string();
    assert!(notes.contains("q6's configured simulated offset (0.1 Nm) is replaced") && notes.contains("by pivot setting"), "{notes}");
    // A simulation that has the offsets already is left as it is (they must better its replay
    // of the training parts significantly, as any cause's plant terms must).
    let json: serde_json::Value = serde_json::from_str(&run_ok(Command::new(jointctl()).args(["identify", "--data"]).arg(&file).arg("--config").arg(&plant).args(["--joint", "q7", "--json"]))).unwrap();
    assert!(json["extension"]["plant_causes"].as_array().unwrap().is_empty(), "{}", json["extension"]);
    assert!(json["extension"]["notes"].to_string().contains("left out of the simulation"), "{}", json["extension"]["notes"]);
    let clean_file = both(&config, "clean");
    let refused = Command::new(jointctl()).args(["identify", "--data"]).arg(&clean_file).arg("--config").arg(&config).args(["--joint", "q7", "--out"]).arg(work.join("x")).output().unwrap();
    let why = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && why.contains("nothing to write") && why.contains("none was named"), "--out with no offset to split: {why}");
    let clean = identify(&clean_file);
    for d in clean["directions"].as_array().unwrap() {
        assert!(d["causes"].as_array().unwrap().is_empty(), "the clean wrist along {} deg: {}", d["angle_deg"], d["causes"]);
    }
    assert!(clean["offsets_per_dof"]["note"].as_str().is_some_and(|n| n.contains("none was named")), "{}", clean["offsets_per_dof"]);
}
