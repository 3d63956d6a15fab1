//! What the benchmarks (`benches/runtime.rs`, `benches/latency.rs`, `benches/scale.rs`,
//! `benches/soak.rs`, `benches/recording.rs`, `benches/bridges.rs`, `benches/identify_speed.rs`)
//! share.

use std::path::{Path, PathBuf};

use jointctl_runtime::{Arm, PluginLoader};

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
#[derive(Clone, Copy, Debug, Default)]
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
    /// Deadlines skipped.
    pub missed: u64,
    /// Records the publisher thread could not take.
    pub drops: u64,
    /// Joints faulted by the end of the run.
    pub faulted: usize,
}

/// The full SHERPA arm as `arm_name` at 1 kHz for `seconds`, publishing to shared memory, q2
/// tracking a 5 Nm, 0.5 Hz torque sine and the others holding (the plugins from the release
/// build).
pub fn run_sherpa_loop(seconds: f64, arm_name: &str) -> LoopRun {
    run_sherpa_loop_with(seconds, arm_name, |_| {})
}

/// [`run_sherpa_loop`] with the config edited first (its `timing`, say). Scheduling settings
/// hold for the calling thread after the run: call it on a thread of its own to keep them apart.
pub fn run_sherpa_loop_with(seconds: f64, arm_name: &str, edit: impl FnOnce(&mut jointctl_config::ArmConfig)) -> LoopRun {
    let mut loaded = sherpa(1000.0, arm_name);
    edit(&mut loaded.config);
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
        missed: st.missed_deadlines,
        drops: publisher.drops(),
        faulted: arm.slots.iter().filter(|slot| slot.fault != 0).count(),
    }
}

/// An environment variable's value, or `default` when it is unset or does not parse.
///
/// ```
/// assert_eq!(jointctl_bench::env_or("JOINTCTL_BENCH_UNSET_EXAMPLE", 7_usize), 7);
/// ```
pub fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
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

/// The SHERPA arm as `arm` at `rate_hz`, activated, every DOF holding a position a little off
/// zero; its plugins linked in (`statically`) or loaded from the release build.
pub fn build(statically: bool, rate_hz: f64, arm: &str) -> (Arm, jointctl_config::LoadedConfig) {
    build_with(statically, rate_hz, arm, |_| {})
}

/// [`build`] with the config edited before the arm is built.
pub fn build_with(statically: bool, rate_hz: f64, arm: &str, edit: impl FnOnce(&mut jointctl_config::ArmConfig)) -> (Arm, jointctl_config::LoadedConfig) {
    let mut loaded = sherpa(rate_hz, arm);
    edit(&mut loaded.config);
    let mut loader = PluginLoader::new([release_dir()]);
    if statically {
        register_sherpa_plugins(&mut loader);
    }
    let mut arm = jointctl_backends::build_arm(&loaded, &loader).unwrap_or_else(|e| panic!("{e}\n(build the plugins first: cargo build --release --workspace)"));
    arm.activate().expect("the simulated arm activates");
    hold_near_zero(&mut arm);
    (arm, loaded)
}

/// Every DOF of `arm` holding a position 0.1 rad x its index off zero, alternating in sign.
pub fn hold_near_zero(arm: &mut Arm) {
    for i in 0..arm.dof_names.len() {
        let target_rad = 0.1 * (i as f64 + 1.0) * if i % 2 == 0 { 1.0 } else { -1.0 };
        arm.set_mode(i, jointctl_modes::Mode::Position { target_rad });
    }
}

/// The median of `v` (sorted in place).
///
/// ```
/// assert_eq!(jointctl_bench::median(&mut [3.0, 1.0, 2.0]), 2.0);
/// ```
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The `p`th percentile of `v` (sorted in place), nearest rank; 0 for no values.
///
/// ```
/// assert_eq!(jointctl_bench::percentile(&mut [5, 1, 9, 3], 50.0), 5);
/// assert_eq!(jointctl_bench::percentile(&mut [], 99.0), 0);
/// ```
pub fn percentile(v: &mut [u64], p: f64) -> u64 {
    if v.is_empty() {
        return 0;
    }
    v.sort_unstable();
    v[((p / 100.0) * (v.len() - 1) as f64).round() as usize]
}

/// A HAL with no physics behind it, to time the runtime alone: every drive reads back, fresh
/// and enabled, the last position it was sent, and encoder `i` reads drive `i`'s position (the
/// generated arms' wiring, [`jointctl_test_support::generated_arm`]); an encoder without a
/// drive of its index reads 0. Allocation-free after construction.
///
/// ```
/// use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, SensorFrame};
/// let devices = DeviceIndex { encoders: vec!["e0".into()], drives: vec!["m0".into()], torque_sensors: vec![] };
/// let mut hal = jointctl_bench::EchoHal::new(&devices);
/// let mut out = ActuatorFrame::new(&devices);
/// out.drives[0] = jointctl_api::MotorSetpoint::move_to(0.3);
/// hal.write(&out, 1e-3).unwrap();
/// let mut frame = SensorFrame::new(&devices);
/// hal.read(&mut frame).unwrap();
/// assert_eq!(frame.encoders[0].usable(1.0), Some(0.3));
/// ```
pub struct EchoHal {
    positions_rad: Vec<f64>,
}

impl EchoHal {
    /// Every drive of `devices` at 0 rad.
    pub fn new(devices: &jointctl_hal::DeviceIndex) -> Self {
        EchoHal { positions_rad: vec![0.0; devices.drives.len()] }
    }
}

impl jointctl_hal::Hal for EchoHal {
    fn read(&mut self, frame: &mut jointctl_hal::SensorFrame) -> Result<(), jointctl_hal::HalIoError> {
        use jointctl_api::{DriveReading, Reading};
        for (d, &q) in frame.drives.iter_mut().zip(&self.positions_rad) {
            *d = DriveReading::new(Reading::valid(q), Reading::valid(0.0), true, false);
        }
        for (i, e) in frame.encoders.iter_mut().enumerate() {
            *e = Reading::valid(self.positions_rad.get(i).copied().unwrap_or(0.0));
        }
        frame.torque_sensors.fill(Reading::MISSING);
        Ok(())
    }

    fn write(&mut self, frame: &jointctl_hal::ActuatorFrame, _dt_s: f64) -> Result<(), jointctl_hal::HalIoError> {
        for (q, sp) in self.positions_rad.iter_mut().zip(&frame.drives) {
            if sp.action == jointctl_api::DriveAction::MOVE {
                *q = sp.position_rad;
            }
        }
        Ok(())
    }
}

/// The SHERPA config as arm `arm` at `rate_hz` in a temporary file (its includes made
/// absolute), for a `jointctl` process to run; the caller removes it.
pub fn sherpa_file(arm: &str, rate_hz: f64) -> std::path::PathBuf {
    let root = root();
    let text = std::fs::read_to_string(root.join("configs/sherpa_arm.yaml")).expect("configs/sherpa_arm.yaml");
    let text = text.replacen("arm: sherpa", &format!("arm: {arm}"), 1).replacen("rate_hz: 40 ", &format!("rate_hz: {rate_hz} "), 1);
    let text = text.replace("include: sherpa_", &format!("include: {}/configs/sherpa_", root.display()));
    let text = text.replace("urdf: sherpa_", &format!("urdf: {}/configs/sherpa_", root.display()));
    let path = std::env::temp_dir().join(format!("jointctl-bench-{}-{arm}.yaml", std::process::id()));
    std::fs::write(&path, text).expect("a temporary config");
    path
}

/// CPU time [s] of the children waited for so far (user + system).
pub fn children_cpu_s() -> f64 {
    // SAFETY: getrusage writes into a valid rusage.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: a valid `who` and a valid pointer.
    unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut u) };
    let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
    t(u.ru_utime) + t(u.ru_stime)
}


/// A busy loop per core, as separate processes (ordinary priority), until dropped.
pub struct Hogs(Vec<std::process::Child>);

impl Hogs {
    /// Starts them.
    pub fn start() -> Hogs {
        let n = std::thread::available_parallelism().map_or(1, |n| n.get());
        Hogs((0..n).map(|_| std::process::Command::new("sh").args(["-c", "while :; do :; done"]).spawn().expect("sh")).collect())
    }
}

impl Drop for Hogs {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// The identification benchmarks' record: `n` samples of a 200 Hz characterisation (a 0.2 Hz
/// sine of 0.1 rad), a spring of 120 Nm/rad, eq. 3.5's friction and a hidden Dahl hysteresis
/// (limit 1 Nm), a 14-bit deflection and a noisy torque sensor (uniform, 0.05 Nm wide).
///
/// ```
/// let d = jointctl_bench::hysteresis_record(400);
/// assert_eq!((d.t.len(), d.deflection.len(), d.torque.len()), (400, 400, 400));
/// ```
pub fn hysteresis_record(n: usize) -> jointctl_ident::csv::Data {
    let q = std::f64::consts::TAU / 16384.0;
    let (amp, f, k, fc, lambda) = (0.1, 0.2, 120.0, 1.0, 0.008);
    let mut z: f64 = 0.0;
    let mut prev = 0.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x1234_5678_9abc_def1);
    let mut noise = || (rng.uniform() - 0.5) * 0.05;
    let mut data = jointctl_ident::csv::Data::default();
    for i in 0..n {
        let t = i as f64 / 200.0;
        let x = amp * (std::f64::consts::TAU * f * t).sin();
        let step = x - prev;
        if step != 0.0 {
            let sgn = step.signum();
            z = sgn + (z - sgn) * (-step.abs() / lambda).exp();
        }
        prev = x;
        data.t.push(t);
        data.deflection.push((x / q).round() * q);
        data.torque.push(k * x + 0.3 * (80.0 * amp * std::f64::consts::TAU * f * (std::f64::consts::TAU * f * t).cos()).atan() + fc * z + noise());
    }
    data
}
