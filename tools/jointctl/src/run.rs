//! `jointctl run`: the order of the start-up is the safety argument. Signals are caught first
//! (a signal during set-up still holds the joints), the arm's single-runtime lock is taken before
//! any hardware is opened, the loop runs, and every way out holds the joints.

use std::path::PathBuf;
use std::process::ExitCode;

use jointctl_runtime::signals::{StopRequest, signal_name};
use jointctl_runtime::{ArmPublisher, RunOptions};

use crate::{fail, fail_err, static_loader};

/// `jointctl run`'s arguments.
#[derive(clap::Args)]
pub struct RunArgs {
    /// The arm description (e.g. configs/sherpa_arm.yaml).
    config: PathBuf,
    /// Stop after N cycles.
    #[arg(long)]
    cycles: Option<u64>,
    /// Stop after S seconds.
    #[arg(long, value_parser = crate::seconds)]
    duration: Option<f64>,
    /// Use the plugins linked into this binary instead of loading shared libraries.
    #[arg(long)]
    static_plugins: bool,
    /// Do not publish to shared memory.
    #[arg(long)]
    no_ipc: bool,
    /// Simulated backend: take the arm off its clamps, every joint of its URDF a joint of the
    /// free arm (its links loading each other under gravity), whatever environment the YAML
    /// gives them.
    #[arg(long)]
    free_arm: bool,
}

/// Says which signal ended set-up, after the joints were held.
fn stopped_during_setup(stop: &StopRequest, arm: Option<&mut jointctl_runtime::Arm>) -> ExitCode {
    if let Some(arm) = arm {
        arm.shutdown();
    }
    let by = stop.signal().map_or_else(|| "a stop request".to_string(), signal_name);
    fail(format!("stopped by {by} before the loop started; joints held"))
}

/// Where the arm's shared memory and its locks are: the YAML's `ipc`.
fn ipc_scope(config: &jointctl_config::ArmConfig) -> jointctl_ipc::IpcScope {
    jointctl_ipc::IpcScope { domain: config.ipc.domain.clone(), root: config.ipc.root.clone(), group: config.ipc.group.clone() }
}

/// The locks held while a process drives an arm's hardware, released when dropped.
pub struct HardwareLocks {
    _arm: jointctl_runtime::lock::ArmLock,
    _machine: Vec<jointctl_runtime::lock::MachineLock>,
}

/// Why the locks for driving an arm's hardware were not taken: each step's own error, whose
/// message says what and where (the lock file, the process holding it).
#[derive(Debug, thiserror::Error)]
pub enum LockHardwareError {
    /// The arm's shared-memory root could not be made or used.
    #[error(transparent)]
    Root(jointctl_ipc::IpcSetupError),
    /// The folder of the arm's lock in its domain and root could not be found.
    #[error(transparent)]
    LockDir(jointctl_ipc::IpcSetupError),
    /// The arm's lock in its domain and root is held, or could not be taken.
    #[error(transparent)]
    Arm(jointctl_runtime::lock::LockError),
    /// A machine-wide lock (the arm's name, a CAN interface) is held, or could not be taken.
    #[error(transparent)]
    Machine(jointctl_runtime::lock::LockError),
}

/// Takes, before any bus is opened, the locks a process must hold to drive the arm of `loaded`:
/// the arm's in its domain and root (where `cmd stop` finds the runtime), and machine-wide the
/// arm name's and every CAN interface's, whatever the domain or root (one runtime per arm and
/// one host per bus). `jointctl run` and `jointctl check-transmission` both command the drives.
pub fn lock_hardware(loaded: &jointctl_config::LoadedConfig) -> Result<HardwareLocks, LockHardwareError> {
    let scope = ipc_scope(&loaded.config);
    jointctl_ipc::prepare_root(&scope).map_err(LockHardwareError::Root)?;
    let lock_dir = jointctl_ipc::lock_dir_in(&scope).map_err(LockHardwareError::LockDir)?;
    let arm = jointctl_runtime::lock::ArmLock::acquire(&lock_dir, &loaded.config.arm).map_err(LockHardwareError::Arm)?;
    let machine_dir = jointctl_runtime::lock::machine_lock_dir();
    let mut machine = vec![jointctl_runtime::lock::MachineLock::arm(&machine_dir, &loaded.config.arm).map_err(LockHardwareError::Machine)?];
    if loaded.config.hal.backend == jointctl_config::HalBackend::Socketcan {
        for bus in &loaded.config.buses.can {
            machine.push(jointctl_runtime::lock::MachineLock::bus(&machine_dir, &bus.interface).map_err(LockHardwareError::Machine)?);
        }
    }
    Ok(HardwareLocks { _arm: arm, _machine: machine })
}

pub fn run(a: RunArgs) -> ExitCode {
    let stop = match StopRequest::install() {
        Ok(s) => s,
        Err(e) => return fail(format!("cannot install the signal handlers: {e}")),
    };
    let mut loaded = match jointctl_config::load(&a.config) {
        Ok(l) => l,
        Err(e) => return fail_err(e),
    };
    if a.free_arm {
        if loaded.config.hal.backend != jointctl_config::HalBackend::Sim {
            return fail("--free-arm is for the simulated backend (`hal: {backend: sim}`)".to_string());
        }
        let Some(chain) = loaded.chain.clone() else {
            return fail(format!("--free-arm needs the arm's URDF: {} has no `kinematics: {{urdf: FILE}}`", a.config.display()));
        };
        let released = jointctl_sim::free_arm::release(&mut loaded.config, &chain);
        tracing::info!("free arm: {} released", released.join(", "));
    }
    let ipc = &loaded.config.ipc;
    let scope = ipc_scope(&loaded.config);
    // Before any bus is opened: a second runtime of this arm must not touch its drives.
    let _locks = match lock_hardware(&loaded) {
        Ok(l) => l,
        Err(e) => return fail_err(e),
    };
    let mut loader = jointctl_runtime::loader_for(&loaded);
    if a.static_plugins && let Err(e) = static_loader(&mut loader) {
        return fail_err(e);
    }
    let mut arm = match jointctl_backends::build_arm(&loaded, &loader) {
        Ok(arm) => arm,
        Err(e) => return fail_err(e),
    };
    if stop.requested() {
        return stopped_during_setup(&stop, Some(&mut arm));
    }
    if let Err(e) = arm.activate() {
        arm.shutdown();
        return fail_err(e);
    }
    let mut publisher = if a.no_ipc {
        None
    } else {
        let limits = jointctl_ipc::PortLimits { max_subscribers: ipc.max_subscribers, max_clients: ipc.max_clients };
        match ArmPublisher::with_limits(&arm, &scope, limits) {
            Ok(p) => Some(p),
            Err(e) => {
                arm.shutdown();
                return fail_err(e);
            }
        }
    };
    if stop.requested() {
        return stopped_during_setup(&stop, Some(&mut arm));
    }
    let opts = RunOptions { cycles: a.cycles, duration_s: a.duration, timing_samples: 0, stop: Some(stop) };
    match jointctl_runtime::run(&mut arm, &loaded.config.timing, publisher.as_mut(), &opts) {
        Ok(report) => {
            eprintln!(
                "{} cycles, {} overruns, {} missed deadlines, max compute {:.1} us, max wake-up lateness {:.1} us{}",
                report.stats.cycles,
                report.stats.overruns,
                report.stats.missed_deadlines,
                report.stats.max_compute_ns as f64 / 1e3,
                report.stats.max_jitter_ns as f64 / 1e3,
                report.signal.map(|s| format!(", stopped by {}", signal_name(s))).unwrap_or_default(),
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail_err(e),
    }
}
