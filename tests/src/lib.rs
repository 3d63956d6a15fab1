//! Helpers for the workspace integration tests: where the built binaries and plugin libraries
//! are, and small arm descriptions written on the fly.
//!
//! The tests use the artifacts of `cargo build --workspace` (the README's test command builds
//! them first): `jointctl` and the plugin `.so` files next to it in `target/<profile>/`.

use std::path::{Path, PathBuf};

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

/// A fresh scratch folder for one test.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("jointctl-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
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
