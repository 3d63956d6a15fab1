//! What identify's per-part commands (per pivot setting, per diagonal) write: the Markdown
//! report into `--report`'s folder, each part's causes in its table, and each part's report as
//! JSON with what tells it apart.

use super::IdentifyArgs;

/// Writes `md` as `report.md` into `--report`'s folder, when one is given.
pub(super) fn write_report_md(a: &IdentifyArgs, md: &str) -> Result<(), String> {
    let Some(dir) = &a.report else { return Ok(()) };
    std::fs::create_dir_all(dir).and_then(|_| std::fs::write(dir.join("report.md"), md)).map_err(|e| format!("cannot write the report: {e}"))
}

/// One part's report as JSON, with `key` (its pivot setting, its direction) set to `value`.
pub(super) fn part_json(report: &jointctl_ident::identify::Report, key: &str, value: f64) -> serde_json::Value {
    let mut v = serde_json::to_value(report).unwrap_or_default();
    v[key] = serde_json::json!(value);
    v
}

/// A part's causes in one table cell: each with its parameters, or `none`.
pub(super) fn causes_cell(report: &jointctl_ident::identify::Report) -> String {
    let causes: Vec<String> = report
        .causes
        .iter()
        .map(|c| {
            let params: Vec<String> = c.params.iter().map(|(k, v)| format!("{k} {v:.4}")).collect();
            format!("{} ({})", c.effect, params.join(", "))
        })
        .collect();
    if causes.is_empty() { "none".into() } else { causes.join("; ") }
}

/// What else was left out before fitting, for the report's first sentence: the deflection's
/// glitches, the samples at the torque sensor's limit and those after pauses, each when there are any.
pub(super) fn left_out_sentence(report: &jointctl_ident::identify::Report) -> String {
    let mut s = String::new();
    if report.glitch_samples > 0 {
        s += &format!(", {} deflection readings left out as glitches (a leap away and back within {} samples, farther than the encoder's resolution, its noise and the motion explain)", report.glitch_samples, jointctl_ident::identify::prepare::MAX_GLITCH_SAMPLES);
    }
    if report.saturated_samples > 0 {
        s += &format!(", {} at the torque sensor's limit (saturated: the sensor past its range) left out", report.saturated_samples);
    }
    if report.after_pauses.samples > 0 {
        s += &format!(", {} after pauses longer than the motion's strokes left out up to its next turn (no model knows a loop's state there)", report.after_pauses.samples);
    }
    s
}

/// The sentence of a report without causes. A friction record's extended model holds the
/// friction's parts its reading found (a Dahl pre-sliding, a Stribeck dip, a lag: part of the
/// friction, not causes), as a spring record's holds its friction's Stribeck dip, so its
/// held-out error, which `unexplained` measures, is not the baseline's there, and the sentence
/// says whose it is.
pub(super) fn no_cause_sentence(report: &jointctl_ident::identify::Report) -> String {
    let u = &report.unexplained;
    let parts: Vec<&str> = report
        .no_spring
        .iter()
        .flat_map(|n| [(!n.presliding.is_empty()).then_some("Dahl pre-sliding"), (!n.stribeck.is_empty()).then_some("Stribeck dip"), (!n.lag.is_empty()).then_some("lag")])
        .flatten()
        .chain(report.friction_dip.as_ref().map(|_| "Stribeck dip"))
        .collect();
    let parts = match parts.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => parts.join(""),
    };
    let with_parts = !parts.is_empty() && report.rmse_after != report.rmse_before;
    match (u.times_noise > jointctl_ident::identify::FAR_ABOVE_NOISE, with_parts) {
        (true, false) => "No listed cause explains what the baseline leaves.".into(),
        (true, true) => format!("No listed cause explains what the baseline and the friction's {parts} leave."),
        (false, false) => format!("No cause found; the baseline's held-out error is {:.1} times the noise floor.", u.times_noise),
        (false, true) => format!(
            "No cause found; with the friction's {parts} read above, the held-out error is {:.1} times the noise floor (the baseline's alone {:.1} times).",
            u.times_noise,
            report.rmse_before / u.noise_floor_nm
        ),
    }
}
