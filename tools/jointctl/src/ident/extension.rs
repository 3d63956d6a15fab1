//! The extended model identify writes: the extension of a joint from the report's causes, its
//! files, gains table and plots.

use std::fmt::Write as _;
use std::path::Path;

use jointctl_experiments::plot::{COLORS, Series, lines};
use jointctl_experiments::model_loop::{Extension, Found};
use jointctl_ident::identify::Report;

use super::IdentifyArgs;

/// The extension of `joint` in `config` from the report's causes, with the config it extends.
pub(super) fn extend(config: &Path, joint: &str, report: &Report, data: &jointctl_ident::csv::Data, split: jointctl_experiments::model_loop::Split) -> Result<(Extension, jointctl_config::LoadedConfig), String> {
    let loaded = jointctl_config::load(config).map_err(|e| e.to_string())?;
    let found: Vec<Found> = report.causes.iter().map(|c| Found { effect: c.effect.clone(), plant: c.fragments.plant.clone(), observer: c.fragments.observer.clone() }).collect();
    let ext = jointctl_experiments::model_loop::extend(&loaded, joint, &found, data, split).map_err(|e| format!("{}: {e}", config.display()))?;
    Ok((ext, loaded))
}

/// The causes in the loop of `joint` in the closed-loop recording `data`.
pub(super) fn loop_causes(data: &Path, config: &Path, joint: &str) -> Result<jointctl_experiments::loop_causes::LoopReport, String> {
    let loaded = jointctl_config::load(config).map_err(|e| e.to_string())?;
    let rec = jointctl_experiments::loop_causes::read(data, &loaded, joint).map_err(|e| e.to_string())?;
    Ok(jointctl_experiments::loop_causes::identify_loop(&rec, &loaded))
}

/// The loop's values as a Markdown table.
pub(super) fn loop_table(l: &jointctl_experiments::loop_causes::LoopReport) -> String {
    let mut md = String::from("\n## In the loop (closed-loop recording)\n\nFitted on the first 70 %, scored on the rest; a cause when the identified value explains the held-out part better than the configured one (block t-test of log RMSE ratios).\n\n| value | key | identified | configured | held-out RMSE configured | identified | t (critical) | cause |\n|---|---|---|---|---|---|---|---|\n");
    for v in &l.values {
        let _ = writeln!(md, "| {} | `{}` | {:.4} | {:.4} | {:.4e} | {:.4e} | {:.1} ({:.1}) | {} |", v.name, v.key, v.value, v.configured, v.rmse_configured, v.rmse_identified, v.t, v.critical, if v.cause { "yes" } else { "no" });
    }
    for n in &l.notes {
        let _ = writeln!(md, "- {n}");
    }
    md
}

/// The extension in `--json`: the observer's terms, the plant's effects and the notes, and the
/// joint's other DOFs whose effects change too (the wrist's split offsets), each by name, with
/// `plant_dof` naming the DOF of `plant`.
pub(super) fn extension_json(ext: &Extension) -> serde_json::Value {
    let mut json = serde_json::json!({"observer": ext.observer_params.get("model_extension"), "plant": ext.plant_effects.to_json(), "plant_causes": ext.plant_causes, "notes": ext.notes});
    if !ext.other_dofs.is_empty() {
        json["plant_dof"] = serde_json::json!(ext.dof);
        json["plant_other_dofs"] = ext.other_dofs.iter().map(|o| serde_json::json!({"dof": o.dof, "plant": o.effects.to_json()})).collect();
    }
    json
}

/// The extension's files (`--out`) and gain plots (`--report`, else `--out`), each said in `md`.
pub(super) fn write_extension(a: &IdentifyArgs, ext: &Extension, loaded: &jointctl_config::LoadedConfig, provenance: &str, loop_sim: &serde_json::Map<String, serde_json::Value>, md: &mut String) -> Result<(), String> {
    if let Some(dir) = &a.out {
        let w = jointctl_experiments::model_loop::write(ext, loaded, dir, provenance, loop_sim).map_err(|e| e.to_string())?;
        let _ = writeln!(md, "\nWritten: {} (the joint's params), {} (its simulated plant's effects), {} (the config with both).", w.observer.display(), w.plant.display(), w.extended.display());
        if let Some(l) = &w.loop_sim {
            let _ = writeln!(md, "The loop's `hal.sim` values: {} (also in the extended config).", l.display());
        }
    }
    if let Some(dir) = a.report.as_ref().or(a.out.as_ref()) {
        for (title, file) in gain_plots(dir, ext)? {
            let _ = writeln!(md, "\n![{title}]({file})");
        }
    }
    Ok(())
}

/// The gains as a Markdown table, with what was left out and why.
pub(super) fn gains_table(ext: &Extension) -> String {
    let mut md = String::from("\n## Gains on the held-out part\n\n| | before [Nm] | after [Nm] | gain |\n|---|---|---|---|\n");
    for (name, g) in [("simulation (replayed along the recorded motion, vs F/T)", ext.simulation), ("observer (recorded deflections, vs F/T)", ext.observer)] {
        let _ = writeln!(md, "| {name} | {:.4} | {:.4} | {:.0} % |", g.rmse_before, g.rmse_after, 100.0 * g.relative());
    }
    if !ext.by_setting.is_empty() {
        md += "\nAt each pivot setting, on what its identification held out:\n\n| pivot [mm] | simulation before [Nm] | after [Nm] | gain | observer before [Nm] | after [Nm] | gain |\n|---|---|---|---|---|---|---|\n";
        for g in &ext.by_setting {
            let (s, o) = (g.simulation, g.observer);
            let _ = writeln!(md, "| {:.2} | {:.4} | {:.4} | {:.0} % | {:.4} | {:.4} | {:.0} % |", g.pivot_mm, s.rmse_before, s.rmse_after, 100.0 * s.relative(), o.rmse_before, o.rmse_after, 100.0 * o.relative());
        }
    }
    let taken = if ext.plant_causes.is_empty() { "none".to_string() } else { ext.plant_causes.join(", ") };
    let _ = writeln!(md, "\nInto the simulation: {taken}.");
    for n in &ext.notes {
        let _ = writeln!(md, "- {n}");
    }
    md
}

/// What an extension's plots are of: its DOF, or its joint's DOFs when others changed too (the
/// wrist's offsets split from its diagonals: the torque along each).
fn subject(ext: &Extension) -> String {
    if ext.other_dofs.is_empty() {
        return ext.dof.clone();
    }
    let mut dofs: Vec<&str> = std::iter::once(ext.dof.as_str()).chain(ext.other_dofs.iter().map(|o| o.dof.as_str())).collect();
    dofs.sort_unstable();
    format!("{} (torque along the diagonals)", dofs.join(" and "))
}

/// Which held-out part the plots show: one, or each diagonal's in turn.
fn held_out_part(ext: &Extension) -> &'static str {
    if ext.other_dofs.is_empty() { "held-out part" } else { "held-out parts, 45 then 135 deg" }
}

/// One plot per side: the held-out F/T torque with the configured and the extended model.
pub(super) fn gain_plots(dir: &Path, ext: &Extension) -> Result<Vec<(String, String)>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for (side, trace, g) in [("simulation", &ext.simulation_trace, ext.simulation), ("observer", &ext.observer_trace, ext.observer)] {
        let pick = |v: &[f64]| trace.t_s.iter().zip(v).filter(|(_, y)| y.is_finite()).map(|(t, y)| (*t, *y)).collect::<Vec<_>>();
        let title = format!("{} {side} vs F/T, {} (RMSE {:.4} -> {:.4} Nm)", subject(ext), held_out_part(ext), g.rmse_before, g.rmse_after);
        let file = format!("gain-{side}.svg");
        lines(&dir.join(&file), &title, "t [s]", "torque [Nm]", &[
            Series { name: "F/T sensor", points: pick(&trace.measured_nm), color: COLORS[0] },
            Series { name: "configured", points: pick(&trace.before_nm), color: COLORS[1] },
            Series { name: "extended", points: pick(&trace.after_nm), color: COLORS[2] },
        ])
        .map_err(|e| e.to_string())?;
        files.push((title, file));
    }
    Ok(files)
}
