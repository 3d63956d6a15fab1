//! The generator's own checks: determinism, coverage of the suite, answers that agree with the
//! data, time stamps and quantisation as declared.

use jointctl_blind_gen::{Case, Spec, Truth, case, suite_plan, synth::ALL_CAUSES, write_set};
use std::collections::BTreeMap;
use std::f64::consts::PI;

fn spec(seed: u64, effect: &str, variant: &str, baseline: Option<&str>) -> Spec {
    Spec {
        name: format!("t_{seed}"),
        effect: effect.into(),
        variant: variant.into(),
        baseline: baseline.map(str::to_string),
        duration_s: Some(25.0),
        seed,
    }
}

fn gen_truth(seed: u64, effect: &str, variant: &str, baseline: Option<&str>) -> (Case, Truth) {
    spec(seed, effect, variant, baseline)
        .generate()
        .unwrap_or_else(|e| panic!("{effect} {variant}: {e}"))
}

fn std_dev(x: &[f64]) -> f64 {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

#[test]
fn same_seed_same_data_other_seed_other_data() {
    let a = case(7, "hysteresis+time_delay", "irregular+epoch");
    let b = case(7, "hysteresis+time_delay", "irregular+epoch");
    assert_eq!(a.t, b.t);
    assert_eq!(a.deflection, b.deflection);
    assert_eq!(a.torque, b.torque);
    assert_eq!(a.answer, b.answer);
    let c = case(8, "hysteresis+time_delay", "irregular+epoch");
    assert_ne!(a.torque, c.torque);
    // The suite plan (names, seeds) is a pure function of the seed, and a planned case is
    // reproducible on its own.
    let p1 = suite_plan(3);
    let p2 = suite_plan(3);
    assert_eq!(
        p1.iter().map(|s| (&s.name, s.seed)).collect::<Vec<_>>(),
        p2.iter().map(|s| (&s.name, s.seed)).collect::<Vec<_>>()
    );
    let (x, _) = p1[5].generate().unwrap();
    let (y, _) = p2[5].generate().unwrap();
    assert_eq!(x.torque, y.torque);
}

#[test]
fn suite_covers_every_effect_and_variant_mix() {
    let plan = suite_plan(1);
    let mut single: BTreeMap<String, usize> = BTreeMap::new();
    let (mut pairs, mut clean, mut plain) = (0, 0, 0);
    for s in &plan {
        let causes: Vec<&str> = s
            .effect
            .split('+')
            .map(|c| c.split(':').next().unwrap())
            .collect();
        match (s.effect.as_str(), causes.len()) {
            ("none", _) => clean += 1,
            (_, 1) => *single.entry(causes[0].to_string()).or_default() += 1,
            _ => pairs += 1,
        }
        if s.variant == "plain" {
            plain += 1;
        }
    }
    for c in ALL_CAUSES {
        assert!(
            single.get(c.name()).copied().unwrap_or(0) >= 8,
            "{}",
            c.name()
        );
    }
    assert!(single.values().sum::<usize>() >= 60);
    assert!(pairs >= 20, "{pairs}");
    assert!(clean >= 20, "{clean}");
    let frac_plain = plain as f64 / plan.len() as f64;
    assert!((0.35..0.65).contains(&frac_plain), "{frac_plain}");
    let mut names: Vec<&String> = plan.iter().map(|s| &s.name).collect();
    names.dedup();
    assert_eq!(names.len(), plan.len());
}

#[test]
fn clean_records_are_baseline_plus_declared_noise() {
    for (seed, variant, baseline) in [
        (1, "plain", Some("atan")),
        (2, "plain", Some("stribeck")),
        (3, "irregular+epoch", None),
        (4, "bin20", None),
        (5, "restart", None),
        (6, "friction_position", Some("lugre")),
        (7, "friction_position", Some("stribeck")),
        (8, "linear2e-6", None),
    ] {
        let (c, tr) = gen_truth(seed, "none", variant, baseline);
        let a = &c.answer;
        assert_eq!(a.effect, "none");
        assert!(a.params.is_empty());
        // Against the truth: torque - baseline is exactly the noise, whose std is declared.
        let r: Vec<f64> = c
            .torque
            .iter()
            .zip(&tr.tau_base)
            .map(|(t, b)| t - b)
            .collect();
        let s = std_dev(&r);
        assert!(
            (s / a.noise - 1.0).abs() < 1e-3,
            "{variant}: {s} vs {}",
            a.noise
        );
        // Noise level within 0.5-5 % of the span (less once bin-averaged).
        let frac = a.noise_white_raw / a.torque_span;
        assert!(
            (0.004..0.06).contains(&frac),
            "{variant}: noise {frac} of span"
        );
    }
}

#[test]
fn clean_record_from_data_and_answer_alone() {
    // What a tool sees: torque - k * measured deflection - k_a atan(k_b v) (v of the truth)
    // leaves the noise plus the encoder's quantisation error times k.
    let (c, tr) = gen_truth(11, "none", "plain", Some("atan"));
    let a = &c.answer;
    let (ka, kb) = (a.friction["k_a"], a.friction["k_b"]);
    let r: Vec<f64> = (0..c.t.len())
        .map(|i| c.torque[i] - a.k * c.deflection[i] - ka * (kb * tr.vel[i]).atan())
        .collect();
    let expected = (a.noise.powi(2) + (a.k * a.encoder_step).powi(2) / 12.0).sqrt();
    let s = std_dev(&r);
    assert!((s / expected - 1.0).abs() < 0.1, "{s} vs {expected}");
}

#[test]
fn single_effects_are_clearly_present_and_parameters_match() {
    for (i, cause) in ALL_CAUSES.iter().enumerate() {
        let (c, tr) = gen_truth(100 + i as u64, cause.name(), "plain", None);
        let a = &c.answer;
        assert_eq!(a.effect, cause.name());
        assert!(
            (1.0..=10.5).contains(&a.effect_rms_over_noise),
            "{}: ratio {}",
            cause.name(),
            a.effect_rms_over_noise
        );
        assert!(a.level >= 1 && a.level <= 3);
        let extra: Vec<f64> = tr
            .tau_clean
            .iter()
            .zip(&tr.tau_base)
            .map(|(x, b)| x - b)
            .collect();
        let p = &a.params;
        match cause.name() {
            "viscous_friction" => {
                // The extra torque is exactly b v.
                for (e, v) in extra.iter().zip(&tr.vel) {
                    assert!((e - p["b"] * v).abs() < 1e-9 * (1.0 + e.abs()));
                }
            }
            "sensor_offset" => {
                assert!((mean(&extra) - p["offset"]).abs() < 1e-9);
            }
            "vibration" => {
                // Project the extra torque on sin/cos at the declared frequency.
                let w = 2.0 * PI * p["frequency"];
                let (mut s, mut co) = (0.0, 0.0);
                for (e, t) in extra.iter().zip(&c.t) {
                    s += e * (w * t).sin();
                    co += e * (w * t).cos();
                }
                let amp = 2.0 * (s * s + co * co).sqrt() / extra.len() as f64;
                assert!((amp / p["amplitude"] - 1.0).abs() < 0.02, "{amp}");
                assert!((8.0..=60.0).contains(&p["frequency"]));
                assert!(p["frequency"] < 0.4 * a.fs);
            }
            "dead_zone" => {
                // Inside the play (minus the ramp) the spring carries nothing.
                let inner = p["width"] - p["width_ramp"];
                for (i, phi) in tr.phi.iter().enumerate() {
                    if phi.abs() < inner {
                        let spring = tr.tau_clean[i] - tr.friction[i];
                        assert!(spring.abs() < 1e-9, "{spring}");
                    }
                }
            }
            "stiffness_nonlinearity" => {
                assert!(p["k3"] != 0.0 && p["k3"].is_finite());
            }
            "time_delay" => {
                assert!(p["delay"] > 0.0 && p["delay"] <= 0.1 + 1e-12);
                assert!(p["delay"] >= p["delay_transport"]);
            }
            "hysteresis" => {
                let f = p["force"];
                assert!(f > 0.0 && f <= 0.25 * a.torque_span + 1e-9);
                // The hysteretic torque stays within its saturation limit.
                for e in &extra {
                    assert!(e.abs() <= f * 1.7, "{e} vs {f}");
                }
            }
            _ => unreachable!(),
        }
    }
}

#[test]
fn pure_transport_delay_is_a_time_shift() {
    let (c, tr) = gen_truth(21, "time_delay:transport", "plain", Some("atan"));
    let d = c.answer.params["delay"];
    // tau_clean(t) = baseline(t - d): compare with the baseline sampled d earlier by
    // interpolating the baseline series.
    let dt = c.t[1] - c.t[0];
    let shift = d / dt;
    let (mut worst, mut scale) = (0.0_f64, 0.0_f64);
    for i in (shift.ceil() as usize + 1)..c.t.len() {
        let p = i as f64 - shift;
        let j = p.floor() as usize;
        let f = p - j as f64;
        let b = tr.tau_base[j] * (1.0 - f) + tr.tau_base[j + 1] * f;
        worst = worst.max((tr.tau_clean[i] - b).abs());
        scale = scale.max(tr.tau_base[i].abs());
    }
    // Interpolation between samples is the only difference (friction is steep at reversals).
    assert!(worst < 0.05 * scale, "{worst} vs {scale}");
}

#[test]
fn pairs_name_both_causes() {
    let c = case(31, "dead_zone+stiffness_nonlinearity", "plain");
    assert_eq!(c.answer.effect, "dead_zone+stiffness_nonlinearity");
    assert!(c.answer.params.contains_key("width") && c.answer.params.contains_key("k3"));
    assert_eq!(c.answer.effect_rms_each.len(), 2);
    assert!(c.answer.effect_rms_over_noise >= 1.0);
}

#[test]
fn time_stamps_increase_except_restarts() {
    for variant in [
        "plain",
        "irregular",
        "epoch",
        "repetitions",
        "bin20+irregular",
        "restart",
    ] {
        let (c, tr) = gen_truth(41, "none", variant, None);
        let restart = variant.contains("restart");
        for i in 1..c.t.len() {
            if restart && tr.rep[i] != tr.rep[i - 1] {
                assert!(
                    c.t[i] < c.t[i - 1] && c.t[i] == 0.0,
                    "{variant}: restart at {i}"
                );
            } else {
                assert!(c.t[i] > c.t[i - 1], "{variant}: t[{i}] not increasing");
            }
        }
        if variant == "epoch" {
            assert!(c.t[0] > 1.69e9 && c.t[0] < 1.8e9);
        }
        if restart {
            assert!(c.answer.repetitions >= 2);
            assert_eq!(c.t[0], 0.0);
        }
    }
}

#[test]
fn irregular_time_stamps_look_like_a_real_logger() {
    let c = case(51, "none", "irregular");
    let mut d: Vec<f64> = c.t.windows(2).map(|w| w[1] - w[0]).collect();
    d.sort_by(|a, b| a.total_cmp(b));
    let med = d[d.len() / 2];
    let p99 = d[(d.len() as f64 * 0.99) as usize];
    assert!((0.9e-3..2.1e-3).contains(&med), "median {med}");
    assert!((5e-3..15e-3).contains(&p99), "p99 {p99}");
    let gaps = d.iter().filter(|x| **x >= 0.1).count();
    assert!((1..=3).contains(&gaps), "gaps {gaps}");
    assert!((c.answer.fs - 1.0 / med).abs() < 1e-6 * c.answer.fs);
}

#[test]
fn deflection_is_quantised_as_declared() {
    for (variant, step) in [
        ("plain", 2.0 * PI / 16384.0),
        ("encoder17", 2.0 * PI / 131072.0),
        ("linear2e-6", 2e-6),
    ] {
        let (c, tr) = gen_truth(61, "none", variant, None);
        assert_eq!(c.answer.encoder_step, step);
        assert!(c.answer.quantised);
        for (d, p) in c.deflection.iter().zip(&tr.phi) {
            let n = d / step;
            assert!(
                (n - n.round()).abs() < 1e-6,
                "{variant}: {d} not on the grid"
            );
            // Rounding (and for the linear encoder 1-2 counts of flicker) only.
            let lim = if variant == "linear2e-6" {
                4.0
            } else {
                0.5 + 1e-9
            };
            assert!((d - p).abs() <= lim * step, "{variant}: {d} vs {p}");
        }
        let counts = c.deflection.iter().map(|d| (d / step).round() as i64);
        let span = counts.clone().max().unwrap() - counts.min().unwrap();
        assert!(span >= 60, "{variant}: only {span} counts");
    }
    // Binned records are averages, no longer on the grid, and say so.
    let c = case(62, "none", "bin20");
    assert!(!c.answer.quantised);
    assert_eq!(c.answer.fs, 20.0);
}

#[test]
fn friction_position_records_have_no_spring() {
    let (c, tr) = gen_truth(71, "viscous_friction", "friction_position", None);
    assert_eq!(c.answer.k, 0.0);
    let centre = mean(&tr.phi[..10]);
    assert!((0.15..0.85).contains(&centre.abs()), "centre {centre}");
    assert!(c.answer.friction_model == "lugre" || c.answer.friction_model == "stribeck");
}

#[test]
fn written_files_keep_their_precision() {
    let dir = std::env::temp_dir().join(format!("blind-gen-test-{}", std::process::id()));
    let cases = vec![case(81, "none", "linear2e-6+epoch")];
    write_set(&cases, &dir).unwrap();
    let text = std::fs::read_to_string(dir.join(format!("{}.csv", cases[0].name))).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,deflection,torque"));
    for (i, line) in lines.enumerate() {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        assert!((v[0] - cases[0].t[i]).abs() < 1e-6, "time {i}");
        let n = v[1] / 2e-6;
        assert!((n - n.round()).abs() < 1e-6, "deflection {i}");
        assert!((v[2] - cases[0].torque[i]).abs() <= 5e-7 + 1e-12);
    }
    let answers: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("answers.json")).unwrap()).unwrap();
    let a = &answers[format!("{}.csv", cases[0].name)];
    for key in [
        "effect",
        "params",
        "noise",
        "fs",
        "k",
        "tau_max",
        "variant",
        "device",
        "level",
        "effect_rms_over_noise",
    ] {
        assert!(a.get(key).is_some(), "answers.json lacks {key}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn impossible_requests_are_refused() {
    use jointctl_blind_gen::try_case;
    assert!(try_case(1, "vibration", "bin20").is_err());
    assert!(try_case(1, "hysteresis", "friction_position").is_err());
    assert!(try_case(1, "no_such_cause", "plain").is_err());
    assert!(try_case(1, "none", "no_such_variant").is_err());
}

#[test]
fn device_variants_share_their_physics() {
    let all = jointctl_blind_gen::device_variants_with_truth(5);
    let mut by_dev: BTreeMap<String, Vec<&Case>> = BTreeMap::new();
    for (c, _) in &all {
        by_dev
            .entry(c.answer.device.clone().expect("device set"))
            .or_default()
            .push(c);
    }
    assert!(by_dev.len() >= 4);
    for (dev, cases) in &by_dev {
        assert!(cases.len() >= 3, "{dev}");
        let a0 = &cases[0].answer;
        let variants: Vec<&str> = cases.iter().map(|c| c.answer.variant.as_str()).collect();
        assert!(
            variants.contains(&"bin20") && variants.contains(&"repetitions"),
            "{variants:?}"
        );
        for c in &cases[1..] {
            let a = &c.answer;
            assert_eq!(a.effect, a0.effect, "{dev}");
            assert_eq!(a.k, a0.k, "{dev}");
            assert_eq!(a.friction, a0.friction, "{dev}");
            assert_eq!(a.models, a0.models, "{dev}");
            for (key, v) in &a0.params {
                // Everything but the record-dependent offset mean is identical; that one is
                // constant for devices, so it agrees closely too.
                assert!(
                    (a.params[key] - v).abs() <= 1e-6 * v.abs().max(1e-9),
                    "{dev} {key}"
                );
            }
        }
    }
}

/// The full suite (the crate is optimised in debug builds too: see the workspace's profile).
#[test]
fn whole_suite_generates_within_budget() {
    let t0 = std::time::Instant::now();
    let cases = jointctl_blind_gen::suite(1);
    let secs = t0.elapsed().as_secs_f64();
    let total: usize = cases.iter().map(|c| c.t.len()).sum();
    eprintln!(
        "suite(1): {} cases, {total} samples, {secs:.1} s",
        cases.len()
    );
    assert!(total < 5_000_000, "{total}");
    for c in &cases {
        let a = &c.answer;
        if a.effect != "none" {
            assert!(
                (1.0..=12.0).contains(&a.effect_rms_over_noise),
                "{}: {}",
                c.name,
                a.effect_rms_over_noise
            );
        }
        assert!(c.t.iter().all(|t| t.is_finite()) && c.torque.iter().all(|t| t.is_finite()));
    }
    for cause in ALL_CAUSES {
        let n = cases
            .iter()
            .filter(|c| c.answer.effect == cause.name())
            .count();
        assert!(n >= 8, "{}: {n}", cause.name());
    }
}

/// Many draws of every cause on every variant: no panics, effects always clearly present.
#[test]
fn many_seeds_never_fail() {
    let variants = [
        "plain",
        "irregular",
        "epoch",
        "repetitions",
        "restart",
        "encoder17",
        "linear2e-6",
        "bin20",
        "friction_position",
    ];
    let mut worst = (f64::MAX, String::new());
    for seed in 0..6u64 {
        for cause in ALL_CAUSES.iter().map(|c| c.name()).chain(["none"]) {
            for v in variants {
                if (cause == "vibration" && v == "bin20")
                    || (v == "friction_position"
                        && !matches!(cause, "viscous_friction" | "sensor_offset" | "none"))
                {
                    continue;
                }
                let c = jointctl_blind_gen::try_case(seed, cause, v)
                    .unwrap_or_else(|e| panic!("{seed} {cause} {v}: {e}"));
                if cause != "none" && c.answer.effect_rms_over_noise < worst.0 {
                    worst = (
                        c.answer.effect_rms_over_noise,
                        format!("{seed} {cause} {v}"),
                    );
                }
                if cause != "none" {
                    assert!(
                        c.answer.effect_rms_over_noise >= 1.0,
                        "{seed} {cause} {v}: {}",
                        c.answer.effect_rms_over_noise
                    );
                }
            }
        }
    }
    eprintln!("lowest ratio {worst:?}");
}
