//! `identify` on records it was not developed on: the blind generator (`tests/blind-gen`,
//! written without reading this crate) makes characterisation records from the thesis' set-up
//! and published friction and hysteresis models that the cause library does not fit exactly
//! (LuGre, Bouc-Wen, Stribeck, ramped backlash, filtered delays), some with real loggers' traits
//! (irregular steps and gaps, epoch time, repetitions whose time restarts, 17-bit and 2e-6 rad
//! encoders, 20 Hz bins, friction records whose deflection column is a position).
//!
//! Every record goes through the CSV reader, as a user's file would. The figures are printed
//! per effect and per variant; the test holds the engine to what it reaches today on this
//! generator, so that a change that worsens it fails here (issue 31 asks for 95 % named, at most
//! 1 false cause in 20 clean records and 90 % of parameters within tolerance: docs/benchmarks.md
//! says how far each source is).

use std::collections::{BTreeMap, BTreeSet};

use jointctl_blind_gen::{Case, device_variants, suite};
use jointctl_ident::identify::prepare::HeldOut;
use jointctl_ident::identify::{IdentifyOptions, identify};

mod through_the_reader;

/// What identify named in a case, with the parameters, or why it refused the file.
type Outcome = Result<Vec<(String, BTreeMap<String, f64>)>, String>;

fn run(case: &Case) -> Outcome {
    Ok(run_causes(case)?.into_iter().map(|c| (c.effect, c.params)).collect())
}

/// The causes named on `case` (dropouts left out), with their uncertainty.
fn run_causes(case: &Case) -> Result<Vec<jointctl_ident::identify::Cause>, String> {
    // One file a case, removed once read (a folder per process was left behind after every run).
    let data = through_the_reader::try_blind_case(case, &case.name)?;
    let report = identify(&data, &IdentifyOptions { held_out: held_out(), ..IdentifyOptions::default() }).map_err(|e| e.to_string())?;
    Ok(report.causes.into_iter().filter(|c| c.effect != "dropout").collect())
}

/// The held-out part: identify's default (a window like the rest), or with
/// `JOINTCTL_BLIND_HELD_OUT=last` always the last 30 % (`--held-out last`), to measure that
/// option on the suite.
fn held_out() -> HeldOut {
    match std::env::var("JOINTCTL_BLIND_HELD_OUT").as_deref() {
        Ok("last") => HeldOut::Last,
        _ => IdentifyOptions::default().held_out,
    }
}

fn hidden(case: &Case) -> BTreeSet<String> {
    case.answer.effect.split('+').filter(|e| *e != "none" && !e.is_empty()).map(str::to_string).collect()
}

/// The generator's parameter and identify's, and the relative tolerance (25 %, issue 31).
const CHECKS: [(&str, &str, &str); 6] = [
    ("viscous_friction", "b", "damping_nms_per_rad"),
    ("hysteresis", "force", "limit_nm"),
    ("dead_zone", "width", "half_width_rad"),
    ("stiffness_nonlinearity", "k3", "k3_nm_per_rad3"),
    ("sensor_offset", "offset", "offset_nm"),
    ("time_delay", "delay", "delay_s"),
];

#[derive(Default)]
struct Tally {
    cases: usize,
    named: usize,
    extra: usize,
    refused: usize,
    params: usize,
    params_ok: usize,
}

fn score(cases: &[Case], what: &str) -> (Tally, Tally, BTreeMap<String, Tally>) {
    let (mut with, mut clean) = (Tally::default(), Tally::default());
    let mut by: BTreeMap<String, Tally> = BTreeMap::new();
    println!("\n{what}");
    for case in cases {
        let want = hidden(case);
        let outcome = run(case);
        let got: BTreeSet<String> = outcome.as_ref().map(|c| c.iter().map(|x| x.0.clone()).collect()).unwrap_or_default();
        let all = want.iter().all(|w| got.contains(w));
        let extra = got.iter().any(|g| !want.contains(g));
        let count = |tally: &mut Tally| {
            tally.cases += 1;
            tally.refused += outcome.is_err() as usize;
            tally.named += (outcome.is_ok() && all && !want.is_empty()) as usize;
            tally.extra += extra as usize;
        };
        count(if want.is_empty() { &mut clean } else { &mut with });
        count(by.entry(format!("effect {}", case.answer.effect)).or_default());
        count(by.entry(format!("variant {}", case.answer.variant)).or_default());
        if let Ok(causes) = &outcome {
            for (effect, truth_key, key) in CHECKS {
                let (Some(truth), Some((_, params))) = (case.answer.params.get(truth_key), causes.iter().find(|c| c.0 == effect)) else { continue };
                if !want.contains(effect) {
                    continue;
                }
                let ok = params.get(key).is_some_and(|v| (v - truth).abs() <= 0.25 * truth.abs());
                with.params += 1;
                with.params_ok += ok as usize;
            }
        }
        let verdict = match (&outcome, want.is_empty()) {
            (Err(e), _) => format!("refused: {e}"),
            (Ok(_), false) if !all => "MISSED".into(),
            (Ok(_), _) if extra => "EXTRA".into(),
            _ => "pass".into(),
        };
        println!("  {:40} {:36} {:40} {verdict}", case.name, case.answer.effect, got.iter().cloned().collect::<Vec<_>>().join("+"));
    }
    println!(
        "{what}: hidden effects named in {} of {} records, extra causes in {} of them; {} of {} clean records got a cause; {} refused; parameters within 25 %: {} of {}",
        with.named, with.cases, with.extra, clean.extra, clean.cases, with.refused + clean.refused, with.params_ok, with.params
    );
    for (k, t) in &by {
        println!("  {k:40} {} of {} named, {} with an extra cause, {} refused", t.named, t.cases, t.extra, t.refused);
    }
    (with, clean, by)
}

#[test]
fn the_blind_generators_suite_is_identified_at_least_as_well_as_today() {
    let cases = suite(1);
    let (with, clean, _) = score(&cases, "blind generator, suite(1)");
    // What this engine reached when the test was written (see docs/benchmarks.md); a change
    // that loses ground here fails. Issue 31's targets are higher.
    // None refused: two records of a single velocity reversal (step-and-hold tests) were
    // refused while identification asked for three.
    assert!(with.refused + clean.refused == 0, "{} records refused", with.refused + clean.refused);
    // 82 of 88 named, 1 with an extra cause, 0 of 21 clean records with a cause, 84 of 88
    // parameters within 25 % (2 with an extra cause before rings were searched past critical
    // damping and a vibration's phase was fitted per repetition; 81, 0 and 83 of 86 before;
    // 76, 0 and 81 of 83 before the arctan had to bend inside the recorded speeds and modes
    // were scanned on the median step's grid; 69, 1 and 74 of 76 before forecast encompassing
    // and the local velocity window).
    assert!(with.extra <= 2, "{} records with a cause besides the hidden ones", with.extra);
    assert!(with.named * 100 >= 90 * with.cases, "named in {} of {}", with.named, with.cases);
    assert!(clean.extra * 100 <= 5 * clean.cases, "{} of {} clean records got a cause", clean.extra, clean.cases);
    assert!(with.params_ok * 100 >= 90 * with.params, "{} of {} parameters within 25 %", with.params_ok, with.params);
}

/// One device's data written six ways (full-rate irregular, 20 Hz bins, one repetition, three
/// repetitions, and as a test rig logs a stiffness test: at one or at five drive amplitudes,
/// three runs each, ~550 Hz irregular epoch stamps and a 2e-6 rad encoder): the same causes
/// should be named on each (issue 36).
#[test]
fn one_device_written_six_ways() {
    let cases = device_variants(1);
    // Per device: each variant's name, causes, and whether it is one of the rig's variants.
    let mut variants: BTreeMap<String, Vec<(String, BTreeSet<String>, bool)>> = BTreeMap::new();
    let mut causes: BTreeMap<String, Vec<Vec<jointctl_ident::identify::Cause>>> = BTreeMap::new();
    for case in &cases {
        let found = run_causes(case);
        let got = found.as_ref().map(|c| c.iter().map(|x| x.effect.clone()).collect()).unwrap_or_else(|e| BTreeSet::from([format!("refused: {e}")]));
        let device = case.answer.device.clone().unwrap_or_default();
        variants.entry(device.clone()).or_default().push((case.answer.variant.clone(), got, case.answer.drive.is_some()));
        causes.entry(device).or_default().push(found.unwrap_or_default());
    }
    let mut same = 0;
    // Where the variants name the same causes, each parameter within two combined standard
    // errors between every two variants (issue 36: "parameters inside their stated
    // uncertainty"): asserted over the four loggings of one test, printed for the rig's.
    let (mut parameters, mut disagree, mut rig_apart) = (0, Vec::new(), Vec::new());
    for (device, each_variant) in &variants {
        let agree = each_variant.windows(2).all(|w| w[0].1 == w[1].1);
        same += agree as usize;
        println!("device {device}: {}", each_variant.iter().map(|(v, g, _)| format!("{v}: {}", g.iter().cloned().collect::<Vec<_>>().join("+"))).collect::<Vec<_>>().join("; "));
        if !agree {
            continue;
        }
        let found = &causes[device];
        for cause in &found[0] {
            // Each variant's cause of the same effect (causes are listed by their gain, which
            // may order them differently from one variant to the next).
            let same: Option<Vec<&jointctl_ident::identify::Cause>> = found.iter().map(|v| v.iter().find(|c| c.effect == cause.effect)).collect();
            let Some(same) = same else { continue };
            for name in cause.params.keys() {
                let Some(each) = same.iter().map(|c| Some((*c.params.get(name)?, *c.uncertainty.get(name)?))).collect::<Option<Vec<_>>>() else { continue };
                let apart_in = |pick: &dyn Fn(usize) -> bool| {
                    let chosen: Vec<(f64, f64)> = each.iter().enumerate().filter(|(i, _)| pick(*i)).map(|(_, e)| *e).collect();
                    chosen.iter().enumerate().any(|(i, a)| chosen[i + 1..].iter().any(|b| (a.0 - b.0).abs() > 2.0 * (a.1 * a.1 + b.1 * b.1).sqrt()))
                };
                // A delay's lag on the 20 Hz bins read 32.9 +- 4.4 ms for 43-44 +- 2-3 at full
                // rate here until the lag ran along a cubic between the bins (41.7 +- 3.8 ms
                // since): asserted now with the other parameters.
                parameters += 1;
                if apart_in(&|i| !each_variant[i].2) {
                    disagree.push(format!("{device} {} {name}: {each:?}", cause.effect));
                } else if apart_in(&|_| true) {
                    rig_apart.push(format!("{device} {} {name}: {each:?}", cause.effect));
                }
            }
        }
    }
    println!("devices whose variants all got the same causes: {same} of {}", variants.len());
    println!("their parameters within two combined standard errors on the four loggings of one test: {} of {parameters}", parameters - disagree.len());
    println!("apart only with the rig's variants (not asserted): {rig_apart:#?}");
    let (_, _, _) = score(&cases, "blind generator, device_variants(1)");
    // 2 of 5 devices when this was written (13 of 16 records named); 3 of 5 since the rate's
    // window narrows where the deflection bends (14 of 16); 4 of 5 since the hysteresis loop
    // has a shape (device A's Bouc-Wen loop got a cubic beside it on the three-repetition record).
    // The same 4 of 5 with the rig's two variants (device E's viscous friction is missed on
    // the irregular one).
    assert!(same >= 4, "{same} of {} devices got the same causes on every variant", variants.len());
    // Before, only the loop's limit and sigma of these 6 had an error (a dead zone's width and
    // ramp and a delay none), and both disagreed: limits of 1.72-1.77 Nm with classical errors
    // of 0.005-0.05 Nm. On seeds 1-8,
    // 38 of 59 agree: the rest is the part of a misspecified model's parameter that follows
    // its excitation (docs/identification.md, Parameter uncertainty). The rig's variants show
    // that part: device A's Bouc-Wen loop, fitted at the middle of five drive amplitudes, reads
    // `sigma` 38.3 +- 5.1 Nm/rad where every other variant reads 52.8-57.2 (and over five
    // amplitudes the loop comes out as Dahl's, shape 1, where one amplitude reads shape 2).
    assert!(parameters >= 6 && disagree.is_empty(), "{parameters} parameters compared; apart: {disagree:#?}");
}

/// Other seeds of the blind suite, for a change's check on records it was not looked at on:
/// `JOINTCTL_BLIND_SEED=2 cargo test --release -p jointctl-ident --test blind_suite -- --ignored
/// --nocapture`. Prints the tallies; asserts nothing (no target was set on other seeds).
#[test]
#[ignore]
fn other_seeds_of_the_blind_suite() {
    let seed = std::env::var("JOINTCTL_BLIND_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(2);
    let _ = score(&suite(seed), &format!("blind generator, suite({seed})"));
}
