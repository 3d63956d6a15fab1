//! The plugin boundary: refused libraries, contained panics, plugins found from YAML alone.

use jointctl_modes::Mode;
use jointctl_api::MotorSetpoint;
use jointctl_runtime::{LoadPluginError, PluginLoader};
use jointctl_tests::{arm_name, artifact, rig_yaml, scratch};

fn loader() -> PluginLoader {
    PluginLoader::new([])
}

#[test]
fn a_library_with_another_abi_version_is_refused_with_the_fix() {
    let so = artifact("libjointctl_fixture_wrong_abi.so");
    let err = loader().load("wrong_abi", Some(&so)).map(|_| ()).unwrap_err();
    // The fixture claims the next major version.
    let (host, minor) = (jointctl_api::abi::ABI_MAJOR, jointctl_api::abi::ABI_MINOR);
    assert!(matches!(err, LoadPluginError::AbiVersion { found_major, host_major, .. } if found_major == host + 1 && host_major == host), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("libjointctl_fixture_wrong_abi.so"), "names the file: {msg}");
    assert!(msg.contains(&format!("ABI {}.{minor}", host + 1)) && msg.contains(&format!("speaks ABI {host}.{minor}")), "names both versions: {msg}");
    assert!(msg.contains("rebuild the plugin"), "says the fix: {msg}");
}

#[test]
fn a_library_with_another_layout_is_refused() {
    let so = artifact("libjointctl_fixture_wrong_layout.so");
    let err = loader().load("wrong_layout", Some(&so)).map(|_| ()).unwrap_err();
    assert!(matches!(err, LoadPluginError::Layout { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("different layout") && msg.contains("rebuild"), "{msg}");
}

#[test]
fn a_library_without_the_named_entry_is_refused() {
    let so = artifact("libjointctl_plugin_rigid.so");
    let err = loader().load("elastic", Some(&so)).map(|_| ()).unwrap_err();
    assert!(matches!(err, LoadPluginError::NoEntry { .. }), "{err:?}");
    assert!(err.to_string().contains("jointctl_plugin_elastic"));
}

#[test]
fn a_plugin_is_loaded_from_a_path_given_only_in_yaml() {
    // Copy the library under a name and folder no search rule knows.
    let dir = scratch("by-path");
    let hidden = dir.join("somewhere").join("my_joint_type.so");
    std::fs::create_dir_all(hidden.parent().unwrap()).unwrap();
    std::fs::copy(artifact("libjointctl_plugin_faulty.so"), &hidden).unwrap();
    let extra = "  - name: b\n    plugin: {name: faulty, path: somewhere/my_joint_type.so}\n    encoders: {output: e1}\n    drives: {motor: m1}\n";
    let yaml = dir.join("arm.yaml");
    std::fs::write(&yaml, rig_yaml(&arm_name("bypath"), 100.0, extra)).unwrap();
    let loaded = jointctl_config::load(&yaml).unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &jointctl_runtime::loader_for(&loaded)).expect("loads from the YAML path");
    assert_eq!(arm.slots[1].plugin, "faulty");
    arm.activate().unwrap();
    arm.step(0.0);
    assert!(arm.states[1].position().is_some());
}

#[test]
fn a_missing_plugin_is_reported_at_its_yaml_line() {
    let extra = "  - name: b\n    plugin: no_such_joint\n";
    let loaded = jointctl_config::parse_str(&rig_yaml("x", 40.0, extra), "rig.yaml").unwrap();
    let errs = jointctl_backends::build_arm(&loaded, &loader()).map(|_| ()).unwrap_err();
    let e = &errs.0[0];
    assert_eq!(e.field, "joints[1].plugin");
    assert_eq!(e.line, 28);
    assert!(e.message.contains("plugin `no_such_joint` not found"), "{}", e.message);
}

#[test]
fn plugin_parameter_and_wiring_errors_point_into_the_yaml() {
    let extra = "  - name: b\n    plugin: elastic\n    encoders: {outptu: e1}\n    drives: {motor: m1}\n    params: {stiffness_nm_per_rad: -3, output_per_motor: 1, position_pi: {kp: 0, ki: 0}}\n  - name: c\n    plugin: elastic\n    encoders: {output: e2}\n    drives: {motor: m2}\n    params: {stiffness_nm_per_rad: -3, output_per_motor: 1, position_pi: {kp: 0, ki: 0}}\n";
    let loaded = jointctl_config::parse_str(&rig_yaml("x", 40.0, extra), "rig.yaml").unwrap();
    let errs = jointctl_backends::build_arm(&loaded, &loader()).map(|_| ()).unwrap_err();
    let shown: Vec<String> = errs.0.iter().map(|e| e.to_string()).collect();
    assert_eq!(errs.0.len(), 3, "{shown:#?}");
    assert_eq!(errs.0[0].field, "joints[1].encoders.outptu");
    assert!(errs.0[0].message.contains("no encoder role `outptu`; its roles are: output"));
    assert_eq!(errs.0[1].field, "joints[1].encoders");
    assert_eq!(errs.0[2].field, "joints[2].params.stiffness_nm_per_rad");
    assert_eq!(errs.0[2].line, 36);
    assert!(errs.0[2].message.contains("must be a finite number > 0, got -3"), "{}", shown[2]);
}

fn arm_with_faulty(params: &str) -> jointctl_runtime::Arm {
    let extra = format!("  - name: b\n    plugin: faulty\n    encoders: {{output: e1}}\n    drives: {{motor: m1}}\n    params: {params}\n");
    let loaded = jointctl_config::parse_str(&rig_yaml("x", 100.0, &extra), "rig.yaml").unwrap();
    let mut arm = jointctl_backends::build_arm(&loaded, &loader()).unwrap();
    arm.activate().unwrap();
    arm
}

#[test]
fn a_panic_in_observe_faults_only_its_joint() {
    let mut arm = arm_with_faulty("{panic_in_observe_at: 5}");
    arm.set_mode(0, position(0.3));
    arm.set_mode(1, position(0.3));
    for i in 0..500 {
        arm.step(i as f64 * 0.01);
    }
    let (a, b) = (&arm.slots[0], &arm.slots[1]);
    assert_eq!(b.fault, jointctl_api::JointFault::PANICKED.code());
    assert_eq!(b.fault_count, 1, "faulted once, then never called again");
    assert!(b.last_message().contains("deliberate panic in observe at cycle 5"), "{}", b.last_message());
    assert!(b.held && arm.states[1].position().is_none(), "the faulted joint is held and unknown");
    assert_eq!(arm.last_setpoints()[1], MotorSetpoint::HOLD);
    // The other joint went on and reached its set-point.
    assert_eq!(a.fault, 0);
    assert!(!a.held);
    assert!((arm.states[0].position().unwrap() - 0.3).abs() < 2e-3, "{:?}", arm.states[0]);
}

#[test]
fn a_panic_in_control_and_a_fault_code_are_contained_too() {
    let mut arm = arm_with_faulty("{panic_in_control_at: 3}");
    for i in 0..10 {
        arm.step(i as f64 * 0.01);
    }
    assert_eq!(arm.slots[1].fault, 1);
    assert!(arm.slots[1].last_message().contains("deliberate panic in control"));
    assert_eq!(arm.slots[0].fault, 0);

    let mut arm = arm_with_faulty("{fault_at: 2}");
    for i in 0..10 {
        arm.step(i as f64 * 0.01);
    }
    assert_eq!(arm.slots[1].fault, 42);
    assert_eq!(arm.slots[0].fault, 0);
}

#[test]
fn a_panic_in_create_is_a_located_config_error() {
    let extra = "  - name: b\n    plugin: faulty\n    encoders: {output: e1}\n    drives: {motor: m1}\n    params: {panic_in_create: true}\n";
    let loaded = jointctl_config::parse_str(&rig_yaml("x", 100.0, extra), "rig.yaml").unwrap();
    let errs = jointctl_backends::build_arm(&loaded, &loader()).map(|_| ()).unwrap_err();
    assert_eq!(errs.0[0].field, "joints[1].params");
    assert!(errs.0[0].message.contains("deliberate panic in create"), "{}", errs.0[0]);
}

#[test]
fn static_and_loaded_plugins_behave_the_same() {
    let yaml = rig_yaml("x", 100.0, "");
    let loaded = jointctl_config::parse_str(&yaml, "rig.yaml").unwrap();
    let mut statics = PluginLoader::new([]);
    statics.register_static(jointctl_plugin_rigid::plugin_descriptor()).unwrap();
    let mut runs = Vec::new();
    for l in [loader(), statics] {
        let mut arm = jointctl_backends::build_arm(&loaded, &l).unwrap();
        arm.activate().unwrap();
        arm.set_mode(0, position(0.5));
        for i in 0..50 {
            arm.step(i as f64 * 0.01);
        }
        // Debug text compares NaN fields (unknown torque) as equal, unlike f64 ==.
        runs.push(format!("{:?}", arm.states[0]));
    }
    assert_eq!(runs[0], runs[1]);
}


fn position(target_rad: f64) -> Mode {
    Mode::Position { target_rad }
}

/// Issue finding: `deactivate` was called on an instance that had panicked. A panicked plugin is
/// never entered again; an instance that did not panic is deactivated as usual.
#[test]
fn a_panicked_plugin_is_never_entered_again_not_even_to_deactivate() {
    let dir = scratch("no-reentry");
    for (params, expect_called) in [("{}", true), ("{panic_in_observe_at: 2}", false), ("{panic_in_control_at: 2}", false)] {
        let marker = dir.join("deactivated");
        let _ = std::fs::remove_file(&marker);
        let params = format!("{{deactivate_marker: {}, {}", marker.display(), &params[1..]);
        let params = params.replace(", }", "}");
        let mut arm = arm_with_faulty(&params);
        for i in 0..10 {
            arm.step(i as f64 * 0.01);
        }
        let b = &arm.slots[1];
        assert_eq!(b.fault_count, u64::from(!expect_called), "{params}: faulted once at most, then never called");
        arm.shutdown();
        assert_eq!(marker.exists(), expect_called, "{params}: deactivate called = {}", marker.exists());
    }
}

/// A joint type whose descriptor declares what the host cannot wire.
struct Declares;
impl jointctl_api::Observer for Declares {
    fn observe(&mut self, _: &jointctl_api::RawJointView, _: &mut [jointctl_api::JointState]) -> Result<(), jointctl_api::JointFault> {
        Ok(())
    }
}
impl jointctl_api::Controller for Declares {
    fn control(
        &mut self,
        _: &[jointctl_api::JointState],
        _: &[jointctl_api::JointCommand],
        _: &jointctl_api::RawJointView,
        _: &mut [MotorSetpoint],
    ) -> Result<(), jointctl_api::JointFault> {
        Ok(())
    }
}
impl jointctl_api::JointPlugin for Declares {
    fn create(_: &str) -> Result<Self, jointctl_api::PluginError> {
        Ok(Declares)
    }
}

use jointctl_api::abi::PluginDescriptor;
static NINE_ENCODERS: PluginDescriptor =
    PluginDescriptor::new::<Declares>(c"nine", c"0", 1, c"e0,e1,e2,e3,e4,e5,e6,e7,e8", c"motor", true);
static FIVE_DRIVES: PluginDescriptor =
    PluginDescriptor::new::<Declares>(c"five", c"0", 1, c"output", c"m0,m1,m2,m3,m4?", true);
static TWICE: PluginDescriptor = PluginDescriptor::new::<Declares>(c"twice", c"0", 1, c"output,output?", c"motor", true);
static NO_DOF: PluginDescriptor = PluginDescriptor::new::<Declares>(c"nodof", c"0", 0, c"output", c"motor", true);

/// Issue finding: a 9th encoder role panicked `Arm::build`, an unwired optional 5th drive passed
/// `check` and panicked on the first cycle. Such descriptors are refused when registered or
/// loaded, with what is wrong and the limits; `check` and `run` report it at the joint's
/// `plugin` line.
#[test]
fn role_counts_duplicates_and_dofs_are_validated_before_wiring() {
    for (d, wants) in [(&NINE_ENCODERS, "9 encoder roles"), (&FIVE_DRIVES, "5 drive roles"), (&TWICE, "the encoder role `output` twice"), (&NO_DOF, "0 DOFs")] {
        let mut l = PluginLoader::new([]);
        let err = l.register_static(d).unwrap_err();
        assert!(matches!(err, LoadPluginError::Roles { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains(wants) && msg.contains("at most 8 encoder and 4 drive roles"), "{msg}");
    }
    // Through the YAML, as `check` sees it: an error at the plugin line, no panic.
    let mut l = PluginLoader::new([]);
    let _ = l.register_static(&FIVE_DRIVES);
    let extra = "  - name: b\n    plugin: five\n    encoders: {output: e1}\n    drives: {m0: m1}\n";
    let loaded = jointctl_config::parse_str(&rig_yaml("x", 40.0, extra), "rig.yaml").unwrap();
    let errs = jointctl_backends::build_arm_for_check(&loaded, &l).map(|_| ()).unwrap_err();
    assert_eq!(errs.0[0].field, "joints[1].plugin", "{}", errs.0[0]);
    assert!(errs.0[0].message.contains("not found"), "an unregistered descriptor is simply not there: {}", errs.0[0]);
}

/// What a library built with `panic = "abort"` carries: `export_joint_plugin!` sets the flag
/// from `cfg!(panic = "unwind")`, which is false there.
static ABORTS: PluginDescriptor = PluginDescriptor::new::<Declares>(c"aborts", c"0", 1, c"output", c"motor", false);

/// Finding: a plugin built with `panic = "abort"` was accepted although its descriptor says
/// so; its first panic would have killed the host. Pass: refused, with the reason and the fix.
#[test]
fn a_plugin_built_with_panic_abort_is_refused() {
    let err = PluginLoader::new([]).register_static(&ABORTS).unwrap_err();
    assert!(matches!(err, LoadPluginError::PanicAbort { .. }), "{err:?}");
    assert!(err.to_string().contains("panic = \"abort\"") && err.to_string().contains("panic = \"unwind\""), "{err}");
}

/// Finding: a truncated or corrupt plugin file killed the host (SIGBUS in `check` and `run`).
/// Pass: the file is checked before it is mapped; this test process survives every cut and
/// the error names the file and says it is truncated or not an ELF library; `jointctl check`
/// and `jointctl run` exit 1 with the message instead of dying by a signal.
#[test]
fn a_truncated_or_corrupt_plugin_file_is_refused_before_it_is_mapped() {
    let dir = scratch("truncated");
    let good = std::fs::read(artifact("libjointctl_plugin_faulty.so")).unwrap();
    let mut cases: Vec<(String, Vec<u8>)> = [1, 5, 10, 25, 50, 90, 99]
        .iter()
        .map(|pct| (format!("cut at {pct} %"), good[..good.len() * pct / 100].to_vec()))
        .collect();
    let mut garbage = good.clone();
    garbage[64..4096].fill(0xA5);
    cases.push(("program headers overwritten".into(), garbage));
    cases.push(("text file".into(), b"not a library\n".to_vec()));
    for (i, (what, bytes)) in cases.iter().enumerate() {
        let so = dir.join(format!("libcut{i}.so"));
        std::fs::write(&so, bytes).unwrap();
        let err = loader().load("faulty", Some(&so)).map(|_| ()).expect_err(what);
        assert!(matches!(err, LoadPluginError::Malformed { .. } | LoadPluginError::Open { .. }), "{what}: {err:?}");
        assert!(err.to_string().contains(&format!("libcut{i}.so")), "{what}: {err}");
    }
    // The 5 % cut killed `check` with SIGBUS before.
    let so = dir.join("libcut1.so");
    let extra = format!("  - name: b\n    plugin: {{name: faulty, path: {}}}\n    encoders: {{output: e1}}\n    drives: {{motor: m1}}\n", so.display());
    let yaml = dir.join("arm.yaml");
    std::fs::write(&yaml, rig_yaml(&arm_name("truncated"), 100.0, &extra)).unwrap();
    for args in [&["check"][..], &["run", "--cycles", "3", "--no-ipc"][..]] {
        let out = std::process::Command::new(jointctl_tests::jointctl()).args(args).arg(&yaml).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?} exits 1, not by a signal: {:?} {err}", out.status);
        assert!(err.contains("truncated") || err.contains("not a complete 64-bit ELF file"), "{args:?}: {err}");
    }
}

/// Issue 40, finding 5: a plugin overwritten in place while `run` used it (`cp`, which truncates
/// and rewrites the same file) killed the runtime with SIGSEGV: the loader had mapped that file,
/// and its pages changed under the running code. The runtime now loads the bytes it checked from
/// a private in-memory copy. Pass: the file is overwritten with zeros half a second into a 2 s run
/// at 200 Hz, and the run ends at its duration with exit 0.
#[test]
fn a_plugin_file_overwritten_while_it_runs_does_not_touch_the_running_code() {
    use std::io::Write as _;
    let dir = scratch("overwritten");
    let so = dir.join("plugins").join("my_joint.so");
    std::fs::create_dir_all(so.parent().unwrap()).unwrap();
    std::fs::copy(artifact("libjointctl_plugin_faulty.so"), &so).unwrap();
    let extra = "  - name: b\n    plugin: {name: faulty, path: plugins/my_joint.so}\n    encoders: {output: e1}\n    drives: {motor: m1}\n";
    let yaml = dir.join("arm.yaml");
    std::fs::write(&yaml, rig_yaml(&arm_name("overwritten"), 200.0, extra)).unwrap();
    let run = std::process::Command::new(jointctl_tests::jointctl())
        .arg("run")
        .arg(&yaml)
        .args(["--duration", "2"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    let len = std::fs::metadata(&so).unwrap().len() as usize;
    let mut file = std::fs::OpenOptions::new().write(true).truncate(true).open(&so).unwrap();
    file.write_all(&vec![0u8; len]).unwrap();
    drop(file);
    let out = run.wait_with_output().unwrap();
    assert!(out.status.success(), "{:?}: {}", out.status, String::from_utf8_lossy(&out.stderr));
}

/// `bytes` with every relocation of its `.rela.dyn` section pointing at an address far outside
/// the library (its size and its ELF structure unchanged): the dynamic loader writes there.
fn with_relocations_out_of_the_library(mut bytes: Vec<u8>) -> Vec<u8> {
    let u16_at = |b: &[u8], i: usize| u16::from_le_bytes([b[i], b[i + 1]]) as usize;
    let u32_at = |b: &[u8], i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap()) as usize;
    let u64_at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap()) as usize;
    let (shoff, shentsize, shnum, shstrndx) = (u64_at(&bytes, 0x28), u16_at(&bytes, 0x3A), u16_at(&bytes, 0x3C), u16_at(&bytes, 0x3E));
    let header = |i: usize| shoff + i * shentsize;
    let names = u64_at(&bytes, header(shstrndx) + 24);
    let rela = (0..shnum)
        .find(|&i| {
            let name = names + u32_at(&bytes, header(i));
            bytes[name..].starts_with(b".rela.dyn\0")
        })
        .expect("a .rela.dyn section");
    let (offset, size) = (u64_at(&bytes, header(rela) + 24), u64_at(&bytes, header(rela) + 32));
    for entry in (offset..offset + size).step_by(24) {
        bytes[entry..entry + 8].copy_from_slice(&0x7fff_ffff_0000u64.to_le_bytes());
        bytes[entry + 8..entry + 16].copy_from_slice(&8u64.to_le_bytes()); // R_X86_64_RELATIVE
        bytes[entry + 16..entry + 24].copy_from_slice(&0u64.to_le_bytes());
    }
    bytes
}

/// Issue 40, finding 4: a plugin file of the right size whose middle was corrupt passed the ELF
/// structure check, and `check` and `run` died with SIGSEGV inside the dynamic loader (exit 139).
/// Now each library is loaded first in a short-lived child of `jointctl`. Pass: both exit 1 and
/// name the file and the probe's signal.
#[cfg(target_arch = "x86_64")]
#[test]
fn a_plugin_that_kills_the_dynamic_loader_is_refused_by_check_and_run() {
    let dir = scratch("corrupt-middle");
    let so = dir.join("plugins").join("my_joint.so");
    std::fs::create_dir_all(so.parent().unwrap()).unwrap();
    std::fs::write(&so, with_relocations_out_of_the_library(std::fs::read(artifact("libjointctl_plugin_faulty.so")).unwrap())).unwrap();
    let extra = "  - name: b\n    plugin: {name: faulty, path: plugins/my_joint.so}\n    encoders: {output: e1}\n    drives: {motor: m1}\n";
    let yaml = dir.join("arm.yaml");
    std::fs::write(&yaml, rig_yaml(&arm_name("corrupt-middle"), 100.0, extra)).unwrap();
    for args in [vec!["check"], vec!["run", "--cycles", "3"]] {
        let out = std::process::Command::new(jointctl_tests::jointctl()).args(&args[..1]).arg(&yaml).args(&args[1..]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {:?} {err}", out.status);
        assert!(err.contains("my_joint.so") && err.contains("killed a probe process with SIGSEGV"), "{args:?}: {err}");
    }
}
