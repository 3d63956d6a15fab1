//! Velocity reversals: where a structure is rung.

/// Indices of the turning points of the deflection (where its rate changes sign), debounced: a
/// turning point counts once the deflection has come back from it by a tenth of its range (an
/// assumption: noise and quantisation near a turning point are far smaller, and a real stroke far
/// larger).
///
/// ```
/// let d: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.01).sin()).collect();
/// assert_eq!(jointctl_ident::identify::causes::reversals(&d), vec![157, 471, 785]);
/// ```
pub fn reversals(deflection_rad: &[f64]) -> Vec<usize> {
    let d = deflection_rad;
    let (lo, hi) = d.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
    let back = 0.1 * (hi - lo);
    let mut out = Vec::new();
    // Direction of the current stroke (0: not yet known) and its extreme so far.
    let (mut dir, mut top, mut bottom) = (0i8, 0usize, 0usize);
    for i in 1..d.len() {
        if d[i] > d[top] {
            top = i;
        }
        if d[i] < d[bottom] {
            bottom = i;
        }
        if dir >= 0 && d[top] - d[i] > back {
            if dir > 0 {
                out.push(top);
            }
            (dir, bottom) = (-1, i);
        } else if dir <= 0 && d[i] - d[bottom] > back {
            if dir < 0 {
                out.push(bottom);
            }
            (dir, top) = (1, i);
        }
    }
    out
}

/// How finely the log shows the motion where it turns [rad]: the deflection's first step away
/// from each turning point ([`reversals`]: to the first sample that differs from the extreme, in
/// the same segment of contiguous logging, `starts`), the median over the record's turns (the
/// upper of the middle two); 0 when no turn has a next sample in its segment. A step that is
/// not finite is left out. A fast log turns by a count or less; a slow log of bin means jumps, its
/// first bin after a turn already far from it (the blind devices' 20 Hz means: 4e-3 to 3.5e-2
/// rad; 16 to 126 times the false loops named on three of them).
///
/// ```
/// use jointctl_ident::identify::causes::turn_step_rad;
/// // Out to 1 and back, the turn's last rise 0.2, its first fall 0.3 (after a held sample).
/// let d = [0.0, 0.4, 0.8, 1.0, 1.0, 0.7, 0.3, 0.0];
/// assert!((turn_step_rad(&d, &[0]) - 0.3).abs() < 1e-12);
/// ```
pub fn turn_step_rad(deflection_rad: &[f64], starts: &[usize]) -> f64 {
    let d = deflection_rad;
    let mut steps: Vec<f64> = reversals(d)
        .into_iter()
        .filter_map(|r| {
            let next = (r + 1..d.len()).find(|j| d[*j] != d[r])?;
            // Not across a gap: the next segment's first sample is no step of this motion.
            let step = (d[next] - d[r]).abs();
            (step.is_finite() && !starts.iter().any(|s| *s > r && *s <= next)).then_some(step)
        })
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    let middle = steps.len() / 2;
    *steps.select_nth_unstable_by(middle, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::turn_step_rad;

    #[test]
    fn a_turn_steps_within_its_segment_only() {
        // Out to 1 and back twice; the first turn's next sample opens a new segment (a gap).
        let d = [0.0, 0.5, 1.0, 0.9, 0.0, 0.5, 1.0, 0.6, 0.0];
        // Turns at 1.0 (sample 2), 0.0 (4) and 1.0 (6); their steps 0.1, 0.5 and 0.4.
        assert!((turn_step_rad(&d, &[0]) - 0.4).abs() < 1e-12);
        // The first turn's step crosses the gap: 0.5 and 0.4 left, the upper of the two taken.
        assert!((turn_step_rad(&d, &[0, 3]) - 0.5).abs() < 1e-12);
        // No turn with a next sample in its segment: 0.
        assert_eq!(turn_step_rad(&[0.0, 1.0, 0.0], &[0, 2]), 0.0);
        assert_eq!(turn_step_rad(&[0.0, 0.3, 0.6], &[0]), 0.0);
    }
}
