//! The selection's tests: a cause that turns impossible when another leaves, and the like.

use super::*;
use crate::identify::baseline::BaselineModel;
use jointctl_models::effect::Effect;
use crate::identify::causes::{self, CandidateCause};
use crate::identify::prepare::{self, HeldOut as Window};

/// A torque channel behind a first-order filter (64 Hz) and a 0.7 ms transport delay, read
/// every 50 ms: 35 Nm/rad, a multi-sine of 0.23, 0.51 and 0.97 Hz (0.04 rad each), 6 mNm of
/// noise, 14-bit deflection; simulated at 10 kHz for 50 s. Its lag, 3.2 ms, is a negative
/// damping of 0.11 Nm s/rad to a model without a delay.
fn lagging_at_20_hz() -> crate::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x9e37_79b9_7f4a_7c15 ^ 1);
    let phases = [rng.uniform() * TAU, rng.uniform() * TAU, rng.uniform() * TAU];
    let x = |t: f64| [0.23, 0.51, 0.97].iter().zip(&phases).map(|(f, p)| 0.04 * (TAU * f * t + p).sin()).sum::<f64>();
    let (q, dt) = (TAU / 16384.0, 1e-4);
    let alpha = dt * TAU * 64.0 / (1.0 + dt * TAU * 64.0);
    let mut filtered = 0.0;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..500_000 {
        let t = i as f64 * dt;
        filtered += alpha * (35.0 * x(t - 7e-4) - filtered);
        if i % 500 == 0 {
            t_s.push(t);
            phi.push((x(t) / q).round() * q);
            tau.push(filtered + 0.006 * rng.normal());
        }
    }
    crate::csv::Data::from_columns(t_s, phi, tau)
}

/// 60 s at 200 Hz of a 100 Nm/rad spring moved by a 0.4 Hz sine of 0.05 rad (14-bit), 0.01 Nm
/// of noise, and `extra(t)` [Nm] added to the torque.
fn spring_with(extra: impl Fn(f64) -> f64) -> crate::csv::Data {
    spring_sampled(12_000, 5e-3, extra)
}

/// `samples` of the spring of [`spring_with`] every `dt` [s].
fn spring_sampled(samples: usize, dt: f64, extra: impl Fn(f64) -> f64) -> crate::csv::Data {
    let mut rng = jointctl_test_support::XorShift64::new(0x5851_f42d_4c95_7f2d);
    let q = std::f64::consts::TAU / 16384.0;
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..samples {
        let t = i as f64 * dt;
        let x = 0.05 * (std::f64::consts::TAU * 0.4 * t).sin();
        t_s.push(t);
        phi.push((x / q).round() * q);
        tau.push(100.0 * x + extra(t) + 0.01 * rng.normal());
    }
    crate::csv::Data::from_columns(t_s, phi, tau)
}

#[test]
fn a_coefficient_that_wanders_over_the_training_part_is_not_told_from_zero() {
    // Finding (blind device D of seed 2, its 20 Hz bins: a delay behind a torque filter): a
    // hysteresis loop of 0.015 Nm was named beside the delay on a large gain consistent over
    // the held-out part, with no test passed; on the training part its limit was
    // 0.014 +- 0.005 Nm, the loop taking what the filter left in one stretch and not in the
    // next. Here an offset beside a torque that wanders (+-0.05 Nm over 6 s, no mean) is not
    // told from zero; a steady offset of 0.1 Nm beside the same wander is.
    let wander = |t: f64| 0.05 * (std::f64::consts::TAU * t / 6.0).sin();
    let why = offset_untold(&spring_with(wander)).expect("a wandering torque's offset told from zero");
    assert!(why.contains("offset_nm") && why.ends_with("is not told from zero"), "{why}");
    assert_eq!(offset_untold(&spring_with(|t| 0.1 + wander(t))), None);
}

/// Why an offset fitted beside the thesis' line on `data` is not told from zero, if it is not.
fn offset_untold(data: &crate::csv::Data) -> Option<String> {
    let builtin = causes::builtin();
    let all: Vec<&dyn CandidateCause> = builtin.iter().map(|c| c.as_ref()).collect();
    let baseline = BaselineModel::Polynomial(1);
    let offset = all.iter().position(|c| c.effect() == Some(Effect::SensorOffset)).unwrap();
    let spec = Spec { terms: vec![Term { cause: offset, params: Vec::new(), grids: Vec::new(), baseline: false }] };
    let p = prepare::prepare(data, 0.7, Window::Last).unwrap();
    let model = Model { baseline: &baseline, centre_rad: 0.0, middle_s: p.record_middle_s, friction_record: false, causes: &all, held_out: Default::default(), columns: Default::default() };
    let full = held_out_errors(&model, &spec, &p).unwrap();
    let jacobian = Jacobian::new(&model, &spec, &full.fit, &p.train);
    untold_from_zero(&model, &spec, &full, &jacobian, offset, &p)
}

#[test]
fn a_steady_coefficient_beside_a_smooth_misfit_at_a_high_rate_is_told_from_zero() {
    // Finding (the rig generator's seed 5, device 2, one repetition at 550 Hz: a Maxwell-slip
    // loop of 0.26 Nm and a cubic beside a 1.4 Nm offset): Dahl's loop took half of what the
    // offset left over the held-out part, consistently over its parts, and was refused as
    // not told from zero on the training part, limit 0.318 +- 0.205 Nm. That error was the
    // classical one: the residual's lag-1 correlation (a smooth misfit sampled fast, clamped
    // at 0.99) inflated the noise's variance 199 times, an error that grows with the sampling
    // rate whatever the coefficient does; the block error, what the coefficient moves from
    // one stretch of the training part to the next, was 0.100. Here an offset of 0.02 Nm
    // beside a misfit that repeats every cycle (a quadratic no cause models, 0.5 Nm) over 200 s
    // at 1 kHz is told from zero; the wander of the test above is still not.
    // The misfit: the sine's square less its mean, 0.5 Nm at twice its frequency.
    let data = spring_sampled(200_000, 1e-3, |t| 0.02 - 0.5 * (std::f64::consts::TAU * 0.8 * t).cos());
    assert_eq!(offset_untold(&data), None);
}

#[test]
fn a_cause_that_turns_impossible_when_another_leaves_leaves_with_it() {
    // Finding (blind seed 8's 052: a 3.2 ms lag on 20 Hz samples): the delay (refined to
    // 5 ms) and a viscous friction were named; the delay then left as redundant, since the
    // viscous friction took its lag as a negative damping, and the report named a viscous
    // friction of -0.13 Nm s/rad. Here the two are put in the model as the selection left
    // them, and pruned.
    let p = prepare::prepare(&lagging_at_20_hz(), 0.7, Window::Last).unwrap();
    let builtin = causes::builtin();
    let all: Vec<&dyn CandidateCause> = builtin.iter().map(|c| c.as_ref()).collect();
    let baseline = BaselineModel::Polynomial(1);
    let model = Model { baseline: &baseline, centre_rad: 0.0, middle_s: p.record_middle_s, friction_record: false, causes: &all, held_out: Default::default(), columns: Default::default() };
    let index = |effect: Effect| all.iter().position(|c| c.effect() == Some(effect)).unwrap();
    let (viscous, delay) = (index(Effect::ViscousFriction), index(Effect::TimeDelay));
    let term = |cause: usize, params: Vec<f64>| Term { cause, params, grids: Vec::new(), baseline: false };
    let spec = Spec { terms: vec![term(viscous, Vec::new()), term(delay, vec![0.005])] };
    // Without the delay the damping is negative: the lag under another name.
    let alone = held_out_errors(&model, &spec.without(delay), &p).unwrap();
    assert!(alone.fit.of(0)[0] < 0.0, "{:?}", alone.fit.of(0));
    let chosen = [viscous, delay].map(|cause| Chosen { cause, evidence: String::new(), against: None, partner: None }).into();
    let mut s = Selection { spec, chosen, rejected: Vec::new(), negligible: Vec::new(), confounded: Vec::new() };
    prune(&model, &p, &mut s, &|c| all[c].name().to_string());
    let fit = held_out_errors(&model, &s.spec, &p).unwrap().fit.clone();
    for (i, t) in s.spec.terms.iter().enumerate() {
        assert!(all[t.cause].impossible(&t.params, fit.of(i)).is_none(), "{} left at {:?}; rejected {:?}", all[t.cause].name(), fit.of(i), s.rejected);
    }
    // The delay stays: without it, the model is the one without either.
    assert!(s.spec.term(delay).is_some(), "{:?}", s.rejected);
    assert!(s.chosen.iter().all(|ch| s.spec.term(ch.cause).is_some()));
}
