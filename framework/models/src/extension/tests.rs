//! Tests of the extension: each term against `identify`'s, the Dahl state and its dead band, the
//! rate estimate, the terms by pivot setting and the dynamic terms' low-pass.

use super::*;

#[test]
fn the_dahl_state_follows_identifys_per_step_solution_and_resets() {
    let mut e = ModelExtension::new(ExtensionSpec { hysteresis: Some(DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }), ..Default::default() }).unwrap();
    // Up by far more than lambda (4 mrad): the limit; back down: the other limit.
    assert_eq!(e.dahl_torque(0.0), 0.0);
    assert!((e.dahl_torque(0.1) - 1.2).abs() < 1e-9);
    assert!((e.dahl_torque(-0.1) + 1.2).abs() < 1e-9);
    // One lambda up from -1: u = 1 - 2 e^-1.
    let lambda = 1.2 / 300.0;
    let expected = 1.2 * (1.0 - 2.0 * (-1.0f64).exp());
    assert!((e.dahl_torque(-0.1 + lambda) - expected).abs() < 1e-12);
    e.reset();
    assert_eq!(e.dahl_torque(0.3), 0.0, "a reset state starts at zero, where it is");
}

/// A loop that runs the other way (a friction beside the torque sensor) is the mirror of the
/// loop with the opposite limit; a limit and a rest stiffness of opposite signs (no scale) or a
/// zero limit are refused by field.
#[test]
fn a_loop_that_runs_the_other_way_mirrors_its_opposite_and_mixed_signs_are_refused() {
    let spec = |sigma: f64, limit: f64| ExtensionSpec { hysteresis: Some(DahlSpec { sigma_nm_per_rad: sigma, limit_nm: limit, input_dead_band_rad: 0.0, shape: 2.0, presliding_damping_s: 0.0 }), ..Default::default() };
    let (mut up, mut down) = (ModelExtension::new(spec(300.0, 1.2)).unwrap(), ModelExtension::new(spec(-300.0, -1.2)).unwrap());
    for phi in [0.0, 0.002, 0.01, 0.004, -0.003, 0.001] {
        assert_eq!(down.dahl_torque(phi), -up.dahl_torque(phi));
    }
    for (sigma, limit) in [(-300.0, 1.2), (300.0, -1.2), (300.0, 0.0), (f64::NAN, 1.2)] {
        assert_eq!(ModelExtension::new(spec(sigma, limit)).unwrap_err().field, "hysteresis", "{sigma} {limit}");
    }
}

/// A negative pre-sliding damping is refused by field; none is not written out.
#[test]
fn a_negative_presliding_damping_is_refused_and_none_is_not_written() {
    let bad = ExtensionSpec { hysteresis: Some(DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: -0.01 }), ..Default::default() };
    assert_eq!(ModelExtension::new(bad).unwrap_err().field, "hysteresis.presliding_damping_s");
    // Without a damping the term is zero and is not written out.
    let none = DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 };
    assert!(!serde_json::to_string(&none).unwrap().contains("presliding_damping_s"));
}

#[test]
fn a_shaped_loop_steps_as_identifys_loop_step() {
    // Shape 2 from zero, one lambda up: tanh(1) of the limit; then down past zero to the other
    // side, each step as `loop_step` takes it.
    let spec = DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0, shape: 2.0, presliding_damping_s: 0.0 };
    let mut e = ModelExtension::new(ExtensionSpec { hysteresis: Some(spec), ..Default::default() }).unwrap();
    let lambda = 1.2 / 300.0;
    assert_eq!(e.dahl_torque(0.0), 0.0);
    assert!((e.dahl_torque(lambda) - 1.2 * 1f64.tanh()).abs() < 1e-5);
    let mut u = loop_step(0.0, lambda, lambda, 2.0);
    for k in 1..=40 {
        let phi = lambda - k as f64 * 2e-4;
        u = loop_step(u, -2e-4, lambda, 2.0);
        assert!((e.dahl_torque(phi) - 1.2 * u).abs() < 1e-12, "step {k}");
    }
    // A shape outside 1..MAX_LOOP_SHAPE is refused, by field.
    for shape in [0.5, MAX_LOOP_SHAPE + 1.0, f64::NAN] {
        let bad = ExtensionSpec { hysteresis: Some(DahlSpec { shape, ..spec }), ..Default::default() };
        assert_eq!(ModelExtension::new(bad).unwrap_err().field, "hysteresis.shape");
    }
}

#[test]
fn a_reading_that_flickers_inside_the_input_dead_band_leaves_the_dahl_state_at_its_limit() {
    // A stiff loop (lambda 1.3 mrad) read by a 2 um encoder that flickers one count: each
    // flicker steps the state back by 2 s / lambda and the next step returns almost nothing
    // near the limit, so without a band the flicker walks the state towards zero.
    let spec = |band: f64| ExtensionSpec { hysteresis: Some(DahlSpec { sigma_nm_per_rad: 1800.0, limit_nm: 2.4, input_dead_band_rad: band, shape: 1.0, presliding_damping_s: 0.0 }), ..Default::default() };
    let (mut bare, mut banded) = (ModelExtension::new(spec(0.0)).unwrap(), ModelExtension::new(spec(8e-6)).unwrap());
    // Loaded to the limit (20 mrad, 15 lambda), then the reading flickers between two counts.
    let (mut a, mut b) = (0.0, 0.0);
    for k in 0..=100 {
        (a, b) = (bare.dahl_torque(k as f64 * 2e-4), banded.dahl_torque(k as f64 * 2e-4));
    }
    assert!((b - 2.4).abs() < 1e-3 && (a - 2.4).abs() < 1e-3, "{a} {b}");
    for k in 0..400 {
        let phi = 0.02 - (k % 2) as f64 * 2e-6;
        (a, b) = (bare.dahl_torque(phi), banded.dahl_torque(phi));
    }
    assert!((b - 2.4).abs() < 1e-3, "behind the band the state holds its limit: {b}");
    assert!(a < 1.5, "without it the flicker walks the state off its limit: {a}");
    // A real reversal passes the band: the state turns once the reading has moved half the
    // width back, and reaches the other limit.
    for k in 0..=200 {
        b = banded.dahl_torque(0.02 - k as f64 * 2e-4);
    }
    assert!((b + 2.4).abs() < 1e-3, "{b}");
    assert!(ModelExtension::new(spec(-1e-6)).is_err(), "a negative band is refused");
}

#[test]
fn the_rate_is_a_causal_least_squares_slope_over_its_window() {
    let mut e = ModelExtension::new(ExtensionSpec { rate_window_s: 0.02, ..Default::default() }).unwrap();
    let mut w = 0.0;
    for k in 0..100 {
        let t = k as f64 * 1e-3;
        w = e.deflection_rate(t, 0.5 * t + 0.01);
    }
    assert!((w - 0.5).abs() < 1e-9, "{w}");
    // Quantised to 14 bits, a slow ramp still reads its slope to a few per cent.
    let q = std::f64::consts::TAU / 16384.0;
    e.reset();
    for k in 0..200 {
        let t = k as f64 * 1e-3;
        w = e.deflection_rate(t, ((0.2 * t) / q).round() * q);
    }
    assert!((w - 0.2).abs() < 0.03, "{w}");
}

/// A slow motion seen through 14-bit counts is a staircase: a 20 ms window holds one count
/// or none, and its slope jumps between 0 and twice the rate. The window grows until the
/// deflection spans a few counts.
#[test]
fn a_slow_staircase_of_counts_reads_as_its_slope() {
    let q = std::f64::consts::TAU / 16384.0;
    let worst = |spec: ExtensionSpec| {
        let mut e = ModelExtension::new(spec).unwrap();
        let mut worst: f64 = 0.0;
        for k in 0..2000 {
            let t = k as f64 * 1e-3;
            let w = e.deflection_rate(t, ((0.02 * t) / q).round() * q);
            if t > 0.5 {
                worst = worst.max((w - 0.02).abs());
            }
        }
        worst
    };
    let fixed = worst(ExtensionSpec { rate_resolution_rad: 0.0, ..Default::default() });
    let adaptive = worst(ExtensionSpec::default());
    assert!(fixed > 0.015, "a fixed 20 ms window misreads a count staircase by {fixed} rad/s");
    assert!(adaptive < 0.006, "the growing window reads 0.02 rad/s within {adaptive} rad/s");
}

#[test]
fn each_term_is_the_one_identify_fits() {
    let spec = ExtensionSpec {
        torque_scale: 0.9,
        cubic_nm_per_rad3: 200.0,
        dead_zone_rad: 0.01,
        viscous_nms_per_rad: 0.5,
        friction: Some(FrictionSpec { ka_nm: 0.3, kb_s_per_rad: 80.0 }),
        torque_offset_nm: -0.2,
        dynamic_terms_filter_s: 0.0,
        ..Default::default()
    };
    let mut e = ModelExtension::new(spec).unwrap();
    assert_eq!(e.elastic_deflection(0.005), 0.0, "inside the play");
    assert!((e.elastic_deflection(-0.05) + 0.04).abs() < 1e-15);
    // A ramp of 0.2 rad/s: its friction and viscous terms, the cubic and the scale.
    let mut tau = 0.0;
    let mut phi = 0.0;
    for k in 0..50 {
        let t = k as f64 * 1e-3;
        phi = 0.05 + 0.2 * t;
        tau = e.torque(t, phi, 100.0 * e.elastic_deflection(phi));
    }
    let phi_e = phi - 0.01;
    let expected = 0.9 * 100.0 * phi_e + 200.0 * phi_e.powi(3) + 0.5 * 0.2 + 0.3 * (80.0f64 * 0.2).atan() - 0.2;
    assert!((tau - expected).abs() < 1e-9, "{tau} vs {expected}");
}

/// Terms per pivot setting: at a setting the extension is that setting's flat one, sample for
/// sample; between two it weighs each parameter linearly; bad settings are errors at their field.
#[test]
fn terms_by_pivot_are_each_settings_own_and_weighted_between() {
    let a = Terms { cubic_nm_per_rad3: 300.0, hysteresis: Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.4, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }), friction: Some(FrictionSpec { ka_nm: 0.1, kb_s_per_rad: 50.0 }), ..Default::default() };
    let b = Terms { torque_scale: 0.95, dead_zone_rad: 0.002, viscous_nms_per_rad: 0.3, torque_offset_nm: -0.1, ..Default::default() };
    let flat = |t: Terms| ExtensionSpec {
        torque_scale: t.torque_scale,
        cubic_nm_per_rad3: t.cubic_nm_per_rad3,
        dead_zone_rad: t.dead_zone_rad,
        dead_zone_ramp_rad: t.dead_zone_ramp_rad,
        viscous_nms_per_rad: t.viscous_nms_per_rad,
        friction: t.friction,
        hysteresis: t.hysteresis,
        torque_offset_nm: t.torque_offset_nm,
        ..Default::default()
    };
    let by_pivot = ExtensionSpec { by_pivot: vec![PivotTerms { pivot_mm: 10.0, terms: a }, PivotTerms { pivot_mm: 35.0, terms: b }], ..Default::default() };
    let run = |spec: ExtensionSpec, pivot_mm: f64| {
        let mut e = ModelExtension::new(spec).unwrap();
        (0..500)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let phi = 0.05 * (6.0 * t).sin();
                e.at_pivot(pivot_mm);
                let curve = 90.0 * e.elastic_deflection(phi);
                e.torque(t, phi, curve)
            })
            .collect::<Vec<f64>>()
    };
    assert_eq!(run(by_pivot.clone(), 10.0), run(flat(a), 10.0));
    assert_eq!(run(by_pivot.clone(), 35.0), run(flat(b), 35.0));
    assert_eq!(run(by_pivot.clone(), 50.0), run(flat(b), 50.0), "beyond the last setting, its terms");
    assert_eq!(run(by_pivot.clone(), 20.0), run(flat(a.blend(&b, 0.4)), 20.0));
    let mid = a.blend(&b, 0.4);
    assert!((mid.cubic_nm_per_rad3 - 180.0).abs() < 1e-9 && (mid.dead_zone_rad - 0.0008).abs() < 1e-12);
    assert_eq!(mid.hysteresis, Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.4 * 0.6, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 }));

    let err = |spec: ExtensionSpec| ModelExtension::new(spec).unwrap_err();
    let both = ExtensionSpec { cubic_nm_per_rad3: 1.0, ..by_pivot.clone() };
    assert_eq!(err(both).field, "by_pivot");
    let mut backwards = by_pivot.clone();
    backwards.by_pivot.reverse();
    let e = err(backwards);
    assert_eq!(e.field, "by_pivot[1].pivot_mm");
    assert!(e.message.contains("increasing"), "{e}");
    let mut bad = by_pivot;
    bad.by_pivot[1].terms.hysteresis = Some(DahlSpec { sigma_nm_per_rad: -1.0, limit_nm: 0.2, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 });
    assert_eq!(err(bad).field, "by_pivot[1].terms.hysteresis");
}

#[test]
fn terms_by_pivot_read_from_yaml_like_json() {
    let s: ExtensionSpec = serde_json::from_str(r#"{"by_pivot": [{"pivot_mm": 10, "terms": {"cubic_nm_per_rad3": 318}}, {"pivot_mm": 20, "terms": {}}]}"#).unwrap();
    assert_eq!(s.by_pivot.len(), 2);
    assert_eq!(s.by_pivot[1].terms, Terms::default());
    assert!(serde_json::from_str::<ExtensionSpec>(r#"{"by_pivot": [{"pivot_mm": 10, "terms": {"cubic": 1}}]}"#).is_err(), "an unknown term is refused");
}

/// The history- and rate-driven terms reach the torque through a first-order low-pass: a
/// Dahl loop reversed at once moves the torque by 63 % of its swing in one time constant, the
/// static terms at once; with no filter, the swing is there at once.
#[test]
fn the_dynamic_terms_are_low_passed_and_the_static_ones_are_not() {
    let hysteresis = Some(DahlSpec { sigma_nm_per_rad: 1e6, limit_nm: 1.0, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.0 });
    let run = |filter_s: f64| {
        let mut e = ModelExtension::new(ExtensionSpec { hysteresis, torque_offset_nm: 0.5, dynamic_terms_filter_s: filter_s, ..Default::default() }).unwrap();
        // Up (u = +1, settled), then one step down (u = -1 at once: sigma is huge).
        let mut t = 0.0;
        for k in 0..1000 {
            t = k as f64 * 1e-3;
            e.torque(t, 1e-3 * k as f64, 0.0);
        }
        let start = e.torque(t + 1e-3, 0.998, 0.0);
        let mut at_tau = start;
        for k in 2..=51 {
            at_tau = e.torque(t + k as f64 * 1e-3, 0.998, 0.0);
        }
        (start, at_tau)
    };
    let (start, _) = run(0.0);
    assert!((start - (0.5 - 1.0)).abs() < 1e-9, "unfiltered: the reversed loop at once, {start}");
    let (start, after) = run(0.05);
    assert!(start > 0.5 + 1.0 - 2.0 * 0.05, "filtered: a millisecond in, the torque has barely moved: {start}");
    let moved = (0.5 + 1.0 - after) / 2.0;
    assert!((moved - 0.63).abs() < 0.03, "one time constant later, {moved} of the swing");
    assert!(ModelExtension::new(ExtensionSpec { dynamic_terms_filter_s: -1.0, ..Default::default() }).is_err());
}

/// Through [`ModelExtension::torque`], with the observer's causal rate: the pre-sliding damping
/// follows `F_c tau_d du/dt` of the state's true motion (what `identify` fits, the loop's law
/// at a centred rate), also just after a turn, where the causal rate estimate still points the
/// old way. Along a 1 Hz sine the law at that estimate was off by 0.58 of the term's RMS; on a
/// 14-bit reading with the default low-pass the state's step is compared with the exact term
/// through the same low-pass.
#[test]
fn the_presliding_damping_through_torque_follows_the_states_motion_after_a_turn() {
    let count_14_bit_rad = std::f64::consts::TAU / 16384.0;
    // (shape, frequency [Hz], low-pass [s], reading's count [rad] (0: exact), largest RMS error
    // as a share of the term's RMS)
    let cases = [(1.0, 1.0, 0.0, 0.0, 0.05), (1.0, 0.2, 0.0, 0.0, 0.05), (3.0, 1.0, 0.0, 0.0, 0.05), (1.0, 1.0, 0.05, count_14_bit_rad, 0.15), (1.0, 0.2, 0.05, count_14_bit_rad, 0.35)];
    for (shape, frequency_hz, filter_s, count_rad, largest) in cases {
        let spec = |presliding_damping_s| ExtensionSpec {
            hysteresis: Some(DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0, shape, presliding_damping_s }),
            dynamic_terms_filter_s: filter_s,
            ..Default::default()
        };
        let (mut damped, mut bare) = (ModelExtension::new(spec(0.015)).unwrap(), ModelExtension::new(spec(0.0)).unwrap());
        let (dt, w0, lambda) = (1e-3, std::f64::consts::TAU * frequency_hz, 1.2 / 300.0);
        let read = |x: f64| if count_rad > 0.0 { (x / count_rad).round() * count_rad } else { x };
        let (mut err2, mut term2, mut u, mut expected) = (0.0, 0.0, 0.0, 0.0);
        for k in 1..=(3.0 / frequency_hz / dt) as usize {
            let t = k as f64 * dt;
            let (phi, w) = (0.02 * (w0 * t).sin(), 0.02 * w0 * (w0 * t).cos());
            let damping = damped.torque(t, read(phi), 0.0) - bare.torque(t, read(phi), 0.0);
            u = loop_step(u, phi - 0.02 * (w0 * (t - dt)).sin(), lambda, shape);
            let exact = 1.2 * 0.015 * loop_rate(u, w, lambda, shape);
            expected = if filter_s > 0.0 { expected + (exact - expected) * dt / (filter_s + dt) } else { exact };
            // After the first half period: the state starts at zero, off the loop.
            if t > 0.5 / frequency_hz {
                err2 += (damping - expected).powi(2);
                term2 += expected * expected;
            }
        }
        let ratio = (err2 / term2).sqrt();
        assert!(ratio < largest, "shape {shape}, {frequency_hz} Hz, low-pass {filter_s} s, count {count_rad} rad: off by {ratio:.3} of the term's RMS");
    }
}
