//! `jointctl identify` from Rust: what the model gets wrong on a measured record.
//!
//! `cargo run --example identify_from_rust [FILE.csv]`
//!
//! Default: `tests/data/q4_worn_elbow.csv`, an elbow characterisation whose plant has a Dahl
//! hysteresis the thesis' linear model lacks (see `tests/data/README.md`). Columns `t` [s],
//! `deflection` [rad], `torque` [Nm].

use jointctl_ident::identify::{IdentifyOptions, identify};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args_os().nth(1).map_or_else(|| jointctl_examples::repository().join("tests/data/q4_worn_elbow.csv"), Into::into);
    let data = jointctl_ident::csv::read(&path)?;
    // The thesis' structure as the baseline: a line through zero and eq. 3.5's friction.
    let report = identify(&data, &IdentifyOptions::default())?;
    println!("{}: {} samples, held-out RMSE {:.4} Nm with the baseline, {:.4} Nm with the causes", path.display(), report.samples, report.rmse_before, report.rmse_after);
    if report.causes.is_empty() {
        println!("no cause found");
    }
    for cause in &report.causes {
        let params: Vec<String> = cause.params.iter().map(|(k, v)| format!("{k} = {v:.4}")).collect();
        println!("  {:<24} gain {:.4} Nm  {}", cause.effect, cause.rmse_gain, params.join(", "));
    }
    for pair in &report.confounded {
        println!("  cannot tell `{}` from `{}`: {}", pair.effect, pair.alternative, pair.evidence);
    }
    Ok(())
}
