//! Whether a record has a spring: how much of its torque a straight line in the deflection
//! explains, of the whole and beside the friction (see `baseline::reads_as_friction`).

use crate::identify::design::Part;

/// The share of the torque's variance a straight line in the deflection explains on a part: the
/// larger of its share of the whole torque (the squared correlation) and of what the friction's
/// sign and a line in the rate leave (the partial share beside them). A spring beside a friction
/// several times its torque explains little of the whole (the third generator's seed 1's 053, a
/// clean record of 41 Nm/rad on 0.018 rad beside eq. 3.5's 0.96 Nm: 5 % of the variance, and it
/// was read as a friction record, a joint position and no spring, and an offset named on it), and
/// more than 20 % of what the friction leaves. The friction's sign is `tanh(v / v_s)`, `v_s` a
/// twentieth of the 95th percentile of the rate's size (an assumption: a Coulomb friction that
/// turns within the slowest twentieth of the motion; only whether the deflection adds is asked
/// of it).
pub(crate) fn spring_share(part: &Part) -> f64 {
    let n = part.len().min(part.tau.len()).min(part.v.len());
    if n < 2 {
        return 1.0;
    }
    let (mx, my) = (part.d[..n].iter().sum::<f64>() / n as f64, part.tau[..n].iter().sum::<f64>() / n as f64);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in part.d[..n].iter().zip(&part.tau[..n]) {
        sxy += (x - mx) * (y - my);
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
    }
    let whole = if sxx > 0.0 && syy > 0.0 { sxy * sxy / (sxx * syy) } else { 1.0 };
    whole.max(share_beside_friction(part, n))
}

/// The partial share of [`spring_share`]: over the samples that slide (the rate at least `v_s`,
/// where the friction's sign is set; at rest a friction record's torque is whatever held the
/// joint, and where it rests is where it stopped: over every sample, this project's stop-and-go
/// friction records, `tests/friction_stops.rs`, read as springs), the share of what the sign
/// and a line in the rate leave of the torque that a line in the deflection explains; 0 with
/// fewer than 10 such samples or collinear columns.
fn share_beside_friction(part: &Part, n: usize) -> f64 {
    let mut speeds: Vec<f64> = part.v[..n].iter().map(|v| v.abs()).collect();
    let at = (n - 1) * 95 / 100;
    let v_s = 0.05 * *speeds.select_nth_unstable_by(at, f64::total_cmp).1;
    let sliding: Vec<usize> = (0..n).filter(|i| part.v[*i].abs() >= v_s).collect();
    if v_s <= 0.0 || sliding.len() < 10 {
        return 0.0;
    }
    // The columns sign, rate, deflection and the torque, about their means.
    let column = |i: usize| [(part.v[i] / v_s).tanh(), part.v[i], part.d[i], part.tau[i]];
    let m = sliding.len() as f64;
    let mut mean = [0.0; 4];
    sliding.iter().for_each(|i| column(*i).iter().zip(&mut mean).for_each(|(x, acc)| *acc += x / m));
    let mut sums = nalgebra::Matrix4::<f64>::zeros();
    for i in &sliding {
        let c = nalgebra::Vector4::from_iterator(column(*i).iter().zip(&mean).map(|(x, acc)| x - acc));
        sums += c * c.transpose();
    }
    // Residual sums of squares of the torque on the first `k` columns.
    let rss = |k: usize| -> Option<f64> {
        let a = sums.view((0, 0), (k, k)).into_owned();
        let b = sums.view((0, 3), (k, 1)).into_owned();
        let coef = a.cholesky()?.solve(&b);
        Some(sums[(3, 3)] - (b.transpose() * coef)[(0, 0)])
    };
    match (rss(2), rss(3)) {
        (Some(without), Some(with)) if without > 0.0 => ((without - with) / without).clamp(0.0, 1.0),
        _ => 0.0,
    }
}
