//! `jointctl`: run, check and inspect compliant robot arms.

/// `print!` to stdout through [`print_out`]: a reader that has gone (`| head -1`) ends the
/// output, not the program with a panic. Every command's standard output goes through these two.
macro_rules! out {
    ($($arg:tt)*) => { $crate::print_out(&format!($($arg)*)) };
}

/// `println!` through [`print_out`] (see [`out!`]).
macro_rules! outln {
    () => { $crate::print_out("\n") };
    ($($arg:tt)*) => { $crate::print_out(&format!("{}\n", format_args!($($arg)*))) };
}

mod arm_view;
mod bridge;
mod calibrate;
mod cmd;
mod doctor;
mod experiment;
mod experiment_checks;
mod gravity;
mod ident;
mod inspect;
mod joint_effects;
mod record;
mod remote;
mod replay;
mod run;
mod top;
mod transmission;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use jointctl_runtime::PluginLoader;

#[derive(Parser)]
#[command(name = "jointctl", version, about = "Run, simulate and inspect compliant robot joints")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the observe → control → actuate loop of an arm described in YAML.
    Run(run::RunArgs),
    /// Validate an arm description and its plugins without running.
    Check {
        /// The arm description.
        config: PathBuf,
    },
    /// Print the JSON Schema of arm descriptions (for editors).
    Schema,
    /// Load a plugin library read from stdin, as the host would (the probe every library passes
    /// first; exit 0 loaded, 1 refused, killed by a signal: the library is corrupt).
    #[command(name = "__probe-plugin", hide = true)]
    ProbePlugin,
    /// Check eq. 3.3's assumed shoulder differential on the arm before trusting torque control:
    /// each shoulder actuator moves alone by a small step, q2 is read from its own encoders
    /// (exit 0 as assumed, 1 not). Uses the config's backend: the real arm with `socketcan`.
    CheckTransmission {
        /// The arm description.
        config: PathBuf,
        /// How far each actuator moves [rad, at the gearbox output].
        #[arg(long, default_value_t = 0.02, value_parser = finite)]
        step_rad: f64,
    },
    /// Run the thesis' experiments on the simulated arm.
    Experiment {
        #[command(subcommand)]
        command: experiment::ExperimentCommand,
    },
    /// Work with the simulated arm directly.
    Sim {
        #[command(subcommand)]
        command: experiment::SimCommand,
    },
    /// Fit torque-deflection characteristics to a measured experiment (the thesis' Matlab step).
    Fit(ident::FitArgs),
    /// Show what a joint model gets wrong on measured data, name the cause, measure the gain.
    Identify(ident::IdentifyArgs),
    /// Send a command to a running arm (exit 0 accepted, 1 refused or no runtime).
    Cmd(cmd::CmdArgs),
    /// Record a running arm (raw readings, set-points, joint states, diagnostics, accepted
    /// commands) into one MCAP file that Foxglove opens.
    Record(record::RecordArgs),
    /// Feed a recording's raw readings (and its commands) through a config's joint plugins: the
    /// observed torque they give against the recorded one and the F/T sensor.
    Replay(replay::ReplayArgs),
    /// Gravity torques of a pose from the arm's URDF (appendix C): what each joint must apply
    /// to hold it.
    Gravity(gravity::GravityArgs),
    /// Is this machine fit to run the arm? Real-time kernel, memory lock, SCHED_FIFO at the
    /// configured priority, the loop's CPU, the config's CAN interfaces up at their bitrate, and a
    /// short 1 kHz loop's lateness, each with what to do (exit 1 when the arm cannot run here).
    Doctor(doctor::DoctorArgs),
    /// Measure each elastic joint's deflection zero with the arm at rest, every element
    /// unloaded, and write it (`zero:` under the joint's params): a calibrated joint reads its
    /// load at start and refuses a deflection outside its spring's range.
    Calibrate(calibrate::CalibrateArgs),
    /// Read a running arm's shared memory from this separate process.
    Inspect {
        #[command(subcommand)]
        command: inspect::InspectCommand,
    },
    /// Print a shell completion script: `jointctl completions bash > ~/.local/share/bash-completion/completions/jointctl`
    /// (zsh: into a folder of `$fpath` as `_jointctl`; fish: `~/.config/fish/completions/jointctl.fish`).
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// Open a running arm to Foxglove and to other machines (Zenoh).
    Bridge {
        #[command(subcommand)]
        command: bridge::BridgeCommand,
    },
}

/// Plugins linked into this binary, for `--static-plugins` (single-binary deployment).
fn static_loader(loader: &mut PluginLoader) -> Result<(), jointctl_runtime::LoadPluginError> {
    loader.register_static(jointctl_plugin_rigid::plugin_descriptor())?;
    loader.register_static(jointctl_plugin_elastic::plugin_descriptor())?;
    loader.register_static(jointctl_plugin_vsa_shoulder::plugin_descriptor())?;
    loader.register_static(jointctl_plugin_vsa_wrist::plugin_descriptor())?;
    Ok(())
}

/// The loader for experiments: the plugins linked into this binary, then the config's search path
/// (plugins given by path in the YAML are always loaded from there).
fn experiment_loader(loaded: &jointctl_config::LoadedConfig) -> Result<PluginLoader, jointctl_runtime::LoadPluginError> {
    let mut loader = jointctl_runtime::loader_for(loaded);
    static_loader(&mut loader)?;
    Ok(loader)
}

/// A finite number: NaN and infinity are refused where they are typed, with the argument's
/// name (clap adds it), instead of reaching the runtime, where NaN means "not given".
fn finite(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("must be a finite number, got {v}")),
        Err(_) => Err(format!("`{text}` is not a number")),
    }
}

/// The longest duration a command takes [s]: 1e9 s, 31 years (an assumption: longer is "for
/// ever" to a person, and 1e300 s panicked in `Duration`).
pub const MAX_SECONDS: f64 = 1e9;

/// A duration [s]: finite, in [0, [`MAX_SECONDS`]] (a negative, NaN or huge one would panic in
/// `Duration` or end a run at once without saying so).
fn seconds(text: &str) -> Result<f64, String> {
    match finite(text)? {
        v if (0.0..=MAX_SECONDS).contains(&v) => Ok(v),
        v => Err(format!("must be in [0, {MAX_SECONDS:e}] s, got {}", jointctl_config::short_number(v))),
    }
}

/// Loads a plugin library's bytes in a short-lived child of this program before this process
/// loads them: a library that kills the dynamic loader kills the child, and is refused here.
fn probe_in_child(data: &[u8]) -> Result<(), jointctl_runtime::loader::ProbeError> {
    use std::io::Write as _;
    use std::os::unix::process::ExitStatusExt as _;
    const PROBE_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);
    let exe = match std::env::current_exe() {
        Ok(exe) => exe,
        Err(e) => {
            tracing::warn!("plugin libraries are loaded without a probe: cannot find this program ({e})");
            return Ok(());
        }
    };
    let spawned = std::process::Command::new(exe).arg("__probe-plugin").stdin(std::process::Stdio::piped()).stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null()).spawn();
    let mut child = match spawned {
        Ok(c) => c,
        Err(e) => {
            tracing::warn!("plugin libraries are loaded without a probe: cannot start one ({e})");
            return Ok(());
        }
    };
    if let Some(mut stdin) = child.stdin.take() {
        let _ = stdin.write_all(data);
    }
    let started = std::time::Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) if started.elapsed() < PROBE_TIMEOUT => std::thread::sleep(std::time::Duration::from_millis(5)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(jointctl_runtime::loader::ProbeError::TimedOut { seconds: PROBE_TIMEOUT.as_secs() });
            }
        }
    };
    match status.signal() {
        Some(signal) => Err(jointctl_runtime::loader::ProbeError::Killed { signal: jointctl_runtime::signals::signal_name(signal) }),
        // Loaded, or refused with a reason the host's own load gives again.
        None => Ok(()),
    }
}

/// Writes `text` to stdout; a reader that has gone (`| head`) is not an error worth a panic,
/// which `print!` would raise.
fn print_out(text: &str) {
    use std::io::Write as _;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

fn fail(message: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(1)
}

/// An error and every source below it, `outer: inner: innermost`.
fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut next = e.source();
    while let Some(s) = next {
        let part = s.to_string();
        // Errors that print their source inline (`{source}`) would repeat it.
        if !text.ends_with(&part) {
            text = format!("{text}: {part}");
        }
        next = s.source();
    }
    text
}

/// Fails with an error and its sources.
fn fail_err(e: impl std::error::Error + 'static) -> ExitCode {
    fail(chain(&e))
}

fn main() -> ExitCode {
    // Log lines go through a bounded queue to a writer thread, which drops them when stderr
    // blocks (a pipe nobody drains): the runtime's publisher thread, which logs commands and
    // faults, must never wait on stderr, or commands would go unanswered.
    let (log_writer, _log_guard) = tracing_appender::non_blocking::NonBlockingBuilder::default().lossy(true).finish(std::io::stderr());
    tracing_subscriber::fmt()
        // Zenoh's own lines are off unless RUST_LOG asks for them: jointctl reports each failure
        // it meets through Zenoh as its own error, with the endpoint and why, and Zenoh's lines
        // before it (source paths, "Timeout!") only confused that (issue 40, finding 14). The DDS
        // stack's lines likewise: INFO for every matched reader and locator, WARN for every write
        // a slow reader refuses (the ROS 2 bridge counts those and says so itself).
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info,zenoh=off,rustdds=error,ros2_client=warn".into()),
        )
        .with_writer(log_writer)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    let cli = Cli::parse();
    if !matches!(cli.command, Command::ProbePlugin) {
        jointctl_runtime::loader::set_probe(probe_in_child);
    }
    match cli.command {
        Command::ProbePlugin => {
            let mut data = Vec::new();
            if let Err(e) = std::io::Read::read_to_end(&mut std::io::stdin(), &mut data) {
                return fail(format!("cannot read the library from stdin: {e}"));
            }
            match jointctl_runtime::loader::probe_load(&data) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => fail_err(e),
            }
        }
        Command::Run(args) => run::run(args),
        Command::CheckTransmission { config, step_rad } => transmission::run(&config, step_rad),
        Command::Check { config } => {
            let loaded = match jointctl_config::load(&config) {
                Ok(l) => l,
                Err(e) => return fail_err(e),
            };
            let loader = jointctl_runtime::loader_for(&loaded);
            let warnings = match jointctl_backends::check_bus_budget(&loaded) {
                Ok(w) => w,
                Err(e) => return fail_err(e),
            };
            match jointctl_backends::build_arm_for_check(&loaded, &loader) {
                Ok(arm) => {
                    outln!("{}: arm `{}` OK, {} Hz, {} joint(s):", config.display(), arm.name, arm.rate_hz, arm.dof_names.len());
                    for slot in &arm.slots {
                        let dofs: Vec<_> = slot.dofs().map(|i| arm.dof_names[i].as_str()).collect();
                        outln!("  {:<10} plugin {:<14} DOF {}", slot.name, slot.plugin, dofs.join(", "));
                        if let Some(line) = joint_effects::line(&loaded, &slot.name) {
                            outln!("  {:<10} {line}", "");
                        }
                    }
                    let budgets = jointctl_hal::budget::budgets(&loaded.config);
                    if !budgets.is_empty() {
                        outln!("CAN bus budget at {} Hz:", arm.rate_hz);
                        for b in budgets {
                            outln!("  {b}");
                        }
                    }
                    for w in warnings {
                        outln!("{w}");
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail_err(e),
            }
        }
        Command::Schema => {
            outln!("{}", serde_json::to_string_pretty(&jointctl_config::json_schema()).unwrap_or_default());
            ExitCode::SUCCESS
        }
        Command::Inspect { command } => inspect::run(command),
        Command::Bridge { command } => bridge::run(command),
        Command::Completions { shell } => {
            let mut script = Vec::new();
            clap_complete::generate(shell, &mut <Cli as clap::CommandFactory>::command(), "jointctl", &mut script);
            print_out(&String::from_utf8_lossy(&script));
            ExitCode::SUCCESS
        }
        Command::Record(args) => record::run(args),
        Command::Replay(args) => replay::run(args),
        Command::Cmd(args) => cmd::run(args),
        Command::Fit(args) => ident::run_fit(args),
        Command::Identify(args) => ident::run_identify(args),
        Command::Experiment { command } => experiment::experiment(command),
        Command::Sim { command } => experiment::sim(command),
        Command::Gravity(args) => gravity::run(args),
        Command::Doctor(args) => doctor::doctor(&args),
        Command::Calibrate(args) => calibrate::calibrate(&args),
    }
}
