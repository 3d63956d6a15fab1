//! `jointctl bridge`: a running arm in Foxglove and on the network (see `jointctl_bridge`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use clap::Subcommand;

use crate::arm_view::RunningArm;

#[derive(Subcommand)]
pub enum BridgeCommand {
    /// A live view in Foxglove: the official Foxglove SDK's WebSocket server with the recording's
    /// channels (joint_state, diagnostics, raw, commands), JSON with JSON schemas. Open
    /// `ws://HOST:PORT` in Foxglove or Lichtblick ("Open connection", Foxglove WebSocket):
    /// clients of either protocol name (`foxglove.sdk.v1`, `foxglove.websocket.v1`) connect.
    Foxglove {
        #[command(flatten)]
        at: RunningArm,
        /// Address to listen on: 127.0.0.1 for this machine only, 0.0.0.0 for every interface.
        #[arg(long, default_value = "127.0.0.1")]
        host: String,
        /// TCP port (Foxglove's default 8765; 0 picks a free one and says which).
        #[arg(long, default_value_t = 8765)]
        port: u16,
        /// Give up when the arm's services do not appear, or the arm is silent, for this long [s].
        #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
        timeout: f64,
        /// The SDK's server alone on the port, without the relay that lets in clients offering
        /// only `foxglove.websocket.v1`: one hop less, current Foxglove apps only.
        #[arg(long)]
        sdk_only: bool,
    },
    /// ROS 2: the arm's topics over DDS (/joint_states, /diagnostics once a second,
    /// /jointctl/joint_details, /jointctl/raw, /jointctl/commands; ROS 2's default QoS), from a
    /// node `jointctl_<arm>`; commands (/jointctl/joint_trajectory, /jointctl/command) only of
    /// the kinds the YAML's `network.ros2.commands.allow` lists, each answered on
    /// /jointctl/command_responses. No ROS installation needed. See docs/ros2.md.
    Ros2 {
        #[command(flatten)]
        at: RunningArm,
        /// The DDS domain (ROS_DOMAIN_ID), 0-232; default: the YAML's `network.ros2.domain_id`.
        #[arg(long, value_parser = clap::value_parser!(u16).range(0..=232))]
        domain_id: Option<u16>,
        /// The arm's YAML, for its `network` section; default: the file the runtime runs.
        #[arg(long, value_name = "YAML")]
        config: Option<PathBuf>,
        /// Give up when the arm's services do not appear, or the arm is silent, for this long [s].
        #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
        timeout: f64,
    },
    /// Other machines: the arm's samples over Zenoh (`jointctl/<arm>/<topic>`, JSON), and
    /// commands from authenticated peers when the arm's YAML allows them
    /// (`network.zenoh.commands`); every other command is refused with the reason.
    Zenoh {
        #[command(flatten)]
        at: RunningArm,
        /// Zenoh endpoint to publish on (repeatable); scouting is off, so peers connect here.
        #[arg(long, value_name = "ENDPOINT", default_value = "tcp/0.0.0.0:7447")]
        listen: Vec<String>,
        /// The arm's YAML, for its `network` section; default: the file the runtime runs.
        #[arg(long, value_name = "YAML")]
        config: Option<PathBuf>,
        /// Give up when the arm's services do not appear, or the arm is silent, for this long [s].
        #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
        timeout: f64,
    },
}

/// SIGINT and SIGTERM stop a bridge cleanly.
fn stop_flag() -> Result<Arc<AtomicBool>, String> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop)).map_err(|e| format!("cannot install the signal handlers: {e}"))?;
    }
    Ok(stop)
}

pub fn run(command: BridgeCommand) -> ExitCode {
    let stop = match stop_flag() {
        Ok(s) => s,
        Err(e) => return crate::fail(e),
    };
    match command {
        BridgeCommand::Foxglove { at, host, port, timeout, sdk_only } => {
            let opts = jointctl_bridge::foxglove::FoxgloveOptions { arm: at.arm.clone(), scope: at.scope(), host: host.clone(), port, timeout_s: timeout, older_clients: !sdk_only };
            let served = jointctl_bridge::foxglove::serve(&opts, &stop, |port| {
                tracing::info!(arm = %opts.arm, "Foxglove bridge listening on ws://{host}:{port}");
            });
            match served {
                Ok(summary) => {
                    tracing::info!(arm = %opts.arm, messages = ?summary.messages, lost = ?summary.lost, arm_stopped = summary.arm_stopped, "Foxglove bridge stopped");
                    ExitCode::SUCCESS
                }
                Err(e) => crate::fail_err(e),
            }
        }
        BridgeCommand::Ros2 { at, domain_id, config, timeout } => {
            let opts = jointctl_bridge::ros2::Ros2Options { arm: at.arm.clone(), scope: at.scope(), domain_id, config, timeout_s: timeout, command_timeout_s: 2.0 };
            let served = jointctl_bridge::ros2::serve(&opts, &stop, |node, domain| {
                tracing::info!(arm = %opts.arm, "ROS 2 bridge: node /{node} publishing in DDS domain {domain}");
            });
            match served {
                Ok(summary) => {
                    tracing::info!(arm = %opts.arm, messages = ?summary.messages, lost = ?summary.lost, arm_stopped = summary.arm_stopped, "ROS 2 bridge stopped");
                    ExitCode::SUCCESS
                }
                Err(e) => crate::fail_err(e),
            }
        }
        BridgeCommand::Zenoh { at, listen, config, timeout } => {
            let opts = jointctl_bridge::zenoh::ZenohOptions { arm: at.arm.clone(), scope: at.scope(), listen, config, timeout_s: timeout, command_timeout_s: 2.0 };
            let served = jointctl_bridge::zenoh::serve(&opts, &stop, |at| {
                let commands = at.commands.as_deref().map_or_else(|| "refused (the YAML has no network.zenoh.commands)".to_string(), |e| format!("served to authenticated peers on {e}"));
                tracing::info!(arm = %opts.arm, "Zenoh bridge publishing on {}; commands {commands}", at.listen.join(", "));
            });
            match served {
                Ok(summary) => {
                    tracing::info!(arm = %opts.arm, messages = ?summary.messages, lost = ?summary.lost, arm_stopped = summary.arm_stopped, "Zenoh bridge stopped");
                    ExitCode::SUCCESS
                }
                Err(e) => crate::fail_err(e),
            }
        }
    }
}
