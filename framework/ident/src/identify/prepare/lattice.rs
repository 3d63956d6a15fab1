//! The coarse quantiser of a deflection read through two encoders, from the lattice its steps
//! lie on. The SHERPA arm's deflection is a coarse output encoder (14 bits over a turn) less a
//! fine motor encoder through the gear ratio: the reading steps by whole output counts, each
//! blurred by what the motor moved in the sample. Where the motion never holds between samples
//! (100 Hz on the simulated elbow: three to four counts a sample mid-stroke) no step is an
//! isolated tick (`rate::coarsest_tick_rad`), but the steps still gather at whole multiples of
//! the output's count, and that count is what the reading's error is made of.

use crate::identify::numeric::segment_ranges;

/// Share of a count a step may be off a whole multiple and still lie on the lattice (an
/// assumption: the motor's blur within a sample on the simulated elbow's 100 Hz recordings
/// reaches 0.2 of a count, none of its steps between 0.2 and 0.8; a steps' distribution with no
/// lattice puts half its steps this near by chance).
const OFF_LATTICE: f64 = 0.25;

/// Share of the steps on the lattice (a whole multiple, the fine steps at zero among them), and
/// share at a multiple of one or more, for a lattice to stand (assumptions: by chance half lie
/// on it; a lattice whose steps are nearly all below a count says nothing of the count).
const ON_LATTICE: f64 = 0.95;
const ON_A_COUNT: f64 = 0.2;

/// How far coarser than the reading's resolution (its smallest common step) a lattice must be to
/// be a second quantiser (below, the blur is not told from the count).
const COARSER_THAN_RESOLUTION: f64 = 4.0;

/// Steps and candidate steps read, at most (evenly through the record; cost, not accuracy).
const STEPS_READ: usize = 4096;
const CANDIDATES_FROM: usize = 200;

/// The count of the coarsest lattice the deflection's non-zero steps lie on [rad], or
/// `resolution_rad` where there is none coarser (one encoder, bin averages, an unquantised
/// signal). Candidates are steps divided by one to six counts; the largest the steps fit is
/// taken, a count within a few per cent (the blur moves it; a rule on the number of counts a
/// shape spans does not need it finer).
pub(super) fn coarse_lattice_rad(d: &[f64], starts: &[usize], resolution_rad: f64) -> f64 {
    let mut steps: Vec<f64> = segment_ranges(starts, d.len()).flat_map(|r| (r.start + 1..r.end).map(|i| (d[i] - d[i - 1]).abs())).filter(|s| *s > 0.0 && s.is_finite()).collect();
    if steps.len() < CANDIDATES_FROM {
        return resolution_rad;
    }
    let every = steps.len().div_ceil(STEPS_READ);
    steps = steps.into_iter().step_by(every).collect();
    steps.sort_by(f64::total_cmp);
    let pick = steps.len().div_ceil(CANDIDATES_FROM);
    let mut candidates: Vec<f64> = steps.iter().step_by(pick).flat_map(|s| (1..=6).map(move |k| s / k as f64)).filter(|q| *q > COARSER_THAN_RESOLUTION * resolution_rad).collect();
    candidates.sort_by(|a, b| b.total_cmp(a));
    let n = steps.len() as f64;
    candidates
        .into_iter()
        .find(|q| {
            let (mut on, mut counts) = (0usize, 0usize);
            for s in &steps {
                let m = (s / q).round();
                if (s / q - m).abs() <= OFF_LATTICE {
                    on += 1;
                    counts += usize::from(m >= 1.0);
                }
            }
            on as f64 >= ON_LATTICE * n && counts as f64 >= ON_A_COUNT * n
        })
        .map_or(resolution_rad, |q| q.max(resolution_rad))
}

#[cfg(test)]
mod tests {
    use super::coarse_lattice_rad;

    const COUNT: f64 = std::f64::consts::TAU / 16384.0;

    /// A 0.25 Hz sine of 0.08 rad read at 100 Hz by a 14-bit output encoder less a fine motor
    /// encoder that moves up to a fifth of that count a sample: its count is found, though the reading never holds.
    #[test]
    fn two_encoders_at_100_hz_give_the_coarse_count() {
        let fine = 7.67e-6;
        let d: Vec<f64> = (0..4000)
            .map(|i| {
                let t = i as f64 * 0.01;
                let out = 0.08 * (std::f64::consts::TAU * 0.25 * t).sin();
                let motor = 5e-3 * (std::f64::consts::TAU * 0.25 * t).sin();
                (out / COUNT).round() * COUNT - (motor / fine).round() * fine
            })
            .collect();
        let q = coarse_lattice_rad(&d, &[0], fine);
        // Within a few per cent: the motor's blur moves every step one way here (the motor in
        // phase with the output), and a count a little off still takes steps of a few counts.
        assert!((q / COUNT - 1.0).abs() < 0.05, "{q:e} against {COUNT:e}");
    }

    /// One encoder's count is its resolution; an unquantised sine and a fine encoder have no
    /// coarser lattice.
    #[test]
    fn one_encoder_or_none_gives_the_resolution() {
        let sine = |i: usize| 0.05 * (std::f64::consts::TAU * 0.37 * i as f64 * 0.0018).sin();
        let raw: Vec<f64> = (0..20000).map(sine).collect();
        assert_eq!(coarse_lattice_rad(&raw, &[0], 1e-9), 1e-9);
        let fine: Vec<f64> = (0..20000).map(|i| (sine(i) / 2e-6).round() * 2e-6).collect();
        assert_eq!(coarse_lattice_rad(&fine, &[0], 2e-6), 2e-6);
        let coarse: Vec<f64> = (0..20000).map(|i| (sine(i) / COUNT).round() * COUNT).collect();
        assert_eq!(coarse_lattice_rad(&coarse, &[0], COUNT), COUNT);
    }
}
