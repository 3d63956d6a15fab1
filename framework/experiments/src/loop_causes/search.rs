//! The searches of the loop's values: a grid then a finer look around its best (one value), and
//! the Nelder-Mead simplex (several values that trade off); and the error they minimise.

use jointctl_ident::identify::significance::blocks_for;

/// A replay's error over the samples `keep` selects: the geometric mean of the RMS of their
/// blocks, cut as the held-out test cuts its own ([`blocks_for`]) [rad].
///
/// The fits' objective. A replayed drive can part from the recorded one for a few hundred
/// milliseconds: its profile lands on a set-point it crosses and stops there, and whether a
/// crossing falls in a step turns on a millisecond of the set-points' timing. Such a stretch is
/// 0.1 rad off where the rest is 1e-3, so in the plain mean of squares it outweighs everything
/// else, and the values that happen to avoid it win: a shoulder session's command latency was
/// fitted at 24 ms for 50 (a CI run). In the log of each block's error, a block holding such a
/// stretch (35 samples, 15 of them 0.126 rad off) counts as much as halving the error in six
/// others. The held-out test judges its blocks' log ratios the same way.
///
/// A block's mean square is floored at 1e-6 of the blocks' median: a block a thousand times
/// closer (in RMS) than the typical one says nothing more, and a block of exactly zero error (a
/// noise-free record at rest, where the replay is exact) would be minus infinity in the log.
pub(super) fn block_rms_where(sq: &[f64], keep: impl Fn(usize) -> bool) -> f64 {
    let v: Vec<f64> = sq.iter().enumerate().filter(|(i, e)| keep(*i) && e.is_finite()).map(|(_, e)| *e).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    // (No more blocks than samples: a block is never empty.)
    let blocks = blocks_for(v.len()).min(v.len());
    let mut means: Vec<f64> = (0..blocks)
        .map(|b| {
            let part = &v[b * v.len() / blocks..(b + 1) * v.len() / blocks];
            part.iter().sum::<f64>() / part.len() as f64
        })
        .collect();
    let mut sorted = means.clone();
    sorted.sort_by(f64::total_cmp);
    let floor = (1e-6 * sorted[blocks / 2]).max(f64::MIN_POSITIVE);
    means.iter_mut().for_each(|m| *m = m.max(floor));
    (0.5 * means.iter().map(|m| m.ln()).sum::<f64>() / blocks as f64).exp()
}

/// The minimum of `f` over `[lo, hi]`: a grid of 41 points, then around the best at `step`.
pub(super) fn search(lo: f64, hi: f64, step: f64, f: impl Fn(f64) -> f64) -> f64 {
    let coarse = (hi - lo) / 40.0;
    let mut best = (lo, f64::INFINITY);
    for k in 0..=40 {
        let x = lo + coarse * k as f64;
        let v = f(x);
        if v < best.1 {
            best = (x, v);
        }
    }
    let (a, b) = ((best.0 - coarse).max(lo), (best.0 + coarse).min(hi));
    let n = ((b - a) / step).round() as usize;
    for k in 0..=n {
        let x = a + step * k as f64;
        let v = f(x);
        if v < best.1 {
            best = (x, v);
        }
    }
    best.0
}

/// The minimum of `f` near `start` by the Nelder-Mead simplex (`steps`: the first simplex's
/// edges), after at most `iterations`.
pub(super) fn nelder_mead<const N: usize>(f: impl Fn([f64; N]) -> f64, start: [f64; N], steps: [f64; N], iterations: usize) -> [f64; N] {
    let mut simplex: Vec<([f64; N], f64)> = (0..=N)
        .map(|k| {
            let mut x = start;
            if k > 0 {
                x[k - 1] += steps[k - 1];
            }
            (x, f(x))
        })
        .collect();
    let along = |a: &[f64; N], b: &[f64; N], t: f64| -> [f64; N] { std::array::from_fn(|i| a[i] + t * (b[i] - a[i])) };
    for _ in 0..iterations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let centroid: [f64; N] = std::array::from_fn(|i| simplex[..N].iter().map(|p| p.0[i]).sum::<f64>() / N as f64);
        let worst = simplex[N];
        let reflected = along(&centroid, &worst.0, -1.0);
        let fr = f(reflected);
        if fr < simplex[0].1 {
            let expanded = along(&centroid, &worst.0, -2.0);
            let fe = f(expanded);
            simplex[N] = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < simplex[N - 1].1 {
            simplex[N] = (reflected, fr);
        } else {
            let contracted = along(&centroid, &worst.0, 0.5);
            let fc = f(contracted);
            if fc < worst.1 {
                simplex[N] = (contracted, fc);
            } else {
                let best = simplex[0].0;
                for p in simplex.iter_mut().skip(1) {
                    p.0 = along(&best, &p.0, 0.5);
                    p.1 = f(p.0);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0].0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simplex_follows_a_narrow_valley() {
        // Rosenbrock's valley: the minimum at (1, 1).
        let x = nelder_mead(|x: [f64; 2]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2), [-1.0, 1.0], [0.1, 0.1], 2000);
        assert!((x[0] - 1.0).abs() < 1e-3 && (x[1] - 1.0).abs() < 1e-3, "{x:?}");
    }

    #[test]
    fn the_search_finds_a_minimum_between_grid_points() {
        let x = search(0.0, 0.2, 0.0005, |l| (l - 0.0317).abs());
        assert!((x - 0.0317).abs() <= 0.00025, "{x}");
    }
}
