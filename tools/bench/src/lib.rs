//! What the benchmarks (`benches/runtime.rs`, `benches/soak.rs`) share.

use jointctl_runtime::PluginLoader;

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
