//! `jointctl replay` and `jointctl sim replay`: a recording through a config's observers, and
//! its commands on the simulated arm (see `jointctl_experiments::replay`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use jointctl_experiments::plot::{COLORS, PlotError, Series, lines};
use jointctl_experiments::replay::ReplayReport;

#[derive(Args)]
pub struct ReplayArgs {
    /// The recording (`jointctl record`).
    recording: PathBuf,
    /// The arm description whose joint plugins observe the recorded readings (the recorded
    /// arm's own, or a changed model).
    #[arg(long)]
    config: PathBuf,
    /// Print one JSON object `{"cycles", "channels": [...], "notes": [...]}`.
    #[arg(long)]
    json: bool,
    /// Write the table and one plot per joint into this folder.
    #[arg(long)]
    report: Option<PathBuf>,
}

fn json(r: &ReplayReport) -> serde_json::Value {
    serde_json::json!({"cycles": r.cycles, "channels": r.channels, "notes": r.notes})
}

fn table(r: &ReplayReport, title: &str) -> String {
    let mut t = format!("# {title}\n\n{} recorded cycles.\n\n| joint | channel | RMSE | max | unit | samples |\n|---|---|---|---|---|---|\n", r.cycles);
    for c in &r.channels {
        let _ = writeln!(t, "| {} | {} | {:.4} | {:.4} | {} | {} |", c.joint, c.channel, c.rmse, c.max_abs, c.unit, c.samples);
    }
    for n in &r.notes {
        let _ = writeln!(t, "\nNote: {n}");
    }
    t
}

/// The table, and plots (recorded, replayed, third series) per joint, into `dir`.
fn write_report(dir: &Path, r: &ReplayReport, title: &str, names: [&str; 3]) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut md = table(r, title);
    for (joint, trace) in &r.torque_traces {
        if trace.is_empty() {
            continue;
        }
        let file = format!("{joint}-torque.svg");
        let pick = |f: fn(&(f64, f64, f64, f64)) -> f64| trace.iter().map(|p| (p.0, f(p))).collect::<Vec<_>>();
        let series = [
            Series { name: names[0], points: pick(|p| p.1), color: COLORS[0] },
            Series { name: names[1], points: pick(|p| p.2), color: COLORS[1] },
            Series { name: names[2], points: pick(|p| p.3), color: COLORS[2] },
        ];
        // A rigid joint without an F/T sensor has no finite torque to draw: said, not a failure
        // of the whole report.
        match lines(&dir.join(&file), &format!("{joint} torque, {title}"), "t [s]", "torque [Nm]", &series) {
            Ok(()) => {
                let _ = writeln!(md, "\n![{joint}]({file})");
            }
            Err(PlotError::Empty { .. }) => {
                let _ = writeln!(md, "\n{joint}: no torque recorded or replayed (no F/T sensor, no observer), nothing to plot.");
            }
            Err(e) => return Err(e.to_string()),
        }
    }
    std::fs::write(dir.join("report.md"), md).map_err(|e| format!("cannot write {}: {e}", dir.join("report.md").display()))
}

fn finish(r: &ReplayReport, a: &ReplayArgs, title: &str, names: [&str; 3]) -> ExitCode {
    if let Some(dir) = &a.report
        && let Err(e) = write_report(dir, r, title, names)
    {
        return crate::fail(e);
    }
    if a.json {
        crate::print_out(&format!("{}\n", json(r)));
    } else {
        crate::print_out(&table(r, title));
    }
    ExitCode::SUCCESS
}

fn load(a: &ReplayArgs) -> Result<(jointctl_config::LoadedConfig, jointctl_runtime::PluginLoader), ExitCode> {
    let loaded = jointctl_config::load(&a.config).map_err(crate::fail_err)?;
    let loader = crate::experiment_loader(&loaded).map_err(crate::fail_err)?;
    Ok((loaded, loader))
}

/// `jointctl replay`.
pub fn run(a: ReplayArgs) -> ExitCode {
    let (loaded, loader) = match load(&a) {
        Ok(l) => l,
        Err(code) => return code,
    };
    match jointctl_experiments::replay::replay_observers(&a.recording, &loaded, &loader) {
        Ok(r) => finish(&r, &a, &format!("recorded readings through {}", a.config.display()), ["recorded observer", "replayed observer", "F/T sensor"]),
        Err(e) => crate::fail_err(e),
    }
}

/// `jointctl sim replay`.
pub fn run_sim(a: ReplayArgs) -> ExitCode {
    let (loaded, loader) = match load(&a) {
        Ok(l) => l,
        Err(code) => return code,
    };
    match jointctl_experiments::replay::replay_on_sim(&a.recording, &loaded, &loader) {
        Ok(r) => finish(&r, &a, &format!("recorded commands on the simulated arm of {}", a.config.display()), ["recorded F/T", "simulated F/T", "reference"]),
        Err(e) => crate::fail_err(e),
    }
}
