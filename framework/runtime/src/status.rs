//! What the loop tells the command desk about each DOF, so that a command that will not run is
//! refused instead of accepted: written by the control thread every cycle (relaxed atomic
//! stores, no lock, no allocation), read by the IPC thread. The loop's own `Arm::enabled` and
//! slot faults stay the single source of truth; this is their published copy.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// One DOF as the loop last saw it.
#[derive(Debug, Default)]
struct DofStatus {
    enabled: AtomicBool,
    fault: AtomicU32,
}

/// The loop's published status.
///
/// ```
/// let s = jointctl_runtime::status::LoopStatus::new(2);
/// s.set_dof(1, false, 3);
/// assert!(!s.enabled(1) && s.fault(1) == 3 && s.enabled(0));
/// ```
#[derive(Debug)]
pub struct LoopStatus {
    dofs: Box<[DofStatus]>,
    stopping: AtomicBool,
}

impl LoopStatus {
    /// A status of `n` DOFs, every one enabled and without fault (the state before the first cycle).
    pub fn new(n: usize) -> Self {
        let dofs = (0..n).map(|_| DofStatus { enabled: AtomicBool::new(true), fault: AtomicU32::new(0) }).collect();
        LoopStatus { dofs, stopping: AtomicBool::new(false) }
    }

    /// Publishes one DOF. Allocation-free.
    pub fn set_dof(&self, dof: usize, enabled: bool, fault: u32) {
        self.dofs[dof].enabled.store(enabled, Ordering::Relaxed);
        self.dofs[dof].fault.store(fault, Ordering::Relaxed);
    }

    /// Publishes that the loop is stopping.
    pub fn set_stopping(&self) {
        self.stopping.store(true, Ordering::Relaxed);
    }

    /// Whether DOF `dof` is enabled.
    pub fn enabled(&self, dof: usize) -> bool {
        self.dofs[dof].enabled.load(Ordering::Relaxed)
    }

    /// DOF `dof`'s joint fault code, 0 when none.
    pub fn fault(&self, dof: usize) -> u32 {
        self.dofs[dof].fault.load(Ordering::Relaxed)
    }

    /// Whether the loop is stopping.
    pub fn stopping(&self) -> bool {
        self.stopping.load(Ordering::Relaxed)
    }
}
