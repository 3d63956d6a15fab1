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
