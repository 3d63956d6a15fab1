//! The devices' test-rig variants (`5_amp1`, `6_amp5`): a stiffness test at one or five drive
//! amplitudes, three runs each, logged like a series-elastic-actuator rig (~550 Hz irregular
//! epoch stamps, time jumps between runs, a 2e-6 rad linear encoder), with the physics of the
//! device's other variants.

use jointctl_blind_gen::{Case, DEVICE_VARIANTS, DEVICES, Truth, device_variants_with_truth};
use std::collections::BTreeMap;

/// Steps between runs are pauses of 3-10 s; steps inside a run are at most a long step plus
/// a logger stall (0.26 s).
const JUMP_S: f64 = 2.0;

fn quantile(mut x: Vec<f64>, q: f64) -> f64 {
    x.sort_by(|a, b| a.total_cmp(b));
    x[((x.len() - 1) as f64 * q).round() as usize]
}

/// [start, end) of each run: the record split at its time jumps.
fn runs_of(c: &Case) -> Vec<(usize, usize)> {
    let mut cuts = vec![0];
    cuts.extend((1..c.t.len()).filter(|&i| c.t[i] - c.t[i - 1] >= JUMP_S));
    cuts.push(c.t.len());
    cuts.windows(2).map(|w| (w[0], w[1])).collect()
}

fn check_rig_record(c: &Case, tr: &Truth, levels: usize) {
    let name = &c.name;
    let a = &c.answer;
    assert!(
        a.variant.contains("rig550") && a.variant.contains("linear2e-6"),
        "{name}: {}",
        a.variant
    );

    // Epoch time stamps, increasing.
    assert!(c.t[0] > 1.69e9 && c.t[0] < 1.8e9, "{name}: t0 {}", c.t[0]);
    assert!(
        c.t.windows(2).all(|w| w[1] > w[0]),
        "{name}: time not increasing"
    );

    // Runs: `levels` x 3, split by time jumps exactly where the truth changes run.
    let runs = runs_of(c);
    assert_eq!(runs.len(), 3 * levels, "{name}: runs");
    assert_eq!(a.repetitions, runs.len(), "{name}");
    for (r, &(s, e)) in runs.iter().enumerate() {
        assert!(
            tr.rep[s..e].iter().all(|&x| x == r),
            "{name}: run {r} not one run"
        );
    }

    // Inside runs: ~550 Hz irregular steps (median ~1.8 ms, 99th percentile ~15 ms), stalls
    // of at most ~0.26 s.
    let steps: Vec<f64> = runs
        .iter()
        .flat_map(|&(s, e)| (s + 1..e).map(|i| c.t[i] - c.t[i - 1]))
        .collect();
    let med = quantile(steps.clone(), 0.5);
    let p99 = quantile(steps.clone(), 0.99);
    let max = quantile(steps.clone(), 1.0);
    assert!(
        (1.7e-3..1.95e-3).contains(&med),
        "{name}: median step {med}"
    );
    assert!((10e-3..20e-3).contains(&p99), "{name}: p99 step {p99}");
    assert!(max <= 0.29, "{name}: stall {max}");
    let irregular = steps.iter().filter(|d| (*d - med).abs() > 5e-5).count();
    assert!(
        irregular > steps.len() / 2,
        "{name}: steps are not irregular"
    );
    assert!(
        (a.fs - 1.0 / med).abs() < 0.05 * a.fs,
        "{name}: fs {}",
        a.fs
    );

    // The deflection is read by the 2e-6 rad linear encoder (and one count is seen).
    assert_eq!(a.encoder_step, 2e-6);
    assert!(a.quantised);
    for d in &c.deflection {
        let n = d / 2e-6;
        assert!(
            (n - n.round()).abs() < 1e-6,
            "{name}: {d} not on the 2e-6 grid"
        );
    }
    let one_count = c
        .deflection
        .windows(2)
        .filter(|w| ((w[1] - w[0]).abs() - 2e-6).abs() < 1e-12)
        .count();
    assert!(one_count > 100, "{name}: {one_count} one-count steps");

    // Drive amplitudes: `levels` distinct levels in increasing order, each run three times. The
    // size of a run is the time-weighted RMS of its measured deflection (robust to a logger
    // stall at a peak); repeats are within ±1 % of their level.
    let d = a.drive.as_ref().expect("drive amplitudes in the answer");
    assert_eq!(d.scales.len(), levels, "{name}");
    assert_eq!(d.runs_per_level, 3, "{name}");
    assert_eq!(d.effect_rms_each.len(), levels, "{name}");
    assert!(
        d.scales.windows(2).all(|w| w[1] > 1.04 * w[0]),
        "{name}: {:?}",
        d.scales
    );
    let size: Vec<f64> = runs
        .iter()
        .map(|&(s, e)| {
            let ss: f64 = (s..e - 1)
                .map(|i| c.deflection[i].powi(2) * (c.t[i + 1] - c.t[i]))
                .sum();
            (ss / (c.t[e - 1] - c.t[s])).sqrt()
        })
        .collect();
    let level_size: Vec<f64> = size
        .chunks(3)
        .map(|x| x.iter().sum::<f64>() / 3.0)
        .collect();
    for (l, x) in size.chunks(3).enumerate() {
        let (lo, hi) = x
            .iter()
            .fold((f64::MAX, 0.0_f64), |(a, b), v| (a.min(*v), b.max(*v)));
        assert!(hi < 1.03 * lo, "{name}: level {l} runs {x:?}");
    }
    assert!(
        level_size.windows(2).all(|w| w[1] > 1.03 * w[0]),
        "{name}: levels {level_size:?}"
    );
    let unit = level_size[levels - 1] / d.scales[levels - 1];
    for (l, x) in level_size.iter().enumerate() {
        let rel = x / unit;
        assert!(
            (rel / d.scales[l] - 1.0).abs() < 0.025,
            "{name}: level {l} at {rel}, drive {}",
            d.scales[l]
        );
    }
}

#[test]
fn rig_variants_log_a_stiffness_test_at_several_amplitudes() {
    let all = device_variants_with_truth(3);
    assert_eq!(DEVICE_VARIANTS.len(), 6);
    assert_eq!(all.len(), DEVICES.len() * 6);
    let mut by_dev: BTreeMap<String, BTreeMap<String, (&Case, &Truth)>> = BTreeMap::new();
    for (c, tr) in &all {
        let dev = c.answer.device.clone().expect("device set");
        let tag = c
            .name
            .strip_prefix(&format!("{dev}_"))
            .expect("name")
            .to_string();
        by_dev.entry(dev).or_default().insert(tag, (c, tr));
    }
    assert_eq!(by_dev.len(), DEVICES.len());
    for (dev, v) in &by_dev {
        let tags: Vec<&str> = v.keys().map(String::as_str).collect();
        let want: Vec<&str> = DEVICE_VARIANTS.iter().map(|(t, _)| *t).collect();
        assert_eq!(tags, want, "{dev}");
        let (amp1, tr1) = v["5_amp1"];
        let (amp5, tr5) = v["6_amp5"];
        check_rig_record(amp1, tr1, 1);
        check_rig_record(amp5, tr5, 5);
        // One amplitude: one of the five.
        let s1 = amp1.answer.drive.as_ref().expect("drive").scales[0];
        assert!(
            amp5.answer
                .drive
                .as_ref()
                .expect("drive")
                .scales
                .contains(&s1),
            "{dev}"
        );

        // The physics of the device's other variants.
        let a0 = &v["3_rep1"].0.answer;
        for c in [amp1, amp5] {
            let a = &c.answer;
            assert_eq!(a.effect, a0.effect, "{dev}");
            assert_eq!(a.k, a0.k, "{dev}");
            assert_eq!(a.friction, a0.friction, "{dev}");
            assert_eq!(a.models, a0.models, "{dev}");
            assert_eq!(a.noise_white_raw, a0.noise_white_raw, "{dev}");
            assert_eq!(a.torque_span, a0.torque_span, "{dev}");
            assert_eq!(
                a.params.keys().collect::<Vec<_>>(),
                a0.params.keys().collect::<Vec<_>>(),
                "{dev}"
            );
            for (key, x) in &a0.params {
                assert!(
                    (a.params[key] - x).abs() <= 1e-9 * x.abs().max(1e-12),
                    "{dev} {key}"
                );
            }
            assert!((a.noise / a0.noise - 1.0).abs() < 0.05, "{dev}: noise");
            // Each hidden effect clearly present at every amplitude.
            for (l, each) in a
                .drive
                .as_ref()
                .expect("drive")
                .effect_rms_each
                .iter()
                .enumerate()
            {
                assert_eq!(each.len(), a0.effect_rms_each.len(), "{dev}");
                for (cause, r) in each {
                    let full = a0.effect_rms_each[cause];
                    assert!(
                        *r >= 1.4_f64.min(0.65 * full),
                        "{dev} level {l} {cause}: {r} ({full})"
                    );
                }
            }
        }
    }
}
