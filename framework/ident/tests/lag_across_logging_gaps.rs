//! A lag behind a delay runs on through a gap in the log. The blind generator's device D (a
//! transport delay behind a first-order low-pass of the torque) logged irregularly has a gap
//! over ten median periods every quarter second or so; the lag was started again, settled on
//! the input's line, at each, and read the low-pass short: on seed 47 18.4 +- 1.4 ms where one
//! regular run of the same device reads 26.3 +- 1.3 (the generator's 22.4), on seed 60 24.5 +-
//! 3.4 ms for 58.4 +- 1.8 (58.1). Now a gap up to five time constants is bridged on the
//! input's line (`design::OutputLag::of`).

use jointctl_ident::identify::{IdentifyOptions, identify};

mod through_the_reader;

/// The lag [s] and its standard error identify reports on device D's variant `variant` of the
/// blind generator's device set `seed`, and the generator's low-pass time constant [s].
fn device_d_lag(seed: u64, variant: &str) -> (f64, f64, f64) {
    let case = jointctl_blind_gen::device_variants(seed).into_iter().find(|c| c.name.starts_with(&format!("devD_{variant}"))).expect("device D's record");
    assert_eq!(case.answer.effect, "time_delay");
    let truth_s = 1.0 / (std::f64::consts::TAU * case.answer.params["delay_fc_hz"]);
    let report = identify(&through_the_reader::blind_case(&case, "lag-gaps"), &IdentifyOptions::default()).unwrap();
    let delay = report.causes.iter().find(|c| c.effect == "time_delay").unwrap_or_else(|| panic!("no delay named: {}", report.unexplained.summary));
    let lag_s = *delay.params.get("lag_s").unwrap_or_else(|| panic!("no lag behind the delay: {:?}", delay.params));
    (lag_s, delay.uncertainty["lag_s"], truth_s)
}

#[test]
fn an_irregular_logs_lag_agrees_with_a_regular_run_of_the_same_device() {
    for seed in [47, 60] {
        let (irregular, e_irregular, truth) = device_d_lag(seed, "1_irregular");
        let (regular, e_regular, _) = device_d_lag(seed, "3_rep1");
        let apart = (irregular - regular).abs() / e_irregular.hypot(e_regular);
        assert!(apart <= 2.0, "seed {seed}: irregular {irregular:.4} +- {e_irregular:.4} s, one run {regular:.4} +- {e_regular:.4} s: {apart:.1} errors apart");
        assert!((irregular - truth).abs() <= 0.25 * truth, "seed {seed}: irregular {irregular:.4} s for the generator's {truth:.4}");
    }
}
