//! Inspectors: separate processes that read a running arm's shared memory. A slow or killed
//! inspector never slows the loop: its buffer overflows (oldest dropped) instead.

use std::io::Write as _;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Subcommand;
use iceoryx2::prelude::*;
use jointctl_ipc::{ArmState, Diagnostics, ServiceNames};

use crate::arm_view::*;

#[derive(Subcommand)]
pub enum InspectCommand {
    /// List the shared-memory services in the domain (all arms, or one).
    List {
        /// Only this arm's services.
        #[arg(long)]
        arm: Option<String>,
        /// iceoryx2 domain of the arm (its YAML `ipc.domain`).
        #[arg(long)]
        domain: Option<String>,
        /// Shared-memory root of the arm (its YAML `ipc.root`).
        #[arg(long, value_name = "DIR")]
        ipc_root: Option<std::path::PathBuf>,
    },
    /// Print the live joint states of a running arm.
    Echo {
        #[command(flatten)]
        at: RunningArm,
        /// One JSON object per sample.
        #[arg(long)]
        json: bool,
        /// Stop after N samples.
        #[arg(long)]
        count: Option<u64>,
        /// Give up when no sample arrives for this long [s].
        #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
        timeout: f64,
        /// Print at most this many samples per second (the newest; the rest are skipped).
        #[arg(long, value_parser = positive_rate)]
        rate: Option<f64>,
        /// Only these joints (DOF names, comma-separated or repeated).
        #[arg(long, value_delimiter = ',')]
        joint: Vec<String>,
        /// Read the arm's latest-state blackboard instead of its joint-state stream: each cycle's
        /// state as soon as the loop has observed it (before control: with the mode and torque
        /// reference of the cycle before), the newest only (cycles between two reads are not
        /// printed).
        #[arg(long, conflicts_with = "zenoh")]
        latest: bool,
        /// Read from another machine: the Zenoh endpoint of its `jointctl bridge zenoh` (e.g.
        /// `tcp/192.168.1.10:7447`) instead of this machine's shared memory.
        #[arg(long, value_name = "ENDPOINT")]
        zenoh: Option<String>,
        #[command(flatten)]
        credentials: crate::remote::CredentialArgs,
    },
    /// Print a running arm's loop health: every diagnostics counter, the lateness histogram,
    /// each device's losses by its full name, and each joint's faults and holds with the reason.
    Diag {
        #[command(flatten)]
        at: RunningArm,
        #[command(flatten)]
        snapshot: Snapshot,
    },
    /// A refreshing terminal view: the loop's measured rate, lateness percentiles and
    /// counters, each joint (as `inspect joints`, with position and torque) and each device's
    /// losses. q, Esc or Ctrl-C quits.
    Top {
        #[command(flatten)]
        at: RunningArm,
        /// Refresh interval [s].
        #[arg(long, default_value_t = 0.5, value_parser = positive_seconds)]
        interval: f64,
        /// Show the arm as silent after this long without a sample [s].
        #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
        timeout: f64,
    },
    /// List what runs: each joint's plugin (name, version, library), its DOFs with their mode,
    /// whether they are enabled, faulted, held, and which fields are observed.
    Joints {
        #[command(flatten)]
        at: RunningArm,
        #[command(flatten)]
        snapshot: Snapshot,
    },
}

/// How a one-shot view (`diag`, `joints`) prints and waits.
#[derive(clap::Args)]
pub struct Snapshot {
    /// One JSON object.
    #[arg(long)]
    json: bool,
    /// Give up when no sample arrives for this long [s].
    #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
    timeout: f64,
}

/// An interval [s]: finite and > 0.
fn positive_seconds(text: &str) -> Result<f64, String> {
    match crate::finite(text)? {
        v if v > 0.0 => Ok(v),
        v => Err(format!("must be > 0 s, got {v}")),
    }
}

/// A sample rate [Hz]: finite and > 0.
fn positive_rate(text: &str) -> Result<f64, String> {
    // At least one sample in MAX_SECONDS (1/1e-300 Hz panicked in `Duration`).
    let slowest = 1.0 / crate::MAX_SECONDS;
    match crate::finite(text)? {
        v if v >= slowest => Ok(v),
        v => Err(format!("must be >= {slowest:e} Hz, got {}", jointctl_config::short_number(v))),
    }
}

pub fn run(command: InspectCommand) -> ExitCode {
    match command {
        InspectCommand::List { arm, domain, ipc_root } => {
            let config = match jointctl_ipc::iceoryx2_config_in(&jointctl_ipc::IpcScope { domain, root: ipc_root, group: None }) {
                Ok(c) => c,
                Err(e) => return crate::fail_err(e),
            };
            let prefix = arm.map(|a| format!("{a}/"));
            let mut found = 0;
            let r = ipc::Service::list(&config, |s| {
                let name = s.static_details.name().as_str().to_string();
                if prefix.as_ref().is_none_or(|p| name.starts_with(p)) {
                    let pattern = format!("{:?}", s.static_details.messaging_pattern());
                    outln!("{name}  ({})", pattern.split('(').next().unwrap_or("?"));
                    found += 1;
                }
                CallbackProgression::Continue
            });
            if let Err(e) = r {
                return crate::fail(format!("cannot list services: {e:?}"));
            }
            if found == 0 {
                eprintln!("no services found (is an arm running in this domain?)");
            }
            ExitCode::SUCCESS
        }
        InspectCommand::Echo { at: RunningArm { arm, domain, ipc_root }, json, count, timeout, rate, joint, latest, zenoh, credentials } => {
            let opts = EchoOptions { json, count, rate, joint };
            if let Some(endpoint) = zenoh {
                return crate::remote::echo(&endpoint, &arm, &credentials, timeout, &opts);
            }
            let hint = domain_hint(&domain);
            if latest {
                return echo_latest(&arm, jointctl_ipc::IpcScope { domain, root: ipc_root, group: None }, timeout, &hint, &opts);
            }
            let (_node, subscriber) = match subscribe(&arm, domain, ipc_root, timeout, |n| n.joint_state.clone(), jointctl_ipc::joint_state_service) {
                Ok(s) => s,
                Err(e) => return crate::fail(e),
            };
            let names = ServiceNames::for_arm(&arm);
            let mut last = Instant::now();
            echo(&opts, || match subscriber.receive() {
                Ok(Some(sample)) => {
                    last = Instant::now();
                    Ok(Some((ArmState::from(&sample), jointctl_record::feed::wall_clock_ns(sample.user_header().stamp_ns))))
                }
                Ok(None) if last.elapsed() > Duration::from_secs_f64(timeout) => Err(format!(
                    "no joint state from arm `{arm}` for {timeout} s (service `{}`): is `jointctl run` running with this arm and domain?{hint}",
                    names.joint_state
                )),
                Ok(None) => Ok(None),
                Err(e) => Err(format!("receive failed: {e:?}")),
            })
        }
        InspectCommand::Diag { at: RunningArm { arm, domain, ipc_root }, snapshot: Snapshot { json, timeout } } => {
            let d = match newest(&arm, domain, ipc_root, timeout, |n| n.diagnostics.clone(), jointctl_ipc::diagnostics_service) {
                Ok(d) => d,
                Err(e) => return crate::fail(e),
            };
            let text = if json { format!("{}\n", jointctl_record::messages::diagnostics(&d)) } else { diag_human(&d) };
            let _ = std::io::stdout().lock().write_all(text.as_bytes());
            ExitCode::SUCCESS
        }
        InspectCommand::Top { at, interval, timeout } => crate::top::run(at, interval, timeout),
        InspectCommand::Joints { at: RunningArm { arm, domain, ipc_root }, snapshot: Snapshot { json, timeout } } => {
            let read = || -> Result<(jointctl_ipc::JointsDescriptor, ArmState, Diagnostics), String> {
                let instances = newest(&arm, domain.clone(), ipc_root.clone(), timeout, |n| n.joints.clone(), jointctl_ipc::joints_service)?;
                let state = newest(&arm, domain.clone(), ipc_root.clone(), timeout, |n| n.joint_state.clone(), jointctl_ipc::joint_state_service)?;
                let diagnostics = newest(&arm, domain.clone(), ipc_root.clone(), timeout, |n| n.diagnostics.clone(), jointctl_ipc::diagnostics_service)?;
                Ok((instances, state, diagnostics))
            };
            let (instances, state, diagnostics) = match read() {
                Ok(r) => r,
                Err(e) => return crate::fail(e),
            };
            let view = joints_json(&instances, &state, &diagnostics);
            let text = if json { format!("{view}\n") } else { joints_human(&view) };
            let _ = std::io::stdout().lock().write_all(text.as_bytes());
            ExitCode::SUCCESS
        }
    }
}

/// `inspect echo --latest`: the arm's latest-state blackboard, each new cycle it shows; waits up
/// to `timeout_s` for the blackboard to exist and between two new cycles.
fn echo_latest(arm: &str, scope: jointctl_ipc::IpcScope, timeout_s: f64, hint: &str, opts: &EchoOptions) -> ExitCode {
    let name = ServiceNames::for_arm(arm).latest_state;
    let opened = Instant::now();
    let reader = loop {
        match jointctl_ipc::LatestStateReader::open(&scope, arm) {
            Ok(reader) => break reader,
            Err(_) if opened.elapsed() < Duration::from_secs_f64(timeout_s) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return crate::fail(format!("no latest-state blackboard `{name}` after {timeout_s} s: is `jointctl run` running with arm `{arm}`?{hint} ({})", crate::chain(&e))),
        }
    };
    let (mut shown, mut last) = (None, Instant::now());
    echo(opts, || {
        let s = reader.latest().map_err(|e| format!("cannot read `{name}`: {e}"))?;
        if s.stamp_ns != 0 && shown != Some(s.cycle) {
            (shown, last) = (Some(s.cycle), Instant::now());
            let wall_ns = jointctl_record::feed::wall_clock_ns(s.stamp_ns);
            return Ok(Some((s, wall_ns)));
        }
        if last.elapsed() > Duration::from_secs_f64(timeout_s) {
            return Err(format!("no new cycle on `{name}` for {timeout_s} s: has the arm's loop stopped?"));
        }
        Ok(None)
    })
}
