//! `jointctl doctor`: is this machine fit to run the arm (real-time kernel, memory lock,
//! SCHED_FIFO, the loop's CPU, the CAN interfaces, a 1 kHz loop's lateness)?

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use jointctl_runtime::doctor::{Status, checks};

use crate::{fail, print_out};

#[derive(Args)]
pub struct DoctorArgs {
    /// The arm description (its timing and, for `socketcan`, its CAN buses).
    config: PathBuf,
    /// How long the 1 kHz lateness loop runs [s].
    #[arg(long, default_value_t = 2.0, value_parser = crate::seconds)]
    seconds: f64,
    /// Print the checks as JSON: `[{"name", "status", "found", "advice"}]`.
    #[arg(long)]
    json: bool,
}

/// Exit 0 when nothing fails (warnings included), 1 when the arm cannot run here.
pub fn doctor(a: &DoctorArgs) -> ExitCode {
    let loaded = match jointctl_config::load(&a.config) {
        Ok(l) => l,
        Err(e) => return fail(e.to_string()),
    };
    let found = checks(&loaded.config, a.seconds);
    if a.json {
        match serde_json::to_string_pretty(&found) {
            Ok(text) => print_out(&format!("{text}\n")),
            Err(e) => return fail(e.to_string()),
        }
    } else {
        let mut text = format!("Is this machine fit to run `{}` ({})?\n", loaded.config.arm, a.config.display());
        for c in &found {
            let mark = match c.status {
                Status::Ok => "ok  ",
                Status::Warn => "WARN",
                Status::Fail => "FAIL",
            };
            let _ = writeln!(text, "{mark}  {}: {}", c.name, c.found);
            if !c.advice.is_empty() {
                let _ = writeln!(text, "      -> {}", c.advice);
            }
        }
        print_out(&text);
    }
    if found.iter().any(|c| c.status == Status::Fail) { ExitCode::from(1) } else { ExitCode::SUCCESS }
}
