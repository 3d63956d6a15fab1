//! A loop's state across a pause the log does not show. A test rig logs a stiffness test's
//! repetitions in one file, and between them re-homes the drive where the log does not see it;
//! the loop's state at a repetition's start is then not the one the last left. Carried across,
//! it put the held-out repetition's first strokes up to a loop's height off and the loop was
//! refused (the rig generator's seed 5 `d2`: an offset and a viscous friction named on its 20 Hz
//! bins, the loop and the cubic unnamed). Where the torque steps across such a pause with the
//! joint at rest, the samples up to the motion's next turn are now left out of the fit and the
//! judgement (`prepare::pauses`).

use jointctl_ident::csv::Data;
use jointctl_ident::identify::{IdentifyOptions, identify};

/// A Maxwell-slip (Iwan) loop, not identify's Dahl loop: eight elasto-slip elements of 0.075 Nm
/// each, slipping from 0.2 to 20 mrad (Masing's rule), beside a 600 Nm/rad spring, a 0.2 Nm
/// offset and 5 mNm of noise. Three repetitions of a 1.5 s hold, two 0.3 Hz cycles of 0.05 rad
/// and a 1.5 s hold at 100 Hz, 20 s apart; in each pause, unlogged, the drive goes to
/// `excursion_rad` and back.
fn repetitions(seed: u64, excursion_rad: f64) -> Data {
    let slips: Vec<f64> = (0..8).map(|j| 2e-4 * 100f64.powf(j as f64 / 7.0)).collect();
    let mut anchors = [0.0f64; 8];
    let mut element_nm = |x: f64| -> f64 {
        anchors.iter_mut().zip(&slips).map(|(p, s)| {
            *p = p.clamp(x - s, x + s);
            0.075 * (x - *p) / s
        }).sum()
    };
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut gauss = move || {
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (uniform(), uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    };
    let (mut t, mut d, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let mut start = 1.7e9;
    for rep in 0..3 {
        if rep > 0 {
            for i in 0..400 {
                element_nm(excursion_rad * (1.0 - (i as f64 / 199.5 - 1.0).abs()));
            }
            start += 20.0;
        }
        for i in 0..967 {
            let s = i as f64 * 0.01;
            let x = if (1.5..1.5 + 2.0 / 0.3).contains(&s) { 0.05 * (std::f64::consts::TAU * 0.3 * (s - 1.5)).sin() } else { 0.0 };
            let x = (x / 2e-6).round() * 2e-6;
            t.push(start + s);
            d.push(x);
            tau.push(600.0 * x + element_nm(x) + 0.2 + 0.005 * gauss());
        }
        start = t[t.len() - 1];
    }
    Data::from_columns(t, d, tau)
}

#[test]
fn a_loop_turned_in_unlogged_pauses_is_named() {
    for seed in [1, 2] {
        // Each excursion ends on the way down: each repetition starts from the other side of
        // the loop than the last one's end.
        let r = identify(&repetitions(seed, 0.05), &IdentifyOptions::default()).unwrap();
        let named: Vec<&str> = r.causes.iter().map(|c| c.effect.as_str()).collect();
        // Before: the loop unnamed. Now 0.578 Nm, the offset 0.2045 Nm and a cubic beside them
        // for the slip elements' shape, held out 0.417 -> 0.043 Nm.
        let h = r.causes.iter().find(|c| c.effect == "hysteresis").unwrap_or_else(|| panic!("seed {seed}: {named:?}, held out {} -> {}", r.rmse_before, r.rmse_after));
        assert!((h.params["limit_nm"] - 0.6).abs() < 0.15, "seed {seed}: {:?}", h.params);
        let offset = r.causes.iter().find(|c| c.effect == "sensor_offset").unwrap_or_else(|| panic!("seed {seed}: {named:?}"));
        assert!((offset.params["offset_nm"] - 0.2).abs() < 0.05, "seed {seed}: {:?}", offset.params);
        assert!(r.after_pauses.samples > 0 && r.rmse_after < 0.1, "seed {seed}: {} left out, held out {}", r.after_pauses.samples, r.rmse_after);
    }
}

#[test]
fn a_joint_that_holds_its_state_through_its_pauses_keeps_every_sample() {
    // Each excursion ends on the way up, as each repetition did: the torque does not step.
    let r = identify(&repetitions(1, -0.05), &IdentifyOptions::default()).unwrap();
    assert_eq!(r.after_pauses.samples, 0);
    assert!(r.causes.iter().any(|c| c.effect == "hysteresis"), "{:?}", r.causes.iter().map(|c| &c.effect).collect::<Vec<_>>());
}

#[test]
fn a_rig_record_names_its_loop_and_cubic() {
    // The rig generator (written without reading this crate), seed 5, device d2, three
    // repetitions at 20 Hz (`tests/data/README.md`): a Maxwell-slip loop of 0.612 Nm and a
    // softening cubic of -1501 Nm/rad^3 (its answers). Before: an offset and a viscous friction
    // (4.9 Nm s/rad where the answers hold 1.6), 0.257 Nm held out.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/rig_seed5_d2_three_repetitions_20hz.csv");
    let data = jointctl_ident::csv::read(path.as_ref()).unwrap();
    let r = identify(&data, &IdentifyOptions::default()).unwrap();
    let param = |effect: &str, key: &str| r.causes.iter().find(|c| c.effect == effect).map(|c| c.params[key]);
    let named: Vec<&str> = r.causes.iter().map(|c| c.effect.as_str()).collect();
    let limit = param("hysteresis", "limit_nm").unwrap_or_else(|| panic!("{named:?}"));
    let cubic = param("stiffness_nonlinearity", "k3_nm_per_rad3").unwrap_or_else(|| panic!("{named:?}"));
    assert!((limit - 0.612).abs() < 0.25 * 0.612 && (cubic + 1501.0).abs() < 0.25 * 1501.0, "limit {limit}, k3 {cubic}");
    assert!(!named.contains(&"viscous_friction") && r.after_pauses.samples > 0, "{named:?}");
}

#[test]
fn a_held_out_part_left_out_whole_is_judged_whole_instead() {
    // A review's finding: the parts' sizes were checked before the samples after a pause were
    // left out. Four cycles, a pause across which the torque steps 0.5 Nm, then a long rest and
    // a last stroke to a crest 0.15 s before the record's end: of the last 30 % held out (the
    // rest and the stroke) 14 samples are left after the turn, fewer than a held-out part needs.
    let (mut t, mut d, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..1600 {
        let s = i as f64 * 0.01;
        let x = if (1.0..15.0).contains(&s) { 0.05 * (std::f64::consts::TAU * (s - 1.0) / 3.5).sin() } else { 0.0 };
        t.push(s);
        d.push(x);
        tau.push(600.0 * x + 0.001 * ((i * 7919) % 13) as f64);
    }
    for i in 0..640 {
        let s = i as f64 * 0.01;
        let x = if s < 6.0 { 0.0 } else { 0.05 * (std::f64::consts::TAU * (s - 6.0)).sin() };
        t.push(36.0 + s);
        d.push(x);
        tau.push(600.0 * x - 0.5 + 0.001 * ((i * 7919) % 13) as f64);
    }
    let last = IdentifyOptions { held_out: jointctl_ident::identify::prepare::HeldOut::Last, ..IdentifyOptions::default() };
    let r = identify(&Data::from_columns(t, d, tau), &last).unwrap();
    assert_eq!(r.after_pauses.samples, 0);
    assert!(r.rmse_after.is_finite());
}
