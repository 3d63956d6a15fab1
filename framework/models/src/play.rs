//! Play in an elastic element: the deflection the element transmits torque for.
//!
//! An ideal dead zone `sgn(phi) max(|phi| - w, 0)` takes up its play at once; a real contact
//! (gear flanks, a cable's slack, a coupling's elastomer) stiffens over a band of deflection. The
//! band is modelled as the C1 quadratic blend between zero slope and unit slope over
//! `w - r <= |phi| <= w + r` (the smoothed dead zone, the same construction as Huber's loss):
//! slope and value are continuous, the asymptote `|phi| - w` is the ideal dead zone's, and
//! `r = 0` is the ideal one. Allocation-free: the control cycle evaluates it.

/// The transmitted deflection [rad] of `phi` [rad] through a play of half width `half_width_rad`
/// whose contact stiffens over `ramp_rad` on either side of it (`0 <= ramp_rad <= half_width_rad`;
/// a larger ramp is taken as the half width, a negative one as none).
///
/// ```
/// use jointctl_models::play::elastic_deflection;
/// // Ideal: nothing inside, |phi| - w beyond.
/// assert_eq!(elastic_deflection(0.004, 0.005, 0.0), 0.0);
/// assert!((elastic_deflection(-0.02, 0.005, 0.0) + 0.015).abs() < 1e-15);
/// // A ramp: nothing until w - r, a quarter of r at w, the ideal line from w + r.
/// assert_eq!(elastic_deflection(0.003, 0.005, 0.002), 0.0);
/// assert!((elastic_deflection(0.005, 0.005, 0.002) - 0.0005).abs() < 1e-15);
/// assert!((elastic_deflection(0.02, 0.005, 0.002) - 0.015).abs() < 1e-15);
/// ```
pub fn elastic_deflection(phi: f64, half_width_rad: f64, ramp_rad: f64) -> f64 {
    let (a, w) = (phi.abs(), half_width_rad.max(0.0));
    let r = ramp_rad.clamp(0.0, w);
    let s = if a >= w + r {
        a - w
    } else if a <= w - r {
        0.0
    } else {
        let d = a - (w - r);
        d * d / (4.0 * r)
    };
    phi.signum() * s
}

#[cfg(test)]
mod tests {
    use super::elastic_deflection;

    #[test]
    fn the_blend_is_continuous_in_value_and_slope() {
        let (w, r) = (0.01, 0.004);
        let f = |x: f64| elastic_deflection(x, w, r);
        for edge in [w - r, w + r] {
            let h = 1e-9;
            assert!((f(edge - h) - f(edge + h)).abs() < 1e-8, "value at {edge}");
            let slope = |x: f64| (f(x + h) - f(x - h)) / (2.0 * h);
            assert!(
                (slope(edge - 1e-7) - slope(edge + 1e-7)).abs() < 1e-3,
                "slope at {edge}"
            );
        }
        assert!((f(-0.012) + f(0.012)).abs() < 1e-15, "odd");
    }
}
