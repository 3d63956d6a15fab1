//! Is this machine fit to run an arm? (issue 37, finding 7: real-time set-up was left to luck,
//! and a user could not tell.) Each check says what it found and, when it is not what the loop
//! needs, what to do: a PREEMPT_RT kernel, memory that can be locked, permission for
//! SCHED_FIFO at the configured priority, the loop's CPU (isolated or not), the CAN interfaces
//! of the config up at their bitrate, and the lateness of a short 1 kHz loop on this machine.
//!
//! Only what cannot work is a failure (a CAN interface of the config missing, down or at another
//! bitrate; a loop CPU this machine does not have). What makes the loop late under load (no RT
//! kernel, no SCHED_FIFO, no memory lock) is a warning: the simulated arm runs without it.

use std::path::Path;

use jointctl_config::{ArmConfig, HalBackend};

/// How a check came out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// As the loop needs it.
    Ok,
    /// Works, but the loop may be late under load: see the advice.
    Warn,
    /// The arm cannot run like this.
    Fail,
}

/// One check's outcome.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Check {
    /// What was checked.
    pub name: String,
    /// How it came out.
    pub status: Status,
    /// What was found.
    pub found: String,
    /// What to do when the status is not `Ok` (empty otherwise).
    pub advice: String,
}

fn check(name: impl Into<String>, status: Status, found: impl Into<String>, advice: impl Into<String>) -> Check {
    let advice = if status == Status::Ok { String::new() } else { advice.into() };
    Check { name: name.into(), status, found: found.into(), advice }
}

/// Every check for running `config` on this machine; the lateness loop runs for `seconds`.
///
/// ```
/// let yaml = "arm: a\nhal: {backend: sim}\nbuses:\n  can:\n    - interface: can0\n      drives: [{name: m, node_id: 1}]\njoints: [{name: q, plugin: rigid, drives: {motor: m}}]\n";
/// let config = jointctl_config::parse_str(yaml, "a.yaml").unwrap().config;
/// let checks = jointctl_runtime::doctor::checks(&config, 0.05);
/// assert!(checks.iter().any(|c| c.name == "real-time kernel"));
/// assert!(checks.iter().all(|c| c.status != jointctl_runtime::doctor::Status::Fail));
/// ```
pub fn checks(config: &ArmConfig, seconds: f64) -> Vec<Check> {
    let mut out = vec![kernel(), memory_lock(), realtime_priority(config.timing.realtime_priority), loop_cpu(config.timing.cpu)];
    if config.hal.backend == HalBackend::Socketcan {
        out.extend(config.buses.can.iter().map(|b| can_interface(&b.interface, b.bitrate)));
    }
    out.push(lateness_1khz(seconds, config.timing.realtime_priority, config.timing.cpu));
    out
}

fn read_trimmed(path: impl AsRef<Path>) -> Option<String> {
    std::fs::read_to_string(path).ok().map(|s| s.trim().to_string())
}

fn kernel() -> Check {
    let version = read_trimmed("/proc/sys/kernel/version").unwrap_or_default();
    let release = read_trimmed("/proc/sys/kernel/osrelease").unwrap_or_default();
    let rt = read_trimmed("/sys/kernel/realtime").as_deref() == Some("1") || version.contains("PREEMPT_RT");
    check(
        "real-time kernel",
        if rt { Status::Ok } else { Status::Warn },
        format!("{release} {version}"),
        "not PREEMPT_RT: the loop's lateness is unbounded under load; on the arm's computer install a PREEMPT_RT kernel (Debian/Ubuntu: linux-image-rt-amd64 or the realtime kernel)",
    )
}

fn memory_lock() -> Check {
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit writes the struct it is given.
    let known = unsafe { libc::getrlimit(libc::RLIMIT_MEMLOCK, &mut limit) } == 0;
    let shown = match (known, limit.rlim_cur) {
        (false, _) => "unknown".to_string(),
        (true, libc::RLIM_INFINITY) => "unlimited".to_string(),
        (true, n) => format!("{} KiB", n / 1024),
    };
    // A real attempt: lock what this process has mapped now and will map, then let it go.
    let locked = crate::timing::lock_all_memory().is_ok();
    if locked {
        // SAFETY: undoes the lock just taken; no memory is freed.
        unsafe { libc::munlockall() };
    }
    check(
        "memory lock",
        if locked { Status::Ok } else { Status::Warn },
        format!("mlockall {}, limit {shown}", if locked { "permitted" } else { "refused" }),
        "page faults can stall the loop: raise the memlock limit for the user that runs it (limits.conf: `USER - memlock unlimited`, or LimitMEMLOCK=infinity in its systemd unit) and set timing.lock_memory",
    )
}

/// Runs `f` on a new thread (scheduling settings are per thread and must not stick to the
/// caller's).
fn on_own_thread<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> Option<T> {
    std::thread::spawn(f).join().ok()
}

fn realtime_priority(configured: Option<u8>) -> Check {
    let priority = configured.unwrap_or(1);
    let result = on_own_thread(move || crate::timing::set_fifo(priority).map_err(|e| e.to_string())).unwrap_or_else(|| Err("the check's thread died".into()));
    let found = match (&result, configured) {
        (Ok(()), Some(p)) => format!("SCHED_FIFO at the configured priority {p} permitted"),
        (Ok(()), None) => "SCHED_FIFO permitted (timing.realtime_priority is not set: the loop runs without it)".to_string(),
        (Err(e), _) => format!("SCHED_FIFO at priority {priority} refused: {e}"),
    };
    let status = match (&result, configured) {
        (Ok(()), Some(_)) => Status::Ok,
        _ => Status::Warn,
    };
    check(
        "SCHED_FIFO",
        status,
        found,
        "the loop competes with every other thread: set timing.realtime_priority (e.g. 80) and allow it (limits.conf: `USER - rtprio 90`, or `setcap cap_sys_nice+ep` on jointctl)",
    )
}

fn loop_cpu(configured: Option<usize>) -> Check {
    // Every CPU the machine has, isolated ones included (available_parallelism counts only the
    // CPUs this process may use, which leaves isolated ones out).
    // SAFETY: sysconf takes a name only.
    let cpus = usize::try_from(unsafe { libc::sysconf(libc::_SC_NPROCESSORS_CONF) }).unwrap_or(1).max(1);
    let isolated = read_trimmed("/sys/devices/system/cpu/isolated").unwrap_or_default();
    let isolated_list = cpu_list(&isolated);
    let shown = if isolated.is_empty() { "none".to_string() } else { isolated.clone() };
    match configured {
        Some(cpu) if cpu >= cpus => check("loop CPU", Status::Fail, format!("timing.cpu {cpu}, this machine has CPUs 0-{}", cpus - 1), "set timing.cpu to a CPU this machine has"),
        Some(cpu) if isolated_list.contains(&cpu) => check("loop CPU", Status::Ok, format!("timing.cpu {cpu}, isolated (isolated CPUs: {shown})"), ""),
        Some(cpu) => check(
            "loop CPU",
            Status::Warn,
            format!("timing.cpu {cpu}, not isolated (isolated CPUs: {shown})"),
            format!("other work shares CPU {cpu}: isolate it (kernel command line `isolcpus={cpu} nohz_full={cpu}`)"),
        ),
        None => check(
            "loop CPU",
            Status::Warn,
            format!("timing.cpu not set; {cpus} CPUs, isolated: {shown}"),
            "the loop may move between CPUs: set timing.cpu, best one isolated with `isolcpus=`",
        ),
    }
}

/// `0-2,5` as the CPUs it names.
fn cpu_list(text: &str) -> Vec<usize> {
    text.split(',')
        .filter_map(|part| {
            let part = part.trim();
            match part.split_once('-') {
                Some((a, b)) => Some((a.parse().ok()?..=b.parse().ok()?).collect::<Vec<usize>>()),
                None => part.parse().ok().map(|c| vec![c]),
            }
        })
        .flatten()
        .collect()
}

/// A CAN interface: present, up, and at the configured bitrate (read from `ip -details -json
/// link`, iproute2's; a virtual interface has none).
pub fn can_interface(name: &str, bitrate: u32) -> Check {
    let what = format!("CAN interface {name}");
    let up_command = format!("sudo ip link set {name} up type can bitrate {bitrate}");
    let dir = Path::new("/sys/class/net").join(name);
    if !dir.exists() {
        return check(what, Status::Fail, "does not exist", format!("connect the adapter and load its driver, then `{up_command}`"));
    }
    // IFF_UP is bit 0 of the interface's flags.
    let flags = read_trimmed(dir.join("flags")).and_then(|f| u32::from_str_radix(f.trim_start_matches("0x"), 16).ok()).unwrap_or(0);
    if flags & 1 == 0 {
        return check(what, Status::Fail, "down", format!("`{up_command}`"));
    }
    let details = std::process::Command::new("ip").args(["-details", "-json", "link", "show", "dev", name]).output();
    let measured = details.ok().and_then(|o| serde_json::from_slice::<serde_json::Value>(&o.stdout).ok()).map(|v| v[0]["linkinfo"].clone());
    let kind = measured.as_ref().and_then(|l| l["info_kind"].as_str().map(str::to_string)).unwrap_or_default();
    let rate = measured.as_ref().and_then(|l| l["info_data"]["bittiming"]["bitrate"].as_u64());
    match rate {
        Some(r) if r == u64::from(bitrate) => check(what, Status::Ok, format!("up at {r} bit/s"), ""),
        Some(r) => check(what, Status::Fail, format!("up at {r} bit/s, the config says {bitrate}"), format!("`sudo ip link set {name} down` then `{up_command}`, or correct buses.can[].bitrate")),
        // A virtual interface has no bitrate; without iproute2's JSON it is not read.
        None if kind.is_empty() => check(what, Status::Ok, "up (bitrate not read: `ip -details -json link` gave none)", ""),
        None => check(what, Status::Ok, format!("up ({kind}, no bitrate)"), ""),
    }
}

/// The lateness of a 1 kHz loop that does nothing but wait, for `seconds`, with the config's
/// priority and CPU where permitted: what this machine gives any loop.
fn lateness_1khz(seconds: f64, priority: Option<u8>, cpu: Option<usize>) -> Check {
    const PERIOD_NS: u64 = 1_000_000;
    let cycles = ((seconds * 1e3).ceil() as usize).max(10);
    let measured = on_own_thread(move || {
        let applied = (priority.is_some_and(|p| crate::timing::set_fifo(p).is_ok()), cpu.is_some_and(|c| crate::timing::pin_to_cpu(c).is_ok()));
        let stop = crate::signals::StopRequest::manual();
        let mut pacer = crate::timing::Pacer::new(PERIOD_NS, 200_000);
        let (mut late, mut missed) = (Vec::with_capacity(cycles), 0u64);
        for _ in 0..cycles {
            let deadline = pacer.deadline_ns();
            let woke = pacer.wait(&stop);
            late.push(woke.saturating_sub(deadline));
            missed += pacer.advance(crate::timing::monotonic_ns());
        }
        late.sort_unstable();
        (late, missed, applied)
    });
    let Some((late, missed, (fifo, pinned))) = measured else {
        return check("1 kHz lateness", Status::Warn, "the measuring thread died", "run `jointctl doctor` again");
    };
    let at = |p: f64| late[((p / 100.0) * (late.len() - 1) as f64).round() as usize] as f64 / 1e3;
    let found = format!(
        "{} cycles ({}{}): lateness p50 {:.1} us, p99 {:.1} us, max {:.1} us; {missed} missed deadlines",
        late.len(),
        if fifo { "SCHED_FIFO" } else { "normal scheduling" },
        if pinned { ", pinned" } else { "" },
        at(50.0),
        at(99.0),
        at(100.0)
    );
    check(
        "1 kHz lateness",
        if missed == 0 { Status::Ok } else { Status::Warn },
        found,
        "this machine missed deadlines of an idle 1 kHz loop: see the checks above (RT kernel, SCHED_FIFO, an isolated CPU)",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_lists_read_as_the_kernel_writes_them() {
        assert_eq!(cpu_list("0-2,5"), [0, 1, 2, 5]);
        assert!(cpu_list("").is_empty());
    }

    #[test]
    fn a_can_interface_that_does_not_exist_fails_with_the_command_that_brings_it_up() {
        let c = can_interface("jcdoc0", 500_000);
        assert_eq!(c.status, Status::Fail);
        assert!(c.advice.contains("ip link set jcdoc0 up type can bitrate 500000"), "{c:?}");
    }
}
