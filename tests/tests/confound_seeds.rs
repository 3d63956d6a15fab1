//! Confounded pairs on the elbow, seed by seed (issue 32): a plant holds one cause of a pair whose
//! other cause explains a one-frequency characterisation about as well; the first `identify`
//! should report the pair as confounded and propose an experiment; on the experiment's record the
//! second `identify` should name the cause the plant holds and not the other.
//!
//! The pairs: a stiffening cubic against a play, eq. 3.5's arctan friction against Dahl
//! hysteresis, Dahl hysteresis against viscous friction. Even seeds hide the pair's first cause,
//! odd seeds its second, at the sizes of `model_loop/`'s draws (a few per cent to a tenth of
//! the characterisation's ~11 Nm).
//!
//! A campaign, not a gate: it runs two simulated records and two identifications per case, and
//! prints a table per pair (the figures in `docs/model-loop.md`). Run it with
//! `cargo build --release --workspace && cargo test --release -p jointctl-tests --test
//! confound_seeds -- --ignored --nocapture`; `JOINTCTL_CONFOUND_SEEDS=1,2,...` picks the seeds
//! (default 1-10), `JOINTCTL_CONFOUND_SCALE` scales the effects (default 1), and
//! `JOINTCTL_CONFOUND_KEEP=1` keeps each case's records and configs in the temporary folder.

use std::path::Path;
use std::process::Command;

use jointctl_sim::rng::SplitMix64;
use jointctl_tests::{Edit, arm_name, jointctl, scratch, sherpa_with};
use serde_yaml::Value;

/// Draws one side of a pair: the plant's `sim.effects` YAML.
type Draw = fn(&mut SplitMix64) -> String;

/// One side of a pair: the cause `identify` must name, and how the plant's effect is drawn.
type Side = (&'static str, Draw);

/// A draw between `lo` and `hi`, times the campaign's scale (`JOINTCTL_CONFOUND_SCALE`, 1 by
/// default: smaller effects are nearer the noise, where a pair is more often confounded).
fn u(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    let scale: f64 = std::env::var("JOINTCTL_CONFOUND_SCALE").ok().and_then(|s| s.parse().ok()).unwrap_or(1.0);
    scale * (lo + (hi - lo) * rng.uniform())
}

fn cubic(rng: &mut SplitMix64) -> String {
    format!("cubic_nm_per_rad3: {:.0}", u(rng, 300.0, 900.0))
}
fn play(rng: &mut SplitMix64) -> String {
    format!("dead_zone_rad: {:.5}", u(rng, 0.006, 0.015))
}
fn arctan(rng: &mut SplitMix64) -> String {
    format!("arctan_friction: {{k_a_nm: {:.3}, k_b_s_per_rad: 50.0}}", u(rng, 0.2, 0.5))
}
fn dahl(rng: &mut SplitMix64) -> String {
    format!("hysteresis: {{sigma_nm_per_rad: {:.0}, limit_nm: {:.3}}}", 150.0 + 250.0 * rng.uniform(), u(rng, 0.4, 1.2))
}
fn viscous(rng: &mut SplitMix64) -> String {
    format!("viscous_nms_per_rad: {:.3}", u(rng, 2.0, 6.0))
}

/// The pairs, each with a short label (arm names are at most 32 characters).
const PAIRS: [(&str, Side, Side); 3] = [
    ("cubic-play", ("stiffness_nonlinearity", cubic), ("dead_zone", play)),
    ("atan-dahl", ("coulomb_friction", arctan), ("hysteresis", dahl)),
    ("dahl-visc", ("hysteresis", dahl), ("viscous_friction", viscous)),
];

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{cmd:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn identify(csv: &Path, config: &Path, report: Option<&Path>) -> serde_json::Value {
    let mut cmd = Command::new(jointctl());
    cmd.args(["identify", "--data"]).arg(csv).arg("--config").arg(config).args(["--joint", "q4", "--json"]);
    if let Some(dir) = report {
        cmd.arg("--report").arg(dir);
    }
    serde_json::from_str(&run_ok(&mut cmd)).unwrap()
}

fn named(json: &serde_json::Value) -> Vec<String> {
    json["causes"].as_array().unwrap().iter().map(|c| c["effect"].as_str().unwrap().to_string()).collect()
}

/// Is the pair `a`, `b` among the report's confounds (either way round)?
fn reports_pair(json: &serde_json::Value, a: &str, b: &str) -> bool {
    json["confounded"].as_array().unwrap().iter().any(|c| (c["effect"] == a && c["alternative"] == b) || (c["effect"] == b && c["alternative"] == a))
}

/// What one case came to.
struct Case {
    confound_reported: bool,
    /// Named the hidden cause and not the other: after the experiment when one was proposed,
    /// else on the first record.
    resolved: bool,
}

fn case(label: &str, seed: u64, hidden: Side, other: &str) -> Case {
    let mut rng = SplitMix64(seed ^ 0xc0f0_0000 ^ label.len() as u64);
    let effect = (hidden.1)(&mut rng);
    let name = format!("cf-{label}-{seed}");
    let arm = arm_name(&name);
    let edits = |effects: &str| {
        let effects: Value = serde_yaml::from_str(&format!("{{torque_noise_nm: 0.01, {effects}}}")).unwrap();
        vec![
            Edit::Set("joints[q4].sim.effects", effects),
            Edit::Remove("joints[q4].params.include"),
            Edit::Set("joints[q4].params.stiffness_nm_per_rad", 113.78.into()),
        ]
    };
    let config = sherpa_with(&format!("{name}-c"), &arm, &edits(""));
    let plant = sherpa_with(&format!("{name}-p"), &arm, &edits(&effect));
    let work = scratch(&format!("{name}-w"));
    let first = work.join("first.csv");
    run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&first).args([
        "--amplitude",
        "0.0967",
        "--frequency",
        "0.25",
        "--duration",
        "80",
        "--rate",
        "200",
    ]));
    let report = work.join("report");
    let json = identify(&first, &config, Some(&report));
    let confound_reported = reports_pair(&json, hidden.0, other);
    let experiment = report.join("experiment.yaml");
    let (second, last) = if experiment.is_file() {
        let csv = work.join("experiment.csv");
        run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&csv).arg("--experiment").arg(&experiment).args(["--rate", "200"]));
        let again = identify(&csv, &config, None);
        (Some(named(&again)), named(&again))
    } else {
        (None, named(&json))
    };
    let resolved = last.iter().any(|c| c == hidden.0) && !last.iter().any(|c| c == other);
    println!(
        "{label} seed {seed}: hidden {{{effect}}}; first {:?}, confounds {}; after the experiment {:?}; {}",
        named(&json),
        json["confounded"],
        second,
        if resolved { "resolved" } else { "not resolved" }
    );
    if std::env::var_os("JOINTCTL_CONFOUND_KEEP").is_none() {
        let _ = std::fs::remove_dir_all(&work);
    }
    Case { confound_reported, resolved }
}

#[test]
#[ignore = "a campaign of 60 simulated records and identifications; see the module's doc"]
fn confounded_pairs_are_reported_and_resolved_by_the_proposed_experiment() {
    let seeds: Vec<u64> = std::env::var("JOINTCTL_CONFOUND_SEEDS").ok().map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect()).unwrap_or_else(|| (1..=10).collect());
    let mut table = Vec::new();
    for (label, a, b) in PAIRS {
        let cases: Vec<Case> = seeds.iter().map(|&s| if s.is_multiple_of(2) { case(label, s, a, b.0) } else { case(label, s, b, a.0) }).collect();
        let reported = cases.iter().filter(|c| c.confound_reported).count();
        let resolved = cases.iter().filter(|c| c.resolved).count();
        table.push(format!("{} vs {}: confound reported in {reported} of {}, the hidden cause named alone at the end in {resolved} of {}", a.0, b.0, cases.len(), cases.len()));
    }
    println!("{}", table.join("\n"));
}
