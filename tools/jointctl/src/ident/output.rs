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
/// glitches and the samples at the torque sensor's limit, each when there are any.
pub(super) fn left_out_sentence(report: &jointctl_ident::identify::Report) -> String {
    let mut s = String::new();
    if report.glitch_samples > 0 {
        s += &format!(", {} deflection readings left out as glitches (a leap away and back within {} samples, farther than the encoder's resolution, its noise and the motion explain)", report.glitch_samples, jointctl_ident::identify::prepare::MAX_GLITCH_SAMPLES);
    }
    if report.saturated_samples > 0 {
        s += &format!(", {} at the torque sensor's limit (saturated: the sensor past its range) left out", report.saturated_samples);
    }
    s
}
