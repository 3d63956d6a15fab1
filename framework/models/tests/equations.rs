//! Each thesis equation against values computed by hand, and the characteristic properties.

use std::f64::consts::PI;

use jointctl_models::assumed::{shoulder_spec, wrist_spec};
use jointctl_models::characteristic::*;
use jointctl_models::lever_arm::*;
use jointctl_models::transmission::*;
use proptest::prelude::*;

#[test]
fn eq_2_6_by_hand() {
    // l = 150 mm, q = 50 mm, R = 30 mm, k_s = 30 kN/m: ((100/50) * 0.03)^2 * 30000 = 0.0036 * 30000 = 108
    assert!((eq_2_6_stiffness(0.15, 0.05, 0.03, 30_000.0) - 108.0).abs() < 1e-9);
    // Eq. 2.5 is eq. 2.6 times the deflection; eq. 2.1 for phi = pi/6: 2 * 0.5 * 0.03 = 0.03 m.
    assert!((eq_2_5_torque(0.15, 0.05, 0.03, 30_000.0, 0.1) - 10.8).abs() < 1e-9);
    assert!((eq_2_1_spring_elongation(0.15, 0.05, 0.03, PI / 6.0) - 0.03).abs() < 1e-12);
    // The pivot setting moves q: 20 mm on a 30 mm offset is q = 50 mm.
    let lever = LeverArm { lever_length_m: 0.15, crank_radius_m: 0.03, spring_n_per_m: 30_000.0, pivot_offset_m: 0.03 };
    assert!((lever.stiffness_at(20.0) - 108.0).abs() < 1e-9);
}

#[test]
fn eq_3_4_3_7_3_8_by_hand() {
    // Ns = 24, Nr = 72: ring fixed, sun 1 rad/s -> carrier 24/96 = 0.25 rad/s.
    assert!((eq_3_4_planet_carrier(0.0, 1.0, 24.0, 72.0) - 0.25).abs() < 1e-15);
    // Both: 0.5 * 72/96 + 2 * 24/96 = 0.375 + 0.5 = 0.875.
    assert!((eq_3_4_planet_carrier(0.5, 2.0, 24.0, 72.0) - 0.875).abs() < 1e-15);
    // Eq. 3.7: phi1 = 0.5, phi2 = -0.1 -> theta_x = 0.2, theta_y = 0.3.
    let (x, y) = eq_3_7_bevel(0.5, -0.1);
    assert!((x - 0.2).abs() < 1e-15 && (y - 0.3).abs() < 1e-15);
    // Eq. 3.6 with d1/d2 = 2 doubles theta_y.
    assert!((eq_3_6_bevel(0.5, -0.1, 2.0, 1.0).1 - 0.6).abs() < 1e-15);
    // Eq. 3.8: theta_pc = 1.6, Ns/(Ns+Nr) = 0.25, belt 30/40 -> expected 0.3; measured 0.28 -> 0.02.
    let expected = eq_3_8_expected_bevel_input(1.6, 24.0, 72.0, 30.0 / 40.0);
    assert!((expected - 0.3).abs() < 1e-15);
    assert!((eq_3_8_deflection(expected, 0.28) - 0.02).abs() < 1e-15);
}

#[test]
fn polar_round_trip_in_all_four_quadrants() {
    for (x, y, theta) in [(1.0, 1.0, PI / 4.0), (-1.0, 1.0, 3.0 * PI / 4.0), (-1.0, -1.0, -3.0 * PI / 4.0), (1.0, -1.0, -PI / 4.0)] {
        let (r, th) = eq_b_2_polar(x, y);
        assert!((r - 2f64.sqrt()).abs() < 1e-12);
        assert!((th - theta).abs() < 1e-12, "quadrant of ({x}, {y}): {th}");
        let (x2, y2) = eq_b_3_cartesian(r, th);
        assert!((x2 - x).abs() < 1e-12 && (y2 - y).abs() < 1e-12);
    }
}

fn two_settings() -> PivotCharacteristic {
    PivotCharacteristic::from_spec(&CharacteristicSpec {
        source: Source::Assumed,
        curves: vec![
            CurveSpec { pivot_mm: Some(0.0), angle_deg: None, coefficients: None, positive: Some(vec![100.0]), negative: Some(vec![80.0]), offset_nm: None, stiffness_nm_per_rad: 90.0, range_rad: None },
            CurveSpec { pivot_mm: Some(10.0), angle_deg: None, coefficients: Some(vec![20.0, 0.0, 100.0]), positive: None, negative: None, offset_nm: None, stiffness_nm_per_rad: 30.0, range_rad: None },
        ],
    })
    .unwrap()
}

#[test]
fn pivot_interpolation_at_between_and_beyond_the_settings() {
    let c = two_settings();
    // At a setting: that curve alone.
    let e = c.evaluate(0.0, 0.1);
    assert_eq!((e.torque_nm, e.stiffness_nm_per_rad, e.clamped), (10.0, 90.0, false));
    // Between: weight 0.25 on the second: 0.75 * 10 + 0.25 * (2 + 0.1) = 8.025; stiffness 75.
    let e = c.evaluate(2.5, 0.1);
    assert!((e.torque_nm - 8.025).abs() < 1e-12 && (e.stiffness_nm_per_rad - 75.0).abs() < 1e-12 && !e.clamped);
    // Negative branch: 0.75 * (80 * -0.1) + 0.25 * (-2 - 0.1) = -6.525.
    assert!((c.evaluate(2.5, -0.1).torque_nm + 6.525).abs() < 1e-12);
    // Beyond: clamped to the nearest setting and flagged, not extrapolated.
    let e = c.evaluate(14.0, 0.1);
    assert!(e.clamped && (e.torque_nm - 2.1).abs() < 1e-12 && e.stiffness_nm_per_rad == 30.0);
    let e = c.evaluate(-3.0, 0.1);
    assert!(e.clamped && e.torque_nm == 10.0);
    // The inverse of the stiffness table.
    assert!((c.pivot_for_stiffness(60.0).unwrap() - 5.0).abs() < 1e-12);
    assert_eq!(c.pivot_for_stiffness(500.0), Some(0.0));
}

#[test]
fn a_bad_spec_names_the_field() {
    let mut spec = shoulder_spec();
    spec.curves[3].positive = None;
    assert_eq!(PivotCharacteristic::from_spec(&spec).unwrap_err().field, "curves[3]");
    let mut spec = shoulder_spec();
    spec.curves[2].stiffness_nm_per_rad = -1.0;
    assert_eq!(PivotCharacteristic::from_spec(&spec).unwrap_err().field, "curves[2].stiffness_nm_per_rad");
    let mut spec = wrist_spec();
    spec.curves.remove(5);
    assert!(WristCharacteristic::from_spec(&spec).unwrap_err().message.contains("same directions"));
}

#[test]
fn a_characteristic_whose_torque_does_not_rise_over_its_range_is_refused() {
    // Issue 40, finding 10 (the runtime's half): a curve with a positive first-order stiffness
    // that turns down inside the spring's range loaded as any other, whoever wrote the file.
    // The shoulder's assumed curves (cubics fitted up to their maximum torque) turn down beyond
    // the deflections they were fitted over: refused over the default range, accepted over their own.
    let mut spec = shoulder_spec();
    spec.curves[0].range_rad = None;
    let e = PivotCharacteristic::from_spec(&spec).unwrap_err();
    assert_eq!(e.field, "curves[0]");
    assert!(e.message.contains("does not rise") && e.message.contains("give `range_rad`"), "{}", e.message);
    assert!(PivotCharacteristic::from_spec(&shoulder_spec()).is_ok());
    // A falling curve (a negative cubic strong enough to turn within 0.1 rad) over a range that
    // says so; and a range written the wrong way round.
    let falling = CurveSpec { pivot_mm: Some(0.0), angle_deg: None, coefficients: Some(vec![100.0, 0.0, -20_000.0]), positive: None, negative: None, offset_nm: None, stiffness_nm_per_rad: 90.0, range_rad: Some([-0.1, 0.1]) };
    let one = |c: CurveSpec| PivotCharacteristic::from_spec(&CharacteristicSpec { source: Source::Measured, curves: vec![c] });
    let e = one(falling.clone()).unwrap_err();
    assert!(e.message.contains("does not rise with deflection at -0.09") && !e.message.contains("default"), "{}", e.message);
    assert!(one(CurveSpec { range_rad: Some([-0.03, 0.03]), ..falling.clone() }).is_ok());
    assert_eq!(one(CurveSpec { range_rad: Some([0.03, -0.03]), ..falling }).unwrap_err().field, "curves[0].range_rad");
}

#[test]
fn assumed_tables_follow_the_lever_arm_model() {
    let shoulder = PivotCharacteristic::from_spec(&shoulder_spec()).unwrap();
    assert_eq!(shoulder.pivots_mm(), &[0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0]);
    let wrist = WristCharacteristic::from_spec(&wrist_spec()).unwrap();
    assert_eq!(wrist.pivots_mm().len(), 11);
    // Stiffer at a small pivot setting than at a large one (eq. 2.6: K falls as q grows).
    assert!(shoulder.stiffness(0.0) > 5.0 * shoulder.stiffness(45.0));
    // The first-order fit is near the lever-arm stiffness (below it: dead-zone and asymmetry).
    let k = jointctl_models::assumed::SHOULDER_LEVER.stiffness_at(20.0);
    let fit = shoulder.stiffness(20.0);
    assert!(fit < k && fit > 0.6 * k, "{fit} vs {k}");
    // Asymmetric like figure 3.14: the negative branch is softer.
    assert!(shoulder.evaluate(20.0, 0.1).torque_nm > -shoulder.evaluate(20.0, -0.1).torque_nm);
}

static SHOULDER: std::sync::LazyLock<PivotCharacteristic> =
    std::sync::LazyLock::new(|| PivotCharacteristic::from_spec(&shoulder_spec()).unwrap());
static WRIST: std::sync::LazyLock<WristCharacteristic> =
    std::sync::LazyLock::new(|| WristCharacteristic::from_spec(&wrist_spec()).unwrap());

fn shoulder() -> &'static PivotCharacteristic {
    &SHOULDER
}

fn wrist() -> &'static WristCharacteristic {
    &WRIST
}

static SPEC: std::sync::LazyLock<CharacteristicSpec> = std::sync::LazyLock::new(wrist_spec);

proptest! {
    #[test]
    fn zero_deflection_gives_zero_torque(p in -5.0..55.0f64) {
        prop_assert_eq!(shoulder().evaluate(p, 0.0).torque_nm, 0.0);
        let w = wrist().evaluate(p, 0.0, 0.0);
        prop_assert_eq!((w.torque_q6_nm, w.torque_q7_nm), (0.0, 0.0));
    }

    #[test]
    fn shoulder_torque_is_continuous_across_branches_and_pivots(p in 0.0..45.0f64, x in -0.2..0.2f64) {
        let c = shoulder();
        let h = 1e-7;
        let t = c.evaluate(p, x).torque_nm;
        // Across the branch boundary and any pivot boundary, a tiny step makes a tiny change.
        prop_assert!((c.evaluate(p, x + h).torque_nm - t).abs() < 1e-3);
        prop_assert!((c.evaluate(p + h, x).torque_nm - t).abs() < 1e-3);
        for boundary in [5.0, 25.0] {
            let below = c.evaluate(boundary - h, x).torque_nm;
            let above = c.evaluate(boundary + h, x).torque_nm;
            prop_assert!((above - below).abs() < 1e-3, "jump at pivot {}: {} vs {}", boundary, below, above);
        }
        prop_assert!((c.evaluate(p, h).torque_nm - c.evaluate(p, -h).torque_nm).abs() < 1e-3);
    }

    #[test]
    fn wrist_torque_is_continuous_in_direction_and_pivot(p in 0.0..50.0f64, r in 0.0..0.3f64, theta in -PI..PI) {
        let w = wrist();
        let h = 1e-7;
        let (x, y) = (r * theta.cos(), r * theta.sin());
        let a = w.evaluate(p, y, x);
        let b = w.evaluate(p + h, y + h, x - h);
        prop_assert!((a.torque_q6_nm - b.torque_q6_nm).abs() < 1e-3 && (a.torque_q7_nm - b.torque_q7_nm).abs() < 1e-3);
        // Across the fold at 180 deg (the negative x axis): same torque from both sides.
        let up = w.evaluate(p, h, -r);
        let down = w.evaluate(p, -h, -r);
        prop_assert!((up.torque_q7_nm - down.torque_q7_nm).abs() < 1e-3);
    }

    #[test]
    fn swapping_q6_and_q7_is_consistent(p in 0.0..50.0f64, a in -0.3..0.3f64, b in -0.3..0.3f64) {
        // A wrist whose 0 and 90 deg curves are equal and whose 45/135 deg curves are odd is
        // symmetric under swapping q6 and q7: swapping the deflections swaps the torques.
        let mut spec = SPEC.clone();
        for c in &mut spec.curves {
            let k = jointctl_models::assumed::WRIST_LEVER.stiffness_at(c.pivot_mm.unwrap());
            c.coefficients = Some(match c.angle_deg {
                Some(a) if a == 0.0 || a == 90.0 => vec![k, 2.0 * k, 5.0 * k],
                _ => vec![1.1 * k, 0.0, 4.0 * k],
            });
        }
        let w = WristCharacteristic::from_spec(&spec).unwrap();
        let e = w.evaluate(p, a, b);
        let s = w.evaluate(p, b, a);
        prop_assert!((e.torque_q6_nm - s.torque_q7_nm).abs() < 1e-9, "{:?} vs {:?}", e, s);
        prop_assert!((e.torque_q7_nm - s.torque_q6_nm).abs() < 1e-9);
    }

    #[test]
    fn the_shoulder_differential_round_trips(q2 in -2.0..2.0f64, q3 in -2.0..2.0f64) {
        let (a2, a3) = eq_3_3_shoulder_actuators(q2, q3);
        let (r2, r3) = eq_3_3_shoulder_joints(a2, a3);
        prop_assert!((r2 - q2).abs() < 1e-12 && (r3 - q3).abs() < 1e-12);
    }
}
