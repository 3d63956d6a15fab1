//! Inspectors: separate processes that read a running arm's shared memory. A slow or killed
//! inspector never slows the loop: its buffer overflows (oldest dropped) instead.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Subcommand;
use iceoryx2::prelude::*;
use jointctl_ipc::{ArmState, FieldMask, JointSample, ServiceNames, decode_name};

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
        /// The arm (its YAML `arm:` name).
        #[arg(long, default_value = "sherpa")]
        arm: String,
        /// iceoryx2 domain of the arm (its YAML `ipc.domain`).
        #[arg(long)]
        domain: Option<String>,
        /// Shared-memory root of the arm (its YAML `ipc.root`).
        #[arg(long, value_name = "DIR")]
        ipc_root: Option<std::path::PathBuf>,
        /// One JSON object per sample.
        #[arg(long)]
        json: bool,
        /// Stop after N samples.
        #[arg(long)]
        count: Option<u64>,
        /// Give up when no sample arrives for this long [s].
        #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
        timeout: f64,
    },
}

fn json_f64(sample: &JointSample, bit: u32, value: f64) -> serde_json::Value {
    sample.get(bit, value).map_or(serde_json::Value::Null, serde_json::Value::from)
}

/// The JSON object of one sample, in the documented shape.
pub fn sample_json(s: &ArmState) -> serde_json::Value {
    let joints: Vec<_> = s
        .joints()
        .iter()
        .map(|j| {
            serde_json::json!({
                "name": decode_name(&j.name),
                "position": json_f64(j, FieldMask::POSITION, j.position_rad),
                "velocity": json_f64(j, FieldMask::VELOCITY, j.velocity_rad_s),
                "deflection": json_f64(j, FieldMask::DEFLECTION, j.deflection_rad),
                "torque": json_f64(j, FieldMask::TORQUE, j.torque_nm),
                "stiffness": json_f64(j, FieldMask::STIFFNESS, j.stiffness_nm_per_rad),
                "valid": j.fault_code == 0 && j.valid_mask & FieldMask::POSITION != 0,
            })
        })
        .collect();
    serde_json::json!({"cycle": s.cycle, "stamp_ns": s.stamp_ns, "joints": joints})
}

fn fmt(v: Option<f64>) -> String {
    v.map_or_else(|| "      -".to_string(), |x| format!("{x:7.3}"))
}

fn human(s: &ArmState) -> String {
    let mut out = format!("cycle {:>8}{}\n", s.cycle, if s.final_sample != 0 { "  (final)" } else { "" });
    out.push_str("  joint   pos[rad] vel[rad/s] defl[rad] torque[Nm]  ref[Nm] K[Nm/rad] pivot[mm] mode       state\n");
    for j in s.joints() {
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
                    println!("{name}  ({})", pattern.split('(').next().unwrap_or("?"));
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
        InspectCommand::Echo { arm, domain, ipc_root, json, count, timeout } => {
            let scope = jointctl_ipc::IpcScope { domain, root: ipc_root, group: None };
            let node = match jointctl_ipc::create_node_in(&scope, &format!("jointctl-inspect-{}", std::process::id())) {
                Ok(n) => n,
                Err(e) => return crate::fail_err(e),
            };
            let names = ServiceNames::for_arm(&arm);
            // The runtime may still be starting: wait for its service up to the timeout.
            let opened = Instant::now();
            let service = loop {
                match jointctl_ipc::joint_state_service(&node, &names.joint_state) {
                    Err(jointctl_ipc::IpcSetupError::OpenPublishSubscribe {
                        source: iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError::DoesNotExist,
                        ..
                    }) if opened.elapsed() < Duration::from_secs_f64(timeout) => std::thread::sleep(Duration::from_millis(20)),
                    other => break other,
                }
            };
            let subscriber = match service
                .map_err(|e| crate::chain(&e))
                .and_then(|s| {
                    s.subscriber_builder().create().map_err(|e| match e {
                        iceoryx2::port::subscriber::SubscriberCreateError::ExceedsMaxSupportedSubscribers => format!(
                            "every subscriber slot of `{}` is taken (the YAML's ipc.max_subscribers): close idle inspectors or raise the limit",
                            names.joint_state
                        ),
                        e => format!("cannot subscribe to `{}`: {e}", names.joint_state),
                    })
                })
            {
                Ok(s) => s,
                Err(e) => return crate::fail(e),
            };
            let mut received = 0u64;
            let mut last = Instant::now();
            let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            for signal in [2, 15] {
                let _ = signal_hook_register(signal, &stop);
            }
            while count.is_none_or(|c| received < c) && !stop.load(std::sync::atomic::Ordering::Relaxed) {
                match subscriber.receive() {
                    Ok(Some(sample)) => {
                        last = Instant::now();
                        received += 1;
                        let s: &ArmState = &sample;
                        if json {
                            println!("{}", sample_json(s));
                        } else {
                            print!("{}", human(s));
                        }
                        if s.final_sample != 0 && count.is_none() {
                            break;
                        }
                    }
                    Ok(None) => {
                        if last.elapsed() > Duration::from_secs_f64(timeout) {
                            return crate::fail(format!(
                                "no joint state from arm `{arm}` for {timeout} s (service `{}`): is `jointctl run` running with this arm and domain?",
                                names.joint_state
                            ));
                        }
                        std::thread::sleep(Duration::from_micros(500));
                    }
                    Err(e) => return crate::fail(format!("receive failed: {e:?}")),
                }
            }
            ExitCode::SUCCESS
        }
    }
}

fn signal_hook_register(signal: i32, flag: &std::sync::Arc<std::sync::atomic::AtomicBool>) -> std::io::Result<()> {
    signal_hook::flag::register(signal, std::sync::Arc::clone(flag)).map(|_| ())
}
