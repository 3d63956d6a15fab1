//! `cargo bench -p jointctl-bench --bench soak`: the full simulated SHERPA arm at 1 kHz for
//! `SOAK_SECONDS` (default 600) under a command flood, with an inspector reading every sample.
//! Prints the allocations counted inside the control cycles, the resident memory over time, and
//! the loop's overruns and lateness. `SOAK_SECONDS=20` makes a smoke run.
//!
//! The flood: 4 command clients in another thread, each keeping 4 requests in flight, cycling
//! through position targets on every joint, a torque sine on q2 and q4 and stiffness requests on
//! q2 and q6, as fast as the runtime answers.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use jointctl_ipc::{CommandKind, CommandRequest, TorqueWaveform};
use jointctl_runtime::timing::Pacer;
use jointctl_runtime::{ArmPublisher, ControlLoop, PluginLoader};
use jointctl_test_support::{CountingAlloc, count_allocations};

/// Counts the control thread's allocations; the publisher, flood and inspector threads
/// allocate inside iceoryx2 by design and are not the control cycle.
#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

const ARM: &str = "soak";

fn vm_rss_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmRSS:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// The requests the flood cycles through.
fn flood_requests() -> Vec<CommandRequest> {
    let mut r = Vec::new();
    for (joint, q) in [("q1", 0.3), ("q3", -0.2), ("q5", 0.25), ("q7", -0.1)] {
        r.push(CommandRequest::new(CommandKind::POSITION, joint, &[q]));
        r.push(CommandRequest::new(CommandKind::POSITION, joint, &[-q]));
    }
    r.push(CommandRequest::torque("q2", TorqueWaveform::SINE, &[3.0, 0.5, 0.0, 0.0]));
    r.push(CommandRequest::torque("q4", TorqueWaveform::SINE, &[2.0, 0.5, 0.0, 0.0]));
    r.push(CommandRequest::new(CommandKind::STIFFNESS, "q2", &[200.0]));
    r.push(CommandRequest::new(CommandKind::STIFFNESS, "q6", &[5.0]));
    r.push(CommandRequest::new(CommandKind::HOLD, "q6", &[]));
    r
}

/// Floods the arm with commands until `stop`; returns the refusals by reason.
fn flood(stop: Arc<AtomicBool>, sent: Arc<AtomicU64>, accepted: Arc<AtomicU64>) -> std::thread::JoinHandle<std::collections::BTreeMap<String, u64>> {
    std::thread::spawn(move || {
        let node = jointctl_ipc::create_node(None, "soak-flood").unwrap();
        let service = jointctl_ipc::command_service(&node, &jointctl_ipc::command_service_name(ARM), None).unwrap();
        let clients: Vec<_> = (0..4).map(|_| service.client_builder().create().unwrap()).collect();
        let requests = flood_requests();
        let mut refusals = std::collections::BTreeMap::new();
        let mut k = 0;
        while !stop.load(Ordering::Relaxed) {
            let mut pending = Vec::new();
            for c in &clients {
                for _ in 0..4 {
                    pending.push(c.send_copy(requests[k % requests.len()]).unwrap());
                    k += 1;
                }
            }
            sent.fetch_add(pending.len() as u64, Ordering::Relaxed);
            for p in &pending {
                let t = Instant::now();
                loop {
                    if let Ok(Some(r)) = p.receive() {
                        accepted.fetch_add(u64::from(r.accepted), Ordering::Relaxed);
                        if r.accepted == 0 {
                            *refusals.entry(r.text().to_string()).or_insert(0) += 1;
                        }
                        break;
                    }
                    if t.elapsed() > Duration::from_secs(2) || stop.load(Ordering::Relaxed) {
                        break;
                    }
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
        refusals
    })
}

/// Reads every joint-state sample until `stop`; returns how many.
fn inspector(stop: Arc<AtomicBool>) -> std::thread::JoinHandle<u64> {
    std::thread::spawn(move || {
        let node = jointctl_ipc::create_node(None, "soak-inspector").unwrap();
        let sub = jointctl_ipc::joint_state_service(&node, &jointctl_ipc::ServiceNames::for_arm(ARM).joint_state)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        let mut n = 0;
        while !stop.load(Ordering::Relaxed) {
            while let Ok(Some(_)) = sub.receive() {
                n += 1;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        n
    })
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let seconds: f64 = std::env::var("SOAK_SECONDS").ok().and_then(|v| v.parse().ok()).unwrap_or(600.0);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/sherpa_arm.yaml");
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text.replacen("arm: sherpa", &format!("arm: {ARM}"), 1).replacen("rate_hz: 40 ", "rate_hz: 1000 ", 1);
    let loaded = jointctl_config::parse_str(&text, &path).unwrap();
    let mut loader = PluginLoader::new([]);
    // Statically linked, so that a plugin's allocation would be counted here too.
    jointctl_bench::register_sherpa_plugins(&mut loader);
    let mut arm = jointctl_backends::build_arm(&loaded, &loader).unwrap();
    arm.activate().unwrap();
    let mut publisher = ArmPublisher::new(&arm, None).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let (sent, accepted) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
    let inspect = inspector(Arc::clone(&stop));
    let flooding = flood(Arc::clone(&stop), Arc::clone(&sent), Arc::clone(&accepted));
    let cycles = (seconds * 1000.0) as usize;
    // Timings go into arrays touched now (filled with 1, not 0: zeroed pages would be mapped
    // lazily), so that the RSS figures below show the runtime's memory, not these arrays filling.
    let mut lateness_ns = vec![1u64; cycles];
    let mut compute_ns = vec![1u64; cycles];
    let mut lp = ControlLoop::new(&mut arm, Some(&mut publisher), 0);
    let mut pacer = Pacer::new(1_000_000, 200_000);
    let never = jointctl_runtime::signals::StopRequest::manual();
    let mut allocations = 0u64;
    let mut rss = vec![(0.0, vm_rss_kb())];
    let t0 = Instant::now();
    let mut next_rss = 10.0;
    while lp.cycle < cycles as u64 {
        let deadline = pacer.deadline_ns();
        let woke = pacer.wait(&never);
        let i = lp.cycle as usize;
        let (done, n) = count_allocations(|| lp.step(deadline, woke, Some(&mut pacer)));
        allocations += n;
        lateness_ns[i] = woke.saturating_sub(deadline);
        compute_ns[i] = done - woke;
        let elapsed = t0.elapsed().as_secs_f64();
        if elapsed >= next_rss {
            rss.push((elapsed, vm_rss_kb()));
            next_rss += 10.0;
        }
    }
    stop.store(true, Ordering::Relaxed);
    let st = lp.stats.clone();
    let (_, refused) = lp.finish();
    let refusals = flooding.join().unwrap();
    let received = inspect.join().unwrap();
    lateness_ns.sort_unstable();
    compute_ns.sort_unstable();
    let pct = |v: &[u64], p: f64| v[((v.len() - 1) as f64 * p / 100.0).round() as usize] as f64 / 1e3;
    let (first, last) = (rss.get(1).copied().unwrap_or(rss[0]), *rss.last().unwrap());
    let max_rss = rss.iter().map(|r| r.1).max().unwrap_or(0);
    println!("## Soak: SHERPA arm, 1 kHz, {seconds} s, command flood and an inspector");
    println!("| cycles | allocations in the cycle | overruns | missed deadlines | p50 lateness us | p99 lateness us | max lateness us | p99 compute us | max compute us |");
    println!("|---|---|---|---|---|---|---|---|---|");
    println!(
        "| {} | {allocations} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
        st.cycles,
        st.overruns,
        st.missed_deadlines,
        pct(&lateness_ns, 50.0),
        pct(&lateness_ns, 99.0),
        st.max_jitter_ns as f64 / 1e3,
        pct(&compute_ns, 99.0),
        st.max_compute_ns as f64 / 1e3
    );
    println!();
    println!(
        "commands: {} sent, {} accepted; inspector received {received} samples; publisher refused {refused}",
        sent.load(Ordering::Relaxed),
        accepted.load(Ordering::Relaxed)
    );
    println!(
        "RSS: {} kB at start, {} kB after {:.0} s (after warm-up), {} kB at the end ({:.0} s), max {max_rss} kB; growth after warm-up {} kB",
        rss[0].1,
        first.1,
        first.0,
        last.1,
        last.0,
        last.1 as i64 - first.1 as i64
    );
    for (reason, n) in &refusals {
        println!("refused {n} x: {reason}");
    }
    println!("| joint | plugin | fault | budget us | max plugin time us | cycles over budget |");
    println!("|---|---|---|---|---|---|");
    for slot in &arm.slots {
        println!(
            "| {} | {} | {} | {:.0} | {:.1} | {} |",
            slot.name,
            slot.plugin,
            slot.fault,
            slot.budget_ns as f64 / 1e3,
            slot.max_used_ns as f64 / 1e3,
            slot.over_budget_cycles
        );
    }
    println!("RSS samples (s, kB): {}", rss.iter().map(|(t, kb)| format!("({t:.0}, {kb})")).collect::<Vec<_>>().join(" "));
}
