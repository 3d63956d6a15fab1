//! A table of broken arm descriptions: each must be rejected at the right line, column and
//! field, with a message that says what is wrong.

use jointctl_config::parse_str;

const GOOD: &str = r#"arm: rig
rate_hz: 40
hal:
  backend: sim
buses:
  can:
    - interface: can0
      drives:
        - {name: m1, node_id: 1}
        - {name: m2, node_id: 2}
  spi:
    - device: /dev/spidev0
      encoders:
        - {name: e1, chip_select: 0}
        - {name: e2, chip_select: 1}
joints:
  - name: q1
    plugin: rigid
    encoders: {output: e1}
    drives: {motor: m1}
    limits: {position_rad: [-1.0, 1.0], torque_nm: 10}
    params: {position_pi: {kp: 0.5, ki: 0.1}}
  - name: q2
    plugin: elastic
    encoders: {output: e2}
    drives: {motor: m2}
    params: {stiffness_nm_per_rad: 113.78}
"#;

/// (what is broken, text replaced, replacement, expected line, expected field, message fragment)
const CASES: &[(&str, &str, &str, usize, &str, &str)] = &[
    ("YAML syntax (tab indentation)", "  backend: sim", "\tbackend: sim", 4, "hal", "found character that cannot start any token"),
    ("unknown top-level field", "rate_hz: 40", "rate_hz: 40\nspeed: 3", 3, "speed", "unknown field `speed`"),
    ("misspelt joint field", "    limits: {position_rad", "    limts: {position_rad", 21, "joints[0].limts", "unknown field `limts`"),
    ("wrong type", "rate_hz: 40", "rate_hz: fast", 2, "rate_hz", "invalid type: string \"fast\""),
    ("missing required field", "    plugin: elastic\n", "", 23, "joints[1]", "missing field `plugin`"),
    ("duplicate joint name", "  - name: q2", "  - name: q1", 23, "joints[1].name", "already defined at joints[0]"),
    ("duplicate device name", "{name: e2, chip_select: 1}", "{name: m1, chip_select: 1}", 15, "buses.spi[0].encoders[1].name", "device `m1` is already defined"),
    ("encoder that does not exist", "encoders: {output: e2}", "encoders: {output: e9}", 25, "joints[1].encoders.output", "no encoder named `e9`"),
    ("drive that does not exist", "drives: {motor: m2}", "drives: {motor: m7}", 26, "joints[1].drives.motor", "no drive named `m7`"),
    ("non-finite number", "torque_nm: 10", "torque_nm: .nan", 21, "joints[0].limits.torque_nm", "must be a finite number"),
    ("rate out of range", "rate_hz: 40", "rate_hz: -5", 2, "rate_hz", "must be in [1, 10000] Hz"),
    // Issue 40, finding 6: a rate whose period is not a time (run panicked) or lasts days
    // (run no longer answered SIGINT) passed.
    ("rate too slow to be a loop", "rate_hz: 40", "rate_hz: 1.0e-300", 2, "rate_hz", "must be in [1, 10000] Hz, got 1.000e-300"),
    ("rate of a loop that never turns", "rate_hz: 40", "rate_hz: 1e-6", 2, "rate_hz", "must be in [1, 10000] Hz, got 1.000e-6"),
    ("node id out of range", "{name: m2, node_id: 2}", "{name: m2, node_id: 200}", 10, "buses.can[0].drives[1].node_id", "node id is 1-127"),
    ("limits upside down", "position_rad: [-1.0, 1.0]", "position_rad: [1.0, -1.0]", 21, "joints[0].limits.position_rad", "lower limit 1 must be below upper limit -1"),
    ("invalid arm name", "arm: rig", "arm: my arm/1", 1, "arm", "not a valid arm name"),
    ("one drive, two masters", "drives: {motor: m2}", "drives: {motor: m1}", 26, "joints[1].drives.motor", "already commanded by joints[0].drives.motor"),
    ("duplicate node id", "{name: m2, node_id: 2}", "{name: m2, node_id: 1}", 10, "buses.can[0].drives[1].node_id", "node id 1 is already used by `m1`"),
    ("non-finite plugin parameter", "stiffness_nm_per_rad: 113.78", "stiffness_nm_per_rad: .inf", 27, "joints[1].params", "stiffness_nm_per_rad: must be a finite number"),
    ("unknown backend", "  backend: sim", "  backend: ethercat", 4, "hal.backend", "unknown variant `ethercat`"),
    ("plugin of the wrong type", "plugin: rigid", "plugin: 42", 18, "joints[0].plugin", "expected a plugin name"),
    ("negative torque limit", "torque_nm: 10", "torque_nm: -10", 21, "joints[0].limits.torque_nm", "must be > 0"),
    // Finding: limits of +-1000 rad and 1e12 Nm passed.
    ("implausible position limits", "position_rad: [-1.0, 1.0]", "position_rad: [-1000.0, 1000.0]", 21, "joints[0].limits.position_rad", "implausible for a joint"),
    ("implausible torque limit", "torque_nm: 10", "torque_nm: 1e12", 21, "joints[0].limits.torque_nm", "must be > 0 and at most 1000 Nm"),
    ("implausible velocity limit", "torque_nm: 10", "torque_nm: 10, velocity_rad_s: 1e6", 21, "joints[0].limits.velocity_rad_s", "at most 50 rad/s"),
    // Finding: device names were cut to 15 bytes in diagnostics; now whole, up to 47.
    ("device name too long", "{name: e2, chip_select: 1}", "{name: enc_a_very_long_device_name_of_more_than_47_bytes, chip_select: 1}", 15, "buses.spi[0].encoders[1].name", "not a valid device name: use 1-47"),
    // Issue 37: the heartbeat's times have a range (a grace of days would never call a
    // drive silent).
    ("heartbeat grace out of range", "  backend: sim", "  backend: sim\n  canopen: {heartbeat_grace_s: 1e9}", 5, "hal.canopen.heartbeat_grace_s", "must be in [0.001, 60] s, got 1.000e9"),
    ("negative heartbeat timeout", "  backend: sim", "  backend: sim\n  canopen: {heartbeat_timeout_s: -1}", 5, "hal.canopen.heartbeat_timeout_s", "must be in [0.001, 60] s, got -1"),
    // Issue 37, finding 8: a file from another jointctl was read with today's meanings. The
    // version is checked before the fields (a newer file's unknown field is not the reason).
    ("a file from a newer jointctl", "rate_hz: 40", "version: 2\nrate_hz: 40\nspeed: 3", 2, "version", "format 2 is from a newer jointctl; this one reads formats 1 to 1"),
    ("format 0", "rate_hz: 40", "version: 0\nrate_hz: 40", 2, "version", "there is no format 0"),
    ("a version that is not a number", "rate_hz: 40", "version: one\nrate_hz: 40", 2, "version", "must be the file format's number"),
    // Issue 37, finding 2: the drive's own limits are checked before they are written to it.
    ("a drive limit of no torque", "{name: m2, node_id: 2}", "{name: m2, node_id: 2, limits: {max_torque_permille: 0}}", 10, "buses.can[0].drives[1].limits.max_torque_permille", "must be > 0"),
    ("a set-point window upside down", "{name: m2, node_id: 2}", "{name: m2, node_id: 2, setpoint_window_rad: [1.0, -1.0]}", 10, "buses.can[0].drives[1].setpoint_window_rad", "lower end 1 must be below upper end -1"),
    ("a stop sequence CiA 402 cannot follow", "rate_hz: 40", "rate_hz: 40\nsafety: {stop_sequence: [quick_stop, disable_operation]}", 3, "safety.stop_sequence[1]", "a drive in quick stop does not take disable_operation"),
    ("a following error window below one count", "{name: m2, node_id: 2}", "{name: m2, node_id: 2, limits: {following_error_window_rad: 1e-9}}", 10, "buses.can[0].drives[1].limits.following_error_window_rad", "less than one count"),
    ("joint time budget beyond the period", "    plugin: elastic\n", "    plugin: elastic\n    budget_us: 30000\n", 25, "joints[1].budget_us", "at most the period (25000 us)"),
];

#[test]
fn the_good_config_loads() {
    let loaded = parse_str(GOOD, "rig.yaml").expect("the reference config of this table must load");
    assert_eq!(loaded.config.joints.len(), 2);
    assert_eq!(loaded.config.rate_hz, 40.0);
}

#[test]
fn each_broken_config_is_rejected_at_the_right_place() {
    assert!(CASES.len() >= 15);
    let mut failures = Vec::new();
    for (what, from, to, line, field, fragment) in CASES {
        assert!(GOOD.contains(from), "case `{what}`: the good config has no `{from}`");
        let text = GOOD.replacen(from, to, 1);
        match parse_str(&text, "rig.yaml") {
            Ok(_) => failures.push(format!("{what}: accepted")),
            Err(errs) => {
                let e = &errs.0[0];
                let rendered = e.to_string();
                if e.line != *line || e.field != *field || !e.message.contains(fragment) || !rendered.starts_with("rig.yaml:") {
                    failures.push(format!("{what}: got `{rendered}` (line {}, field `{}`)", e.line, e.field));
                }
            }
        }
    }
    assert!(failures.is_empty(), "misreported configs:\n{}", failures.join("\n"));
}

/// Issue 37, finding 8, for the files a joint includes: an included file from a newer jointctl
/// is refused naming the file; one of this format loads, and its `version` is not a parameter
/// of the plugin.
#[test]
fn an_included_file_carries_its_format() {
    let dir = std::env::temp_dir().join(format!("jointctl-include-version-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("rig.yaml");
    std::fs::write(&config, GOOD.replacen("params: {stiffness_nm_per_rad: 113.78}", "params: {include: k.yaml}", 1)).unwrap();
    std::fs::write(dir.join("k.yaml"), "version: 1\nstiffness_nm_per_rad: 113.78\n").unwrap();
    let loaded = jointctl_config::load(&config).unwrap();
    assert_eq!(loaded.config.joints[1].params.0, serde_json::json!({"stiffness_nm_per_rad": 113.78}));
    std::fs::write(dir.join("k.yaml"), "version: 3\nstiffness_nm_per_rad: 113.78\n").unwrap();
    let e = jointctl_config::load(&config).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("joints[1].params.include") && e.contains("k.yaml: version: format 3 is from a newer jointctl"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_empty_joint_list_is_refused() {
    let text = GOOD.split("joints:").next().unwrap().to_string() + "joints: []\n";
    let errs = parse_str(&text, "rig.yaml").unwrap_err();
    assert_eq!(errs.0[0].field, "joints");
    assert!(errs.0[0].message.contains("at least one joint"));
}

#[test]
fn several_problems_are_all_reported() {
    let text = GOOD.replacen("rate_hz: 40", "rate_hz: 0", 1).replacen("drives: {motor: m2}", "drives: {motor: m7}", 1);
    let errs = parse_str(&text, "rig.yaml").unwrap_err();
    let fields: Vec<_> = errs.0.iter().map(|e| e.field.as_str()).collect();
    assert_eq!(fields, ["rate_hz", "joints[1].drives.motor"]);
}

#[test]
fn the_schema_covers_the_top_level_fields() {
    let schema = jointctl_config::json_schema();
    let props = schema["properties"].as_object().expect("schema has properties");
    for key in ["arm", "rate_hz", "hal", "buses", "joints", "timing", "ipc", "plugin_dirs"] {
        assert!(props.contains_key(key), "schema lacks `{key}`");
    }
}

/// Finding: 100 000 nested brackets under one key took 36 s to reject (with the YAML parser's
/// own message). Pass: refused at once, at the bracket that goes one level too deep.
#[test]
fn deep_nesting_is_refused_before_parsing() {
    let text = GOOD.replacen("    params: {stiffness_nm_per_rad: 113.78}", &format!("    params: {{x: {}{}}}", "[".repeat(100_000), "]".repeat(100_000)), 1);
    let e = &parse_str(&text, "rig.yaml").unwrap_err().0[0];
    assert!(e.message.contains("nest deeper than 64 levels"), "{e}");
    // `params: {` opens level 1 at column 13, `x: [` level 2 at column 17: level 65 is column 80.
    assert_eq!((e.line, e.column), (27, 80), "{e}");
    // Quotes, comments and apostrophes in plain text do not count as brackets or hide them.
    let fine = GOOD.replacen("arm: rig", "arm: rig # the thesis' arm [[[[ {{{{\n# ]]]]", 1).replacen("name: q2", "name: 'q2' # [[", 1);
    assert!(parse_str(&fine, "rig.yaml").is_ok());
    assert!(parse_str(&format!("x: \"{}\"\n{GOOD}", "[".repeat(200)), "rig.yaml").unwrap_err().0[0].message.contains("unknown field `x`"));
}

/// Finding: a 50 MB name was echoed whole into the error. Pass: the error stays short and says
/// the value's size (5 MB here: the same path, a tenth of the test time).
#[test]
fn a_huge_value_is_shortened_in_the_error() {
    let name = "q".repeat(5_000_000);
    let text = GOOD.replacen("  - name: q2", &format!("  - name: {name}"), 1);
    let errs = parse_str(&text, "rig.yaml").unwrap_err();
    let rendered = errs.to_string();
    assert!(rendered.len() < 1000, "{} bytes", rendered.len());
    assert!(rendered.contains("(5000000 bytes)"), "{rendered}");
}

#[test]
fn more_encoders_than_one_runtime_builds_are_refused_at_the_bus() {
    // Whether an arm fits the shared-memory samples is the publisher's check (a bigger arm runs
    // without publishing); a description beyond what one runtime builds is refused here.
    let buses = jointctl_config::MAX_LOOP_DEVICES / 16 + 1;
    let extra: String = (0..buses)
        .map(|b| {
            let encoders: String = (0..16).map(|cs| format!("        - {{name: x{b}_{cs}, chip_select: {cs}}}\n")).collect();
            format!("    - device: /dev/spidev9.{b}\n      encoders:\n{encoders}")
        })
        .collect();
    let text = GOOD.replacen("joints:\n", &format!("{extra}joints:\n"), 1);
    let errs = parse_str(&text, "rig.yaml").unwrap_err();
    let e = errs.0.iter().find(|e| e.field == "buses.spi").unwrap_or_else(|| panic!("{errs:?}"));
    let expected = format!("{} encoders exceed the maximum of {}", buses * 16 + 2, jointctl_config::MAX_LOOP_DEVICES);
    assert!(e.message.contains(&expected), "{}", e.message);
}

#[test]
fn an_arm_of_17_dofs_is_a_valid_description() {
    // 17 DOFs: one more than the shared-memory samples once carried.
    let joints: String = (3..=17).map(|i| format!("  - {{name: q{i}, plugin: rigid, encoders: {{output: e{i}}}, drives: {{motor: m{i}}}}}\n")).collect();
    let drives: String = (3..=17).map(|i| format!("        - {{name: m{i}, node_id: {i}}}\n")).collect();
    let encoders: String = (3..=17).map(|i| format!("        - {{name: e{i}, chip_select: {}}}\n", i % 16)).collect();
    let text = GOOD
        .replacen("        - {name: m2, node_id: 2}\n", &format!("        - {{name: m2, node_id: 2}}\n{drives}"), 1)
        .replacen("joints:\n", &format!("    - device: /dev/spidev1\n      encoders:\n{encoders}joints:\n"), 1)
        + &joints;
    parse_str(&text, "rig.yaml").unwrap_or_else(|e| panic!("{e}"));
}
