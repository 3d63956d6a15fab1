//! `jointctl cmd`: send one command to a running arm and report the runtime's answer. Exit 0
//! when the runtime accepted it; 1 with the runtime's reason when it refused it, or when no
//! runtime serves the arm.

mod experiment;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Subcommand};

use crate::{finite, seconds};
use jointctl_ipc::{CommandKind as kind, CommandRequest, MAX_COMMAND_POINTS, TorqueWaveform};

#[derive(Args)]
pub struct CmdArgs {
    /// The arm (its YAML `arm:` name).
    #[arg(long, global = true, default_value = "sherpa")]
    arm: String,
    /// iceoryx2 domain of the arm (its YAML `ipc.domain`).
    #[arg(long, global = true)]
    domain: Option<String>,
    /// Shared-memory root of the arm (its YAML `ipc.root`).
    #[arg(long, global = true, value_name = "DIR")]
    ipc_root: Option<std::path::PathBuf>,
    /// How long to wait for the runtime's answer [s].
    #[arg(long, global = true, default_value_t = 2.0, value_parser = seconds, allow_negative_numbers = true)]
    timeout: f64,
    /// A streamed command: the joint falls back to holding if it is not renewed within its
    /// watchdog time.
    #[arg(long, global = true)]
    stream: bool,
    /// Command from another machine: the Zenoh endpoint of the arm's `jointctl bridge zenoh`
    /// command session (`network.zenoh.commands.listen`), e.g. `tcp/192.168.1.10:7448`.
    #[arg(long, global = true, value_name = "ENDPOINT")]
    pub zenoh: Option<String>,
    #[command(flatten)]
    pub credentials: crate::remote::CredentialArgs,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Torque control (figure 4.6) following a step, sine or cosine reference [Nm].
    Torque {
        /// Joint name (e.g. q2).
        joint: String,
        /// Step to NM.
        #[arg(long, value_name = "NM", group = "waveform", value_parser = finite, allow_negative_numbers = true)]
        step: Option<f64>,
        /// Sine of amplitude NM (needs --freq).
        #[arg(long, value_name = "NM", group = "waveform", requires = "freq", value_parser = finite, allow_negative_numbers = true)]
        sine: Option<f64>,
        /// Cosine of amplitude NM (needs --freq).
        #[arg(long, value_name = "NM", group = "waveform", requires = "freq", value_parser = finite, allow_negative_numbers = true)]
        cosine: Option<f64>,
        /// Frequency of the sine or cosine [Hz].
        #[arg(long, value_name = "HZ", value_parser = finite, allow_negative_numbers = true)]
        freq: Option<f64>,
        /// Offset added to the reference [Nm].
        #[arg(long, value_name = "NM", default_value_t = 0.0, value_parser = finite, allow_negative_numbers = true)]
        offset: f64,
        /// Start the reference this long after the command arrives [s].
        #[arg(long, value_name = "S", default_value_t = 0.0, value_parser = seconds, allow_negative_numbers = true)]
        delay: f64,
    },
    /// Position control with the feedback PI (section 4.3) to RAD.
    Position {
        /// Joint name.
        joint: String,
        /// Target [rad].
        #[arg(allow_negative_numbers = true, value_parser = finite)]
        rad: f64,
    },
    /// A direct joint set-point, like the thesis' GUI (through the feedback PI unless the joint's
    /// `controller.manual_position_feedback` is false, section 4.3).
    Manual {
        /// Joint name.
        joint: String,
        /// Set-point [rad].
        #[arg(allow_negative_numbers = true, value_parser = finite)]
        rad: f64,
    },
    /// Follow a trajectory: points "T:Q[:V]" (time [s], position [rad], velocity [rad/s]).
    Trajectory {
        /// Joint name.
        joint: String,
        /// Points, e.g. 0:0 1:0.5 2:0.2:0.
        #[arg(required = true, num_args = 1.., allow_negative_numbers = true)]
        points: Vec<String>,
    },
    /// Request a stiffness for a variable stiffness joint [Nm/rad].
    Stiffness {
        /// Joint name.
        joint: String,
        /// [Nm/rad]
        #[arg(value_parser = finite, allow_negative_numbers = true)]
        nm_per_rad: f64,
    },
    /// Impedance control: tau = K (target - q) - D dq/dt, through the torque mode.
    Impedance {
        /// Joint name.
        joint: String,
        /// K [Nm/rad].
        #[arg(long = "k", value_name = "NM_PER_RAD", value_parser = finite, allow_negative_numbers = true)]
        k: f64,
        /// D [Nms/rad].
        #[arg(long = "d", value_name = "NMS_PER_RAD", value_parser = finite, allow_negative_numbers = true)]
        d: f64,
        /// Target [rad]; default: where the joint is.
        #[arg(long, allow_negative_numbers = true, value_parser = finite)]
        target: Option<f64>,
    },
    /// Hold one joint, or every joint.
    Hold {
        /// Joint name; all joints when left out.
        joint: Option<String>,
    },
    /// Enable a joint (it starts in hold).
    Enable {
        /// Joint name.
        joint: String,
    },
    /// Disable a joint: it holds and refuses commands until enabled.
    Disable {
        /// Joint name.
        joint: String,
    },
    /// Stop the runtime: joints held, final state published.
    Stop,
    /// Run an experiment file (`experiment.yaml`, as `jointctl identify` proposes it for a
    /// confounded pair) on a joint whose output is fixed: each segment a torque sine of the
    /// joint's stiffness times its deflection amplitude, at its frequency, from rest, for whole
    /// periods, then a second at zero torque. Record it with `jointctl record` alongside, then
    /// `jointctl identify --data` the recording. The joint is left at a zero torque reference.
    /// With `--position`, for a set-up that deflects the element by this joint's position (a
    /// rig moving the output): each segment a position sine about where the joint stands, as
    /// trajectories of at most 64 points cut at the sine's peaks, for whole periods and a
    /// quarter to the peak, back to the start in half a period, then a second held. On this machine only (not over --zenoh),
    /// not streamed.
    Experiment {
        /// Joint name.
        joint: String,
        /// The experiment file.
        file: PathBuf,
        /// Stiffness that turns deflections into torques [Nm/rad]; default: the joint's
        /// stiffness as the runtime publishes it.
        #[arg(long, value_name = "NM_PER_RAD", value_parser = finite, conflicts_with = "position")]
        stiffness: Option<f64>,
        /// Run each segment as a position sine of the joint (trajectories), not a torque sine.
        #[arg(long)]
        position: bool,
        /// Print the sines, send nothing.
        #[arg(long)]
        dry_run: bool,
    },
}

fn parse_points(points: &[String]) -> Result<Vec<[f64; 3]>, String> {
    if points.len() > MAX_COMMAND_POINTS {
        return Err(format!("at most {MAX_COMMAND_POINTS} points, got {}", points.len()));
    }
    points
        .iter()
        .map(|p| {
            let parts: Vec<&str> = p.split(':').collect();
            let num = |s: &str| finite(s).map_err(|e| format!("point `{p}`: {e}"));
            match parts.as_slice() {
                [t, q] => Ok([num(t)?, num(q)?, f64::NAN]),
                [t, q, v] => Ok([num(t)?, num(q)?, num(v)?]),
                _ => Err(format!("point `{p}` is not T:Q or T:Q:V")),
            }
        })
        .collect()
}

fn request(command: &Command) -> Result<CommandRequest, String> {
    Ok(match command {
        Command::Torque { joint, step, sine, cosine, freq, offset, delay } => {
            let (waveform, amplitude) = match (step, sine, cosine) {
                (Some(a), _, _) => (TorqueWaveform::STEP, *a),
                (_, Some(a), _) => (TorqueWaveform::SINE, *a),
                (_, _, Some(a)) => (TorqueWaveform::COSINE, *a),
                _ => return Err("give one of --step NM, --sine NM --freq HZ, --cosine NM --freq HZ".into()),
            };
            CommandRequest::torque(joint, waveform, &[amplitude, freq.unwrap_or(0.0), *offset, *delay])
        }
        Command::Position { joint, rad } => CommandRequest::new(kind::POSITION, joint, &[*rad]),
        Command::Manual { joint, rad } => CommandRequest::new(kind::MANUAL, joint, &[*rad]),
        Command::Trajectory { joint, points } => {
            let pts = parse_points(points)?;
            let mut r = CommandRequest::new(kind::TRAJECTORY, joint, &[]);
            r.point_count = pts.len() as u32;
            r.points[..pts.len()].copy_from_slice(&pts);
            r
        }
        Command::Stiffness { joint, nm_per_rad } => CommandRequest::new(kind::STIFFNESS, joint, &[*nm_per_rad]),
        Command::Impedance { joint, k, d, target } => CommandRequest::new(kind::IMPEDANCE, joint, &[*k, *d, target.unwrap_or(f64::NAN)]),
        Command::Hold { joint } => CommandRequest::new(kind::HOLD, joint.as_deref().unwrap_or(""), &[]),
        Command::Enable { joint } => CommandRequest::new(kind::ENABLE, joint, &[]),
        Command::Disable { joint } => CommandRequest::new(kind::DISABLE, joint, &[]),
        Command::Stop => CommandRequest::new(kind::STOP, "", &[]),
        Command::Experiment { .. } => return Err("an experiment is a sequence of commands (cmd experiment), not one request".into()),
    })
}

pub fn run(args: CmdArgs) -> ExitCode {
    if let Command::Experiment { joint, file, stiffness, position, dry_run } = &args.command {
        return experiment::run(&args, joint, file, *stiffness, *position, *dry_run);
    }
    let mut req = match request(&args.command) {
        Ok(r) => r,
        Err(e) => return crate::fail(e),
    };
    req.streamed = args.stream as u32;
    if let Some(endpoint) = &args.zenoh {
        return crate::remote::command(endpoint, &args.arm, &args.credentials, &req, args.timeout);
    }
    let is_stop = matches!(args.command, Command::Stop);
    let answer = jointctl_ipc::CommandClient::open(&scope(&args), &args.arm, &format!("jointctl-cmd-{}", std::process::id()))
        .and_then(|client| client.send(req, args.timeout));
    match answer {
        Ok(response) if response.accepted != 0 => {
            outln!("accepted: {}", response.text());
            ExitCode::SUCCESS
        }
        Ok(response) => crate::fail(format!("refused: {}", response.text())),
        // A stop needs no free client slot and no answer: the runtime is signalled instead.
        Err(e @ (jointctl_ipc::CommandError::SlotsTaken { .. } | jointctl_ipc::CommandError::NoAnswer { .. })) if is_stop => stop_by_signal(&args, &e.to_string()),
        Err(e @ jointctl_ipc::CommandError::SlotsTaken { .. }) => crate::fail(format!("{e}: close idle clients or raise the limit")),
        Err(e) => crate::fail_err(e),
    }
}

fn stop_by_signal(args: &CmdArgs, why: &str) -> ExitCode {
    let dir = match jointctl_ipc::lock_dir_in(&scope(args)) {
        Ok(d) => d,
        Err(e) => return crate::fail_err(e),
    };
    match jointctl_runtime::lock::signal_stop(&dir, &args.arm) {
        Ok(pid) => {
            outln!("accepted: stopping ({why}; sent SIGTERM to the runtime, process {pid})");
            ExitCode::SUCCESS
        }
        Err(e) => crate::fail(format!("{why}, and the runtime could not be signalled: {e}")),
    }
}

fn scope(args: &CmdArgs) -> jointctl_ipc::IpcScope {
    jointctl_ipc::IpcScope { domain: args.domain.clone(), root: args.ipc_root.clone(), group: None }
}
