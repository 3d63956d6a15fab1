//! Every signal that would end the process by default stops the loop instead, so the joints
//! are held, a final sample is published and shared memory is released: an SSH disconnect
//! (SIGHUP) must not leave a drive on its last set-point.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use signal_hook::consts::signal;

/// The asynchronous signals whose default action ends the process. SIGPIPE is left ignored
/// (Rust's default): a closed log pipe is not a reason to stop an arm. SIGKILL and SIGSTOP
/// cannot be caught; the synchronous ones (SIGSEGV, SIGBUS, SIGILL, SIGFPE) mean the process
/// itself is broken and may not run a handler.
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
