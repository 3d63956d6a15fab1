//! One runtime per arm and per CAN bus: a second runtime of a running arm, in any domain, or on a
//! CAN interface another runtime drives, is refused before it opens the hardware.

use std::process::Command;
use std::time::Duration;

use jointctl_tests::{jointctl, stop};

use super::{spawn_run, stderr_of, write_rig};

/// Finding: with `hal: socketcan`, a second runtime built and activated the HAL (an NMT
/// broadcast to every drive) before it found the arm already running. Pass: a second runtime of
/// a running arm, configured for a CAN interface that does not exist, is refused as "already
/// running": it never got as far as opening the bus (which would have failed first).
#[test]
fn a_second_runtime_is_refused_before_it_opens_the_hardware() {
    let (arm, yaml) = write_rig("lock-first", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let can_yaml = yaml.with_file_name("can.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&can_yaml, jointctl_tests::yaml_with(&text, &[
        jointctl_tests::Edit::Set("hal.backend", "socketcan".into()),
        jointctl_tests::Edit::Set("buses.can[0].interface", "jcnone0".into()),
    ])).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    stop(&mut first);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("arm `{arm}` is already running (process {})", first.id())), "{err}");
    assert!(!err.contains("jcnone0"), "the bus was never opened: {err}");
    // Alone, the same config does try the bus: the refusal above came before it.
    let alone = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    assert!(String::from_utf8_lossy(&alone.stderr).contains("jcnone0"), "{}", String::from_utf8_lossy(&alone.stderr));
}

#[test]
fn a_second_runtime_of_the_same_arm_is_refused() {
    let (_, yaml) = write_rig("twice", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let second = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    stop(&mut first);
    assert_eq!(second.status.code(), Some(1));
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(err.contains("is already running"), "{err}");
}

/// Issue 40, finding 16: the one-runtime lock held per domain and root, and a copy of a
/// SocketCAN config in another domain went on to open `can0` beside the running arm: two hosts
/// would drive the same bus. Pass: while another process holds a CAN interface's machine-wide
/// lock, a runtime of another arm in another domain on that interface is refused, naming the
/// interface and the holder, before it opens the bus (alone, it tries the bus).
#[test]
fn a_second_runtime_on_the_same_can_interface_is_refused_whatever_its_domain() {
    let (_, yaml) = write_rig("bus-lock", 100.0);
    let interface = format!("jcb{}", std::process::id() % 100_000);
    let can_yaml = yaml.with_file_name("can.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap();
    let edited = jointctl_tests::yaml_with(&text, &[
        jointctl_tests::Edit::Set("hal.backend", "socketcan".into()),
        jointctl_tests::Edit::Set("buses.can[0].interface", interface.clone().into()),
    ]);
    std::fs::write(&can_yaml, format!("{edited}\nipc:\n  domain: other{}\n", std::process::id())).unwrap();
    let held = jointctl_runtime::lock::MachineLock::bus(&jointctl_runtime::lock::machine_lock_dir(), &interface).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    drop(held);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("CAN interface `{interface}` is driven by another runtime (process {})", std::process::id())), "{err}");
    let alone = Command::new(jointctl()).arg("run").arg(&can_yaml).args(["--cycles", "3"]).output().unwrap();
    jointctl_tests::forget_test_domain(&format!("other{}", std::process::id()));
    let err = String::from_utf8_lossy(&alone.stderr);
    assert!(err.contains(&interface) && !err.contains("driven by another runtime"), "{err}");
}

/// Issue 40, finding 16 (the arm half): the one-runtime lock held per domain and root, so the
/// same arm ran in two domains at once, both driving its drives. Pass: while a runtime of the
/// arm runs in its domain, a runtime of the same arm in another domain is refused, naming the
/// arm and the holder; once the first has stopped, it runs.
#[test]
fn a_second_runtime_of_the_same_arm_is_refused_whatever_its_domain() {
    let (arm, yaml) = write_rig("arm-machine-lock", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    std::thread::sleep(Duration::from_millis(700));
    let other = yaml.with_file_name("other-domain.yaml");
    let domain = format!("other{}", std::process::id());
    std::fs::write(&other, format!("{}\nipc:\n  domain: {domain}\n", std::fs::read_to_string(&yaml).unwrap())).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&other).args(["--cycles", "3"]).output().unwrap();
    stop(&mut first);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("arm `{arm}` is already running on this machine (process {})", first.id())), "{err}");
    let alone = Command::new(jointctl()).arg("run").arg(&other).args(["--cycles", "3"]).output().unwrap();
    jointctl_tests::forget_test_domain(&domain);
    assert!(alone.status.success(), "{}", String::from_utf8_lossy(&alone.stderr));
}

/// Issue 40, finding 16 (the root half): the one-runtime lock held per domain and root, so the
/// same arm with another `ipc.root` ran beside the first. Pass: while a runtime of the arm runs,
/// a runtime of the same arm in the same domain but another, private `ipc.root` is refused,
/// naming the arm and the holder, and the first runs on until it is stopped; once it has
/// stopped, the second runs.
#[test]
fn a_second_runtime_of_the_same_arm_is_refused_whatever_its_ipc_root() {
    use std::os::unix::fs::PermissionsExt as _;
    let (arm, yaml) = write_rig("arm-root-lock", 100.0);
    let mut first = spawn_run(&yaml, &["--duration", "20"]);
    // Up: an inspector sees a sample (not a fixed wait, which a loaded machine outruns).
    let up = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--count", "1", "--timeout", "10"]).output().unwrap();
    assert!(up.status.success(), "the first runtime never came up: {}", String::from_utf8_lossy(&up.stderr));
    let root = yaml.with_file_name("private-root");
    std::fs::create_dir_all(&root).unwrap();
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o700)).unwrap();
    let other = yaml.with_file_name("other-root.yaml");
    std::fs::write(&other, format!("{}\nipc:\n  root: {}\n", std::fs::read_to_string(&yaml).unwrap(), root.display())).unwrap();
    let second = Command::new(jointctl()).arg("run").arg(&other).args(["--cycles", "3"]).output().unwrap();
    let first_ran_on = first.try_wait().unwrap().is_none();
    stop(&mut first);
    let log = stderr_of(&mut first);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("arm `{arm}` is already running on this machine (process {})", first.id())), "{err}");
    assert!(first_ran_on, "the first runtime ended when the second was refused: {log}");
    assert!(log.contains("loop stopped, joints held") && log.contains("signal=SIGINT"), "{log}");
    let alone = Command::new(jointctl()).arg("run").arg(&other).args(["--cycles", "3"]).output().unwrap();
    assert!(alone.status.success(), "{}", String::from_utf8_lossy(&alone.stderr));
}
