//! What the benchmarks (`benches/runtime.rs`, `benches/soak.rs`, `benches/recording.rs`,
//! `benches/bridges.rs`) share.

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

/// The loop's timing in one run of [`run_sherpa_loop`].
#[derive(Clone, Copy, Debug)]
pub struct LoopRun {
    /// Cycles run.
    pub cycles: u64,
    /// Median wake-up lateness [us].
    pub p50_us: f64,
    /// 99th percentile wake-up lateness [us].
    pub p99_us: f64,
    /// Largest wake-up lateness [us].
    pub max_us: f64,
    /// Cycles whose work ended after the next deadline.
    pub overruns: u64,
    /// Records the publisher thread could not take.
    pub drops: u64,
}

/// The full SHERPA arm as `arm_name` at 1 kHz for `seconds`, publishing to shared memory, q2
/// tracking a 5 Nm, 0.5 Hz torque sine and the others holding (the plugins from the release
/// build).
pub fn run_sherpa_loop(seconds: f64, arm_name: &str) -> LoopRun {
    let loaded = sherpa(1000.0, arm_name);
    let loader = PluginLoader::new([release_dir()]);
    let mut arm = jointctl_backends::build_arm(&loaded, &loader).unwrap_or_else(|e| panic!("{e}\n(build first: cargo build --release --workspace)"));
    arm.activate().expect("the simulated arm activates");
    let reference = jointctl_modes::Reference { waveform: jointctl_modes::Waveform::Sine, amplitude: 5.0, frequency_hz: 0.5, offset: 0.0, start_s: 0.0 };
    arm.set_mode(1, jointctl_modes::Mode::Torque { reference });
    let mut publisher = jointctl_runtime::ArmPublisher::new(&arm, None).expect("the arm's shared memory");
    let cycles = (seconds * 1000.0) as u64;
    let opts = jointctl_runtime::RunOptions { cycles: Some(cycles), duration_s: None, timing_samples: cycles as usize, stop: None };
    let r = jointctl_runtime::run(&mut arm, &loaded.config.timing, Some(&mut publisher), &opts).expect("the loop runs");
    let st = &r.stats;
    let us = |v: Option<u64>| v.map_or(f64::NAN, |n| n as f64 / 1e3);
    LoopRun {
        cycles: st.cycles,
        p50_us: us(st.jitter_percentile_ns(50.0)),
        p99_us: us(st.jitter_percentile_ns(99.0)),
        max_us: st.max_jitter_ns as f64 / 1e3,
        overruns: st.overruns,
        drops: publisher.drops(),
    }
}

/// Prints the loop's figures of a run without and a run with something attached, and their
/// difference, as a Markdown table under `title`.
pub fn print_side_by_side(title: &str, runs: [(&str, &LoopRun); 2]) {
    let [(_, alone), (_, with)] = runs;
    println!("## {title} (lateness = wake-up time - deadline)");
    println!("| run | cycles | p50 lateness us | p99 lateness us | max lateness us | overruns | records dropped by the runtime |");
    println!("|---|---|---|---|---|---|---|");
    for (name, r) in runs {
        println!("| {name} | {} | {:.1} | {:.1} | {:.1} | {} | {} |", r.cycles, r.p50_us, r.p99_us, r.max_us, r.overruns, r.drops);
    }
    println!("| with - without | | {:+.1} | {:+.1} | {:+.1} | {:+} | |", with.p50_us - alone.p50_us, with.p99_us - alone.p99_us, with.max_us - alone.max_us, with.overruns as i64 - alone.overruns as i64);
    println!();
}
