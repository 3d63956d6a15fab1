//! What the benchmarks (`benches/runtime.rs`, `benches/soak.rs`, `benches/recording.rs`) share.

use std::path::{Path, PathBuf};

use jointctl_runtime::PluginLoader;

/// The repository's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `configs/sherpa_arm.yaml` as arm `arm` at `rate_hz` (includes resolved next to it).
pub fn sherpa(rate_hz: f64, arm: &str) -> jointctl_config::LoadedConfig {
    let path = root().join("configs/sherpa_arm.yaml");
    let text = std::fs::read_to_string(&path).expect("configs/sherpa_arm.yaml");
    let text = text.replacen("arm: sherpa", &format!("arm: {arm}"), 1).replacen("rate_hz: 40 ", &format!("rate_hz: {rate_hz} "), 1);
    jointctl_config::parse_str(&text, &path).expect("sherpa config")
}

/// Where `cargo build --release` put the binaries and plugin libraries: the folder above the
/// running benchmark's own (`target/release/deps/NAME-xxxx`).
pub fn release_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the benchmark's path");
    exe.parent().and_then(Path::parent).expect("target/release/deps").to_path_buf()
}

/// Registers the SHERPA arm's four plugins, linked into the benchmark (so that their
/// allocations, if any, go through the benchmark's counting allocator).
///
/// ```
/// let mut loader = jointctl_runtime::PluginLoader::new([]);
/// jointctl_bench::register_sherpa_plugins(&mut loader);
/// assert!(loader.load("vsa_wrist", None).is_ok());
/// ```
pub fn register_sherpa_plugins(loader: &mut PluginLoader) {
    for descriptor in [
        jointctl_plugin_rigid::plugin_descriptor(),
        jointctl_plugin_elastic::plugin_descriptor(),
        jointctl_plugin_vsa_shoulder::plugin_descriptor(),
        jointctl_plugin_vsa_wrist::plugin_descriptor(),
    ] {
        loader.register_static(descriptor).expect("the SHERPA plugins pass the host's checks");
    }
}
