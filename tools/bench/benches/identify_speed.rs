//! Identification speed against the thesis' fit step on the same record, in the same run: the
//! 100 000-sample record of `jointctl_bench::hysteresis_record` (500 s at 200 Hz, a hidden Dahl
//! hysteresis), the fit step and `identify` run alternately, `IDENT_ROUNDS` rounds (default 15),
//! so that the machine's changing speed weighs on both alike. The figure is the median of the
//! per-round ratios (issue 31: identify within about 2x the fit step); `identify` runs on every
//! core, the fit step on one.

use std::time::Instant;

use jointctl_bench::{env_or, hysteresis_record, median};

fn main() {
    let rounds: usize = env_or("IDENT_ROUNDS", 15usize).max(1);
    let samples: usize = env_or("IDENT_SAMPLES", 100_000);
    let data = hysteresis_record(samples);
    // One of each first, unmeasured: page faults and lazily set-up state.
    let warm = jointctl_ident::identify::identify(&data, &Default::default()).expect("identify");
    let found = warm.causes.first().map_or("none".to_string(), |c| c.effect.clone());
    let (mut fit_s, mut ident_s, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        let t = Instant::now();
        std::hint::black_box(jointctl_ident::fit::fit(&data, &Default::default()).expect("fit"));
        let fit = t.elapsed().as_secs_f64();
        let t = Instant::now();
        std::hint::black_box(jointctl_ident::identify::identify(&data, &Default::default()).expect("identify"));
        let ident = t.elapsed().as_secs_f64();
        fit_s.push(fit);
        ident_s.push(ident);
        ratio.push(ident / fit);
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    println!("## identify against the fit step, {samples} samples (hidden hysteresis), {rounds} alternating rounds; identify on every core ({cores}), the fit step on one");
    println!("| identify median s (min) | fit median s (min) | identify / fit, median of rounds | first cause | target |");
    println!("|---|---|---|---|---|");
    println!(
        "| {:.4} ({:.4}) | {:.4} ({:.4}) | {:.2}x | {found} | within about 2x (issue 31) |",
        median(&mut ident_s.clone()),
        min(&ident_s),
        median(&mut fit_s.clone()),
        min(&fit_s),
        median(&mut ratio)
    );
}
