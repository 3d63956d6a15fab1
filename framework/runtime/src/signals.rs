//! Every signal that would end the process by default stops the loop instead, so the joints
//! are held, a final sample is published and shared memory is released: an SSH disconnect
//! (SIGHUP) must not leave a drive on its last set-point.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use signal_hook::consts::signal;

/// The asynchronous signals whose default action ends the process. SIGPIPE is left ignored
/// (Rust's default): a closed log pipe is not a reason to stop an arm. SIGKILL and SIGSTOP
/// cannot be caught; the fault signals are [`FAULT_SIGNALS`].
pub const STOP_SIGNALS: [i32; 14] = [
    signal::SIGHUP,
    signal::SIGINT,
    signal::SIGQUIT,
    signal::SIGTERM,
    signal::SIGUSR1,
    signal::SIGUSR2,
    signal::SIGALRM,
    signal::SIGVTALRM,
    signal::SIGPROF,
    signal::SIGXCPU,
    signal::SIGXFSZ,
    signal::SIGIO,
    libc::SIGPWR,
    libc::SIGSTKFLT,
];

/// Signals that mean the process itself is broken when the kernel or the process raises them (a
/// bad address, an illegal instruction, a division by zero, a breakpoint, a forbidden system
/// call, `abort`): the process ends as by default, and the drives' own heartbeat supervision
/// stops them (see docs/faults.md). Sent by another process with `kill`, they are a stop request
/// like [`STOP_SIGNALS`]: `kill -SEGV` was ignored (Rust's stack-overflow handler takes SIGSEGV
/// and SIGBUS, and a fault it does not recognise only resets them), and the others ended the
/// runtime without holding the joints.
pub const FAULT_SIGNALS: [i32; 7] = [signal::SIGSEGV, signal::SIGBUS, signal::SIGILL, signal::SIGFPE, signal::SIGTRAP, signal::SIGSYS, signal::SIGABRT];

/// Whether a signal came from another process (`kill`, `sigqueue`): a non-positive `si_code`
/// and a sender that is not this process (`abort` raises SIGABRT on itself).
fn sent_by_another_process(info: &libc::siginfo_t) -> bool {
    // SAFETY: `si_pid` reads the sender's pid field, present for every non-positive si_code
    // (SI_USER, SI_QUEUE, SI_TKILL); it is read only when si_code says so.
    info.si_code <= 0 && unsafe { info.si_pid() } != std::process::id() as i32
}

/// The stop request of a run: set by a signal (its number) or by the program (any non-zero).
///
/// ```
/// let stop = jointctl_runtime::signals::StopRequest::install().unwrap();
/// assert_eq!(stop.signal(), None);
/// stop.request();
/// assert!(stop.requested());
/// ```
#[derive(Clone, Debug)]
pub struct StopRequest(Arc<AtomicUsize>);

/// Set by [`StopRequest::request`], not a signal number.
const REQUESTED: usize = usize::MAX;

impl StopRequest {
    /// Catches every signal of [`STOP_SIGNALS`] from now on (more than once is fine).
    pub fn install() -> Result<Self, std::io::Error> {
        let flag = Arc::new(AtomicUsize::new(0));
        for s in STOP_SIGNALS {
            signal_hook::flag::register_usize(s, Arc::clone(&flag), s as usize)?;
        }
        for s in FAULT_SIGNALS {
            let flag = Arc::clone(&flag);
            let action = move |info: &libc::siginfo_t| {
                if sent_by_another_process(info) {
                    let _ = flag.compare_exchange(0, s as usize, Ordering::Relaxed, Ordering::Relaxed);
                } else if s != signal::SIGSEGV && s != signal::SIGBUS {
                    // The process's own fault: its default action (SIGSEGV and SIGBUS reach it
                    // through Rust's handler, which runs before this one and resets them).
                    // SAFETY: sigaction and raise are async-signal-safe; the raised signal is
                    // blocked until this handler returns, then ends the process by default.
                    unsafe {
                        let mut default: libc::sigaction = std::mem::zeroed();
                        default.sa_sigaction = libc::SIG_DFL;
                        libc::sigaction(s, &default, std::ptr::null_mut());
                        libc::raise(s);
                    }
                }
            };
            // SAFETY: the action only reads its siginfo, swaps an atomic and calls sigaction and
            // raise, which are async-signal-safe; it allocates and locks nothing.
            unsafe { signal_hook_registry::register_unchecked(s, action) }?;
        }
        Ok(StopRequest(flag))
    }

    /// A request that no signal sets (tests, embedding).
    pub fn manual() -> Self {
        StopRequest(Arc::new(AtomicUsize::new(0)))
    }

    /// Whether a stop was asked for.
    pub fn requested(&self) -> bool {
        self.0.load(Ordering::Relaxed) != 0
    }

    /// Asks for a stop.
    pub fn request(&self) {
        let _ = self.0.compare_exchange(0, REQUESTED, Ordering::Relaxed, Ordering::Relaxed);
    }

    /// The signal that asked for the stop, if a signal did.
    pub fn signal(&self) -> Option<i32> {
        match self.0.load(Ordering::Relaxed) {
            0 | REQUESTED => None,
            s => Some(s as i32),
        }
    }
}

/// A signal's name (`SIGHUP`), or its number.
///
/// ```
/// assert_eq!(jointctl_runtime::signals::signal_name(1), "SIGHUP");
/// ```
pub fn signal_name(signal: i32) -> String {
    signal_hook::low_level::signal_name(signal).map_or_else(|| format!("signal {signal}"), str::to_string)
}
