//! # jointctl examples
//!
//! `cargo run --example NAME` from the repository's root:
//!
//! - `minimal_plugin`: a joint type written in a few dozen lines (observer, controller,
//!   parameters), linked into a program that wires a one-joint arm from YAML on the simulated HAL
//!   and moves it. Built as a `cdylib` instead, the same code is a plugin the host loads by path
//!   (see `plugins/example_sea`).
//! - `read_shared_memory`: what an inspector does: subscribe to a running arm's joint states in
//!   iceoryx2 shared memory and print them (the example runs the arm it reads, in a thread).
//! - `identify_from_rust`: `jointctl identify` called from code, on the elbow characterisation
//!   in `tests/data`.
//!
//! This library holds what the examples share.

use std::path::PathBuf;

/// The book's chapters with Rust in them, compiled and run as doctests here, where the jointctl
/// crates are in scope (`mdbook build docs` renders the same files).
#[doc = include_str!("../docs/writing-a-plugin.md")]
pub mod book_writing_a_plugin {}

/// The repository's root (the examples read its `configs/` and `tests/data/`).
///
/// ```
/// assert!(jointctl_examples::repository().join("configs").is_dir());
/// ```
pub fn repository() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A one-joint arm on the simulated HAL: joint `q` of plugin `plugin`, its output encoder `e`
/// and motor drive `m`, a free link of 0.5 kg m^2 (an assumption: any plausible link), at
/// `rate_hz`, as arm `arm`.
///
/// ```
/// let yaml = jointctl_examples::one_joint_arm("demo", "rigid", 500.0, "{stiffness_nm_per_rad: 8.3e4}");
/// assert!(jointctl_config::parse_str(&yaml, "demo.yaml").is_ok());
/// ```
pub fn one_joint_arm(arm: &str, plugin: &str, rate_hz: f64, params: &str) -> String {
    format!(
        "version: 1\narm: {arm}\nrate_hz: {rate_hz}\nhal: {{backend: sim}}\nbuses:\n  can: [{{interface: can0, drives: [{{name: m, node_id: 1}}]}}]\n  spi: [{{device: /dev/spidev0.0, encoders: [{{name: e, chip_select: 0, sim: {{signal: q.output}}}}]}}]\njoints:\n  - name: q\n    plugin: {plugin}\n    encoders: {{output: e}}\n    drives: {{motor: m}}\n    limits: {{position_rad: [-1.0, 1.0], torque_nm: 20}}\n    sim: {{drives: [m], matrix: [[1.0]], element: {{kind: rigid}}, environment: {{kind: free, inertia_kgm2: 0.5, damping_nms_per_rad: 2.0}}}}\n    params: {params}\n"
    )
}
