//! A step test: out, held, and back. Held out as its last 30 %, the way back is all that turns,
//! and the fit sees one stroke: a loop, which shows where the motion turns, is fitted on the
//! way out alone, and the held-out part judges a baseline that never saw the return. The
//! held-out window then leaves the fit both ways (`prepare::held_out_window`).

use jointctl_ident::identify::{IdentifyOptions, identify};

/// 500 Hz for 30 s: still for 3 s, out to +4 mrad over 2 s, held until 21 s, back over 2 s,
/// still to the end. A spring of 1500 Nm/rad, eq. 3.5's friction `0.1 atan(50 v)`, and a Dahl
/// loop (limit 0.4 Nm, rest stiffness 400 Nm/rad, exact over each step) when `loop_nm` is not
/// zero; 0.03 Nm of normal noise, the deflection on a 2e-6 rad grid (a fine encoder).
fn record(loop_nm: f64) -> jointctl_ident::csv::Data {
    let x = |t: f64| 4e-3 * (((t - 3.0) / 2.0).clamp(0.0, 1.0) - ((t - 21.0) / 2.0).clamp(0.0, 1.0));
    let mut rng = jointctl_test_support::XorShift64::new(0x6a09_e667_f3bc_c908);
    let (mut t_s, mut deflection, mut torque) = (Vec::new(), Vec::new(), Vec::new());
    let (mut state, mut before) = (0.0_f64, 0.0);
    for i in 0..15_000 {
        let t = i as f64 / 500.0;
        let (now, v) = (x(t), (x(t + 1e-6) - x(t - 1e-6)) / 2e-6);
        if loop_nm > 0.0 && now != before {
            // Dahl's loop, `dF/dx = sigma (1 - F / F_c sgn dx)`, solved over the step.
            let towards = loop_nm * (now - before).signum();
            state = towards + (state - towards) * (-400.0 * (now - before).abs() / loop_nm).exp();
        }
        before = now;
        t_s.push(t);
        deflection.push((now / 2e-6).round() * 2e-6);
        torque.push(1500.0 * now + 0.1 * (50.0 * v).atan() + state + 0.03 * rng.normal());
    }
    jointctl_ident::csv::Data::from_columns(t_s, deflection, torque)
}

#[test]
fn a_loop_in_a_step_out_and_back_is_named_with_the_return_in_the_fit() {
    // Seen on the blind generator's seed-12 step on a 2e-6 rad encoder (a Dahl loop of 0.54 Nm):
    // no cause, 0.37 Nm held out for a noise floor of 0.055 (the loop fitted on the one stroke
    // came out of negative width); held out 55-85 %, the loop named (0.565 Nm, 498 Nm/rad for
    // 0.543 and 529) and 0.062 Nm left. This record's loop was named with the last 30 % held
    // out too (0.372 -> 0.030 Nm: the baseline judged on a return it never saw); what fails
    // there is the window, now 45-75 % (0.109 -> 0.030 Nm).
    let report = identify(&record(0.4), &IdentifyOptions::default()).unwrap();
    eprintln!("held out {:?}: {:.4} -> {:.4} Nm", report.held_out_window, report.rmse_before, report.rmse_after);
    let named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    assert_eq!(named, ["hysteresis"], "rejected {:?}", report.rejected);
    assert!(report.held_out_window.moved.as_deref().is_some_and(|m| m.contains("does not move both ways")), "{:?}", report.held_out_window);
    let limit = report.causes[0].params["limit_nm"];
    assert!((limit - 0.4).abs() < 0.25 * 0.4, "limit {limit} Nm for 0.4");
}

#[test]
fn a_step_out_and_back_without_a_loop_names_nothing() {
    let report = identify(&record(0.0), &IdentifyOptions::default()).unwrap();
    assert!(report.causes.is_empty(), "{:?}", report.causes.iter().map(|c| &c.effect).collect::<Vec<_>>());
}
