//! Helpers for the workspace integration tests: where the built binaries and plugin libraries
//! are, and small arm descriptions written on the fly.
//!
//! The tests use the artifacts of `cargo build --workspace` (the README's test command builds
//! them first): `jointctl` and the plugin `.so` files next to it in `target/<profile>/`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// `target/<profile>/`, where cargo puts binaries and cdylibs.
pub fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> -> target/<profile>
    exe.parent().and_then(Path::parent).expect("target dir").to_path_buf()
}

/// A built artifact, with a clear message when `cargo build --workspace` was not run.
pub fn artifact(file: &str) -> PathBuf {
    let p = target_dir().join(file);
    assert!(p.exists(), "{} is missing: run `cargo build --workspace` before the tests (the README's test command does)", p.display());
    p
}

/// The `jointctl` binary.
pub fn jointctl() -> PathBuf {
    artifact("jointctl")
}

/// The repository's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The interop venv's Python (`.ci/setup-python-venv` makes it; the README's test command runs
/// it), or `JOINTCTL_PYTHON`.
pub fn interop_python() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let p = std::env::var_os("JOINTCTL_PYTHON").map(PathBuf::from).unwrap_or_else(|| root.join(".venv-interop/bin/python"));
    assert!(p.exists(), "{} is missing: run `bash .ci/setup-python-venv` first (the README's test command does)", p.display());
    p
}

/// A fresh scratch folder for one test.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("jointctl-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// A child process ended by [`stop`] when the test ends, however it ends (a failed assertion
/// included).
///
/// ```no_run
/// let _arm = jointctl_tests::Running(std::process::Command::new("sleep").arg("60").spawn().unwrap());
/// ```
pub struct Running(pub std::process::Child);

impl Drop for Running {
    fn drop(&mut self) {
        stop(&mut self.0);
    }
}

/// Ends a child process the way a user does: SIGINT (a runtime holds its joints and removes its
/// shared memory; an inspector or bridge closes), then up to 10 s to exit, then SIGKILL.
/// Killing outright left every test's iceoryx2 files in /dev/shm: a test's domain or arm is its
/// own, so no later runtime finds and removes them (431 files after one run of the suite).
pub fn stop(child: &mut std::process::Child) {
    if let Ok(Some(_)) = child.try_wait() {
        return;
    }
    // SAFETY: a signal to our own child, which has not been reaped (its pid is still its own).
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    while std::time::Instant::now() < deadline {
        if let Ok(Some(_)) = child.try_wait() {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// Removes the management segment iceoryx2 keeps per domain in /dev/shm (a node counter, left
/// on purpose after every clean exit: `<domain><hash>_node.<version>.global_mgmt`) of a domain a
/// test made for itself, once everything in it has stopped, so that test runs do not pile them
/// up. Only that file: anything else left behind is a leak a test should see.
pub fn forget_test_domain(domain: &str) {
    let Ok(entries) = std::fs::read_dir("/dev/shm") else { return };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        // The domain, then its 40-digit hash, then the node's segment: `other12` must not take
        // `other123`'s.
        let ours = name.strip_prefix(domain).is_some_and(|rest| {
            rest.len() > 40 && rest.is_char_boundary(40) && rest[..40].bytes().all(|b| b.is_ascii_hexdigit()) && rest[40..].starts_with("_node.") && rest.ends_with(".global_mgmt")
        });
        if ours {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// A unique arm name for a test, so that parallel tests never share services.
pub fn arm_name(test: &str) -> String {
    format!("t{}-{test}", std::process::id())
}

/// A rig: joint `a` (rigid) plus `extra` joints given as YAML list items, with `n` drives and
/// encoders `m0..`/`e0..` (encoder i follows drive i).
pub fn rig_yaml(arm: &str, rate_hz: f64, extra: &str) -> String {
    let mut drives = String::new();
    let mut encoders = String::new();
    for i in 0..4 {
        drives.push_str(&format!("        - {{name: m{i}, node_id: {}}}\n", i + 1));
        encoders.push_str(&format!("        - {{name: e{i}, chip_select: {i}, sim: {{drive: m{i}}}}}\n"));
    }
    format!(
        "arm: {arm}\nrate_hz: {rate_hz}\nhal: {{backend: sim}}\ntiming: {{spin_us: 100}}\nbuses:\n  can:\n    - interface: can0\n      drives:\n{drives}  spi:\n    - device: /dev/spidev0\n      encoders:\n{encoders}joints:\n  - name: a\n    plugin: rigid\n    encoders: {{output: e0}}\n    drives: {{motor: m0}}\n    limits: {{position_rad: [-1.0, 1.0]}}\n    params: {{position_pi: {{kp: 0.2, ki: 0.5, output_limit: 0.05}}}}\n{extra}"
    )
}

/// One typed edit of a YAML document: set (or add) the field at a path, or remove it.
pub enum Edit<'a> {
    /// Set the field at this path; its parent must exist.
    Set(&'a str, serde_yaml::Value),
    /// Remove the field at this path; it must exist.
    Remove(&'a str),
}

/// Applies typed edits to a YAML document and returns the new text. A path is dot-separated
/// keys with `[i]` (an index) or `[name]` (the element whose `name` is `name`):
/// `arm`, `hal.sim.can_loss_rate`, `joints[q4].params.stiffness_nm_per_rad`,
/// `joints[shoulder].dofs[q2].controller.startup`. A path that does not lead anywhere panics,
/// so an edit can never silently miss when the file is reformatted (what a text replacement did).
///
/// ```
/// use jointctl_tests::{Edit, yaml_with};
/// let text = yaml_with("arm: a\njoints: [{name: q, params: {k: 1}}]\n", &[
///     Edit::Set("arm", "b".into()),
///     Edit::Set("joints[q].params.k", 2.into()),
/// ]);
/// let v: serde_yaml::Value = serde_yaml::from_str(&text).unwrap();
/// assert_eq!(v["joints"][0]["params"]["k"], 2);
/// ```
pub fn yaml_with(text: &str, edits: &[Edit]) -> String {
    let mut doc: serde_yaml::Value = serde_yaml::from_str(text).expect("the YAML to edit parses");
    for edit in edits {
        let path = match edit {
            Edit::Set(p, _) | Edit::Remove(p) => *p,
        };
        let (parent_path, last) = path.rsplit_once('.').map_or(("", path), |(a, b)| (a, b));
        let parent = navigate(&mut doc, parent_path, path);
        let map = parent.as_mapping_mut().unwrap_or_else(|| panic!("`{parent_path}` is not a mapping (editing `{path}`)"));
        match edit {
            Edit::Set(_, value) => {
                map.insert(last.into(), value.clone());
            }
            Edit::Remove(_) => {
                map.remove(last).unwrap_or_else(|| panic!("`{path}` is not in the document"));
            }
        }
    }
    serde_yaml::to_string(&doc).expect("serialise")
}

fn navigate<'v>(mut v: &'v mut serde_yaml::Value, path: &str, full: &str) -> &'v mut serde_yaml::Value {
    for seg in path.split('.').filter(|s| !s.is_empty()) {
        let (key, selector) = match seg.split_once('[') {
            Some((k, rest)) => (k, Some(rest.trim_end_matches(']'))),
            None => (seg, None),
        };
        v = v.get_mut(key).unwrap_or_else(|| panic!("`{key}` is not in the document (editing `{full}`)"));
        if let Some(sel) = selector {
            let list = v.as_sequence_mut().unwrap_or_else(|| panic!("`{key}` is not a list (editing `{full}`)"));
            let i = sel.parse::<usize>().ok().or_else(|| list.iter().position(|e| e.get("name").and_then(|n| n.as_str()) == Some(sel)));
            v = i.and_then(|i| list.get_mut(i)).unwrap_or_else(|| panic!("`{key}[{sel}]` is not in the document (editing `{full}`)"));
        }
    }
    v
}

/// The reference arm (`configs/sherpa_arm.yaml`) with typed edits, written to a scratch file
/// (returns its path). The arm is renamed `arm` so that parallel tests never share services.
pub fn sherpa_with(test: &str, arm: &str, edits: &[Edit]) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/sherpa_arm.yaml");
    let mut all = vec![Edit::Set("arm", arm.into())];
    all.extend(edits.iter().map(|e| match e {
        Edit::Set(p, v) => Edit::Set(p, v.clone()),
        Edit::Remove(p) => Edit::Remove(p),
    }));
    let text = yaml_with(&std::fs::read_to_string(&src).expect("configs/sherpa_arm.yaml"), &all);
    let path = scratch(test).join("sherpa.yaml");
    // Files the arm includes (the shoulder's table, the URDF) are found next to it.
    for line in text.lines() {
        // (A test's own include, an absolute path, stays where it is.)
        let trimmed = line.trim();
        let named = trimmed.strip_prefix("include:").or_else(|| trimmed.strip_prefix("urdf:"));
        if let Some(file) = named.map(str::trim).filter(|f| !f.is_empty() && Path::new(f).is_relative()) {
            let from = src.parent().expect("configs/").join(file);
            std::fs::copy(&from, path.with_file_name(file)).unwrap_or_else(|e| panic!("copy {}: {e}", from.display()));
        }
    }
    std::fs::write(&path, text).expect("write the edited arm");
    path
}

/// Replaces the one occurrence of `from` in `text`, for tests whose subject is the text itself
/// (error positions): panics unless `from` occurs exactly once, so it cannot silently miss.
///
/// ```
/// assert_eq!(jointctl_tests::replace_once("rate_hz: 40\n", "rate_hz: 40", "rate_hz: -1"), "rate_hz: -1\n");
/// ```
pub fn replace_once(text: &str, from: &str, to: &str) -> String {
    let n = text.matches(from).count();
    assert_eq!(n, 1, "`{from}` occurs {n} times, expected once");
    text.replacen(from, to, 1)
}

/// Runs `cmd`, asserts that it succeeded (its stderr in the message), and returns its stdout.
pub fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{cmd:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// The relative drop of the held-out RMSE in `jointctl identify --json`'s `gains.<side>`
/// (`simulation`, `observer`; 0.6: 60 % smaller).
pub fn identify_gain(json: &serde_json::Value, side: &str) -> f64 {
    let g = &json["gains"][side];
    1.0 - g["rmse_after"].as_f64().unwrap() / g["rmse_before"].as_f64().unwrap()
}
