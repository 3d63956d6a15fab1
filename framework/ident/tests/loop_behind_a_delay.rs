//! A wide hysteresis loop read through a torque channel that is late: the delay is a negative
//! damping, the loop a positive one, and each hides the other. Alone the loop's fit is
//! impossible (a negative width) and the delay's held-out gain is not consistent; searched again
//! beside the delay, the loop is found and the two are named together.

use jointctl_ident::identify::{IdentifyOptions, identify};

mod through_the_reader;

#[test]
fn a_loop_hidden_by_a_delay_is_searched_again_beside_it_and_both_are_named() {
    // Found on the blind generator's seed 49 (its 097: a LuGre loop of 2.07 Nm over 0.08 rad
    // behind a 54.8 ms transport delay on a 39 Nm/rad spring, 17-bit encoder, 2 kHz, 0.34 Nm
    // of noise), and this test reads that record: no cause at 3.2 times the floor (held out
    // 1.082 Nm), the loop refused as impossible alone, the delay's held-out gain 7 times the
    // relevance threshold but its blocks at t = 0.7. Not reproduced on a generator of this
    // file's own (a Dahl loop behind a delay, sweeps that grow or shrink, 16 records: both
    // named before and after the change), so the record it was found on is the test; over
    // 2588 generated records two reports changed (docs/benchmarks.md).
    let spec = jointctl_blind_gen::suite_plan(49).into_iter().find(|s| s.name.starts_with("097_")).expect("the blind suite's 097");
    let (case, _) = spec.generate().expect("the blind suite's 097");
    let report = identify(&through_the_reader::blind_case(&case, "loop-behind-delay"), &IdentifyOptions::default()).unwrap();
    let mut named: Vec<&str> = report.causes.iter().map(|c| c.effect.as_str()).collect();
    named.sort();
    assert_eq!(named, ["hysteresis", "time_delay"], "held out {:.4} -> {:.4} Nm", report.rmse_before, report.rmse_after);
    let delay = report.causes.iter().find(|c| c.effect == "time_delay").map_or(0.0, |c| c.params["delay_s"]);
    let limit = report.causes.iter().find(|c| c.effect == "hysteresis").map_or(0.0, |c| c.params["limit_nm"]);
    assert!((delay / case.answer.params["delay"] - 1.0).abs() < 0.1, "delay {delay} s");
    assert!((limit / case.answer.params["force"] - 1.0).abs() < 0.25, "limit {limit} Nm");
    assert!(report.rmse_after < 1.5 * report.unexplained.noise_floor_nm, "held out {:.4} Nm", report.rmse_after);
}
