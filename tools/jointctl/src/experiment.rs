//! `jointctl experiment` and `jointctl sim`: the thesis' experiments on the simulated arm.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Subcommand;
use jointctl_experiments::plot::{COLORS, RGBColor, Series, lines};
use jointctl_experiments::record::{RecordOptions, record, write_csv};
use jointctl_experiments::tracking::{Plan, Row, Scenario, bandwidth_hz, run};
use jointctl_ident::identify::experiment::{Experiment, Segment};

use crate::experiment_checks::{PIVOT_TOLERANCE_MM, check_record_options, check_segment, tracking_request_is_measurable};

#[derive(Subcommand)]
pub enum ExperimentCommand {
    /// Chapter 5: torque tracking of one joint, output clamped, at several stiffness settings.
    TorqueTracking {
        /// The arm description (simulated backend).
        config: PathBuf,
        /// The DOF (e.g. q2).
        #[arg(long)]
        joint: String,
        /// `thesis` (40 Hz, 15/30 ms latency) or `modern` (1 kHz, 1 ms).
        #[arg(long, default_value = "thesis")]
        scenario: String,
        /// Stiffness settings to request [Nm/rad], comma-separated; default: low, middle and
        /// high of the joint's stiffness limits (VSA joints), or as configured.
        #[arg(long, value_delimiter = ',', value_parser = crate::finite)]
        stiffness: Vec<f64>,
        /// Print one JSON object `{"rows": [...]}` instead of the table.
        #[arg(long)]
        json: bool,
        /// Where to write the table, rows and plots (default reports/torque-tracking-JOINT-SCENARIO).
        #[arg(long)]
        report: Option<PathBuf>,
        /// Fewer references (step, 0.1 Hz sine, 1 Hz sine): a quick look.
        #[arg(long)]
        quick: bool,
    },
    /// What limited the thesis' arm (section 6.2): the `thesis` scenario's sine sweep (0.1-4 Hz)
    /// with one factor changed at a time (loop rate, each latency, drive profile limits, PI
    /// gains and gain scheduling, the plant's effects), bandwidth and errors in one table.
    Sensitivity {
        /// The arm description (simulated backend).
        config: PathBuf,
        /// The DOF (e.g. q2).
        #[arg(long)]
        joint: String,
        /// Stiffness setting [Nm/rad]; default the geometric middle of the DOF's stiffness limits.
        #[arg(long, value_parser = crate::finite)]
        stiffness: Option<f64>,
        /// Print one JSON object `{"variants": [...]}` instead of the table.
        #[arg(long)]
        json: bool,
        /// Also write the table here (Markdown).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Appendix C's future work: the arm off its clamps (every joint of its URDF a joint of the
    /// simulated free arm), the torque-controlled pitch DOFs holding three poses in impedance,
    /// with and without gravity feed-forward: steady-state error, torques, a plot per pose.
    GravityHold {
        /// The arm description (simulated backend, with `kinematics: {urdf: ...}`).
        config: PathBuf,
        /// `modern` (1 kHz, 1 ms) or `thesis` (40 Hz, 15/30 ms latency).
        #[arg(long, default_value = "modern")]
        scenario: String,
        /// Print one JSON object `{"rows": [...]}` instead of the table.
        #[arg(long)]
        json: bool,
        /// Where to write the table and plots (default reports/gravity-hold-SCENARIO).
        #[arg(long)]
        report: Option<PathBuf>,
    },
}

#[derive(Subcommand)]
pub enum SimCommand {
    /// Re-run a recording's commands on the simulated arm of a config, from the recorded drive
    /// positions: per joint and channel, the error between simulation and recording.
    Replay(crate::replay::ReplayArgs),
    /// Record a characterisation (sections 3.3.1, 3.4.1, 3.5.1) as CSV for `jointctl fit`.
    Record {
        /// The arm description (simulated backend).
        config: PathBuf,
        /// The DOF to deflect.
        #[arg(long)]
        joint: String,
        /// Output CSV file.
        #[arg(long)]
        out: PathBuf,
        /// Flow-source amplitude [rad], in (0, pi].
        #[arg(long, default_value_t = 0.1, value_parser = crate::finite)]
        amplitude: f64,
        /// Flow-source frequency [Hz], in [0.001, 100] and below half the sample rate.
        #[arg(long, default_value_t = 0.2, value_parser = crate::finite)]
        frequency: f64,
        /// Duration [s], in (0, 86400].
        #[arg(long, default_value_t = 20.0, value_parser = crate::finite)]
        duration: f64,
        /// Pivot setting to hold [mm] (VSA joints).
        #[arg(long, value_parser = crate::finite)]
        pivot_mm: Option<f64>,
        /// Deflection direction [deg] (wrist: 0 = q7 only, 90 = q6 only).
        #[arg(long, default_value_t = 0.0, value_parser = crate::finite)]
        angle_deg: f64,
        /// Sample rate [Hz], in [1, 10000] (a config's loop rate); the loop runs at it.
        #[arg(long, default_value_t = 100.0, value_parser = crate::finite)]
        rate: f64,
        /// Run an experiment file instead of one sine (`experiment.yaml` as `jointctl identify`
        /// proposes it for a confounded pair: sines run one after the other, each from rest,
        /// written as one record with a 1 s gap in the time between them).
        #[arg(long, conflicts_with_all = ["amplitude", "frequency", "duration"])]
        experiment: Option<PathBuf>,
    },
    /// Characterise a joint into one CSV for `jointctl fit`: the shoulder (q2) at 0-45 mm in
    /// 5 mm steps (section 3.4.2; fit with `--branches --order 3`), the wrist at 0-50 mm along
    /// 0/45/90/135 deg (section 3.5.2; fit with `--order 4`), an elastic joint (the elbow q4) at
    /// its one setting (section 3.3.2; fit with `--order 1`).
    Characterise {
        /// The arm description (simulated backend).
        config: PathBuf,
        /// The joint: q2, the wrist (`wrist`, q6 or q7), or q4.
        #[arg(long)]
        joint: String,
        /// Output CSV file.
        #[arg(long)]
        out: PathBuf,
    },
}

/// The thesis' validation settings of a VSA as stiffness requests, with their amplitudes: q2 at
/// 13 pivots (section 5.1), the wrist at 14 (section 5.2), evenly from 0 mm to the last the
/// thesis names (q2: 44.9549 mm, figure 5.13) or to the wrist table's last (50 mm); the thesis
/// lists neither set, so even spacing is an assumption. Amplitudes: q2 the medium step's 0.084 rad
/// of deflection (7.5 Nm at 89 Nm/rad, figure 5.7) within the high step's 20 Nm (figure 5.2); the
/// wrist from 1 Nm at its softest to 2 Nm at its stiffest (figures 5.24, 5.16), linear in the
/// pivot. `None` for other joints.
fn thesis_settings(loaded: &jointctl_config::LoadedConfig, joint: &str, wrist: bool) -> Option<(Vec<f64>, Vec<Option<f64>>)> {
    use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic, WristCharacteristic};
    let entry = loaded.config.joints.iter().find(|j| j.name == joint || j.dof_names().contains(&joint))?;
    let spec: CharacteristicSpec = serde_json::from_value(entry.params.0.get("characteristic")?.clone()).ok()?;
    let even = |n: usize, last: f64| (0..n).map(move |k| last * k as f64 / (n - 1) as f64);
    if wrist {
        let table = WristCharacteristic::from_spec(&spec).ok()?;
        let last = *table.pivots_mm().last()?;
        let pivots: Vec<f64> = even(14, last).collect();
        let stiffness = pivots.iter().map(|p| table.evaluate(*p, 0.0, 0.0).stiffness_q6_nm_per_rad).collect();
        let amplitudes = pivots.iter().map(|p| Some(2.0 - p / last)).collect();
        return Some((stiffness, amplitudes));
    }
    if joint != "q2" {
        return None;
    }
    let table = PivotCharacteristic::from_spec(&spec).ok()?;
    let pivots: Vec<f64> = even(13, 44.9549).collect();
    let stiffness: Vec<f64> = pivots.iter().map(|p| table.stiffness(*p)).collect();
    let amplitudes = stiffness.iter().map(|k| Some((7.5 / 89.0 * k).min(20.0))).collect();
    Some((stiffness, amplitudes))
}

fn table(rows: &[Row]) -> String {
    let mut t = String::from(
        "| joint | scenario | reference | f [Hz] | pivot [mm] | NRMSE observed | NRMSE sensor | NRMSE observed vs sensor | offset [Nm] | ripple [Nm] | phase lag [deg] | gain |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {} |",
            r.joint,
            r.scenario,
            if r.together.is_empty() { r.reference.clone() } else { format!("{} (with {})", r.reference, r.together) },
            r.frequency_hz,
            r.pivot_mm.map_or("-".into(), |p| format!("{p:.1}")),
            r.nrmse_observed,
            r.nrmse_sensor,
            r.nrmse_observer_vs_sensor,
            r.offset_nm,
            r.ripple_nm.map_or("-".into(), |p| format!("{p:.3}")),
            r.phase_lag_deg.map_or("-".into(), |p| format!("{p:.1}")),
            r.gain.map_or("-".into(), |g| format!("{g:.2}"))
        );
    }
    t
}

fn plots(dir: &Path, rows: &[Row]) -> Result<(), String> {
    for r in rows {
        // A DOF that ran with others (the wrist's pairs) names them: q6's sine ran with q7's sine
        // and with q7's cosine, two plots.
        let with = if r.together.is_empty() { String::new() } else { format!("-with-{}", r.together.replace(", ", "-").replace(' ', "-")) };
        let name = format!(
            "{}-{}-{}Hz{with}-pivot{}.svg",
            r.joint,
            r.reference,
            r.frequency_hz,
            r.pivot_mm.map_or("none".into(), |p| format!("{p:.1}"))
        );
        let pick = |f: fn(&(f64, f64, f64, f64)) -> f64| r.trace.iter().map(|p| (p.0, f(p))).collect::<Vec<_>>();
        let title = format!(
            "{} torque, {} {} Hz{}, pivot {} mm ({} scenario)",
            r.joint,
            r.reference,
            r.frequency_hz,
            if r.together.is_empty() { String::new() } else { format!(" with {}", r.together) },
            r.pivot_mm.map_or("-".into(), |p| format!("{p:.1}")),
            r.scenario
        );
        lines(
            &dir.join(name),
            &title,
            "t [s]",
            "torque [Nm]",
            &[
                Series { name: "reference", points: pick(|p| p.1), color: COLORS[0] },
                Series { name: "observed", points: pick(|p| p.2), color: COLORS[1] },
                Series { name: "sensor", points: pick(|p| p.3), color: COLORS[2] },
            ],
        )
        .map_err(|e| crate::chain(&e))?;
    }
    Ok(())
}

pub fn experiment(cmd: ExperimentCommand) -> ExitCode {
    match cmd {
        ExperimentCommand::Sensitivity { config, joint, stiffness, json, out } => {
            let loaded = match jointctl_config::load(&config) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            let middle = loaded.config.joints.iter().find_map(|j| {
                let names = j.dof_names();
                names.iter().position(|n| *n == joint).and_then(|i| j.dof_limits()[i]).and_then(|l| l.stiffness_nm_per_rad).map(|[lo, hi]| (lo * hi).sqrt())
            });
            let Some(k) = stiffness.or(middle) else {
                return crate::fail(format!("`{joint}` has no stiffness limits: give --stiffness"));
            };
            let loader = match crate::experiment_loader(&loaded) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            let variants = match jointctl_experiments::sensitivity::run(&loaded, &loader, &joint, k, |done, total| eprint!("\r{done}/{total} variants")) {
                Ok(v) => v,
                Err(e) => return crate::fail_err(e),
            };
            eprintln!();
            let table = format!(
                "# What limits torque tracking of {joint} at {k:.1} Nm/rad\n\nConfig: `{}`. The `thesis` scenario's sine sweep (0.1-4 Hz, output clamped) with one factor changed at a time. \"Good up to\": the highest swept frequency up to which the F/T sensor's NRMSE stays within {} (an assumption: the thesis says \"good at 0.1-0.2 Hz, poor above\" without a number).\n\n{}",
                config.display(),
                jointctl_experiments::sensitivity::POOR_NRMSE,
                jointctl_experiments::sensitivity::table(&variants)
            );
            if let Some(path) = &out
                && let Err(e) = std::fs::write(path, &table)
            {
                return crate::fail(format!("cannot write {}: {e}", path.display()));
            }
            if json {
                outln!("{}", serde_json::json!({ "joint": joint, "stiffness_nm_per_rad": k, "variants": variants }));
            } else {
                out!("{table}");
            }
            ExitCode::SUCCESS
        }
        ExperimentCommand::GravityHold { config, scenario, json, report } => gravity_hold(&config, &scenario, json, report),
        ExperimentCommand::TorqueTracking { config, joint, scenario, stiffness, json, report, quick } => {
            let Some(scn) = Scenario::parse(&scenario) else {
                return crate::fail(format!("--scenario must be `thesis` or `modern`, got `{scenario}`"));
            };
            let loaded = match jointctl_config::load(&config) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            // A joint entry of several DOFs (the wrist) runs them together; its first DOF's
            // stiffness limits choose the settings.
            let entry = loaded.config.joints.iter().find(|j| j.name == joint && j.dof_names().len() > 1);
            if let Err(e) = tracking_request_is_measurable(&loaded, &joint, entry.is_some(), &stiffness) {
                return crate::fail(e);
            }
            let defaults = stiffness.is_empty();
            let settings = if defaults {
                let limits = match entry {
                    Some(e) => e.dof_limits()[0].and_then(|l| l.stiffness_nm_per_rad),
                    None => loaded.config.joints.iter().find_map(|j| {
                        let names = j.dof_names();
                        names.iter().position(|n| *n == joint).and_then(|i| j.dof_limits()[i]).and_then(|l| l.stiffness_nm_per_rad)
                    }),
                };
                limits.map_or_else(Vec::new, |[lo, hi]| vec![lo, (lo * hi).sqrt(), hi])
            } else {
                stiffness
            };
            let (sine, cosine, step) = (jointctl_modes::Waveform::Sine, jointctl_modes::Waveform::Cosine, jointctl_modes::Waveform::Step);
            // The full run covers the thesis' settings (section 5.1: 13 shoulder pivots;
            // section 5.2: 14 wrist pivots); --quick the low, middle and high ones.
            let full = if defaults && !quick { thesis_settings(&loaded, &joint, entry.is_some()) } else { None };
            let mut plan = if entry.is_some() { Plan::wrist(settings) } else { Plan::thesis(settings) };
            // Chapter 5's amplitudes at the low, middle and high settings: the wrist's steps of
            // 1, 1.5 and 2 Nm (figures 5.24, 5.20, 5.16); the shoulder's of 7.5 and 20 Nm at
            // middle and high (figures 5.7, 5.2; none at low: 0.05 rad of deflection, assumed).
            if defaults && plan.stiffness_nm_per_rad.len() == 3 {
                plan.amplitudes_nm = match (entry.is_some(), joint.as_str()) {
                    (true, _) => vec![Some(1.0), Some(1.5), Some(2.0)],
                    (false, "q2") => vec![None, Some(7.5), Some(20.0)],
                    _ => Vec::new(),
                };
            }
            if let Some((stiffness, amplitudes)) = full {
                plan.stiffness_nm_per_rad = stiffness;
                plan.amplitudes_nm = amplitudes;
            }
            if quick {
                plan.references = vec![(step, 0.0), (sine, 0.1), (sine, 1.0)];
                plan.together.retain(|run| matches!(run.as_slice(), [(0, w, _), (1, v, _)] if *w == cosine && *v == cosine) || matches!(run.as_slice(), [(0, w, _)] if *w == step) || matches!(run.as_slice(), [(1, w, f)] if *w == sine && *f == 1.0));
            }
            let bar = indicatif::ProgressBar::new(plan.runs() as u64);
            bar.set_style(indicatif::ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} runs {elapsed}").unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()));
            bar.set_prefix(format!("torque tracking {joint} ({})", scn.name()));
            let loader = match crate::experiment_loader(&loaded) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            let rows = match run(&loaded, &loader, &joint, scn, &plan, |done, _| bar.set_position(done as u64)) {
                Ok(r) => r,
                Err(e) => {
                    bar.abandon();
                    return crate::fail_err(e);
                }
            };
            bar.finish_and_clear();
            let dir = report.unwrap_or_else(|| PathBuf::from(format!("reports/torque-tracking-{joint}-{}", scn.name())));
            let bandwidth = bandwidth_hz(&rows);
            let md = format!(
                "# Torque tracking of {joint}, {} scenario\n\nConfig: `{}`. Output clamped (figures 5.1, 5.14). NRMSE = RMSE / reference amplitude; phase lag and gain of the sensor torque at the reference frequency.\n\n{}\nBandwidth (highest swept frequency with gain >= 0.707 and lag < 90 deg, lowest over the stiffness settings): {}\n",
                scn.name(),
                config.display(),
                table(&rows),
                bandwidth.map_or("-".into(), |b| format!("{b} Hz"))
            );
            let written = std::fs::create_dir_all(&dir)
                .map_err(|e| e.to_string())
                .and_then(|_| std::fs::write(dir.join("table.md"), &md).map_err(|e| e.to_string()))
                .and_then(|_| std::fs::write(dir.join("rows.json"), serde_json::json!({ "rows": rows }).to_string()).map_err(|e| e.to_string()))
                .and_then(|_| plots(&dir, &rows));
            if let Err(e) = written {
                return crate::fail(format!("cannot write the report in {}: {e}", dir.display()));
            }
            print_report(json, serde_json::json!(rows), &md, &dir)
        }
    }
}

/// An experiment file as `jointctl identify` writes it, each segment checked (a sine the
/// simulator can run: finite, positive, at most a day long).
pub(crate) fn read_experiment(file: &std::path::Path) -> Result<Experiment, String> {
    let text = jointctl_files::read_to_string(file, jointctl_files::FileKind::Config).map_err(|e| e.to_string())?;
    // serde_yaml quotes what it could not read, which for a file that is no YAML (a CSV given
    // by mistake) is the whole file: 2.5 MB of error. Bounded as a config's errors are.
    let experiment: Experiment = serde_yaml::from_str(&text).map_err(|e| {
        let why = jointctl_config::bounded_message(&e.to_string());
        match e.location() {
            Some(at) => format!("{}:{}:{}: {why}", file.display(), at.line(), at.column()),
            None => format!("{}: {why}", file.display()),
        }
    })?;
    if experiment.segments.is_empty() {
        return Err(format!("{}: segments: none to run", file.display()));
    }
    for (i, s) in experiment.segments.iter().enumerate() {
        check_segment(s, |field| format!("{}: segments[{i}].{field}", file.display()))?;
    }
    Ok(experiment)
}

pub fn sim(cmd: SimCommand) -> ExitCode {
    match cmd {
        SimCommand::Replay(args) => crate::replay::run_sim(args),
        SimCommand::Record { config, joint, out, amplitude, frequency, duration, pivot_mm, angle_deg, rate, experiment } => {
            let segments = match &experiment {
                Some(file) => match read_experiment(file) {
                    Ok(e) => e.segments,
                    Err(e) => return crate::fail(e),
                },
                None => vec![Segment { amplitude_rad: amplitude, frequency_hz: frequency, duration_s: duration }],
            };
            if let Err(e) = check_record_options(&segments, rate, experiment.as_deref()) {
                return crate::fail(e);
            }
            let loaded = match jointctl_config::load(&config) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            let opts = RecordOptions { joint, amplitude_rad: amplitude, frequency_hz: frequency, duration_s: duration, pivot_mm, angle_deg, rate_hz: rate };
            let loader = match crate::experiment_loader(&loaded) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            let mut samples: Vec<jointctl_experiments::record::Sample> = Vec::new();
            for segment in &segments {
                let opts = RecordOptions { amplitude_rad: segment.amplitude_rad, frequency_hz: segment.frequency_hz, duration_s: segment.duration_s, ..opts.clone() };
                // Each segment from rest, after the last one's end and a gap of 1 s (identify
                // starts a segment of contiguous logging there and never differences across it).
                let offset = samples.last().map_or(0.0, |s| s.t + 1.0);
                match record(&loaded, &loader, &opts) {
                    Ok(more) => samples.extend(more.into_iter().map(|s| jointctl_experiments::record::Sample { t: s.t + offset, ..s })),
                    Err(e) => return crate::fail_err(e),
                }
            }
            // Nothing recorded is no record: a deflection the observer never formed (beyond the
            // joint's travel, a fault), said instead of an empty file.
            if samples.is_empty() {
                return crate::fail(format!("no sample recorded of `{}`: the observer formed no deflection in any cycle (an amplitude beyond the joint's travel, or a fault); nothing written to {}", opts.joint, out.display()));
            }
            // A pivot asked for beyond the joint's travel settles where the travel ends: said,
            // not recorded as if it were the setting asked for.
            if let (Some(asked), Some(held)) = (pivot_mm, samples.first().map(|s| s.pivot_mm).filter(|p| p.is_finite()))
                && (held - asked).abs() > PIVOT_TOLERANCE_MM
            {
                return crate::fail(format!("--pivot-mm {asked}: the pivot settled at {held:.2} mm (beyond the joint's travel?); nothing written to {}", out.display()));
            }
            let file = match std::fs::File::create(&out) {
                Ok(f) => f,
                Err(e) => return crate::fail(format!("cannot create {}: {e}", out.display())),
            };
            let is_wrist = samples.first().is_some_and(|_| opts.angle_deg != 0.0) || angle_deg != 0.0;
            if let Err(e) = write_csv(&samples, is_wrist.then_some(angle_deg), std::io::BufWriter::new(file)) {
                return crate::fail(format!("cannot write {}: {e}", out.display()));
            }
            eprintln!("{} samples written to {}", samples.len(), out.display());
            ExitCode::SUCCESS
        }
        SimCommand::Characterise { config, joint, out } => {
            let loaded = match jointctl_config::load(&config) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            let loader = match crate::experiment_loader(&loaded) {
                Ok(l) => l,
                Err(e) => return crate::fail_err(e),
            };
            // A 2-DOF joint (the wrist, by its name or a DOF's) gets section 3.5.2's plan, along
            // four directions; a 1-DOF VSA section 3.4.2's; a joint without a pivot (the elbow)
            // section 3.3.2's single setting.
            let entry = loaded.config.joints.iter().find(|j| j.name == joint || j.dof_names().contains(&joint.as_str()));
            let two = entry.is_some_and(|e| e.dof_names().len() == 2 && jointctl_experiments::record::is_directional(e));
            let dof = match entry {
                Some(e) if two => e.dof_names()[0].to_string(),
                _ => joint.clone(),
            };
            let has_pivot = entry.and_then(|e| e.sim.as_ref()).is_some_and(|s| s.pivot.is_some());
            let plan = match (two, has_pivot) {
                (true, _) => jointctl_experiments::characterise::Plan::wrist(),
                (false, true) => jointctl_experiments::characterise::Plan::shoulder(),
                (false, false) => jointctl_experiments::characterise::Plan::elastic(),
            };
            let samples = match jointctl_experiments::characterise::characterise(&loaded, &loader, &dof, &plan) {
                Ok(s) => s,
                Err(e) => return crate::fail_err(e),
            };
            let file = match std::fs::File::create(&out) {
                Ok(f) => f,
                Err(e) => return crate::fail(format!("cannot create {}: {e}", out.display())),
            };
            if let Err(e) = write_csv(&samples, None, std::io::BufWriter::new(file)) {
                return crate::fail(format!("cannot write {}: {e}", out.display()));
            }
            let settings = if plan.pivots_mm.is_empty() { "one setting".to_string() } else { format!("{} pivot settings", plan.pivots_mm.len()) };
            eprintln!("{} samples at {settings}{} written to {}", samples.len(), if two { " and 4 directions" } else { "" }, out.display());
            ExitCode::SUCCESS
        }
    }
}

fn gravity_hold(config: &Path, scenario: &str, json: bool, report: Option<PathBuf>) -> ExitCode {
    use jointctl_experiments::gravity_hold;
    let Some(scn) = Scenario::parse(scenario) else {
        return crate::fail(format!("--scenario must be `thesis` or `modern`, got `{scenario}`"));
    };
    let loaded = match jointctl_config::load(config) {
        Ok(l) => l,
        Err(e) => return crate::fail_err(e),
    };
    let loader = match crate::experiment_loader(&loaded) {
        Ok(l) => l,
        Err(e) => return crate::fail_err(e),
    };
    let mut plan = gravity_hold::Plan::sherpa();
    plan.scenario = scn;
    let (rows, traces) = match gravity_hold::run(&loaded, &loader, &plan) {
        Ok(r) => r,
        Err(e) => return crate::fail_err(e),
    };
    let dir = report.unwrap_or_else(|| PathBuf::from(format!("reports/gravity-hold-{}", scn.name())));
    let mut md = format!(
        "# Impedance hold on the free arm, {} scenario\n\nConfig: `{}`, every joint of its URDF released (`jointctl_sim::free_arm::release`). From upright to each pose in position mode ({} s), then {} in impedance for {} s; steady state = mean over the last {} s. The other DOFs hold their targets in position mode. Error = observed position - target; gravity = the host's holding torque from the URDF; reference = the torque beyond gravity; observed = the joint's observer; sensor = the simulated torque sensor.\n\n| pose | DOF | K [Nm/rad] | target [rad] | feed-forward | error [rad] | ripple [rad] | gravity [Nm] | reference [Nm] | observed [Nm] | sensor [Nm] | position unknown [cycles] | error ratio |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        scn.name(),
        config.display(),
        plan.approach_s,
        plan.impedance.iter().map(|g| g.dof.as_str()).collect::<Vec<_>>().join(", "),
        plan.hold_s,
        plan.average_s
    );
    for r in &rows {
        let ratio = if r.feedforward {
            rows.iter().find(|o| !o.feedforward && o.pose == r.pose && o.dof == r.dof).map_or("-".into(), |o| format!("{:.1}x", o.error_rad.abs() / r.error_rad.abs()))
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:+.3} | {} | {:+.5} | {:.5} | {:+.3} | {:+.3} | {:+.3} | {:+.3} | {} | {} |",
            r.pose, r.dof, r.stiffness_nm_per_rad, r.target_rad, if r.feedforward { "on" } else { "off" }, r.error_rad, r.ripple_rad, r.gravity_nm, r.reference_nm, r.observed_nm, r.sensed_nm, r.unknown_cycles, ratio
        );
    }
    let written = std::fs::create_dir_all(&dir).map_err(|e| e.to_string()).and_then(|_| std::fs::write(dir.join("table.md"), &md).map_err(|e| e.to_string()));
    if let Err(e) = written {
        return crate::fail(format!("cannot write the report in {}: {e}", dir.display()));
    }
    // One plot per pose: each held DOF's error without (dashed colours would hide nothing, so
    // separate colours) and with feed-forward.
    let palette = [RGBColor(31, 119, 180), RGBColor(255, 127, 14), RGBColor(44, 160, 44), RGBColor(214, 39, 40), RGBColor(148, 103, 189), RGBColor(140, 86, 75)];
    for pose in &plan.poses {
        let names: Vec<String> = traces.iter().filter(|t| t.pose == pose.name).map(|t| format!("{} {}", t.dof, if t.feedforward { "with feed-forward" } else { "without" })).collect();
        let series: Vec<Series> = traces
            .iter()
            .filter(|t| t.pose == pose.name)
            .zip(&names)
            .enumerate()
            .map(|(k, (t, name))| Series { name, points: t.points.clone(), color: palette[k % palette.len()] })
            .collect();
        let targets = pose.targets.iter().map(|(d, q)| format!("{d} {q:.2}")).collect::<Vec<_>>().join(", ");
        let title = format!("free arm, pose {} ({targets} rad), impedance hold, {}", pose.name, scn.name());
        if let Err(e) = lines(&dir.join(format!("{}.svg", pose.name)), &title, "time in impedance [s]", "position error [rad]", &series) {
            return crate::fail_err(e);
        }
    }
    print_report(json, serde_json::json!(rows), &md, &dir)
}

/// `{"rows": [...]}` with `--json`, else the Markdown table and where the report is.
fn print_report(json: bool, rows: serde_json::Value, md: &str, dir: &Path) -> ExitCode {
    if json {
        outln!("{}", serde_json::json!({ "rows": rows }));
    } else {
        out!("{md}");
        outln!("\nReport and plots: {}", dir.display());
    }
    ExitCode::SUCCESS
}
