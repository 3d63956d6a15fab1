//! `jointctl fit` and `jointctl identify`: `fit` the thesis' fit step, `extension` the extended
//! model identify writes; here the data and the identify command.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use jointctl_experiments::plot::{COLORS, Series, lines};
use jointctl_experiments::model_loop::{Found, Gain};
use jointctl_ident::identify::{BaselineModel, IdentifyOptions, identify};

mod diagonals;
mod extension;
mod fit;
mod output;
mod reading;
mod settings;

pub use fit::{FitArgs, run_fit};
use extension::{extend, extension_json, gains_table, loop_causes, loop_table, write_extension};
use reading::{bins_sentence, narrow_rate_sentence, rest_sentence, split_sentence};

#[derive(Args)]
pub struct IdentifyArgs {
    /// Measured experiment: CSV, or a recording (`jointctl record`, .mcap, with --joint; with
    /// --config it also gives the causes in the loop: latencies, the drives' profile limits and position-loop gain).
    #[arg(long)]
    data: PathBuf,
    /// The arm description whose joint model is the baseline (with --joint).
    #[arg(long, requires = "joint")]
    config: Option<PathBuf>,
    /// The DOF: in the config (its model is the baseline) and in a recording (its signals).
    #[arg(long)]
    joint: Option<String>,
    /// Baseline characteristic order when no config is given.
    #[arg(long, default_value_t = 1, conflicts_with = "config")]
    baseline_order: usize,
    /// Write a Markdown report with plots into this folder.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Print exactly one JSON object.
    #[arg(long)]
    json: bool,
    /// Which part of the record is held out to judge the causes: `like-the-rest` (the default:
    /// the last 30 % unless its motion is 4 times faster or slower, or wider or narrower, than
    /// the rest's: then the 30 % window most like the rest, for a sweep that grows or a test
    /// that ends in a hold; the report says which and why) or `last` (always its last 30 % of
    /// time).
    #[arg(long, value_enum, default_value_t = HeldOutArg::LikeTheRest)]
    held_out: HeldOutArg,
    /// Write the extension into this folder (with --config): `observer.yaml` (the joint's
    /// complete params with the extended observer: `params: {include: observer.yaml}` alone
    /// configures it), `plant.yaml` (its simulated effects: `sim.effects`, `effects_per_dof` or
    /// `effects_by_pivot`) and `extended.yaml` (the config with both).
    #[arg(long, requires = "config")]
    out: Option<PathBuf>,
}

/// `--held-out`'s values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum HeldOutArg {
    Last,
    LikeTheRest,
}

impl From<HeldOutArg> for jointctl_ident::identify::prepare::HeldOut {
    fn from(a: HeldOutArg) -> Self {
        match a {
            HeldOutArg::Last => Self::Last,
            HeldOutArg::LikeTheRest => Self::LikeTheRest,
        }
    }
}

/// Measured data from a CSV file, or from a recording (.mcap) for one joint: its observed
/// deflection against its F/T sensor's torque, time from the cycle stamps; samples where either
/// is unknown are left out (and said so), never used as values.
fn load_data(path: &Path, joint: Option<&str>) -> Result<jointctl_ident::csv::Data, String> {
    if !jointctl_record::reader::is_mcap(path) {
        return jointctl_ident::csv::read(path).map_err(|e| e.to_string());
    }
    let joint = joint.ok_or_else(|| format!("{}: a recording holds every joint: say which with --joint", path.display()))?;
    let m = jointctl_record::reader::measured(path, joint).map_err(|e| crate::chain(&e))?;
    if m.t_s.is_empty() {
        let why = if m.ft_samples == 0 { ": it has no F/T torque (wire a `torque_sensor` to the joint)" } else { ": its deflection is never known" };
        return Err(format!("{}: joint `{joint}` has no sample with both a deflection and an F/T torque{why}", path.display()));
    }
    let mut data = jointctl_ident::csv::Data::from_columns(m.t_s, m.deflection_rad, m.torque_nm);
    data.pivot_mm = m.pivot_mm;
    data.reference_torque = m.reference_torque_nm;
    data.motor_position = m.motor_position_rad;
    data.angle_deg = m.angle_deg;
    if m.left_out > 0 {
        data.notes.push(format!("{} of {} samples of `{joint}` left out: deflection, F/T torque or pivot unknown", m.left_out, m.samples));
    }
    Ok(data)
}

/// A config's joint as identify uses it: its params, which DOF of it, and its characteristic.
struct ConfiguredJoint {
    params: serde_json::Value,
    dof: usize,
    /// The joint's DOF names, in its order (the wrist: q6, then q7).
    dof_names: Vec<String>,
    spec: Option<jointctl_models::characteristic::CharacteristicSpec>,
}

/// `joint` of `config`, loaded once.
fn configured_joint(config: &Path, joint: &str) -> Result<ConfiguredJoint, String> {
    let loaded = jointctl_config::load(config).map_err(|e| e.to_string())?;
    let entry = loaded.config.joints.iter().find(|j| j.dof_names().contains(&joint)).ok_or_else(|| format!("no joint `{joint}` in {}", config.display()))?;
    let params = entry.params.0.clone();
    let spec = params.get("characteristic").map(|s| serde_json::from_value(s.clone()).map_err(|e| format!("{}: params.characteristic: {e}", entry.name))).transpose()?;
    let dof_names: Vec<String> = entry.dof_names().iter().map(|n| n.to_string()).collect();
    Ok(ConfiguredJoint { dof: dof_names.iter().position(|n| n == joint).unwrap_or(0), dof_names, params, spec })
}

impl ConfiguredJoint {
    /// The baseline: the joint's configured model (its characteristic, the wrist's for this
    /// DOF, or its stiffness).
    fn baseline(&self) -> Result<BaselineModel, String> {
        let torque = jointctl_experiments::model_loop::configured_torque(&self.params, self.dof).map_err(|e| e.to_string())?;
        // identify's baseline takes (deflection, pivot).
        Ok(BaselineModel::Given(Box::new(move |deflection_rad, pivot_mm| torque(pivot_mm, deflection_rad))))
    }

    /// The baseline along deflection direction `angle_deg` of a 2-DOF joint (the wrist): the
    /// table's torque along it, both DOFs deflected (section 3.5.2).
    fn baseline_along(&self, angle_deg: f64) -> Result<BaselineModel, String> {
        let torque = jointctl_experiments::model_loop::configured_torque_along(&self.params, angle_deg).map_err(|e| e.to_string())?;
        Ok(BaselineModel::Given(Box::new(move |deflection_rad, pivot_mm| torque(pivot_mm, deflection_rad))))
    }

    /// Whether its model changes with a pivot (the shoulder, the wrist).
    fn has_pivot_settings(&self) -> bool {
        self.spec.as_ref().is_some_and(|s| s.pivot_settings_mm().len() > 1)
    }

    /// The direction a wrist record deflects along, if it is not the DOF's own axis (section
    /// 3.5.2's 0 deg for q7, 90 deg for q6): `Some(45.0)` for a record along 45 deg, where both
    /// DOFs deflect and the baseline is the table's torque along that direction. A record along
    /// the other DOF's axis, or along several directions, is refused.
    fn diagonal(&self, joint: &str, data: &jointctl_ident::csv::Data, data_file: &Path) -> Result<Option<f64>, String> {
        if !self.spec.as_ref().is_some_and(|s| s.is_two_dof()) {
            return Ok(None);
        }
        let (own, other, other_joint) = if self.dof == 0 { (90.0, 0.0, "q7") } else { (0.0, 90.0, "q6") };
        let mut angles = data.angle_deg.iter().enumerate().filter(|(_, a)| a.is_finite());
        let Some((_, &first)) = angles.next() else { return Ok(None) };
        if let Some((i, a)) = angles.find(|(_, a)| (*a - first).abs() > 0.5) {
            return Err(format!("{}: sample {}: deflection direction {a} deg after {first} deg: identify one direction's record at a time", data_file.display(), i + 1));
        }
        // The table's own axes are 0 deg (q7) and 90 deg (q6), each with its sign: an axis
        // reversed (180, 270 deg) holds the DOF's deflection and torque negated.
        let near = |a: f64| {
            let d = (first - a).rem_euclid(360.0);
            d <= 0.5 || d >= 359.5
        };
        if near(own) {
            Ok(None)
        } else if near(other) {
            Err(format!(
                "{}: deflection direction {first} deg is the other wrist DOF's axis: identify `{other_joint}` from this record (`{joint}` from one along {own} deg)",
                data_file.display()
            ))
        } else if near(own + 180.0) || near(other + 180.0) {
            Err(format!(
                "{}: deflection direction {first} deg is a wrist axis reversed: record q7 along 0 deg and q6 along 90 deg (the table's axes, with their signs)",
                data_file.display()
            ))
        } else {
            Ok(Some(first))
        }
    }
}

/// What a record along a diagonal direction of the wrist says, in the report and its JSON.
fn diagonal_note(angle_deg: f64) -> String {
    format!(
        "a wrist record along {angle_deg} deg deflects both DOFs (q6 by sin, q7 by cos of the direction): the baseline is the table's torque along it, and a cause found here belongs to the pair; the extension is per DOF and is written from records along 90 deg (q6) and 0 deg (q7), and each DOF's torque offset from one record along both 45 and 135 deg"
    )
}

pub fn run_identify(a: IdentifyArgs) -> ExitCode {
    if a.joint.is_some() && a.config.is_none() && !jointctl_record::reader::is_mcap(&a.data) {
        return crate::fail("--joint without --config picks a joint of a recording (.mcap); a CSV file holds one joint");
    }
    let data = match load_data(&a.data, a.joint.as_deref()) {
        Ok(d) => d,
        Err(e) => return crate::fail(e),
    };
    for n in &data.notes {
        eprintln!("note: {n}");
    }
    // A configured joint's model has no eq. 3.5 friction (the joint plugins observe torque from
    // the characteristic alone): friction is then a cause to name, not part of the baseline.
    let baseline_friction = a.config.is_none();
    let configured = match (&a.config, &a.joint) {
        (Some(c), Some(j)) => match configured_joint(c, j) {
            Ok(cj) => Some(cj),
            Err(e) => return crate::fail(e),
        },
        _ => None,
    };
    let mut diagonal = None;
    let mut baseline = match &configured {
        Some(cj) => match cj.baseline() {
            Ok(b) => b,
            Err(e) => return crate::fail(e),
        },
        // Without --config (--joint alone picks a recording's joint): the thesis' structure.
        _ if (1..=6).contains(&a.baseline_order) => BaselineModel::Polynomial(a.baseline_order),
        _ => return crate::fail(format!("--baseline-order must be 1-6, got {}", a.baseline_order)),
    };
    if let Err(e) = settings::fit_the_baseline(&a, configured.as_ref(), &data) {
        return crate::fail(e);
    }
    if let (Some(cj), Some(config), Some(joint)) = (&configured, &a.config, &a.joint) {
        let settings = data.pivot_settings(MIN_SETTING_SAMPLES);
        if let Some(i) = diagonals::first_without_direction(cj, &data) {
            return crate::fail(format!("{}: sample {} (t = {} s): no deflection direction (angle_deg), where the record's other samples have one", a.data.display(), i + 1, data.t[i]));
        }
        // Along both diagonals in one record: each apart, and the torque offset per DOF.
        if let (Some(parts), [first, second]) = (diagonals::pair(cj, &data), cj.dof_names.as_slice()) {
            return diagonals::identify_both(&a, cj, &data, parts, [first, second]);
        }
        diagonal = match cj.diagonal(joint, &data, &a.data) {
            Ok(d) => d,
            Err(e) => return crate::fail(e),
        };
        if let Some(angle) = diagonal {
            if a.out.is_some() {
                return crate::fail(format!("{}: --out is refused: {}", a.data.display(), diagonal_note(angle)));
            }
            if settings.len() >= 2 {
                let listed: Vec<String> = settings.iter().map(|(p, _)| format!("{p:.2}")).collect();
                return crate::fail(format!("{}: {} pivot settings along {angle} deg ({} mm): identify one setting's record at a time along a diagonal", a.data.display(), settings.len(), listed.join(", ")));
            }
            baseline = match cj.baseline_along(angle) {
                Ok(b) => b,
                Err(e) => return crate::fail(e),
            };
        }
        // A record of several pivot settings against a joint with pivot settings: each setting apart.
        if settings.len() >= 2 {
            if !cj.has_pivot_settings() {
                return crate::fail(format!(
                    "{}: {} pivot settings, and `{joint}` in {} has none (its model does not change with a pivot): identify one setting's record",
                    a.data.display(),
                    settings.len(),
                    config.display()
                ));
            }
            return identify_by_pivot(&a, config, joint, cj, &data, settings);
        }
    }
    let spinner = (!a.json).then(|| {
        let s = indicatif::ProgressBar::new_spinner();
        s.set_message(format!("identifying {} samples", data.len()));
        s.enable_steady_tick(std::time::Duration::from_millis(100));
        s
    });
    let result = identify(&data, &IdentifyOptions { baseline, baseline_friction, held_out: a.held_out.into(), ..IdentifyOptions::default() });
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    let report = match result {
        Ok(r) => r,
        Err(e) => return crate::fail(format!("{}: {e}", a.data.display())),
    };
    // With a config: the extension written out for the observer and the simulation, and the
    // gain of each on the held-out part.
    let extension = match (&a.config, &a.joint) {
        (Some(config), Some(joint)) if diagonal.is_none() => match extend(config, joint, &report, &data, split(&a)) {
            Ok(e) => Some(e),
            Err(e) if a.out.is_some() => return crate::fail(format!("cannot write the extension: {e}")),
            // The causes stand without it (a config with no simulated joint): said, not fatal.
            Err(e) => {
                eprintln!("note: no simulation or observer gains: {e}");
                None
            }
        },
        _ => None,
    };
    // A closed-loop recording (set-points and readings of a running arm): the causes in the loop.
    let loop_report = match (&a.config, &a.joint) {
        (Some(config), Some(joint)) if diagonal.is_none() && jointctl_record::reader::is_mcap(&a.data) => match loop_causes(&a.data, config, joint) {
            Ok(r) => Some(r),
            Err(e) => {
                eprintln!("note: no causes in the loop: {e}");
                None
            }
        },
        _ => None,
    };
    let u = &report.unexplained;
    let mut md = format!(
        "# What the model misses: {}\n\n{} samples in {} segment(s), {} dropped as dropouts{}; deflection resolution {:.3e} rad (from its steps). {}{}{}{}\n\n| | held-out torque RMSE [Nm] |\n|---|---|\n| baseline | {:.4} |\n| extended | {:.4} |\n| noise floor (measured) | {:.4} |\n\n",
        a.data.display(),
        report.samples,
        report.segments,
        report.dropped_samples,
        output::left_out_sentence(&report),
        report.resolution_rad,
        split_sentence(&report.held_out_window),
        bins_sentence(report.bin_averages.as_ref()),
        narrow_rate_sentence(report.narrow_rate.as_ref()),
        rest_sentence(report.at_rest.as_ref()),
        report.rmse_before,
        report.rmse_after,
        u.noise_floor_nm
    );
    if let Some(w) = &report.warning {
        eprintln!("warning: {w}");
        let _ = writeln!(md, "**Warning:** {w}.\n");
    }
    // The configured extension's gain along the diagonal; the causes stand without it (a bad
    // extension in the config is said, not fatal, as for the gains along an axis).
    let along_observer = match (diagonal, &configured, &a.config) {
        (Some(angle), Some(cj), Some(config)) => match jointctl_experiments::model_loop::observer_gain_along(&cj.params, angle, &data, split(&a)) {
            Ok(g) => g,
            Err(e) => {
                eprintln!("note: no observer gain along {angle} deg: {}: {e}", config.display());
                None
            }
        },
        _ => None,
    };
    if let Some(angle) = diagonal {
        let _ = writeln!(md, "Direction: {}.\n", diagonal_note(angle));
        if let Some(g) = along_observer {
            let _ = writeln!(md, "The configured wrist observer along {angle} deg, held-out RMSE: {:.4} Nm with the table alone, {:.4} Nm with its model_extension.\n", g.rmse_before, g.rmse_after);
        }
    }
    if let Some(n) = &report.no_spring {
        let _ = writeln!(md, "Read as a friction record: {}.\n", n.note);
    }
    if let Some(dip) = &report.friction_dip {
        let _ = writeln!(md, "The friction: {}; {}.\n", dip.note, dip.evidence);
    }
    let _ = writeln!(
        md,
        "A cause is named when BIC on the training part proposes it, its held-out gain is relevant ({}) and there is evidence for it: a {} at level {} ({} blocks).\n",
        report.significance.relevance, report.significance.test, report.significance.level, report.significance.blocks
    );
    if report.causes.is_empty() {
        let _ = writeln!(md, "{}", output::no_cause_sentence(&report));
    } else {
        md.push_str("| cause | parameters (± standard error) | RMSE gain [Nm] | evidence |\n|---|---|---|---|\n");
        for c in &report.causes {
            let params: Vec<String> = c
                .params
                .iter()
                .map(|(k, v)| match c.uncertainty.get(k) {
                    Some(e) => format!("{k} = {} ± {e:.2e}", jointctl_ident::identify::format_value(*v)),
                    None => format!("{k} = {}", jointctl_ident::identify::format_value(*v)),
                })
                .collect();
            let _ = writeln!(md, "| {} | {} | {:.4} | {} |", c.effect, params.join(", "), c.rmse_gain, c.evidence);
        }
    }
    let _ = writeln!(
        md,
        "\nLeft over: {}. Held-out RMSE by |deflection| (small, middle, large third): {:.4}, {:.4}, {:.4} Nm; by |rate|: {:.4}, {:.4}, {:.4} Nm; by quarter of the time: {:.4}, {:.4}, {:.4}, {:.4} Nm.",
        u.summary, u.by_deflection_nm[0], u.by_deflection_nm[1], u.by_deflection_nm[2], u.by_rate_nm[0], u.by_rate_nm[1], u.by_rate_nm[2], u.by_time_nm[0], u.by_time_nm[1], u.by_time_nm[2], u.by_time_nm[3]
    );
    if !report.confounded.is_empty() {
        let list: Vec<String> = report.confounded.iter().map(|c| format!("{} or {}: {}", c.effect, c.alternative, c.evidence)).collect();
        let _ = writeln!(md, "\nConfounded (for each pair, by which rule the data explain them about as well, and, where it was asked, what the held-out part said): {}.", list.join("; "));
    }
    if let Some(experiment) = &report.experiment {
        let _ = writeln!(md, "\nAn experiment that tells them apart: {}.", experiment.purpose.join("; "));
        if let Some(dir) = a.report.as_ref().or(a.out.as_ref()) {
            let file = dir.join("experiment.yaml");
            let written = std::fs::create_dir_all(dir).map_err(|e| e.to_string()).and_then(|_| serde_yaml::to_string(experiment).map_err(|e| e.to_string())).and_then(|yaml| {
                let header = format!("# Proposed by `jointctl identify --data {}`: run with `jointctl sim record CONFIG --joint J --experiment {}`\n", a.data.display(), file.display());
                std::fs::write(&file, header + &yaml).map_err(|e| e.to_string())
            });
            match written {
                Ok(()) => {
                    let _ = writeln!(md, "Written as {} (run it with `jointctl sim record CONFIG --joint J --experiment {}`, then identify the new record).", file.display(), file.display());
                }
                Err(e) => return crate::fail(format!("cannot write {}: {e}", file.display())),
            }
        }
    }
    if !report.negligible.is_empty() {
        let list: Vec<String> = report.negligible.iter().map(|c| format!("{} ({})", c.effect, c.evidence)).collect();
        let _ = writeln!(md, "\nSignificant but negligible (not named): {}.", list.join(", "));
    }
    if !report.rejected.is_empty() {
        let _ = writeln!(md, "\nRejected (physically impossible, or no evidence on the held-out part): {}.", report.rejected.join(", "));
    }
    if let Some((ext, _)) = &extension {
        md += &gains_table(ext);
    }
    if let Some(l) = &loop_report {
        md += &loop_table(l);
    }
    if let Some((ext, loaded)) = &extension {
        let provenance = format!("by `jointctl identify --data {}`", a.data.display());
        let loop_sim = loop_report.as_ref().map(|l| l.hal_sim()).unwrap_or_default();
        if let Err(e) = write_extension(&a, ext, loaded, &provenance, &loop_sim, &mut md) {
            return crate::fail(e);
        }
    }
    if let Some(dir) = &a.report {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return crate::fail(format!("cannot create {}: {e}", dir.display()));
        }
        let h = &report.held_out;
        let col = |i: usize, j: usize| h.iter().map(|r| (r[i], r[j])).collect::<Vec<_>>();
        let resid = |j: usize, x: usize| h.iter().map(|r| (r[x], r[3] - r[j])).collect::<Vec<_>>();
        let plots: [(&str, &str, &str, &str, Vec<Series>); 4] = [
            ("loop.svg", "torque-deflection loop (held-out part)", "deflection [rad]", "torque [Nm]", vec![
                Series { name: "measured", points: col(1, 3), color: COLORS[0] },
                Series { name: "baseline", points: col(1, 4), color: COLORS[1] },
                Series { name: "extended", points: col(1, 5), color: COLORS[2] },
            ]),
            ("residual-vs-deflection.svg", "residual vs deflection", "deflection [rad]", "residual [Nm]", vec![
                Series { name: "baseline", points: resid(4, 1), color: COLORS[1] },
                Series { name: "extended", points: resid(5, 1), color: COLORS[2] },
            ]),
            ("residual-vs-velocity.svg", "residual vs deflection rate", "deflection rate [rad/s]", "residual [Nm]", vec![
                Series { name: "baseline", points: resid(4, 2), color: COLORS[1] },
                Series { name: "extended", points: resid(5, 2), color: COLORS[2] },
            ]),
            ("torque-vs-time.svg", "torque over time (held-out part)", "t [s]", "torque [Nm]", vec![
                Series { name: "measured", points: col(0, 3), color: COLORS[0] },
                Series { name: "baseline", points: col(0, 4), color: COLORS[1] },
                Series { name: "extended", points: col(0, 5), color: COLORS[2] },
            ]),
        ];
        for (file, title, x, y, series) in plots.iter() {
            if let Err(e) = lines(&dir.join(file), title, x, y, series) {
                return crate::fail_err(e);
            }
            let _ = writeln!(md, "\n![{title}]({file})");
        }
        if let Err(e) = std::fs::write(dir.join("report.md"), &md) {
            return crate::fail(format!("cannot write the report: {e}"));
        }
    }
    if a.json {
        let mut json = serde_json::to_value(&report).unwrap_or_default();
        let mut gains = serde_json::json!({"static": Gain { rmse_before: report.rmse_before, rmse_after: report.rmse_after }});
        if let Some((ext, _)) = &extension {
            gains["simulation"] = serde_json::json!(ext.simulation);
            gains["observer"] = serde_json::json!(ext.observer);
            json["extension"] = extension_json(ext);
        }
        json["gains"] = gains;
        if let Some(angle) = diagonal {
            json["direction"] = serde_json::json!({"angle_deg": angle, "note": diagonal_note(angle)});
            if let Some(g) = along_observer {
                json["direction"]["observer"] = serde_json::json!({"rmse_table": g.rmse_before, "rmse_extended": g.rmse_after});
            }
        }
        if let Some(l) = &loop_report {
            json["loop"] = serde_json::json!({"values": l.values, "notes": l.notes, "hal_sim": l.hal_sim()});
        }
        outln!("{json}");
    } else {
        out!("{md}");
    }
    ExitCode::SUCCESS
}

/// The samples a pivot setting's hold needs to count as a setting (an assumption: identify's own
/// minimum excitation is checked per setting; a shorter hold is the pivot in transit between two
/// settings, see [`jointctl_ident::csv::Data::pivot_settings`]).
const MIN_SETTING_SAMPLES: usize = 200;

/// `identify` on a record of several pivot settings (the shoulder q2, issue 32): each setting
/// identified apart against the configured table at that setting, and one extension whose terms
/// are given `by_pivot`, weighted at the joint's pivot online.
fn identify_by_pivot(a: &IdentifyArgs, config: &Path, joint: &str, configured: &ConfiguredJoint, data: &jointctl_ident::csv::Data, settings: Vec<(f64, Vec<usize>)>) -> ExitCode {
    let mut md = format!(
        "# What the model misses, per pivot setting: {}

{} samples at {} pivot settings, each identified apart (its first 70 % of time fitted and its last 30 % scored, or, where that part moves unlike the rest, a window like the rest: each setting's line says which).

| pivot [mm] | samples | baseline [Nm] | extended [Nm] | noise floor [Nm] | causes |
|---|---|---|---|---|---|
",
        a.data.display(),
        data.len(),
        settings.len()
    );
    let mut reports = Vec::new();
    let mut found = Vec::new();
    for (pivot_mm, samples) in &settings {
        let baseline = match configured.baseline() {
            Ok(b) => b,
            Err(e) => return crate::fail(e),
        };
        let report = match identify(&data.subset(samples), &IdentifyOptions { baseline, baseline_friction: false, held_out: a.held_out.into(), ..IdentifyOptions::default() }) {
            Ok(r) => r,
            Err(e) => return crate::fail(format!("{} at pivot {pivot_mm:.2} mm: {e}", a.data.display())),
        };
        let _ = writeln!(
            md,
            "| {pivot_mm:.2} | {} | {:.4} | {:.4} | {:.4} | {} |",
            samples.len(),
            report.rmse_before,
            report.rmse_after,
            report.unexplained.noise_floor_nm,
            output::causes_cell(&report)
        );
        if let Some(why) = &report.held_out_window.moved {
            let _ = writeln!(md, "|  |  |  |  |  | at {pivot_mm:.2} mm {why} |");
        }
        found.push(jointctl_experiments::model_loop::SettingFound {
            pivot_mm: *pivot_mm,
            samples: samples.clone(),
            found: report.causes.iter().map(|c| Found { effect: c.effect.clone(), plant: c.fragments.plant.clone(), observer: c.fragments.observer.clone() }).collect(),
        });
        reports.push((*pivot_mm, report));
    }
    let loaded = match jointctl_config::load(config) {
        Ok(l) => l,
        Err(e) => return crate::fail(e.to_string()),
    };
    let ext = match jointctl_experiments::model_loop::extend_by_pivot(&loaded, joint, &found, data, split(a)) {
        Ok(e) => Some(e),
        Err(e) if a.out.is_some() => return crate::fail(format!("cannot write the extension: {}: {e}", config.display())),
        // The causes stand without it (a config with no simulated joint): said, not fatal.
        Err(e) => {
            eprintln!("note: no simulation or observer gains: {}: {e}", config.display());
            None
        }
    };
    if let Some(ext) = &ext {
        md += &gains_table(ext);
    }
    if let Some(ext) = &ext {
        let provenance = format!("by `jointctl identify --data {}` (per pivot setting)", a.data.display());
        if let Err(e) = write_extension(a, ext, &loaded, &provenance, &Default::default(), &mut md) {
            return crate::fail(e);
        }
    }
    if let Err(e) = output::write_report_md(a, &md) {
        return crate::fail(e);
    }
    if a.json {
        let settings: Vec<serde_json::Value> = reports
            .iter()
            .map(|(pivot_mm, r)| {
                let mut v = output::part_json(r, "pivot_mm", *pivot_mm);
                // The extension's gains on what this setting held out.
                if let Some(g) = ext.as_ref().and_then(|e| e.by_setting.iter().find(|g| g.pivot_mm == *pivot_mm)) {
                    v["gains"] = serde_json::json!({"simulation": g.simulation, "observer": g.observer});
                }
                v
            })
            .collect();
        let mut json = serde_json::json!({"settings": settings});
        if let Some(ext) = &ext {
            json["gains"] = serde_json::json!({"simulation": ext.simulation, "observer": ext.observer});
            json["extension"] = extension_json(ext);
        }
        outln!("{json}");
    } else {
        out!("{md}");
    }
    ExitCode::SUCCESS
}

/// The split identify used: the model loop's gains are measured on what it held out.
fn split(a: &IdentifyArgs) -> jointctl_experiments::model_loop::Split {
    jointctl_experiments::model_loop::Split { held_out: a.held_out.into(), ..jointctl_experiments::model_loop::Split::of(&IdentifyOptions::default()) }
}
