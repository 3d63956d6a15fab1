//! Confounded pairs on the elbow, seed by seed (issue 32): a plant holds one cause of a pair whose
//! other cause explains a one-frequency characterisation about as well; the first `identify`
//! should report the pair as confounded and propose an experiment; on the experiment's record the
//! second `identify` should name the cause the plant holds and not the other.
//!
//! The pairs: a stiffening cubic against a play, eq. 3.5's arctan friction against Dahl
//! hysteresis, Dahl hysteresis against viscous friction. Even seeds hide the pair's first cause,
//! odd seeds its second, at the sizes of `model_loop/`'s draws (a few per cent to a tenth of
//! the characterisation's ~11 Nm). A fourth pair, eq. 3.5's arctan nearly straight against a
//! viscous friction, is identified against the thesis' baseline (its arctan fitted, no config)
//! on a slower, noisier record (0.05 rad, 0.1 Nm of noise), where the two are one line: a
//! viscous friction beside a small sharp arctan, or a straight arctan alone, which the
//! baseline's arctan is (nothing named is the answer).
//!
//! A campaign, not a gate: it runs two simulated records and two identifications per case, and
//! prints a table per pair (the figures in `docs/model-loop.md`). Run it with
//! `cargo build --release --workspace && cargo test --release -p jointctl-tests --test
//! confound_seeds -- --ignored --nocapture`; `JOINTCTL_CONFOUND_SEEDS=1,2,...` picks the seeds
//! (default 1-10), `JOINTCTL_CONFOUND_PAIRS=atan-visc,...` picks the pairs by label (default
//! all), `JOINTCTL_CONFOUND_SCALE` scales the effects (default 1), `JOINTCTL_CONFOUND_NOISE_NM`
//! sets the plant's torque noise [Nm] for every pair (default each pair's own), and
//! `JOINTCTL_CONFOUND_KEEP=1` keeps each case's records and configs in the temporary folder.

use std::path::Path;
use std::process::Command;

use jointctl_sim::rng::SplitMix64;
use jointctl_tests::{Edit, arm_name, jointctl, run_ok, scratch, sherpa_with};
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
/// A viscous friction beside a small arctan that saturates within the slow record's rates.
fn viscous_beside_arctan(rng: &mut SplitMix64) -> String {
    format!("viscous_nms_per_rad: {:.3}, arctan_friction: {{k_a_nm: {:.3}, k_b_s_per_rad: {:.1}}}", u(rng, 2.0, 6.0), u(rng, 0.02, 0.05), 30.0 + 30.0 * rng.uniform())
}
/// An arctan nearly straight over the slow record's rates (`k_b` times its 0.079 rad/s peak
/// 0.4-1.2).
fn straight_arctan(rng: &mut SplitMix64) -> String {
    format!("arctan_friction: {{k_a_nm: {:.3}, k_b_s_per_rad: {:.1}}}", u(rng, 0.3, 0.8), 5.0 + 10.0 * rng.uniform())
}

/// How a pair is characterised: the sine's amplitude [rad], the plant's torque noise [Nm], and
/// whether identify runs against the config (the observer's line) or the thesis' baseline.
struct Characterisation {
    amplitude_rad: f64,
    noise_nm: f64,
    against_config: bool,
}

/// `model_loop.rs`'s characterisation.
const USUAL: Characterisation = Characterisation { amplitude_rad: 0.0967, noise_nm: 0.01, against_config: true };
/// Slower and noisier, against the thesis' baseline (its arctan fitted).
const SLOW: Characterisation = Characterisation { amplitude_rad: 0.05, noise_nm: 0.1, against_config: false };

/// The pairs, each with a short label (arm names are at most 32 characters).
/// The fourth pair's arctan side is the baseline's own arctan: named as `coulomb_friction` only
/// against a config without one.
const PAIRS: [(&str, Side, Side, &Characterisation); 4] = [
    ("cubic-play", ("stiffness_nonlinearity", cubic), ("dead_zone", play), &USUAL),
    ("atan-dahl", ("coulomb_friction", arctan), ("hysteresis", dahl), &USUAL),
    ("dahl-visc", ("hysteresis", dahl), ("viscous_friction", viscous), &USUAL),
    ("atan-visc", ("viscous_friction", viscous_beside_arctan), ("coulomb_friction", straight_arctan), &SLOW),
];

fn identify(csv: &Path, config: Option<&Path>, report: Option<&Path>) -> serde_json::Value {
    let mut cmd = Command::new(jointctl());
    cmd.args(["identify", "--data"]).arg(csv).arg("--json");
    if let Some(config) = config {
        cmd.arg("--config").arg(config).args(["--joint", "q4"]);
    }
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
    /// Named the hidden cause and not the other (for the baseline's own arctan, hidden against
    /// the thesis' baseline: the other not named and the pair no longer reported): after the
    /// experiment when one was proposed, else on the first record.
    resolved: bool,
}

fn case(label: &str, seed: u64, hidden: Side, other: &str, how: &Characterisation) -> Case {
    let mut rng = SplitMix64(seed ^ 0xc0f0_0000 ^ label.len() as u64);
    let effect = (hidden.1)(&mut rng);
    let name = format!("cf-{label}-{seed}");
    let arm = arm_name(&name);
    // A noisier record hides what tells a pair apart (`JOINTCTL_CONFOUND_NOISE_NM`).
    let noise_nm: f64 = std::env::var("JOINTCTL_CONFOUND_NOISE_NM").ok().and_then(|s| s.parse().ok()).unwrap_or(how.noise_nm);
    let edits = |effects: &str| {
        let effects: Value = serde_yaml::from_str(&format!("{{torque_noise_nm: {noise_nm}, {effects}}}")).unwrap();
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
        &how.amplitude_rad.to_string(),
        "--frequency",
        "0.25",
        "--duration",
        "80",
        "--rate",
        "200",
    ]));
    let report = work.join("report");
    let against = how.against_config.then_some(config.as_path());
    let json = identify(&first, against, Some(&report));
    let confound_reported = reports_pair(&json, hidden.0, other);
    let experiment = report.join("experiment.yaml");
    let again = experiment.is_file().then(|| {
        let csv = work.join("experiment.csv");
        run_ok(Command::new(jointctl()).args(["sim", "record"]).arg(&plant).args(["--joint", "q4", "--out"]).arg(&csv).arg("--experiment").arg(&experiment).args(["--rate", "200"]));
        identify(&csv, against, None)
    });
    let second = again.as_ref().map(named);
    let last_json = again.as_ref().unwrap_or(&json);
    let last = named(last_json);
    // Against the thesis' baseline eq. 3.5's friction is the baseline's: hidden, it is found when
    // nothing stands in its place (the other cause not named, the pair no longer reported).
    let baselines = !how.against_config && hidden.0 == "coulomb_friction";
    let resolved = (baselines || last.iter().any(|c| c == hidden.0)) && !last.iter().any(|c| c == other) && !(baselines && reports_pair(last_json, hidden.0, other));
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
#[ignore = "a campaign of 80 simulated records and identifications; see the module's doc"]
fn confounded_pairs_are_reported_and_resolved_by_the_proposed_experiment() {
    let seeds: Vec<u64> = std::env::var("JOINTCTL_CONFOUND_SEEDS").ok().map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect()).unwrap_or_else(|| (1..=10).collect());
    let mut table = Vec::new();
    let picked: Option<Vec<String>> = std::env::var("JOINTCTL_CONFOUND_PAIRS").ok().map(|s| s.split(',').map(|x| x.trim().to_string()).collect());
    for (label, a, b, how) in PAIRS {
        if picked.as_ref().is_some_and(|p| !p.iter().any(|x| x == label)) {
            continue;
        }
        let cases: Vec<Case> = seeds.iter().map(|&s| if s.is_multiple_of(2) { case(label, s, a, b.0, how) } else { case(label, s, b, a.0, how) }).collect();
        let reported = cases.iter().filter(|c| c.confound_reported).count();
        let resolved = cases.iter().filter(|c| c.resolved).count();
        table.push(format!("{} vs {}: confound reported in {reported} of {}, the hidden cause named alone at the end in {resolved} of {}", a.0, b.0, cases.len(), cases.len()));
    }
    println!("{}", table.join("\n"));
}
