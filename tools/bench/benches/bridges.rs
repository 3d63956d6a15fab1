//! `cargo bench -p jointctl-bench --bench bridges`: the network bridges against the full SHERPA
//! arm at 1 kHz. One run of the loop alone, then one with `jointctl bridge zenoh` and
//! `jointctl bridge foxglove` attached (separate processes, as in use) and a client on each:
//! the loop's lateness and overruns side by side, and each client's latency from the cycle's
//! stamp to receipt (p50/p99).
//!
//! Latency: the cycle's CLOCK_MONOTONIC stamp, put on the wall clock by the bridge (`wall_ns`,
//! Foxglove's log time), against the wall clock when the client has the message. Both clocks
//! are this machine's. The Zenoh client is this process (zenoh's Rust API); the Foxglove client
//! is the Python `websockets` client of the tests, so its figure includes Python's decoding.
//!
//! Then four runs for the ROS 2 bridge: `jointctl bridge ros2` with no DDS reader; with a Cyclone
//! DDS listener (the Python client of the tests, `tests/interop/ros2_listener.py`); and with the
//! listener and the loop at SCHED_FIFO on its CPU, beside a run alone at that setting. The loop's
//! figures side by side, the share of joint states that reached the listener, and each helper
//! process's CPU as a share of one core over its own lifetime.
//!
//! Last, the Foxglove relay (clients of `foxglove.websocket.v1`) against the SDK's server alone:
//! two `jointctl bridge foxglove` on one arm, one with the relay, one with `--sdk-only`, and a
//! Rust client on each that keeps up with 1 kHz (the Python client does not): latency from the
//! cycle's stamp to receipt, the share of cycles received, each bridge's CPU. Same run.
//!
//! Environment: `BENCH_BRIDGE_S` (default 30) seconds per run; `BENCH_QUICK=1` for 5 s;
//! `BENCH_ONLY=foxglove` runs the relay's comparison alone.
//! Needs `cargo build --release --workspace` first and `bash .ci/setup-python-venv`.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;



fn unix_ns() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((p / 100.0 * (sorted.len() - 1) as f64).round() as usize).min(sorted.len() - 1)]
}

/// Waits for a child started at `started` and returns the CPU time it used (user and system, its
/// rusage) as a share of its lifetime [0..1 per core].
#[allow(unsafe_code)]
fn wait_cpu_share(child: Child, started: std::time::Instant) -> f64 {
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value for wait4 to fill in.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: our own child, not yet reaped (Child only reaps in wait, which is not called).
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    if pid <= 0 {
        return f64::NAN;
    }
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    (seconds(usage.ru_utime) + seconds(usage.ru_stime)) / started.elapsed().as_secs_f64()
}

/// Starts `jointctl bridge ARGS` and returns it with the log line containing `ready` (waits
/// in a thread so that the loop can start meanwhile).
fn bridge(exe: &std::path::Path, args: &[String], ready: &'static str) -> ((Child, std::time::Instant), std::sync::mpsc::Receiver<String>) {
    let mut child = Command::new(exe).arg("bridge").args(args).env("RUST_LOG", "info").stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let started = std::time::Instant::now();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains(ready) {
                let _ = tx.send(line);
            }
        }
    });
    ((child, started), rx)
}

/// One run of the loop with `jointctl bridge ros2` attached, and with a DDS listener or none.
struct Ros2Run {
    run: jointctl_bench::LoopRun,
    states: usize,
    bridge_cpu: f64,
    listener_cpu: f64,
    listener_error: String,
}

/// The loop's `timing`: SCHED_FIFO 80 on the machine's last CPU, or the defaults.
fn timing(realtime: bool) -> impl FnOnce(&mut jointctl_config::ArmConfig) {
    move |c| {
        if realtime {
            let last_cpu = std::thread::available_parallelism().map_or(0, |n| n.get() - 1);
            (c.timing.realtime_priority, c.timing.cpu) = (Some(80), Some(last_cpu));
        }
    }
}

fn ros2_run(exe: &std::path::Path, python: &std::path::Path, seconds: f64, arm: &'static str, listen: bool, realtime: bool) -> Ros2Run {
    // A DDS domain of this run's own.
    let domain = (100 + std::process::id() % 130).to_string();
    let (bridge_child, ready) = bridge(exe, &["ros2".into(), "--arm".into(), arm.into(), "--domain-id".into(), domain.clone(), "--timeout".into(), "10".into()], "publishing in DDS domain");
    let looping = std::thread::spawn(move || jointctl_bench::run_sherpa_loop_with(seconds, arm, timing(realtime)));
    ready.recv_timeout(Duration::from_secs(20)).expect("the ROS 2 bridge never started");
    let mut out = Ros2Run { run: jointctl_bench::LoopRun::default(), states: 0, bridge_cpu: 0.0, listener_cpu: 0.0, listener_error: String::new() };
    let listener = listen.then(|| {
        let started = std::time::Instant::now();
        let mut child = Command::new(python)
            .arg(jointctl_bench::root().join("tests/interop/ros2_listener.py"))
            .args([domain.as_str(), &format!("{}", seconds + 3.0), &format!("{}", (seconds * 2000.0) as u64)])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (mut stdout, mut stderr) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
        let reading = std::thread::spawn(move || {
            let (mut text, mut err) = (Vec::new(), String::new());
            let _ = std::io::Read::read_to_end(&mut stdout, &mut text);
            let _ = std::io::Read::read_to_string(&mut stderr, &mut err);
            (text, err)
        });
        (child, started, reading)
    });
    out.run = looping.join().unwrap();
    if let Some((child, started, reading)) = listener {
        out.listener_cpu = wait_cpu_share(child, started);
        let (text, err) = reading.join().unwrap();
        let v: serde_json::Value = serde_json::from_slice(&text).unwrap_or_default();
        out.states = v["joint_states"].as_array().map_or(0, Vec::len);
        if v.is_null() {
            out.listener_error = err.lines().last().unwrap_or("").to_string();
        }
    }
    out.bridge_cpu = wait_cpu_share(bridge_child.0, bridge_child.1);
    out
}

/// A Foxglove WebSocket client written from the protocol's specification (as the Python client
/// of the tests is): subscribes to `joint_state` and returns each message's latency, receipt on
/// the wall clock less its log time [us], until `until`.
fn foxglove_latencies(url: &str, subprotocol: &str, until: std::time::Instant) -> Result<Vec<f64>, String> {
    use tungstenite::client::IntoClientRequest;
    let mut request = url.into_client_request().map_err(|e| e.to_string())?;
    request.headers_mut().insert("sec-websocket-protocol", subprotocol.parse().map_err(|e| format!("{e}"))?);
    let (mut ws, _) = tungstenite::connect(request).map_err(|e| format!("{url} offering {subprotocol}: {e}"))?;
    if let tungstenite::stream::MaybeTlsStream::Plain(tcp) = ws.get_ref() {
        tcp.set_read_timeout(Some(Duration::from_millis(200))).map_err(|e| e.to_string())?;
    }
    let mut latencies = Vec::new();
    let mut subscribed = false;
    while std::time::Instant::now() < until {
        match ws.read() {
            Ok(tungstenite::Message::Text(text)) if !subscribed => {
                let op: serde_json::Value = serde_json::from_str(text.as_str()).unwrap_or_default();
                let channel = op["channels"].as_array().and_then(|c| c.iter().find(|c| c["topic"] == "joint_state")).and_then(|c| c["id"].as_u64());
                if let (Some("advertise"), Some(id)) = (op["op"].as_str(), channel) {
                    ws.send(tungstenite::Message::text(serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": id}]}).to_string())).map_err(|e| e.to_string())?;
                    subscribed = true;
                }
            }
            // Message data: opcode 1, subscription id (u32), log time (u64 ns), payload.
            Ok(tungstenite::Message::Binary(frame)) if frame.len() >= 13 && frame[0] == 1 => {
                let log_time = u64::from_le_bytes(frame[5..13].try_into().unwrap_or_default());
                latencies.push(unix_ns().saturating_sub(log_time) as f64 / 1e3);
            }
            Ok(_) => {}
            Err(tungstenite::Error::Io(e)) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
            Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => break,
            // What arrived before an error is kept (the arm's stop can end the connection).
            Err(_) if !latencies.is_empty() => break,
            Err(e) => return Err(e.to_string()),
        }
    }
    Ok(latencies)
}

/// The relay against the SDK's server alone: both on one arm, a Rust client on each.
fn foxglove_relay_run(exe: &std::path::Path, seconds: f64) {
    let arm = "bench-br-fox";
    let args = |extra: &[&str]| -> Vec<String> { ["foxglove", "--arm", arm, "--port", "0", "--timeout", "10"].iter().chain(extra).map(|s| s.to_string()).collect() };
    let (relayed, relayed_ready) = bridge(exe, &args(&[]), "listening on ws://");
    let (direct, direct_ready) = bridge(exe, &args(&["--sdk-only"]), "listening on ws://");
    let looping = std::thread::spawn(move || jointctl_bench::run_sherpa_loop(seconds, arm));
    let url = |ready: std::sync::mpsc::Receiver<String>| {
        let line = ready.recv_timeout(Duration::from_secs(20)).expect("a Foxglove bridge never started");
        line.split_whitespace().find(|w| w.starts_with("ws://")).unwrap().to_string()
    };
    let until = std::time::Instant::now() + Duration::from_secs_f64(seconds);
    let clients = [(url(relayed_ready), "foxglove.websocket.v1"), (url(direct_ready), "foxglove.sdk.v1")].map(|(url, name)| std::thread::spawn(move || foxglove_latencies(&url, name, until)));
    let run = looping.join().unwrap();
    let [relayed_l, direct_l] = clients.map(|c| c.join().unwrap());
    let cpu = [wait_cpu_share(relayed.0, relayed.1), wait_cpu_share(direct.0, direct.1)];
    println!("## Foxglove: the relay for `foxglove.websocket.v1` clients against the SDK's server alone (same run, a Rust client on each)");
    println!("| path | samples received | of cycles | min ms | p50 ms | p99 ms | max ms | bridge CPU, % of a core |");
    println!("|---|---|---|---|---|---|---|---|");
    for ((name, l), cpu) in [("`bridge foxglove` (relay), client offering `foxglove.websocket.v1`", relayed_l), ("`bridge foxglove --sdk-only`, client offering `foxglove.sdk.v1`", direct_l)].into_iter().zip(cpu) {
        match l {
            Ok(mut l) => {
                l.sort_by(f64::total_cmp);
                println!(
                    "| {name} | {} | {:.0} % | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} |",
                    l.len(),
                    100.0 * l.len() as f64 / run.cycles.max(1) as f64,
                    l.first().copied().unwrap_or(f64::NAN) / 1e3,
                    percentile(&l, 50.0) / 1e3,
                    percentile(&l, 99.0) / 1e3,
                    l.last().copied().unwrap_or(f64::NAN) / 1e3,
                    100.0 * cpu
                );
            }
            Err(e) => println!("| {name} | the client failed: {e} | | | | | | {:.0} |", 100.0 * cpu),
        }
    }
    println!("(the loop: {} cycles, {} overruns)", run.cycles, run.overruns);
    println!();
}

fn main() {
    let quick = std::env::var("BENCH_QUICK").is_ok();
    let seconds: f64 = std::env::var("BENCH_BRIDGE_S").ok().and_then(|v| v.parse().ok()).unwrap_or(if quick { 5.0 } else { 30.0 });
    let exe = jointctl_bench::release_dir().join("jointctl");
    assert!(exe.exists(), "{} is missing: cargo build --release --workspace", exe.display());
    let python = jointctl_bench::root().join(".venv-interop/bin/python");
    assert!(python.exists(), "{} is missing: bash .ci/setup-python-venv", python.display());
    println!("jointctl bridge benchmark ({} cores), full SHERPA arm at 1 kHz, {seconds} s per run", std::thread::available_parallelism().map_or(0, |n| n.get()));
    println!();

    if std::env::var("BENCH_ONLY").is_ok_and(|only| only == "foxglove") {
        foxglove_relay_run(&exe, seconds);
        return;
    }
    let alone = jointctl_bench::run_sherpa_loop(seconds, "bench-br-alone");

    let arm = "bench-br-with";
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let (zenoh_bridge, zenoh_ready) = bridge(&exe, &["zenoh".into(), "--arm".into(), arm.into(), "--listen".into(), endpoint.clone(), "--timeout".into(), "10".into()], "publishing on");
    let (foxglove_bridge, foxglove_ready) = bridge(&exe, &["foxglove".into(), "--arm".into(), arm.into(), "--port".into(), "0".into(), "--timeout".into(), "10".into()], "listening on ws://");
    let looping = std::thread::spawn(move || jointctl_bench::run_sherpa_loop(seconds, arm));
    // The bridges find the arm once its loop runs; then the clients attach.
    zenoh_ready.recv_timeout(Duration::from_secs(20)).expect("the Zenoh bridge never started");
    let ws = foxglove_ready.recv_timeout(Duration::from_secs(20)).expect("the Foxglove bridge never started");
    let url = ws.split_whitespace().find(|w| w.starts_with("ws://")).unwrap().to_string();
    let foxglove_client = Command::new(&python)
        .arg(jointctl_bench::root().join("tests/interop/foxglove_client.py"))
        .args([&url, "joint_state", &format!("{}", (seconds * 1000.0) as u64)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let session = jointctl_bridge::zenoh::connect(&endpoint, None, 5.0).unwrap();
    let subscriber = zenoh::Wait::wait(session.declare_subscriber(jointctl_bridge::zenoh::key(arm, "joint_state"))).unwrap();
    let zenoh_latencies = Arc::new(Mutex::new(Vec::new()));
    let done = Arc::new(AtomicBool::new(false));
    let receiving = {
        let (latencies, done) = (Arc::clone(&zenoh_latencies), Arc::clone(&done));
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                if let Ok(Some(sample)) = subscriber.recv_timeout(Duration::from_millis(100)) {
                    let now = unix_ns();
                    let text = sample.payload().try_to_string().map(|s| s.into_owned()).unwrap_or_default();
                    let v: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
                    if let Some(wall) = v["wall_ns"].as_u64() {
                        latencies.lock().unwrap().push(now.saturating_sub(wall) as f64 / 1e3);
                    }
                }
            }
        })
    };
    let with = looping.join().unwrap();
    done.store(true, Ordering::Relaxed);
    let _ = receiving.join();
    let fox = foxglove_client.wait_with_output().unwrap();
    let zenoh_cpu = wait_cpu_share(zenoh_bridge.0, zenoh_bridge.1);
    let foxglove_cpu = wait_cpu_share(foxglove_bridge.0, foxglove_bridge.1);
    let mut fox_latencies: Vec<f64> = String::from_utf8_lossy(&fox.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|m| Some(m["received_ns"].as_u64()?.saturating_sub(m["log_time_ns"].as_u64()?) as f64 / 1e3))
        .collect();
    let mut zenoh_latencies = std::mem::take(&mut *zenoh_latencies.lock().unwrap());
    zenoh_latencies.sort_by(f64::total_cmp);
    fox_latencies.sort_by(f64::total_cmp);

    jointctl_bench::print_side_by_side("The loop with and without the bridges", [("no bridge", &alone), ("`bridge zenoh` + `bridge foxglove` attached, a client on each", &with)]);
    println!("## Joint state: cycle stamp to client receipt (same machine, loopback)");
    println!("| path | samples received | of cycles | p50 ms | p99 ms | max ms |");
    println!("|---|---|---|---|---|---|");
    for (name, l) in [("Zenoh: bridge → Rust subscriber over TCP", &zenoh_latencies), ("Foxglove: bridge → Python `websockets` client", &fox_latencies)] {
        println!(
            "| {name} | {} | {:.0} % | {:.2} | {:.2} | {:.2} |",
            l.len(),
            100.0 * l.len() as f64 / with.cycles.max(1) as f64,
            percentile(l, 50.0) / 1e3,
            percentile(l, 99.0) / 1e3,
            l.last().copied().unwrap_or(f64::NAN) / 1e3
        );
    }
    println!();

    let ros2_alone = ros2_run(&exe, &python, seconds, "bench-br-ros2-alone", false, false);
    let ros2_heard = ros2_run(&exe, &python, seconds, "bench-br-ros2", true, false);
    // The same with the loop at SCHED_FIFO on a CPU of its own (`timing`, docs/real-time.md).
    let alone_rt = std::thread::spawn(move || jointctl_bench::run_sherpa_loop_with(seconds, "bench-br-alone-rt", timing(true))).join().unwrap();
    let ros2_heard_rt = ros2_run(&exe, &python, seconds, "bench-br-ros2-rt", true, true);
    jointctl_bench::print_side_by_side("The loop with the ROS 2 bridge, nobody listening", [("no bridge", &alone), ("`bridge ros2` attached, no DDS reader", &ros2_alone.run)]);
    jointctl_bench::print_side_by_side("The loop with the ROS 2 bridge and a listener", [("no bridge", &alone), ("`bridge ros2` attached, a Cyclone DDS listener", &ros2_heard.run)]);
    jointctl_bench::print_side_by_side(
        "The loop at SCHED_FIFO 80 on the last CPU, with the ROS 2 bridge and a listener",
        [("no bridge, SCHED_FIFO", &alone_rt), ("`bridge ros2` + Cyclone DDS listener, SCHED_FIFO", &ros2_heard_rt.run)],
    );
    println!(
        "ROS 2: {} /joint_states messages reached the Cyclone DDS listener, {:.0} % of the run's {} cycles (it attaches after DDS discovery, a second or two into the run)",
        ros2_heard.states,
        100.0 * ros2_heard.states as f64 / ros2_heard.run.cycles.max(1) as f64,
        ros2_heard.run.cycles
    );
    println!();
    println!("## CPU of the processes beside the loop (user + system, share of one core over each one's lifetime)");
    println!("| process | % of a core |");
    println!("|---|---|");
    for (name, share) in [
        ("`bridge zenoh` (a Rust subscriber attached)", zenoh_cpu),
        ("`bridge foxglove` (a Python client attached)", foxglove_cpu),
        ("`bridge ros2`, no DDS reader", ros2_alone.bridge_cpu),
        ("`bridge ros2`, a Cyclone DDS listener attached", ros2_heard.bridge_cpu),
        ("the Python Cyclone DDS listener", ros2_heard.listener_cpu),
    ] {
        println!("| {name} | {:.0} |", 100.0 * share);
    }
    if !ros2_heard.listener_error.is_empty() {
        println!("(the DDS listener: {})", ros2_heard.listener_error);
    }
    if !fox.status.success() {
        println!("\n(the Foxglove client: {})", String::from_utf8_lossy(&fox.stderr).lines().last().unwrap_or(""));
    }
    println!();
    foxglove_relay_run(&exe, seconds);
}
