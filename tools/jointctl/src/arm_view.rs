//! A running arm as an inspector sees it: where it publishes ([`RunningArm`]), its newest
//! samples and subscriptions, and its states, joints and diagnostics as JSON or text. Shared by
//! the inspectors on this machine (`inspect`, `top`) and on others (`remote`), which each depend
//! on it and not on each other.

use std::fmt::Write as _;
use std::io::Write as _;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use jointctl_ipc::{ArmState, Diagnostics, FieldMask, JointSample, ServiceNames, decode_name};

/// Where a running arm publishes.
#[derive(clap::Args)]
pub struct RunningArm {
    /// The arm (its YAML `arm:` name).
    #[arg(long, default_value = "sherpa")]
    pub arm: String,
    /// iceoryx2 domain of the arm (its YAML `ipc.domain`).
    #[arg(long)]
    pub domain: Option<String>,
    /// Shared-memory root of the arm (its YAML `ipc.root`).
    #[arg(long, value_name = "DIR")]
    pub ipc_root: Option<std::path::PathBuf>,
}

impl RunningArm {
    /// Its shared memory.
    pub fn scope(&self) -> jointctl_ipc::IpcScope {
        jointctl_ipc::IpcScope { domain: self.domain.clone(), root: self.ipc_root.clone(), group: None }
    }
}

/// What a fault code means (`JointSample::fault_code`).
pub(crate) fn fault_reason(code: u32) -> String {
    match code {
        0 => "none".into(),
        1 => "its plugin panicked (never entered again)".into(),
        2 => "its plugin returned an unknown status".into(),
        3 => "its plugin took longer than its time budget (never called again)".into(),
        4 => "the runtime refused a motor set-point of its plugin".into(),
        c => format!("its plugin reported fault code {c}"),
    }
}

pub(crate) fn json_f64(sample: &JointSample, bit: u32, value: f64) -> serde_json::Value {
    sample.get(bit, value).map_or(serde_json::Value::Null, serde_json::Value::from)
}

pub(crate) fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() { serde_json::Value::from(x) } else { serde_json::Value::Null }
}

/// The JSON object of one sample, in the documented shape: only the joints `keep` accepts;
/// `wall_ns` is the cycle's stamp on the wall clock (UNIX time [ns]).
pub fn sample_json(s: &ArmState, wall_ns: Option<u64>, keep: impl Fn(&str) -> bool) -> serde_json::Value {
    let joints: Vec<_> = s
        .joints()
        .iter()
        .filter(|j| keep(decode_name(&j.name)))
        .map(|j| {
            serde_json::json!({
                "name": decode_name(&j.name),
                "position": json_f64(j, FieldMask::POSITION, j.position_rad),
                "velocity": json_f64(j, FieldMask::VELOCITY, j.velocity_rad_s),
                "deflection": json_f64(j, FieldMask::DEFLECTION, j.deflection_rad),
                "torque": json_f64(j, FieldMask::TORQUE, j.torque_nm),
                "stiffness": json_f64(j, FieldMask::STIFFNESS, j.stiffness_nm_per_rad),
                "valid": j.fault_code == 0 && j.valid_mask & FieldMask::POSITION != 0,
                "pivot": json_f64(j, FieldMask::PIVOT, j.pivot_mm),
                "reference_torque": finite_or_null(j.reference_torque_nm),
                "sensor_torque": finite_or_null(j.sensor_torque_nm),
                "gravity": finite_or_null(j.gravity_nm),
                "mode": j.mode.name(),
                "enabled": j.enabled != 0,
                "fault_code": j.fault_code,
            })
        })
        .collect();
    serde_json::json!({"cycle": s.cycle, "stamp_ns": s.stamp_ns, "wall_ns": wall_ns, "joints": joints})
}

pub(crate) fn fmt(v: Option<f64>) -> String {
    v.map_or_else(|| "      -".to_string(), |x| format!("{x:7.3}"))
}

pub(crate) fn human(s: &ArmState, keep: impl Fn(&str) -> bool) -> String {
    let mut out = format!("cycle {:>8}{}\n", s.cycle, if s.final_sample != 0 { "  (final)" } else { "" });
    out.push_str("  joint   pos[rad] vel[rad/s] defl[rad] torque[Nm]  ref[Nm] K[Nm/rad] pivot[mm] mode       state\n");
    for j in s.joints().iter().filter(|j| keep(decode_name(&j.name))) {
        out.push_str(&format!(
            "  {:<6} {} {}    {}  {}  {} {} {} {:<10} {}\n",
            decode_name(&j.name),
            fmt(j.get(FieldMask::POSITION, j.position_rad)),
            fmt(j.get(FieldMask::VELOCITY, j.velocity_rad_s)),
            fmt(j.get(FieldMask::DEFLECTION, j.deflection_rad)),
            fmt(j.get(FieldMask::TORQUE, j.torque_nm)),
            fmt(j.reference_torque_nm.is_finite().then_some(j.reference_torque_nm)),
            j.get(FieldMask::STIFFNESS, j.stiffness_nm_per_rad).map_or("      -".into(), |k| format!("{k:9.1}")),
            fmt(j.get(FieldMask::PIVOT, j.pivot_mm)),
            j.mode.name(),
            if j.fault_code != 0 {
                format!("FAULT {}", j.fault_code)
            } else if j.enabled == 0 {
                "disabled".into()
            } else {
                "ok".into()
            }
        ));
    }
    out
}

/// A sample an inspector keeps: what one of the arm's services carries, as a process holds it.
pub trait Readable: Sized {
    /// The service's payload.
    type Payload: std::fmt::Debug + iceoryx2::prelude::IceoryxSend + ?Sized + 'static;
    /// Its user header.
    type Header: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static;
    /// The next buffered sample, kept.
    fn receive(subscriber: &Subscription<Self::Payload, Self::Header>) -> Result<Option<Self>, String>;
}

impl Readable for Diagnostics {
    type Payload = [u8];
    type Header = jointctl_ipc::DiagnosticsHeader;
    fn receive(subscriber: &Subscription<[u8], jointctl_ipc::DiagnosticsHeader>) -> Result<Option<Self>, String> {
        match subscriber.receive().map_err(|e| format!("{e:?}"))? {
            Some(s) => Diagnostics::try_from(&s).map(Some).map_err(|e| e.to_string()),
            None => Ok(None),
        }
    }
}

impl Readable for ArmState {
    type Payload = [JointSample];
    type Header = jointctl_ipc::ArmStateHeader;
    fn receive(subscriber: &Subscription<[JointSample], jointctl_ipc::ArmStateHeader>) -> Result<Option<Self>, String> {
        Ok(subscriber.receive().map_err(|e| format!("{e:?}"))?.map(|s| ArmState::from(&s)))
    }
}

impl Readable for jointctl_ipc::JointsDescriptor {
    type Payload = [jointctl_ipc::JointDescriptor];
    type Header = jointctl_ipc::JointsDescriptorHeader;
    fn receive(subscriber: &Subscription<Self::Payload, Self::Header>) -> Result<Option<Self>, String> {
        Ok(subscriber.receive().map_err(|e| format!("{e:?}"))?.map(|s| jointctl_ipc::JointsDescriptor::from(&s)))
    }
}

/// [`newest`] for a running arm's options.
pub fn newest_of<T: Readable>(
    at: &RunningArm,
    timeout: f64,
    service_name: impl Fn(&ServiceNames) -> String,
    open: Opener<T::Payload, T::Header>,
) -> Result<T, String> {
    newest(&at.arm, at.domain.clone(), at.ipc_root.clone(), timeout, service_name, open)
}

/// [`subscribe`] for a running arm's options.
pub fn subscription_of<T: std::fmt::Debug + iceoryx2::prelude::IceoryxSend + ?Sized + 'static, H: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static>(
    at: &RunningArm,
    timeout: f64,
    service_name: impl Fn(&ServiceNames) -> String,
    open: Opener<T, H>,
) -> Result<(iceoryx2::node::Node<ipc::Service>, Subscription<T, H>), String> {
    subscribe(&at.arm, at.domain.clone(), at.ipc_root.clone(), timeout, service_name, open)
}

/// The newest sample of one of the arm's services: waits up to `timeout` [s] for the first, then
/// drains what is buffered.
pub(crate) fn newest<T: Readable>(
    arm: &str,
    domain: Option<String>,
    ipc_root: Option<std::path::PathBuf>,
    timeout: f64,
    service_name: impl Fn(&ServiceNames) -> String,
    open: Opener<T::Payload, T::Header>,
) -> Result<T, String> {
    let hint = domain_hint(&domain);
    let name = service_name(&ServiceNames::for_arm(arm));
    let (_node, subscriber) = subscribe(arm, domain, ipc_root, timeout, |n| service_name(n), open)?;
    let started = Instant::now();
    let mut newest: Option<T> = None;
    loop {
        match T::receive(&subscriber) {
            Ok(Some(sample)) => newest = Some(sample),
            Ok(None) => match newest {
                Some(n) => return Ok(n),
                None if started.elapsed() > Duration::from_secs_f64(timeout) => {
                    return Err(format!("nothing from arm `{arm}` for {timeout} s (service `{name}`): is `jointctl run` running with this arm and domain?{hint}"));
                }
                None => std::thread::sleep(Duration::from_millis(1)),
            },
            Err(e) => return Err(format!("receive from `{name}` failed: {e}")),
        }
    }
}

/// Names of the observed fields in a [`FieldMask`].
pub(crate) fn field_names(mask: u32) -> Vec<&'static str> {
    [
        (FieldMask::POSITION, "position"),
        (FieldMask::VELOCITY, "velocity"),
        (FieldMask::DEFLECTION, "deflection"),
        (FieldMask::TORQUE, "torque"),
        (FieldMask::STIFFNESS, "stiffness"),
        (FieldMask::PIVOT, "pivot"),
    ]
    .iter()
    .filter(|(bit, _)| mask & bit != 0)
    .map(|(_, n)| *n)
    .collect()
}

/// `inspect joints --json`: each plugin instance and its DOFs' state at the newest cycle.
pub fn joints_json(instances: &jointctl_ipc::JointsDescriptor, state: &ArmState, diagnostics: &Diagnostics) -> serde_json::Value {
    let joints: Vec<_> = instances
        .joints()
        .iter()
        .map(|j| {
            let first = j.first_dof as usize;
            let dofs: Vec<_> = (first..first + j.dof_count as usize)
                .filter_map(|i| Some((state.joints().get(i)?, diagnostics.joints.get(i)?)))
                .map(|(s, d)| {
                    serde_json::json!({
                        "name": decode_name(&s.name),
                        "mode": s.mode.name(),
                        "enabled": s.enabled != 0,
                        "valid": s.fault_code == 0 && s.valid_mask & FieldMask::POSITION != 0,
                        "observed": field_names(s.valid_mask),
                        "held": d.held != 0,
                        "fault_code": s.fault_code,
                        "fault": fault_reason(s.fault_code),
                        "fault_message": decode_name(&d.fault_message),
                    })
                })
                .collect();
            let library = decode_name(&j.library);
            serde_json::json!({
                "name": decode_name(&j.name),
                "plugin": decode_name(&j.plugin),
                "version": decode_name(&j.version),
                "library": if library.is_empty() { serde_json::Value::Null } else { library.into() },
                "budget_us": j.budget_ns as f64 / 1e3,
                "dofs": dofs,
            })
        })
        .collect();
    serde_json::json!({"cycle": state.cycle, "rate_hz": instances.rate_hz, "joints": joints})
}

/// `inspect joints` as a table, from its JSON.
pub(crate) fn joints_human(view: &serde_json::Value) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "cycle {}  rate {} Hz", view["cycle"], view["rate_hz"]);
    let _ = writeln!(out, "{:<14} {:<14} {:<8} {:<8} {:<10} {:<8} {:<6} {:<6} {:<52} source", "joint", "plugin", "version", "dof", "mode", "enabled", "valid", "held", "observed");
    let empty = Vec::new();
    for j in view["joints"].as_array().unwrap_or(&empty) {
        let source = j["library"].as_str().unwrap_or("linked into the host");
        for (k, d) in j["dofs"].as_array().unwrap_or(&empty).iter().enumerate() {
            let text = |v: &serde_json::Value| v.as_str().unwrap_or("?").to_string();
            let yes = |v: &serde_json::Value| if v.as_bool() == Some(true) { "yes" } else { "no" };
            let observed: Vec<String> = d["observed"].as_array().unwrap_or(&empty).iter().map(text).collect();
            let (name, plugin, version) = if k == 0 { (text(&j["name"]), text(&j["plugin"]), text(&j["version"])) } else { Default::default() };
            let _ = writeln!(
                out,
                "{name:<14} {plugin:<14} {version:<8} {:<8} {:<10} {:<8} {:<6} {:<6} {:<52} {}",
                text(&d["name"]),
                text(&d["mode"]),
                yes(&d["enabled"]),
                yes(&d["valid"]),
                yes(&d["held"]),
                observed.join(","),
                if k == 0 { source } else { "" },
            );
            if d["fault_code"].as_u64().unwrap_or(0) != 0 {
                let _ = writeln!(out, "{:<14} fault: {}: {}", "", text(&d["fault"]), text(&d["fault_message"]));
            }
        }
    }
    out
}

/// How `inspect echo` prints, wherever its samples come from.
pub struct EchoOptions {
    /// One JSON object per sample.
    pub json: bool,
    /// Stop after N samples.
    pub count: Option<u64>,
    /// At most this many samples per second.
    pub rate: Option<f64>,
    /// Only these joints (all when empty).
    pub joint: Vec<String>,
}

/// Prints the samples `next` gives (`Ok(None)`: none yet) until the count, the arm's final
/// sample, SIGINT/SIGTERM or a closed pipe; `next`'s error ends it with exit 1.
pub fn echo<E: std::fmt::Display>(opts: &EchoOptions, mut next: impl FnMut() -> Result<Option<(ArmState, Option<u64>)>, E>) -> ExitCode {
    let keep = |name: &str| opts.joint.is_empty() || opts.joint.iter().any(|j| j == name);
    let min_gap = opts.rate.map(|hz| Duration::from_secs_f64(1.0 / hz));
    let mut received = 0u64;
    let mut last_printed: Option<Instant> = None;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    for signal in [2, 15] {
        let _ = signal_hook_register(signal, &stop);
    }
    let mut out = std::io::stdout().lock();
    while opts.count.is_none_or(|c| received < c) && !stop.load(std::sync::atomic::Ordering::Relaxed) {
        match next() {
            Ok(Some((s, wall_ns))) => {
                let final_sample = s.final_sample != 0;
                // --rate: skip samples that come sooner than the rate allows (never the final
                // one).
                if !final_sample && min_gap.zip(last_printed).is_some_and(|(gap, at)| at.elapsed() < gap) {
                    continue;
                }
                last_printed = Some(Instant::now());
                received += 1;
                let text = if opts.json { format!("{}\n", sample_json(&s, wall_ns, keep)) } else { human(&s, keep) };
                // A closed pipe (`| head`) ends the inspector quietly.
                if out.write_all(text.as_bytes()).and_then(|_| out.flush()).is_err() {
                    return ExitCode::SUCCESS;
                }
                if final_sample && opts.count.is_none() {
                    break;
                }
            }
            Ok(None) => std::thread::sleep(Duration::from_micros(500)),
            Err(e) => return crate::fail(e.to_string()),
        }
    }
    ExitCode::SUCCESS
}

/// What to try when no runtime answers in the default domain.
pub(crate) fn domain_hint(domain: &Option<String>) -> String {
    match domain {
        None => " (an arm whose YAML sets `ipc.domain` is found with `--domain D`)".into(),
        Some(d) => format!(" (looked in domain `{d}`)"),
    }
}

pub type Opener<T, H = ()> = fn(&iceoryx2::node::Node<ipc::Service>, &str) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, H>, jointctl_ipc::IpcSetupError>;

/// A subscriber of the arm's samples of payload `T` and header `H`.
pub type Subscription<T, H = ()> = iceoryx2::port::subscriber::Subscriber<ipc::Service, T, H>;

/// A subscriber to one of the arm's services, waiting up to `timeout` [s] for the runtime to
/// create it (it may still be starting). The node must outlive the subscriber.
pub(crate) fn subscribe<T: std::fmt::Debug + iceoryx2::prelude::IceoryxSend + ?Sized + 'static, H: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static>(
    arm: &str,
    domain: Option<String>,
    ipc_root: Option<std::path::PathBuf>,
    timeout: f64,
    service_name: impl Fn(&ServiceNames) -> String,
    open: Opener<T, H>,
) -> Result<(iceoryx2::node::Node<ipc::Service>, Subscription<T, H>), String> {
    let hint = domain_hint(&domain);
    let scope = jointctl_ipc::IpcScope { domain, root: ipc_root, group: None };
    let node = jointctl_ipc::create_node_in(&scope, &format!("jointctl-inspect-{}", std::process::id())).map_err(|e| crate::chain(&e))?;
    let name = service_name(&ServiceNames::for_arm(arm));
    let opened = Instant::now();
    let service = loop {
        match open(&node, &name) {
            Err(jointctl_ipc::IpcSetupError::OpenPublishSubscribe {
                source: iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError::DoesNotExist,
                ..
            }) if opened.elapsed() < Duration::from_secs_f64(timeout) => std::thread::sleep(Duration::from_millis(20)),
            Err(jointctl_ipc::IpcSetupError::OpenPublishSubscribe {
                source: iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError::DoesNotExist,
                ..
            }) => return Err(format!("no service `{name}` after {timeout} s: is `jointctl run` running with arm `{arm}`?{hint}")),
            other => break other,
        }
    };
    let subscriber = service.map_err(|e| crate::chain(&e))?.subscriber_builder().create().map_err(|e| match e {
        iceoryx2::port::subscriber::SubscriberCreateError::ExceedsMaxSupportedSubscribers => {
            format!("every subscriber slot of `{name}` is taken (the YAML's ipc.max_subscribers): close idle inspectors or raise the limit")
        }
        e => format!("cannot subscribe to `{name}`: {e}"),
    })?;
    Ok((node, subscriber))
}

/// Diagnostics as a person reads them.
pub(crate) fn diag_human(d: &Diagnostics) -> String {
    let mut out = String::new();
    let period_us = d.period_ns as f64 / 1e3;
    let _ = writeln!(out, "cycle {}  period {period_us:.0} us ({:.1} Hz)", d.cycle, if d.period_ns > 0 { 1e9 / d.period_ns as f64 } else { f64::NAN });
    let _ = writeln!(
        out,
        "overruns {}  missed deadlines {}  HAL errors {}  publish drops {}",
        d.overruns, d.missed_deadlines, d.hal_errors, d.publish_drops
    );
    let _ = writeln!(out, "compute: last {:.1} us, max {:.1} us   lateness: max {:.1} us", d.last_compute_ns as f64 / 1e3, d.max_compute_ns as f64 / 1e3, d.max_jitter_ns as f64 / 1e3);
    let _ = writeln!(out, "lateness histogram (cycles per bucket):");
    let mut lower = 0;
    for (upper, n) in jointctl_ipc::JITTER_BUCKET_UPPER_US.iter().zip(&d.jitter_histogram) {
        let range = if *upper == u64::MAX { format!(">= {lower} us") } else { format!("{lower}-{upper} us") };
        let _ = writeln!(out, "  {range:>14}  {n}");
        lower = *upper;
    }
    let _ = writeln!(out, "joints:");
    let _ = writeln!(out, "  {:<8} {:>6} {:>8} {:>7} {:>10} {:>8} {:>8} {:>9} {:>8} {:>8} {:>10}  fault", "joint", "held", "invalid", "faults", "pos clamp", "tq clamp", "rate lim", "watchdog", "missing", "refused", "max us");
    for j in &d.joints {
        let _ = writeln!(
            out,
            "  {:<8} {:>6} {:>8} {:>7} {:>10} {:>8} {:>8} {:>9} {:>8} {:>8} {:>10.1}  {}",
            decode_name(&j.name),
            if j.held != 0 { "yes" } else { "no" },
            j.invalid_cycles,
            j.fault_count,
            j.setpoint_clamps,
            j.torque_clamps,
            j.rate_limited,
            j.watchdog_trips,
            j.missing_inputs,
            j.setpoint_rejections,
            j.plugin_max_ns as f64 / 1e3,
            if j.fault_code == 0 { fault_reason(0) } else { format!("{}: {}", fault_reason(j.fault_code), decode_name(&j.fault_message)) }
        );
    }
    let _ = writeln!(out, "devices:");
    let _ = writeln!(out, "  {:<32} {:>8} {:>8} {:>11} {:>6}  flags", "device", "missing", "invalid", "implausible", "emcy");
    for dev in &d.devices {
        let flags: Vec<&str> = [(1, "silent"), (2, "fault"), (4, "bus-off"), (8, "error-passive")].iter().filter(|(bit, _)| dev.flags & bit != 0).map(|(_, n)| *n).collect();
        let _ = writeln!(out, "  {:<32} {:>8} {:>8} {:>11} {:>6}  {}", decode_name(&dev.name), dev.missing, dev.invalid, dev.implausible, dev.emcy, if flags.is_empty() { "-".into() } else { flags.join(",") });
    }
    out
}

pub(crate) fn signal_hook_register(signal: i32, flag: &std::sync::Arc<std::sync::atomic::AtomicBool>) -> std::io::Result<()> {
    signal_hook::flag::register(signal, std::sync::Arc::clone(flag)).map(|_| ())
}
