//! `jointctl run`: the fixed-rate loop around an [`Arm`], with signals, deadlines and shared
//! memory.
//!
//! Per cycle: wait for the deadline → read HAL and observe → (commands) → control and write →
//! hand the cycle's record (state and diagnostics) to the publisher thread. Nothing here allocates,
//! locks or logs inside a cycle; a fault raised in a cycle is logged once, after that cycle's
//! set-points are written.

use jointctl_config::TimingConfig;

use crate::arm::Arm;
pub use crate::publisher::{ArmPublisher, HopSample};
pub use crate::run_error::RunError;
use crate::signals::StopRequest;
use crate::timing::{LoopStats, Pacer, monotonic_ns};

/// How long to run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Stop after this many cycles.
    pub cycles: Option<u64>,
    /// Stop after this many seconds.
    pub duration_s: Option<f64>,
    /// Keep this many per-cycle timings for percentiles (benchmarks).
    pub timing_samples: usize,
    /// The stop request to follow, installed early by the caller so that a signal during setup
    /// is not lost; when `None`, [`run`] installs one itself.
    pub stop: Option<StopRequest>,
}

/// What a run did.
#[derive(Debug)]
pub struct RunReport {
    /// Timing statistics.
    pub stats: LoopStats,
    /// Samples iceoryx2 refused (loan or send failed).
    pub publish_failures: u64,
    /// Stopped by a signal or a stop request.
    pub interrupted: bool,
    /// The signal that stopped the loop, if one did.
    pub signal: Option<i32>,
}

/// Applies the timing settings that need privileges; says what it could not do. The publisher
/// thread (`publisher_tid`) follows the loop: on its CPU, and one priority below it when the loop
/// got SCHED_FIFO at 2 or more, so that it runs as soon as the loop sleeps after handing a cycle
/// over, and never before the loop.
fn apply_thread_settings(timing: &TimingConfig, publisher_tid: Option<libc::pid_t>) {
    if timing.lock_memory
        && let Err(e) = crate::timing::lock_all_memory()
    {
        tracing::warn!("could not lock the runtime's memory (timing.lock_memory): {e}; page faults can stall the loop. Raise the memlock limit of this user (limits.conf `memlock unlimited`, or LimitMEMLOCK=infinity); `jointctl doctor` checks it");
    }
    if let Some(cpu) = timing.cpu
        && let Err(e) = crate::timing::pin_to_cpu(cpu)
    {
        tracing::warn!(cpu, "could not pin the loop thread: {e}");
    }
    let loop_fifo = timing.realtime_priority.filter(|&priority| match crate::timing::set_fifo(priority) {
        Ok(()) => true,
        Err(e) => {
            tracing::warn!(priority, "could not switch the loop to SCHED_FIFO: {e}");
            false
        }
    });
    let Some(tid) = publisher_tid else { return };
    if let Some(cpu) = timing.cpu
        && let Err(e) = crate::timing::pin_to_cpu_of(tid, cpu)
    {
        tracing::warn!(cpu, "could not pin the publisher thread beside the loop: {e}");
    }
    // Strictly below the loop, and only when the loop got its priority: at the loop's own
    // priority (1) a publisher still sending would hold the waking loop off; above an
    // unprivileged loop it would preempt it.
    if let Some(priority) = loop_fifo.filter(|&p| p >= 2)
        && let Err(e) = crate::timing::set_fifo_of(tid, priority - 1)
    {
        tracing::warn!(priority, "could not switch the publisher thread to SCHED_FIFO: {e}");
    }
}

/// One arm's loop state between cycles: what [`ControlLoop::step`] needs so that a cycle
/// allocates nothing.
pub struct ControlLoop<'a> {
    /// The arm.
    pub arm: &'a mut Arm,
    publisher: Option<&'a mut ArmPublisher>,
    /// Timing statistics so far.
    pub stats: LoopStats,
    /// Cycles run.
    pub cycle: u64,
    start_ns: u64,
}

impl<'a> ControlLoop<'a> {
    /// Prepares a loop; `timing_samples` cycle timings are kept for percentiles.
    pub fn new(arm: &'a mut Arm, publisher: Option<&'a mut ArmPublisher>, timing_samples: usize) -> Self {
        ControlLoop { arm, publisher, stats: LoopStats::with_samples(timing_samples), cycle: 0, start_ns: monotonic_ns() }
    }

    /// One cycle, woken at `woke_ns` for the deadline `deadline_ns`: observe, apply the commands
    /// that arrived, control, write, then publish the cycle's state and diagnostics together, so
    /// that each sample's mode and torque reference are the ones used with the torque beside
    /// them. Returns the time the work ended [ns]. Allocation-free.
    pub fn step(&mut self, deadline_ns: u64, woke_ns: u64, pacer: Option<&mut Pacer>) -> u64 {
        let stamp_s = woke_ns.saturating_sub(self.start_ns) as f64 * 1e-9;
        self.arm.observe(stamp_s);
        if let Some(p) = self.publisher.as_deref_mut() {
            p.post_observed(self.arm, self.cycle, woke_ns);
            p.apply_commands(self.arm);
        }
        self.arm.control();
        let done = monotonic_ns();
        let missed = pacer.map_or(0, |p| p.advance(done));
        self.stats.record(woke_ns.saturating_sub(deadline_ns), done - woke_ns, missed);
        if let Some(p) = self.publisher.as_deref_mut() {
            p.set_done_ns(done);
            p.publish_state(self.arm, self.cycle, woke_ns, false);
            p.publish_diagnostics(self.arm, &self.stats, self.cycle, woke_ns);
        }
        self.cycle += 1;
        done
    }

    /// Logs faults raised since the last call when no publisher thread does (`--no-ipc`): the
    /// publisher thread logs them from the diagnostics, so that the control thread writes
    /// nothing. Outside the timed part of a cycle; rare.
    pub fn report_faults(&mut self) {
        let published = self.publisher.is_some();
        for slot in self.arm.slots.iter_mut().filter(|s| s.fault_unreported) {
            slot.fault_unreported = false;
            if !published {
                tracing::error!(joint = %slot.name, plugin = %slot.plugin, fault = slot.fault, "joint faulted and is held: {}", slot.fault_reason());
            }
        }
    }

    /// Holds every joint, publishes a final state and diagnostics.
    pub fn finish(self) -> (LoopStats, u64) {
        self.arm.shutdown();
        let failures = match self.publisher {
            Some(p) => {
                let now = monotonic_ns();
                p.publish_state(self.arm, self.cycle, now, true);
                p.publish_diagnostics(self.arm, &self.stats, self.cycle, now);
                p.close()
            }
            None => 0,
        };
        (self.stats, failures)
    }
}

/// Runs the loop until `opts` says stop, a stop command arrives or a terminating signal does
/// (see [`crate::signals`]); then holds every joint, publishes a final state and releases
/// shared memory.
pub fn run(
    arm: &mut Arm,
    timing: &TimingConfig,
    publisher: Option<&mut ArmPublisher>,
    opts: &RunOptions,
) -> Result<RunReport, RunError> {
    let stop = match &opts.stop {
        Some(s) => s.clone(),
        None => StopRequest::install().map_err(RunError::Signals)?,
    };
    apply_thread_settings(timing, publisher.as_ref().map(|p| p.thread_id()));
    let period_ns = (1e9 / arm.rate_hz).round() as u64;
    let max_cycles = opts.cycles.unwrap_or(u64::MAX);
    let end_ns = opts.duration_s.map(|d| monotonic_ns() + (d * 1e9) as u64);
    tracing::info!(arm = %arm.name, rate_hz = arm.rate_hz, joints = arm.dof_names.len(), "loop started");
    let mut lp = ControlLoop::new(arm, publisher, opts.timing_samples);
    let mut pacer = Pacer::new(period_ns, timing.spin_us as u64 * 1000);
    while lp.cycle < max_cycles && !stop.requested() && !lp.arm.stop_requested {
        let deadline = pacer.deadline_ns();
        let woke = pacer.wait(&stop);
        if stop.requested() || end_ns.is_some_and(|e| woke >= e) {
            break;
        }
        lp.step(deadline, woke, Some(&mut pacer));
        lp.report_faults();
    }
    let interrupted = stop.requested();
    let signal = stop.signal();
    let (stats, publish_failures) = lp.finish();
    tracing::info!(
        cycles = stats.cycles,
        overruns = stats.overruns,
        missed = stats.missed_deadlines,
        max_compute_us = stats.max_compute_ns / 1000,
        max_jitter_us = stats.max_jitter_ns / 1000,
        interrupted,
        signal = %signal.map_or_else(|| "none".to_string(), crate::signals::signal_name),
        "loop stopped, joints held"
    );
    Ok(RunReport { stats, publish_failures, interrupted, signal })
}
