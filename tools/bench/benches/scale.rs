//! `cargo bench -p jointctl-bench --bench scale`: the loop at scale and under load (issue 34).
//!
//! 1. Generated arms of 7, 16, 70 and 700 DOFs, rigid and elastic, on the simulated HAL and on
//!    a HAL with no physics ([`jointctl_bench::EchoHal`]): cycle compute per DOF, and what
//!    publishing costs the loop thread.
//! 2. Publishing and recording at 7, 70 and 700 DOFs: `jointctl run` with `jointctl record`.
//! 3. Several arms on one machine, each its own `jointctl run` process.
//! 4. The SHERPA arm at 1 kHz on an idle and on a loaded machine (a busy loop per core), with and
//!    without SCHED_FIFO and CPU affinity, with and without locked memory.
//!
//! Environment: `BENCH_LOAD_S` (default 60) seconds per loaded-machine run, `BENCH_ARMS_S`
//! (default 10) per several-arms run, `BENCH_RECORD_S` (default 5) per recorded run; `BENCH_QUICK=1` shortens everything for a smoke run.
//! Needs `cargo build --release --workspace` first (the `jointctl` binary and the plugins).

use std::process::{Child, Command, Stdio};
use std::time::Duration;

use jointctl_bench::{EchoHal, median, percentile};
use jointctl_runtime::timing::monotonic_ns;
use jointctl_runtime::{Arm, ArmPublisher, PluginLoader};
use jointctl_test_support::generated_arm::{JointKind, arm_yaml};

/// A generated arm, plugins linked in, on the simulated HAL or the echo HAL, activated and
/// holding.
fn generated(name: &str, dofs: usize, kind: JointKind, physics: bool) -> Arm {
    let loaded = jointctl_config::parse_str(&arm_yaml(name, dofs, kind, 1000.0), "generated.yaml").unwrap_or_else(|e| panic!("{e}"));
    let mut loader = PluginLoader::new([]);
    jointctl_bench::register_sherpa_plugins(&mut loader);
    let hal: Box<dyn jointctl_hal::Hal> = if physics {
        jointctl_backends::build_hal(&loaded).unwrap_or_else(|e| panic!("{e}"))
    } else {
        Box::new(EchoHal::new(&jointctl_hal::DeviceIndex::of(&loaded.config)))
    };
    let mut arm = Arm::build(&loaded, &loader, hal).unwrap_or_else(|e| panic!("{e}"));
    arm.activate().expect("a generated arm activates");
    jointctl_bench::hold_near_zero(&mut arm);
    arm
}

/// Each of `cycles` cycles' compute [ns], one `Arm::step` each.
fn cycle_times(arm: &mut Arm, cycles: usize, t0: &mut f64) -> Vec<u64> {
    let mut v = Vec::with_capacity(cycles);
    for _ in 0..cycles {
        let start = monotonic_ns();
        arm.step(*t0);
        v.push(monotonic_ns() - start);
        *t0 += 1e-3;
    }
    v
}

/// One row of the scale table.
struct Scale {
    kind: JointKind,
    dofs: usize,
    physics: bool,
    arm: Arm,
    clock_s: f64,
    medians: Vec<f64>,
    p99s: Vec<f64>,
}

fn scale_table(quick: bool) {
    let sizes = [7, 16, 70, 700];
    let rounds = if quick { 2 } else { 7 };
    let mut rows = Vec::new();
    for kind in [JointKind::Rigid, JointKind::Elastic] {
        for &dofs in &sizes {
            for physics in [true, false] {
                let name = format!("bench-scale-{}-{dofs}-{}", kind.plugin(), if physics { "sim" } else { "none" });
                let arm = generated(&name, dofs, kind, physics);
                rows.push(Scale { kind, dofs, physics, arm, clock_s: 0.0, medians: Vec::new(), p99s: Vec::new() });
            }
        }
    }
    // Round by round through every arm, so that the machine's changing speed hits all alike;
    // each round runs about the same number of DOF-cycles per arm.
    for round in 0..=rounds {
        for r in &mut rows {
            let cycles = (if quick { 200_000 } else { 1_400_000 } / r.dofs).clamp(300, 20_000);
            let mut t = cycle_times(&mut r.arm, cycles, &mut r.clock_s);
            if round > 0 {
                r.medians.push(percentile(&mut t, 50.0) as f64);
                r.p99s.push(percentile(&mut t, 99.0) as f64);
            }
        }
    }
    println!("## Cycle compute by arm size, 1 kHz, plugins linked in, {rounds} interleaved rounds (median of the rounds' medians and 99th percentiles)");
    println!("One cycle = read HAL, observe, control, write HAL (`Arm::step`). \"none\": the HAL echoes the set-points with no physics, so the cycle is the runtime and the plugins alone.");
    println!();
    println!("| joints | DOFs | HAL | median us/cycle | p99 us/cycle | median ns per DOF | p99 ns per DOF | per DOF, against 7 DOFs |");
    println!("|---|---|---|---|---|---|---|---|");
    let per_dof = |r: &Scale| median(&mut r.medians.clone()) / r.dofs as f64;
    for r in &rows {
        let base = rows.iter().find(|b| b.kind == r.kind && b.physics == r.physics && b.dofs == 7).map_or(f64::NAN, per_dof);
        let (m, p) = (median(&mut r.medians.clone()), median(&mut r.p99s.clone()));
        println!(
            "| {} | {} | {} | {:.1} | {:.1} | {:.0} | {:.0} | {:.2} |",
            r.kind.plugin(),
            r.dofs,
            if r.physics { "sim" } else { "none" },
            m / 1e3,
            p / 1e3,
            m / r.dofs as f64,
            p / r.dofs as f64,
            per_dof(r) / base
        );
    }
    println!();
    println!("target: per DOF at 700 DOFs within 1.5x of that at 7, HAL \"none\" (issue 34)");
    println!();
    drop(rows);

    // What publishing costs the loop thread: filling the cycle's record and handing it to the
    // publisher thread, where the arm fits the samples.
    println!("## Publishing, 1 kHz: the loop thread's share (fill the state, diagnostics and raw record, hand it over), HAL \"none\"");
    let size = |n: usize| format!("{:.1} KiB", n as f64 / 1024.0);
    println!(
        "A cycle's record is sized by the arm: per DOF, joint state {}, diagnostics {}; per device, diagnostics {}; per drive, raw readings {}, per encoder {}.",
        size(std::mem::size_of::<jointctl_ipc::JointSample>()),
        size(std::mem::size_of::<jointctl_ipc::JointDiagnostics>()),
        size(std::mem::size_of::<jointctl_ipc::DeviceDiagnostics>()),
        size(std::mem::size_of::<jointctl_ipc::raw::RawDrive>()),
        size(std::mem::size_of::<jointctl_ipc::raw::RawReading>())
    );
    println!();
    println!("| joints | DOFs | median ns/cycle | p99 ns/cycle | median ns per DOF | records dropped (the publisher thread behind) |");
    println!("|---|---|---|---|---|---|");
    for kind in [JointKind::Rigid, JointKind::Elastic] {
        for &dofs in &sizes {
            let name = format!("bench-pub-{}-{dofs}", kind.plugin());
            let mut arm = generated(&name, dofs, kind, false);
            let mut publisher = match ArmPublisher::new(&arm, None) {
                Ok(p) => p,
                Err(e) => {
                    println!("| {} | {dofs} | - | - | - | - (not published: {}) |", kind.plugin(), short_reason(&e.to_string()));
                    continue;
                }
            };
            let stats = jointctl_runtime::timing::LoopStats::with_samples(0);
            let cycles = if quick { 2_000 } else { 20_000 };
            let mut times = Vec::with_capacity(cycles);
            for cycle in 0..cycles as u64 {
                arm.step(cycle as f64 * 1e-3);
                let start = monotonic_ns();
                publisher.publish_state(&arm, cycle, start, false);
                publisher.publish_diagnostics(&arm, &stats, cycle, start);
                times.push(monotonic_ns() - start);
                // Paced loosely so that the publisher thread keeps up, as at 1 kHz.
                if cycle % 16 == 15 {
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
            let (m, p) = (percentile(&mut times, 50.0), percentile(&mut times, 99.0));
            println!("| {} | {dofs} | {m} | {p} | {:.0} | {} of {cycles} |", kind.plugin(), m as f64 / dofs as f64, publisher.drops());
        }
    }
    println!();
}

/// The first sentence of a long error.
fn short_reason(e: &str) -> String {
    e.split(':').next().unwrap_or(e).to_string()
}

/// The numbers of `jointctl run`'s summary line ("N cycles, N overruns, N missed deadlines, max
/// compute X us, max wake-up lateness X us").
fn run_summary(stderr: &str) -> Option<[f64; 5]> {
    let line = stderr.lines().rev().find(|l| l.contains(" cycles, "))?;
    let nums: Vec<f64> = line.split([',', ' ']).filter_map(|w| w.parse().ok()).collect();
    (nums.len() >= 5).then(|| [nums[0], nums[1], nums[2], nums[3], nums[4]])
}

fn several_arms(quick: bool) {
    let exe = jointctl_bench::release_dir().join("jointctl");
    let seconds = jointctl_bench::env_or("BENCH_ARMS_S", if quick { 3.0 } else { 10.0 });
    println!("## Several arms on one machine: each a `jointctl run` process of the 7-DOF SHERPA arm at 1 kHz (simulated, publishing), {seconds} s");
    println!("| arms | cycles (all) | overruns (all) | missed deadlines (all) | worst max compute us | worst max lateness us | CPU, % of one core per arm |");
    println!("|---|---|---|---|---|---|---|");
    for n in [1, 2, 4, 8] {
        let files: Vec<_> = (0..n).map(|i| jointctl_bench::sherpa_file(&format!("bench-arms-{n}-{i}"), 1000.0)).collect();
        let cpu_before = jointctl_bench::children_cpu_s();
        let children: Vec<Child> = files
            .iter()
            .map(|f| Command::new(&exe).arg("run").arg(f).args(["--duration", &seconds.to_string()]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap())
            .collect();
        let outs: Vec<_> = children.into_iter().map(|c| c.wait_with_output().unwrap()).collect();
        let cpu = jointctl_bench::children_cpu_s() - cpu_before;
        let sums: Vec<[f64; 5]> = outs.iter().filter_map(|o| run_summary(&String::from_utf8_lossy(&o.stderr))).collect();
        if sums.len() != n {
            let why: Vec<_> = outs.iter().map(|o| String::from_utf8_lossy(&o.stderr).lines().last().unwrap_or("").to_string()).collect();
            println!("| {n} | - | - | - | - | - | - ({} of {n} runs reported: {why:?}) |", sums.len());
        } else {
            let total = |k: usize| sums.iter().map(|s| s[k]).sum::<f64>();
            let worst = |k: usize| sums.iter().map(|s| s[k]).fold(0.0, f64::max);
            println!("| {n} | {} | {} | {} | {:.1} | {:.1} | {:.1} |", total(0), total(1), total(2), worst(3), worst(4), 100.0 * cpu / seconds / n as f64);
        }
        for f in files {
            let _ = std::fs::remove_file(f);
        }
    }
    println!();
}

/// A generated arm run as `jointctl run` at 1 kHz (simulated, publishing) with `jointctl record`
/// attached, at each size: what the loop keeps of its deadlines, and what the recorder costs and
/// loses. The recorder's CPU is its own (it is waited for before the runtime).
fn recorded_at_size(quick: bool) {
    let exe = jointctl_bench::release_dir().join("jointctl");
    let seconds = jointctl_bench::env_or("BENCH_RECORD_S", if quick { 2.0 } else { 5.0 });
    println!("## Publishing and recording at size: a generated rigid arm, `jointctl run --static-plugins` at 1 kHz (simulated HAL, publishing), alone and with `jointctl record` ({seconds} s, its JSON and its ROS 2 profile)");
    println!("| DOFs | recorder | recorded messages | lost by the recorder | MiB written | recorder wall s | recorder CPU s | loop cycles | overruns | missed deadlines | max compute us |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for dofs in [7, 70, 700] {
        for profile in [None, Some("json"), Some("ros2")] {
            let arm = format!("bench-rec-{dofs}-{}-{}", profile.unwrap_or("none"), std::process::id());
            let yaml = std::env::temp_dir().join(format!("{arm}.yaml"));
            let out = std::env::temp_dir().join(format!("{arm}.mcap"));
            std::fs::write(&yaml, arm_yaml(&arm, dofs, JointKind::Rigid, 1000.0)).expect("the arm's YAML");
            let mut run = Command::new(&exe).arg("run").arg(&yaml).args(["--static-plugins", "--duration", &(seconds + 30.0).to_string()]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
            let cpu_before = jointctl_bench::children_cpu_s();
            let recorder_started = std::time::Instant::now();
            let record = if let Some(profile) = profile {
                Some(Command::new(&exe).args(["record", "--arm", &arm, "--profile", profile, "--out"]).arg(&out).args(["--duration", &seconds.to_string(), "--json"]).output().unwrap())
            } else {
                // As long as the recorder's wait for the arm and its run: the arm's start and
                // `seconds` of its loop.
                let started = std::time::Instant::now();
                while Command::new(&exe).args(["inspect", "diag", "--arm", &arm, "--json", "--timeout", "10"]).output().map(|o| !o.status.success()).unwrap_or(true) && started.elapsed().as_secs_f64() < 10.0 {}
                std::thread::sleep(Duration::from_secs_f64(seconds));
                None
            };
            let recorder_cpu = jointctl_bench::children_cpu_s() - cpu_before;
            let recorder_wall = recorder_started.elapsed().as_secs_f64();
            let _ = Command::new(&exe).args(["cmd", "stop", "--arm", &arm]).output();
            let _ = run.kill_if_running();
            let ran = run.wait_with_output().unwrap();
            let run_sum = run_summary(&String::from_utf8_lossy(&ran.stderr));
            let recorder = match &record {
                None => Some("none | - | - | - | - | -".to_string()),
                Some(record) => {
                    let summary: serde_json::Value = serde_json::from_slice(&record.stdout).unwrap_or(serde_json::Value::Null);
                    summary.get("messages").map(|m| {
                        let messages: u64 = m.as_object().map_or(0, |o| o.values().filter_map(serde_json::Value::as_u64).sum());
                        let mib = summary["bytes"].as_f64().unwrap_or(f64::NAN) / (1024.0 * 1024.0);
                        format!("{} | {messages} | {} | {mib:.1} | {recorder_wall:.1} | {recorder_cpu:.1}", profile.unwrap_or("-"), summary["lost"])
                    })
                }
            };
            match (recorder, run_sum) {
                (Some(rec), Some(r)) => println!("| {dofs} | {rec} | {} | {} | {} | {:.1} |", r[0], r[1], r[2], r[3]),
                _ => println!(
                    "| {dofs} | - | - | - | - | - | - | - | - | - | - (record: {}; run: {}) |",
                    record.as_ref().map_or(String::new(), |r| String::from_utf8_lossy(&r.stderr).lines().last().unwrap_or("").to_string()),
                    String::from_utf8_lossy(&ran.stderr).lines().last().unwrap_or("")
                ),
            }
            let _ = std::fs::remove_file(&yaml);
            let _ = std::fs::remove_file(&out);
        }
    }
    println!();
}

/// Stops a child that outlived what it was asked to do.
trait KillIfRunning {
    fn kill_if_running(&mut self) -> std::io::Result<()>;
}

impl KillIfRunning for Child {
    fn kill_if_running(&mut self) -> std::io::Result<()> {
        // Given the `cmd stop` a moment to end the run cleanly first.
        for _ in 0..100 {
            if self.try_wait()?.is_some() {
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.kill()
    }
}

/// The loop's settings in one loaded-machine run.
#[derive(Clone, Copy)]
struct Settings {
    loaded: bool,
    realtime: bool,
    lock_memory: bool,
}

fn loaded_machine(quick: bool) {
    let seconds = jointctl_bench::env_or("BENCH_LOAD_S", if quick { 3.0 } else { 60.0 });
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Locked memory last: mlockall holds for the whole process once granted.
    let runs = [
        ("idle", Settings { loaded: false, realtime: false, lock_memory: false }),
        ("loaded", Settings { loaded: true, realtime: false, lock_memory: false }),
        ("loaded, SCHED_FIFO 80 + pinned", Settings { loaded: true, realtime: true, lock_memory: false }),
        ("loaded, SCHED_FIFO 80 + pinned + mlockall", Settings { loaded: true, realtime: true, lock_memory: true }),
        ("idle, SCHED_FIFO 80 + pinned + mlockall", Settings { loaded: false, realtime: true, lock_memory: true }),
    ];
    println!("## The 7-DOF SHERPA arm at 1 kHz on an idle and a loaded machine ({cores} cores; loaded = a busy loop per core at ordinary priority), {seconds} s per run");
    println!("| machine, loop settings | p50 lateness us | p99 lateness us | max lateness us | overruns | missed deadlines | records dropped by the publisher | joints faulted |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut missed = Vec::new();
    for (i, (what, s)) in runs.iter().enumerate() {
        let hogs = s.loaded.then(jointctl_bench::Hogs::start);
        std::thread::sleep(Duration::from_millis(200));
        let s = *s;
        let name = format!("bench-load-{i}");
        let last_cpu = std::thread::available_parallelism().map_or(1, |n| n.get()) - 1;
        // On a thread of its own: scheduling settings are per thread.
        let r = std::thread::spawn(move || {
            jointctl_bench::run_sherpa_loop_with(seconds, &name, |c| {
                if s.realtime {
                    (c.timing.realtime_priority, c.timing.cpu) = (Some(80), Some(last_cpu));
                }
                c.timing.lock_memory = s.lock_memory;
            })
        })
        .join()
        .expect("the loop thread");
        let (p50, p99, max, overruns, miss, drops, faulted) = (r.p50_us, r.p99_us, r.max_us, r.overruns, r.missed, r.drops, r.faulted);
        drop(hogs);
        missed.push(miss);
        println!("| {what} | {p50:.1} | {p99:.1} | {max:.1} | {overruns} | {miss} | {drops} | {faulted} |");
    }
    println!();
    println!("target: missed deadlines loaded with SCHED_FIFO and pinning ({}) <= idle without them ({})", missed[2], missed[0]);
    println!();
}

fn main() {
    let quick = std::env::var("BENCH_QUICK").is_ok();
    let only = std::env::var("BENCH_ONLY").unwrap_or_default();
    println!("jointctl scale benchmarks ({} cores)", std::thread::available_parallelism().map_or(0, |n| n.get()));
    println!();
    if only.is_empty() || only == "size" {
        scale_table(quick);
    }
    if only.is_empty() || only == "record" {
        recorded_at_size(quick);
    }
    if only.is_empty() || only == "arms" {
        several_arms(quick);
    }
    if only.is_empty() || only == "load" {
        loaded_machine(quick);
    }
}
