//! Files a user names (a plugin, an include, a URDF, data) that are not regular files: refused at
//! once with the file and the reason, never read without end and never waited on (issue 40,
//! findings 1-3).

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use jointctl_tests::{Edit, jointctl, scratch, sherpa_with};

/// Runs jointctl with `args` and a deadline: (exit success, stderr, seconds taken). A child still
/// running at the deadline is killed and the test fails (it blocked or ran away).
fn run_with_deadline(args: &[&std::ffi::OsStr], deadline_s: u64) -> (bool, String, f64) {
    let start = Instant::now();
    let mut child = Command::new(jointctl()).args(args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
            return (status.success(), err, start.elapsed().as_secs_f64());
        }
        if start.elapsed() > Duration::from_secs(deadline_s) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("jointctl {args:?} still running after {deadline_s} s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn fifo(path: &std::path::Path) {
    let _ = std::fs::remove_file(path);
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success(), "mkfifo {}", path.display());
}

#[test]
fn check_refuses_a_device_or_a_fifo_named_as_a_plugin_include_or_urdf_at_once() {
    let dir = scratch("user_files_check");
    let pipe = dir.join("pipe");
    fifo(&pipe);
    let pipe_s = pipe.to_str().unwrap().to_string();
    // Each a field of the reference arm pointed at something that is not a regular file.
    let cases: Vec<(&str, Edit, &str)> = vec![
        ("include /dev/zero", Edit::Set("joints[q4].params.include", "/dev/zero".into()), "/dev/zero"),
        ("include FIFO", Edit::Set("joints[q4].params.include", pipe_s.clone().into()), "pipe"),
        ("URDF /dev/urandom", Edit::Set("kinematics.urdf", "/dev/urandom".into()), "/dev/urandom"),
        ("URDF FIFO", Edit::Set("kinematics.urdf", pipe_s.clone().into()), "pipe"),
        ("plugin /dev/zero", Edit::Set("joints[q1].plugin", serde_yaml::from_str("{name: rigid, path: /dev/zero}").unwrap()), "/dev/zero"),
        ("plugin FIFO", Edit::Set("joints[q1].plugin", serde_yaml::from_str(&format!("{{name: rigid, path: {pipe_s}}}")).unwrap()), "pipe"),
    ];
    for (i, (label, edit, named)) in cases.into_iter().enumerate() {
        let yaml = sherpa_with(&format!("user_files_check_{i}"), &format!("uf{i}"), &[edit]);
        let (ok, err, secs) = run_with_deadline(&["check".as_ref(), yaml.as_os_str()], 20);
        assert!(!ok, "{label}: check passed");
        assert!(err.contains(named) && err.contains("not a regular file"), "{label}: {err}");
        assert!(secs < 10.0, "{label}: {secs} s");
    }
    std::fs::remove_file(&pipe).unwrap();
}

/// Finding (issue 40, 2): a FIFO named as a joint's `params.include`, a plugin's path or the
/// URDF made `run` block for ever (the open waited for a writer that never came), and `run`
/// ignored SIGINT meanwhile, so only SIGKILL ended it. `run` loads the same files as `check`,
/// through the same refusal. Pass: `run --duration 2` on each exits non-zero within seconds, and
/// its error names the FIFO and says it is not a regular file.
#[test]
fn run_refuses_a_fifo_named_as_a_plugin_include_or_urdf_at_once() {
    let dir = scratch("user_files_run");
    let pipe = dir.join("pipe");
    fifo(&pipe);
    let pipe_s = pipe.to_str().unwrap().to_string();
    let cases: Vec<(&str, Edit)> = vec![
        ("include FIFO", Edit::Set("joints[q4].params.include", pipe_s.clone().into())),
        ("plugin FIFO", Edit::Set("joints[q1].plugin", serde_yaml::from_str(&format!("{{name: rigid, path: {pipe_s}}}")).unwrap())),
        ("URDF FIFO", Edit::Set("kinematics.urdf", pipe_s.clone().into())),
    ];
    for (i, (label, edit)) in cases.into_iter().enumerate() {
        let yaml = sherpa_with(&format!("user_files_run_{i}"), &format!("ufr{i}"), &[edit]);
        let (ok, err, secs) = run_with_deadline(&["run".as_ref(), yaml.as_os_str(), "--duration".as_ref(), "2".as_ref()], 20);
        assert!(!ok, "{label}: run did not fail: {err}");
        assert!(err.contains(&pipe_s) && err.contains("FIFO, not a regular file"), "{label}: {err}");
        assert!(secs < 10.0, "{label}: {secs} s");
    }
    std::fs::remove_file(&pipe).unwrap();
}

#[test]
fn fit_and_identify_refuse_a_device_or_a_fifo_as_data_at_once() {
    let dir = scratch("user_files_data");
    let pipe = dir.join("data.csv");
    fifo(&pipe);
    for data in [std::path::Path::new("/dev/zero"), pipe.as_path()] {
        for args in [vec!["fit".as_ref(), data.as_os_str()], vec!["identify".as_ref(), "--data".as_ref(), data.as_os_str()]] {
            let (ok, err, secs) = run_with_deadline(&args, 20);
            assert!(!ok && err.contains("not a regular file"), "{args:?}: {err}");
            assert!(secs < 10.0, "{args:?}: {secs} s");
        }
    }
    std::fs::remove_file(&pipe).unwrap();
}
