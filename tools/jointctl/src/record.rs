//! `jointctl record`: a running arm's raw readings, joint states, diagnostics and accepted
//! commands into one MCAP file (see `jointctl_record`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use clap::Args;

/// `--profile`'s values.
#[derive(Clone, Copy, clap::ValueEnum)]
enum ProfileArg {
    Json,
    Ros2,
}

#[derive(Args)]
pub struct RecordArgs {
    /// The arm (its YAML `arm:` name).
    #[arg(long, default_value = "sherpa")]
    arm: String,
    /// iceoryx2 domain of the arm (its YAML `ipc.domain`).
    #[arg(long)]
    domain: Option<String>,
    /// Shared-memory root of the arm (its YAML `ipc.root`).
    #[arg(long, value_name = "DIR")]
    ipc_root: Option<PathBuf>,
    /// The MCAP file to write.
    #[arg(long)]
    out: PathBuf,
    /// Stop after this long [s] of the arm's time; without it, until SIGINT/SIGTERM or the arm
    /// stops.
    #[arg(long, value_parser = crate::seconds)]
    duration: Option<f64>,
    /// Give up when the arm's services do not appear, or nothing arrives, for this long [s].
    #[arg(long, default_value_t = 5.0, value_parser = crate::seconds)]
    timeout: f64,
    /// The file's form: `json` (jointctl's channels as JSON, what Foxglove opens) or `ros2`
    /// (ROS 2 topics and types as CDR, what `ros2 bag play`, rosbags and PlotJuggler read:
    /// /joint_states, /diagnostics, /jointctl/joint_details, /jointctl/raw, /jointctl/commands).
    /// fit, identify and replay read both.
    #[arg(long, value_enum, default_value_t = ProfileArg::Json)]
    profile: ProfileArg,
    /// Print one JSON object: `{"file", "duration_s", "messages": {...}, "lost", ...}`.
    #[arg(long)]
    json: bool,
}

pub fn run(a: RecordArgs) -> ExitCode {
    // SIGINT and SIGTERM end the recording with a valid, indexed file.
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        if let Err(e) = signal_hook::flag::register(signal, Arc::clone(&stop)) {
            return crate::fail(format!("cannot install the signal handlers: {e}"));
        }
    }
    let opts = jointctl_record::recorder::RecordOptions {
        arm: a.arm,
        scope: jointctl_ipc::IpcScope { domain: a.domain, root: a.ipc_root, group: None },
        out: a.out,
        duration_s: a.duration,
        timeout_s: a.timeout,
        profile: match a.profile {
            ProfileArg::Json => jointctl_record::recorder::Profile::Json,
            ProfileArg::Ros2 => jointctl_record::recorder::Profile::Ros2,
        },
    };
    let (summary, failure) = match jointctl_record::recorder::record(&opts, &stop) {
        Ok(s) => (s, None),
        // Stopped part way (a full disk): the summary of what the file holds, then the reason.
        Err(jointctl_record::recorder::RecordError::Stopped { summary, source }) => (*summary, Some(source)),
        Err(e) => return crate::fail_err(e),
    };
    if a.json {
        let mut json = summary.json();
        if let Some(e) = &failure {
            json["error"] = serde_json::Value::String(crate::chain(e.as_ref()));
        }
        crate::print_out(&format!("{json}\n"));
    } else {
        eprintln!("{}: {:.2} s of arm `{}`, {} bytes", summary.file.display(), summary.duration_s, opts.arm, summary.bytes);
        for (channel, n) in &summary.messages {
            eprintln!("  {channel:<24} {n:>8} messages");
        }
        // Losses are the arm's samples, counted per channel of the arm (the ROS 2 profile writes
        // a joint state on two topics).
        let lost: Vec<String> = summary.lost_by_channel.iter().map(|(c, n)| format!("{c} {n}")).collect();
        eprintln!("  lost samples: {}", lost.join(", "));
    }
    if let Some(e) = failure {
        return crate::fail_err(jointctl_record::recorder::RecordError::Stopped { summary: Box::new(summary), source: e });
    }
    if summary.lost() > 0 {
        eprintln!("warning: {} samples lost (the recorder fell behind, or the runtime dropped records: see diagnostics.publish_drops)", summary.lost());
    }
    ExitCode::SUCCESS
}
