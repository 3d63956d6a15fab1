//! A spring's own loop beside a bearing's friction that the torque sensor does not see. On a
//! stiffness rig the element (a spring with an Iwan loop: ten spring-slider pairs that slip over
//! 1.2-27 mrad) is read by a sensor beside which a bearing carries part of the torque: the
//! reading loses a LuGre friction (Canudas de Wit et al. 1995) that pre-slides over 10 urad and
//! has a Stribeck rise (static 1.0 Nm, Coulomb 0.64 Nm). Over the training part the error of a
//! fit against a loop's scale then has two basins: a loop of a fraction of a milliradian, which
//! takes the bearing's turns as eq. 3.5's arctan cannot, and the element's own loop, a hundred
//! times wider. The narrow one fits the training part better; the held-out part refused it, and
//! the element's loop was never tried (the rig generator's seed 4, `d2-rep1.csv`: an offset alone
//! at 1.33 times the plain least-squares reference). This file's records are its own: an Iwan
//! loop and LuGre's friction, neither of them identify's Dahl loop.

use jointctl_ident::identify::{IdentifyOptions, identify};

const K_NM_PER_RAD: f64 = 575.0;
/// The element's loop: its elements' total slip force [Nm] and their slip deflections [rad].
const LOOP_NM: f64 = 0.9;
const SLIP_RAD: (f64, f64) = (1.2e-3, 27e-3);
const ELEMENTS: usize = 10;
/// The bearing's Coulomb and static levels [Nm], Stribeck speed [rad/s] and exponent, and its
/// pre-sliding deflection [rad] (the Coulomb level over the bristles' stiffness).
const COULOMB_NM: f64 = 0.64;
const STATIC_NM: f64 = 1.0;
const STRIBECK_RAD_PER_S: f64 = 4e-3;
const STRIBECK_EXPONENT: f64 = 1.7;
const PRESLIDING_RAD: f64 = 1e-5;
const OFFSET_NM: f64 = -0.7;
const NOISE_NM: f64 = 0.005;
/// The linear encoder's step [rad].
const STEP_RAD: f64 = 2e-6;
/// The simulation's rate and the logger's mean rate [Hz].
const SIM_HZ: f64 = 2000.0;
const LOG_HZ: f64 = 550.0;

/// One repetition of a stiffness test: 1 s at rest, five periods of `amplitude_rad sin(2 pi
/// frequency_hz t)`, 1 s at rest. Simulated at 2 kHz (the loop's elements and the bearing's
/// bristles exact per step, the bearing's level from the rate's central difference), then
/// logged at irregular intervals (550 Hz on average, each interval's logarithm spread by 0.1)
/// by linear interpolation; the deflection on a 2e-6 rad encoder, white noise on the torque.
fn record(amplitude_rad: f64, frequency_hz: f64, seed: u64) -> jointctl_ident::csv::Data {
    use std::f64::consts::TAU;
    let mut rng = jointctl_test_support::XorShift64::new(0x1da1_b0a7_2e11_0c5e ^ seed);
    let duration = 2.0 + 5.0 / frequency_hz;
    let n = (duration * SIM_HZ) as usize;
    let x: Vec<f64> = (0..n).map(|i| i as f64 / SIM_HZ).map(|t| if (1.0..duration - 1.0).contains(&t) { amplitude_rad * (TAU * frequency_hz * (t - 1.0)).sin() } else { 0.0 }).collect();
    let slip = |e: usize| SLIP_RAD.0 + (SLIP_RAD.1 - SLIP_RAD.0) * e as f64 / (ELEMENTS - 1) as f64;
    let force = LOOP_NM / ELEMENTS as f64;
    let mut elements = [0.0; ELEMENTS];
    let sigma0 = COULOMB_NM / PRESLIDING_RAD;
    let (mut z, mut torque) = (0.0, Vec::with_capacity(n));
    for i in 0..n {
        let step = if i == 0 { 0.0 } else { x[i] - x[i - 1] };
        for (e, f) in elements.iter_mut().enumerate() {
            *f = (*f + force / slip(e) * step).clamp(-force, force);
        }
        if step != 0.0 {
            let v = (x[(i + 1).min(n - 1)] - x[i.saturating_sub(1)]) * SIM_HZ / 2.0;
            let level = COULOMB_NM + (STATIC_NM - COULOMB_NM) * (-(v / STRIBECK_RAD_PER_S).abs().powf(STRIBECK_EXPONENT)).exp();
            let target = step.signum() * level / sigma0;
            z = target + (z - target) * (-sigma0 * step.abs() / level).exp();
        }
        torque.push(K_NM_PER_RAD * x[i] + elements.iter().sum::<f64>() - sigma0 * z + OFFSET_NM);
    }
    let (mut t_s, mut phi, mut tau) = (Vec::new(), Vec::new(), Vec::new());
    let mut t = 0.0;
    while t < duration - 1.0 / SIM_HZ {
        let at = t * SIM_HZ;
        let (i, w) = (at as usize, at.fract());
        let between = |y: &[f64]| y[i] + w * (y[(i + 1).min(n - 1)] - y[i]);
        t_s.push(t);
        phi.push((between(&x) / STEP_RAD).round() * STEP_RAD);
        tau.push(between(&torque) + NOISE_NM * rng.normal());
        t += (0.1 * rng.normal()).exp() / LOG_HZ;
    }
    jointctl_ident::csv::Data::from_columns(t_s, phi, tau)
}

/// Refused at its best scale (the bearing's turns), the loop is tried in its scale's other basin
/// and named there: the element's own sign, a scale of milliradians, and the held-out error
/// below the offset's alone. Before: the offset alone (held out 0.331 Nm on each seed; 0.317
/// with the loop).
#[test]
fn a_loop_refused_at_a_bearings_scale_is_named_at_the_elements() {
    for seed in 0..3 {
        let r = identify(&record(0.045, 0.45, seed), &IdentifyOptions::default()).unwrap();
        let names: Vec<&str> = r.causes.iter().map(|c| c.effect.as_str()).collect();
        let case = format!("seed {seed}: named {names:?}, held out {} -> {}", r.rmse_before, r.rmse_after);
        let h = r.causes.iter().find(|c| c.effect == "hysteresis").unwrap_or_else(|| panic!("{case}"));
        let (limit, scale) = (h.params["limit_nm"], h.params["limit_nm"] / h.params["sigma_nm_per_rad"]);
        assert!(limit > 0.0 && scale > 1e-3, "{case}: limit {limit} Nm, scale {scale} rad");
        assert!(h.evidence.contains("other basin"), "{case}: {}", h.evidence);
        let offset = r.causes.iter().find(|c| c.effect == "sensor_offset").unwrap_or_else(|| panic!("{case}"));
        assert!((offset.params["offset_nm"] - OFFSET_NM).abs() < 0.05, "{case}: offset {:?}", offset.params);
        assert!(r.rmse_after < 0.325, "{case}");
    }
}
