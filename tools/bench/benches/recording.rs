//! `cargo bench -p jointctl-bench --bench recording`: the recorder against the full SHERPA arm
//! at 1 kHz. One run of the loop without a recorder, then one with `jointctl record` attached
//! (a separate process, as in use), side by side: the loop's lateness and overruns, the
//! recorder's losses, CPU time and file size per minute; then `jointctl sim replay`'s speed on
//! that recording.
//!
//! Environment: `BENCH_RECORD_S` (default 60) seconds per run; `BENCH_QUICK=1` for 5 s.
//! Needs `cargo build --release --workspace` first (the `jointctl` binary and the plugins).

use std::process::{Command, Stdio};
use std::time::Instant;


fn main() {
    let quick = std::env::var("BENCH_QUICK").is_ok();
    let seconds: f64 = std::env::var("BENCH_RECORD_S").ok().and_then(|v| v.parse().ok()).unwrap_or(if quick { 5.0 } else { 60.0 });
    let exe = jointctl_bench::release_dir().join("jointctl");
    assert!(exe.exists(), "{} is missing: cargo build --release --workspace", exe.display());
    println!("jointctl recording benchmark ({} cores), full SHERPA arm at 1 kHz, {seconds} s per run", std::thread::available_parallelism().map_or(0, |n| n.get()));
    println!();

    let alone = jointctl_bench::run_sherpa_loop(seconds, "bench-rec-alone");
    let file = std::env::temp_dir().join(format!("jointctl-bench-{}.mcap", std::process::id()));
    let cpu_before = jointctl_bench::children_cpu_s();
    // The recorder stops on the arm's final sample, when the loop below ends.
    let recorder = Command::new(&exe)
        .args(["record", "--arm", "bench-rec-with", "--json", "--timeout", "10", "--out"])
        .arg(&file)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let with = jointctl_bench::run_sherpa_loop(seconds, "bench-rec-with");
    let out = recorder.wait_with_output().unwrap();
    let recorder_cpu_s = jointctl_bench::children_cpu_s() - cpu_before;
    assert!(out.status.success(), "record: {}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let duration = summary["duration_s"].as_f64().unwrap_or(f64::NAN);
    let bytes = summary["bytes"].as_f64().unwrap_or(f64::NAN);

    jointctl_bench::print_side_by_side("The loop with and without a recorder", [("no recorder", &alone), ("`jointctl record` attached", &with)]);
    println!("## The recorder");
    println!("| recorded s | messages (raw / joint_state / diagnostics / commands) | lost | CPU time s | CPU, % of one core | MB per minute | target |");
    println!("|---|---|---|---|---|---|---|");
    let m = &summary["messages"];
    println!(
        "| {duration:.1} | {} / {} / {} / {} | {} | {recorder_cpu_s:.2} | {:.1} | {:.1} | 0 lost, <= 5 % of one core |",
        m["raw"], m["joint_state"], m["diagnostics"], m["commands"], summary["lost"], 100.0 * recorder_cpu_s / duration, bytes / duration * 60.0 / 1e6
    );
    println!();

    // `jointctl sim replay` on this recording: the whole arm's commands re-run at 1 kHz; then
    // on a recording of one joint (the elbow alone), the measure.
    let config = jointctl_bench::sherpa_file("sherpa", 1000.0);
    let t = Instant::now();
    let replay = Command::new(&exe).args(["sim", "replay", "--json", "--config"]).arg(&config).arg(&file).output().unwrap();
    let wall = t.elapsed().as_secs_f64();
    assert!(replay.status.success(), "sim replay: {}", String::from_utf8_lossy(&replay.stderr));
    let one = one_joint_replay(&exe, seconds.min(20.0));
    println!("## `jointctl sim replay` (1 kHz, reading the file included)");
    println!("| recording | recorded s | wall s | times real time | target |");
    println!("|---|---|---|---|---|");
    println!("| the whole arm (7 joints) | {duration:.1} | {wall:.2} | {:.0} | - |", duration / wall);
    println!("| one joint (the elbow alone) | {:.1} | {:.2} | {:.0} | >= 100 |", one.0, one.1, one.0 / one.1);
    let _ = std::fs::remove_file(&file);
    let _ = std::fs::remove_file(&config);
}

/// An arm of one joint, the SHERPA elbow (q4) with its simulated plant, at 1 kHz.
fn one_joint_config(arm: &str) -> String {
    let root = jointctl_bench::root();
    format!(
        "arm: {arm}\nrate_hz: 1000\nhal: {{backend: sim, sim: {{seed: 1}}}}\nbuses:\n  can: [{{interface: can0, drives: [{{name: elmo_q4, node_id: 5}}]}}]\n  spi: [{{device: /dev/spidev0, encoders: [{{name: enc_q4_out, chip_select: 6, sim: {{signal: q4.output}}}}]}}]\n  force_torque: [{{name: ft_q4, sim: {{dof: q4}}}}]\njoints:\n  - name: q4\n    plugin: elastic\n    encoders: {{output: enc_q4_out}}\n    drives: {{motor: elmo_q4}}\n    torque_sensor: ft_q4\n    limits: {{position_rad: [-2.2, 2.2], torque_nm: 30}}\n    sim:\n      drives: [elmo_q4]\n      matrix: [[2.0]]\n      element: {{kind: linear, stiffness_nm_per_rad: 113.78}}\n      environment: {{kind: fixed}}\n      effects: {{cubic_nm_per_rad3: 150.0, hysteresis: {{sigma_nm_per_rad: 100.0, limit_nm: 0.2}}, torque_noise_nm: 0.01}}\n    params: {{include: {}/configs/sherpa_q4_characteristic.yaml, output_per_motor: 2.0, position_pi: {{kp: 0.2, ki: 0.5, output_limit: 0.05}}}}\n",
        root.display()
    )
}

/// Records the elbow alone following a torque sine for `seconds`, then times `sim replay` of
/// the recording: (recorded s, wall s).
fn one_joint_replay(exe: &std::path::Path, seconds: f64) -> (f64, f64) {
    let dir = std::env::temp_dir();
    let config = dir.join(format!("jointctl-bench-{}-one.yaml", std::process::id()));
    let file = dir.join(format!("jointctl-bench-{}-one.mcap", std::process::id()));
    std::fs::write(&config, one_joint_config("bench-rec-one")).unwrap();
    let mut run = Command::new(exe).arg("run").arg(&config).args(["--duration", &format!("{}", seconds + 3.0)]).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    let recorder = Command::new(exe).args(["record", "--arm", "bench-rec-one", "--json", "--timeout", "10", "--duration", &format!("{seconds}"), "--out"]).arg(&file).stdout(Stdio::piped()).spawn().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1000));
    let cmd = Command::new(exe).args(["cmd", "torque", "q4", "--sine", "5", "--freq", "0.5", "--arm", "bench-rec-one"]).output().unwrap();
    assert!(cmd.status.success(), "{}", String::from_utf8_lossy(&cmd.stderr));
    let out = recorder.wait_with_output().unwrap();
    let _ = run.wait();
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let t = Instant::now();
    let replay = Command::new(exe).args(["sim", "replay", "--json", "--config"]).arg(&config).arg(&file).output().unwrap();
    let wall = t.elapsed().as_secs_f64();
    assert!(replay.status.success(), "sim replay: {}", String::from_utf8_lossy(&replay.stderr));
    let _ = std::fs::remove_file(&file);
    let _ = std::fs::remove_file(&config);
    (summary["duration_s"].as_f64().unwrap_or(f64::NAN), wall)
}
