//! The drive amplitudes of a device's test at several levels (`amplitudes<N>`): from the
//! device's usual amplitude down to where each of its hidden effects is still clearly present.

use super::Setup;
use super::answer::only_cause;
use super::sizing::Grid;
use super::timeline::Timeline;
use crate::model;

/// Each cause's unexplained RMS over the noise wanted at the lowest level: the smallest target
/// the generator draws for an effect.
const FLOOR: f64 = 1.5;

/// `n` relative drive amplitudes (rounded to 0.001), evenly spread from the lowest level to 1.0
/// (the amplitude of the device's other variants); 1.0 alone for one level. The lowest level is
/// the smallest of 0.40, 0.45, ... 0.80 at which every cause is predicted at `FLOOR` x noise or
/// more; 0.80 for a device whose effects are weak even at its usual amplitude (they then stay
/// above 0.8 x their size there). No random draws.
pub fn drive_levels(setup: &Setup, n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![1.0];
    }
    // Whole hundredths, so the levels print as short decimals.
    let (first, step, last) = (40, 5, 80);
    let lo_pct = (first..=last)
        .step_by(step)
        .find(|&p| weakest_ratio(setup, f64::from(p) / 100.0) >= FLOOR)
        .unwrap_or(last);
    let lo = f64::from(lo_pct) / 100.0;
    (0..n)
        .map(|i| {
            let s = lo + (1.0 - lo) * i as f64 / (n - 1) as f64;
            (s * 1000.0).round() / 1000.0
        })
        .collect()
}

/// The smallest ratio of a cause's unexplained RMS to the output noise over one run of the
/// test at relative amplitude `s`, predicted on the sizing grid (infinite without causes).
fn weakest_ratio(setup: &Setup, s: f64) -> f64 {
    let ph = &setup.physics;
    let tl = Timeline::build(setup, &[s], &[]);
    let grid = Grid::new(&ph.baseline(), &tl);
    let noise = setup.noise_white.hypot(setup.noise_col).max(1e-300);
    setup
        .causes
        .iter()
        .map(|&c| {
            let only = only_cause(ph, c);
            let unit: Option<Vec<f64>> = only.hysteresis.as_ref().map(|h| {
                let u = model::simulate_hysteresis_unit(&h.model, &tl.phi, tl.dt_s);
                grid.idx.iter().map(|&i| u[i]).collect()
            });
            grid.unexplained(&grid.contribution(&only, &tl, unit.as_deref())) / noise
        })
        .fold(f64::INFINITY, f64::min)
}
