//! Who may reach an arm's shared memory: client and subscriber slot limits from the YAML, another
//! user (permissions of the segments and the root folder), and nothing left in /dev/shm.

use std::process::Command;
use std::time::{Duration, Instant};

use jointctl_tests::{jointctl, stop};

use super::{spawn_run, stderr_of, wait_with_timeout, write_rig};

/// Finding: 16 idle clients locked out `jointctl cmd stop` (`ExceedsMaxSupportedClients`),
/// 16 idle subscribers locked out `inspect`. Pass: with every client slot taken, `cmd stop`
/// still stops the runtime (it signals it) and the runtime ends cleanly, joints held; with
/// every subscriber slot taken, `inspect` says which limit to raise; and `ipc.max_subscribers`
/// in the YAML raises it.
#[test]
fn idle_clients_cannot_lock_out_stop_and_the_limits_come_from_yaml() {
    let (arm, yaml) = write_rig("lockout", 100.0);
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", serde_yaml::from_str("{max_clients: 3, max_subscribers: 2}").unwrap())])).unwrap();
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let node = jointctl_ipc::create_node(None, &format!("lockout-{}", std::process::id())).unwrap();
    let names = jointctl_ipc::ServiceNames::for_arm(&arm);
    let t = Instant::now();
    let state = loop {
        if let Ok(s) = jointctl_ipc::joint_state_service(&node, &names.joint_state) {
            break s;
        }
        assert!(t.elapsed() < Duration::from_secs(10), "the arm never came up");
        std::thread::sleep(Duration::from_millis(20));
    };
    // Idle subscribers take every slot: inspect is refused with the limit's name.
    let idle_subs: Vec<_> = (0..2).map(|_| state.subscriber_builder().create().unwrap()).collect();
    let out = Command::new(jointctl()).args(["inspect", "echo", "--arm", &arm, "--count", "1", "--timeout", "2"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("every subscriber slot") && err.contains("ipc.max_subscribers"), "{err}");
    drop(idle_subs);
    // Idle clients take every slot: a command is refused with the limit's name, a stop is not.
    let command = jointctl_ipc::command_service(&node, &jointctl_ipc::command_service_name(&arm), None).unwrap();
    let idle_clients: Vec<_> = (0..3).map(|_| command.client_builder().create().unwrap()).collect();
    let out = Command::new(jointctl()).args(["cmd", "--arm", &arm, "hold"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("ipc.max_clients"), "{}", String::from_utf8_lossy(&out.stderr));
    let out = Command::new(jointctl()).args(["cmd", "--arm", &arm, "stop"]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}{}", String::from_utf8_lossy(&out.stderr));
    assert!(said.contains(&format!("sent SIGTERM to the runtime, process {}", run.id())), "{said}");
    let status = wait_with_timeout(&mut run, Duration::from_secs(5)).expect("the runtime stops");
    let log = stderr_of(&mut run);
    assert!(status.success() && log.contains("loop stopped, joints held") && log.contains("signal=SIGTERM"), "{log}");
    drop(idle_clients);
}

/// Runs `jointctl` as user `nobody` (uid 65534), as another local user would.
fn jointctl_as_nobody(args: &[&str]) -> std::process::Output {
    Command::new("setpriv").args(["--reuid=65534", "--regid=65534", "--clear-groups"]).arg(jointctl()).args(args).output().expect("setpriv")
}

/// Finding: any local user could lock everyone out of the arm (the domain's management file
/// in /dev/shm was mode 0666; overwriting it made every `cmd`, `inspect` and `run` fail with
/// `UnableToGenerateUniqueNodeId`), and another user's permission failures read
/// "InternalError". Pass, with `ipc: {domain, root}` in the YAML: the root folder is 0700 and
/// the management segment 0600 while the arm runs; another user can neither overwrite the
/// segment nor attach, and is told which file belongs to whom; the owner still commands the arm;
/// a segment another user planted for a domain is refused with that reason. Needs root (to act
/// as `nobody`), which CI has.
#[test]
fn another_user_can_neither_tamper_with_nor_squat_the_shared_memory() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    if jointctl_ipc::access::effective_uid() != 0 {
        eprintln!("skipped: needs root to act as another user");
        return;
    }
    let (arm, yaml) = write_rig("tamper", 100.0);
    let domain = format!("sec{}", std::process::id());
    let root = yaml.parent().unwrap().join("ipc-root");
    let text = std::fs::read_to_string(&yaml).unwrap();
    let ipc: serde_yaml::Value = serde_yaml::from_str(&format!("{{domain: {domain}, root: {}}}", root.display())).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", ipc)])).unwrap();
    let mut run = spawn_run(&yaml, &["--duration", "30"]);
    let scope = jointctl_ipc::IpcScope { domain: Some(domain.clone()), root: Some(root.clone()), group: None };
    let node = jointctl_ipc::create_node_in(&scope, "tamper-watch").unwrap();
    let t = Instant::now();
    while jointctl_ipc::joint_state_service(&node, &jointctl_ipc::ServiceNames::for_arm(&arm).joint_state).is_err() {
        assert!(t.elapsed() < Duration::from_secs(10), "the arm never came up");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(std::fs::metadata(&root).unwrap().permissions().mode() & 0o777, 0o700, "root folder owner-only");
    let segment = jointctl_ipc::access::management_segment(&domain).expect("the domain's management segment");
    assert_eq!(std::fs::metadata(&segment).unwrap().mode() & 0o777, 0o600, "{}", segment.display());
    // Another user cannot overwrite it...
    let tamper = Command::new("setpriv")
        .args(["--reuid=65534", "--regid=65534", "--clear-groups", "sh", "-c"])
        .arg(format!("printf 0123456789abcdef > {}", segment.display()))
        .output()
        .unwrap();
    assert!(!tamper.status.success(), "another user overwrote {}", segment.display());
    // ...nor attach, and is told why.
    let root_arg = root.display().to_string();
    let out = jointctl_as_nobody(&["inspect", "echo", "--arm", &arm, "--domain", &domain, "--ipc-root", &root_arg, "--count", "1", "--timeout", "1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("{} belongs to uid 0 (mode 0600), this process is uid 65534: permission denied", segment.display())), "{err}");
    // The owner still commands the arm.
    let out = Command::new(jointctl()).args(["cmd", "--arm", &arm, "--domain", &domain, "--ipc-root", &root_arg, "hold"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    stop(&mut run);
    // A segment planted by another user for a domain is refused, with whose it is.
    let planted_domain = format!("sq{}", std::process::id());
    let hash_and_rest = segment.file_name().unwrap().to_str().unwrap().strip_prefix(&domain).unwrap().to_string();
    let planted = std::path::Path::new("/dev/shm").join(format!("{planted_domain}{hash_and_rest}"));
    let plant = Command::new("setpriv")
        .args(["--reuid=65534", "--regid=65534", "--clear-groups", "sh", "-c"])
        .arg(format!("umask 0; printf 0123456789abcdef > {}", planted.display()))
        .output()
        .unwrap();
    assert!(plant.status.success(), "{}", String::from_utf8_lossy(&plant.stderr));
    let ipc: serde_yaml::Value = serde_yaml::from_str(&format!("{{domain: {planted_domain}, root: {}}}", root.display())).unwrap();
    std::fs::write(&yaml, jointctl_tests::yaml_with(&text, &[jointctl_tests::Edit::Set("ipc", ipc)])).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3"]).output().unwrap();
    let _ = std::fs::remove_file(&planted);
    jointctl_tests::forget_test_domain(&domain);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("belongs to uid 65534") && err.contains("another user created this domain's management segment"), "{err}");
}

/// Issue 40, finding 18 (its leftovers): `cmd --domain` with a typo left a management segment
/// for that domain in /dev/shm, for good. Pass: a command to a domain nobody runs is refused as
/// "no runtime" and leaves no file of that domain behind.
#[test]
fn a_command_to_a_domain_nobody_runs_leaves_nothing_in_dev_shm() {
    let domain = format!("typo{}", std::process::id());
    let out = Command::new(jointctl()).args(["cmd", "enable", "q1", "--arm", "sherpa", "--domain", &domain]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no runtime is running arm `sherpa`"), "{err}");
    let left: Vec<String> = std::fs::read_dir("/dev/shm").unwrap().filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with(&domain)).collect();
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
}

/// Issue 40, finding 15: `ipc.root` in a world-writable sticky folder (`root: /tmp`) was
/// accepted; another user could make the arm's `services/`, `nodes/` and `jointctl/` folders
/// there first, open to all, and later empty `services/`, cutting `inspect` and `cmd` off the
/// running arm. Pass: a root of mode 1777 is refused before anything is created in it, naming
/// the folder and its mode; the same folder at 0700 runs.
#[test]
fn an_ipc_root_writable_by_others_is_refused_even_when_sticky() {
    use std::os::unix::fs::PermissionsExt as _;
    let (_, yaml) = write_rig("sticky-root", 100.0);
    let root = yaml.with_file_name("shared-root");
    std::fs::create_dir_all(&root).unwrap();
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let text = std::fs::read_to_string(&yaml).unwrap();
    std::fs::write(&yaml, format!("{text}\nipc:\n  domain: sticky{}\n  root: {}\n", std::process::id(), root.display())).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3", "--no-ipc"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("{} is writable by other users (mode 1777)", root.display())), "{err}");
    assert_eq!(std::fs::read_dir(&root).unwrap().count(), 0, "nothing was created in it");
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o700)).unwrap();
    let out = Command::new(jointctl()).arg("run").arg(&yaml).args(["--cycles", "3", "--no-ipc"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
