//! Absolute-deadline pacing on CLOCK_MONOTONIC and the loop's timing statistics.

use jointctl_ipc::JITTER_BUCKET_UPPER_US;

/// CLOCK_MONOTONIC [ns].
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into a valid timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

fn sleep_until_ns(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    // Absolute sleep: a wake-up that comes late does not shift the following deadlines. A signal
    // interrupts it (EINTR); the caller then re-checks its stop flag and the time.
    // SAFETY: valid timespec; the remainder pointer may be null for TIMER_ABSTIME.
    unsafe { libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, core::ptr::null_mut()) };
}

/// Locks every page this process has mapped and will map (`mlockall`): no page fault stalls the
/// loop once it runs.
///
/// # Errors
/// The system refused (the memlock limit, no permission).
///
/// ```no_run
/// if let Err(e) = jointctl_runtime::timing::lock_all_memory() {
///     eprintln!("page faults may stall the loop: {e}");
/// }
/// ```
pub fn lock_all_memory() -> std::io::Result<()> {
    // With MCL_FUTURE, memory mapped beyond a finite memlock limit fails to map, and an
    // allocation that fails aborts the program: lock only where no limit applies (an unlimited
    // limit, or root, whom it does not bind).
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit writes the struct it is given; geteuid has no arguments.
    let (known, root) = unsafe { (libc::getrlimit(libc::RLIMIT_MEMLOCK, &mut limit) == 0, libc::geteuid() == 0) };
    let unlimited = known && limit.rlim_cur == libc::RLIM_INFINITY;
    if !(root || unlimited) {
        let shown = if known { format!("{} KiB", limit.rlim_cur / 1024) } else { "unknown".into() };
        return Err(std::io::Error::other(format!("the memlock limit is {shown}, not unlimited: memory the runtime maps later would fail to map")));
    }
    // SAFETY: mlockall takes flags only.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } == 0 { Ok(()) } else { Err(std::io::Error::last_os_error()) }
}

/// Runs the calling thread with SCHED_FIFO at `priority` (1-99).
///
/// # Errors
/// The system refused (no CAP_SYS_NICE, RLIMIT_RTPRIO below `priority`).
///
/// ```no_run
/// std::thread::spawn(|| jointctl_runtime::timing::set_fifo(80)).join().unwrap().ok();
/// ```
pub fn set_fifo(priority: u8) -> std::io::Result<()> {
    set_fifo_of(0, priority)
}

/// Runs thread `tid` (a Linux thread id, `gettid`; 0 for the calling thread) with SCHED_FIFO at
/// `priority` (1-99).
///
/// # Errors
/// As [`set_fifo`], or no such thread.
///
/// ```
/// assert!(jointctl_runtime::timing::set_fifo_of(-1, 10).is_err());
/// ```
pub fn set_fifo_of(tid: libc::pid_t, priority: u8) -> std::io::Result<()> {
    let param = libc::sched_param { sched_priority: i32::from(priority) };
    // SAFETY: a valid sched_param; the kernel checks the thread id.
    if unsafe { libc::sched_setscheduler(tid, libc::SCHED_FIFO, &param) } == 0 { Ok(()) } else { Err(std::io::Error::last_os_error()) }
}

/// Pins the calling thread to CPU `cpu`.
///
/// # Errors
/// The system refused (no such CPU, outside the process's affinity), or `cpu` is beyond what a
/// CPU set holds (1024).
///
/// ```
/// assert!(jointctl_runtime::timing::pin_to_cpu(5000).is_err());
/// ```
pub fn pin_to_cpu(cpu: usize) -> std::io::Result<()> {
    pin_to_cpu_of(0, cpu)
}

/// Pins thread `tid` (a Linux thread id; 0 for the calling thread) to CPU `cpu`.
///
/// # Errors
/// As [`pin_to_cpu`], or no such thread.
///
/// ```
/// assert!(jointctl_runtime::timing::pin_to_cpu_of(-1, 0).is_err());
/// ```
pub fn pin_to_cpu_of(tid: libc::pid_t, cpu: usize) -> std::io::Result<()> {
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("CPU {cpu} is beyond a CPU set's {}", libc::CPU_SETSIZE)));
    }
    // SAFETY: a zeroed cpu_set_t is valid; CPU_SET stays within it for cpu < CPU_SETSIZE; the
    // kernel checks the thread id.
    let ok = unsafe {
        let mut set: libc::cpu_set_t = core::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(tid, core::mem::size_of::<libc::cpu_set_t>(), &set) == 0
    };
    if ok { Ok(()) } else { Err(std::io::Error::last_os_error()) }
}

/// The calling thread's Linux thread id.
///
/// ```
/// assert!(jointctl_runtime::timing::thread_id() > 0);
/// ```
pub fn thread_id() -> libc::pid_t {
    // SAFETY: gettid has no arguments and cannot fail.
    unsafe { libc::gettid() }
}

/// Wakes the loop at `start + k * period`: sleeps until `spin` before the deadline, then spins.
#[derive(Clone, Debug)]
pub struct Pacer {
    period_ns: u64,
    spin_ns: u64,
    next_ns: u64,
}

impl Pacer {
    /// A pacer whose first deadline is one period from now.
    pub fn new(period_ns: u64, spin_ns: u64) -> Self {
        Pacer { period_ns, spin_ns: spin_ns.min(period_ns / 2), next_ns: monotonic_ns() + period_ns }
    }

    /// The deadline the loop is waiting for [ns].
    pub fn deadline_ns(&self) -> u64 {
        self.next_ns
    }

    /// Waits for the deadline; returns the wake-up time [ns]. Returns early if `stop` is set.
    pub fn wait(&self, stop: &crate::signals::StopRequest) -> u64 {
        let coarse = self.next_ns.saturating_sub(self.spin_ns);
        loop {
            let now = monotonic_ns();
            if now >= coarse || stop.requested() {
                break;
            }
            sleep_until_ns(coarse);
        }
        loop {
            let now = monotonic_ns();
            if now >= self.next_ns || stop.requested() {
                return now;
            }
            core::hint::spin_loop();
        }
    }

    /// Moves to the next deadline after a cycle that ended at `end_ns`. Returns how many
    /// deadlines were missed (0 when the cycle ended in time).
    pub fn advance(&mut self, end_ns: u64) -> u64 {
        self.next_ns += self.period_ns;
        if end_ns <= self.next_ns {
            return 0;
        }
        // Overran: skip the deadlines already past instead of running a burst of late cycles.
        let missed = (end_ns - self.next_ns) / self.period_ns + 1;
        self.next_ns += missed * self.period_ns;
        missed
    }
}

/// Timing statistics of a run. Recording is allocation-free: the sample buffer is reserved up
/// front and stops recording when full.
#[derive(Clone, Debug, Default)]
pub struct LoopStats {
    /// Cycles run.
    pub cycles: u64,
    /// Cycles whose work ended after the next deadline.
    pub overruns: u64,
    /// Deadlines skipped.
    pub missed_deadlines: u64,
    /// Compute time of the last cycle [ns].
    pub last_compute_ns: u64,
    /// Longest compute time [ns].
    pub max_compute_ns: u64,
    /// Largest wake-up lateness [ns].
    pub max_jitter_ns: u64,
    /// Lateness histogram (buckets: [`JITTER_BUCKET_UPPER_US`]).
    pub jitter_histogram: [u64; 16],
    jitter_samples_ns: Vec<u32>,
    compute_samples_ns: Vec<u32>,
}

impl LoopStats {
    /// Statistics that keep up to `samples` individual cycle timings for percentiles.
    pub fn with_samples(samples: usize) -> Self {
        LoopStats {
            jitter_samples_ns: Vec::with_capacity(samples),
            compute_samples_ns: Vec::with_capacity(samples),
            ..Default::default()
        }
    }

    /// Records one cycle.
    pub fn record(&mut self, jitter_ns: u64, compute_ns: u64, missed: u64) {
        self.cycles += 1;
        if missed > 0 {
            self.overruns += 1;
            self.missed_deadlines += missed;
        }
        self.last_compute_ns = compute_ns;
        self.max_compute_ns = self.max_compute_ns.max(compute_ns);
        self.max_jitter_ns = self.max_jitter_ns.max(jitter_ns);
        let us = jitter_ns / 1000;
        let bucket = JITTER_BUCKET_UPPER_US.iter().position(|b| us < *b).unwrap_or(15);
        self.jitter_histogram[bucket] += 1;
        if self.jitter_samples_ns.len() < self.jitter_samples_ns.capacity() {
            self.jitter_samples_ns.push(jitter_ns.min(u32::MAX as u64) as u32);
            self.compute_samples_ns.push(compute_ns.min(u32::MAX as u64) as u32);
        }
    }

    /// The recorded cycles as (wake-up lateness, compute time) [ns].
    pub fn cycle_samples(&self) -> impl Iterator<Item = (u64, u64)> + '_ {
        self.jitter_samples_ns.iter().zip(&self.compute_samples_ns).map(|(j, c)| (*j as u64, *c as u64))
    }

    /// Percentiles (0-100) of the recorded wake-up lateness [ns].
    pub fn jitter_percentile_ns(&self, p: f64) -> Option<u64> {
        percentile(&self.jitter_samples_ns, p)
    }

    /// Percentiles (0-100) of the recorded compute time [ns].
    pub fn compute_percentile_ns(&self, p: f64) -> Option<u64> {
        percentile(&self.compute_samples_ns, p)
    }
}

fn percentile(samples: &[u32], p: f64) -> Option<u64> {
    if samples.is_empty() {
        return None;
    }
    let mut v = samples.to_vec();
    v.sort_unstable();
    let i = ((p / 100.0) * (v.len() - 1) as f64).round() as usize;
    Some(v[i.min(v.len() - 1)] as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_overrun_skips_the_deadlines_already_past() {
        let mut p = Pacer { period_ns: 1000, spin_ns: 0, next_ns: 10_000 };
        assert_eq!(p.advance(10_500), 0);
        assert_eq!(p.deadline_ns(), 11_000);
        // The cycle that should have ended before 12_000 ended at 13_500: 12_000 and 13_000 missed.
        assert_eq!(p.advance(13_500), 2);
        assert_eq!(p.deadline_ns(), 14_000);
    }

    #[test]
    fn stats_count_overruns_and_bucket_jitter() {
        let mut s = LoopStats::with_samples(4);
        s.record(3_000, 10, 0);
        s.record(70_000, 10, 2);
        assert_eq!((s.cycles, s.overruns, s.missed_deadlines), (2, 1, 2));
        assert_eq!(s.jitter_histogram[2], 1); // 3 us: bucket [2, 5)
        assert_eq!(s.jitter_histogram[6], 1); // 70 us: bucket [50, 100)
        assert_eq!(s.jitter_percentile_ns(100.0), Some(70_000));
    }
}
