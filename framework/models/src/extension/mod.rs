//! What `jointctl identify` finds beyond a joint's characteristic, as an observer uses it online
//! (section 6.2's first recommendation: hysteresis and non-linear friction in the observer). The
//! same model `identify` fits, term by term:
//!
//! `tau = s * tau_curve(phi_e) + k3 phi_e^3 + b dphi/dt + k_a atan(k_b dphi/dt) + F_c u + c`
//!
//! with `phi_e = dz(phi, w)` the deflection the element transmits torque for after the play `w`,
//! `u` the unit Dahl state (`du/dphi = (1 - u sgn(dphi)) / lambda`, `lambda = F_c / sigma`),
//! `dphi/dt` the deflection rate, `s` the curve's scale and `c` the sensor's offset. Each term
//! is one function named after its equation. Allocation-free after [`ModelExtension::new`].
//!
//! A joint with pivot settings (the shoulder q2) may give the terms per characterised setting
//! (`by_pivot`): the lever arm's mismatch with its table, and with it what the table misses,
//! changes with the setting, so terms identified at one setting are right there only (issue 32).
//! Between two settings each term's parameters are weighted linearly, as the characteristic's
//! curves are (sections 3.4.2, 4.2); outside them the nearest setting's terms hold.

mod evaluator;
mod pivot;
mod spec;

pub use self::evaluator::{ModelExtension, dead_band_step, loop_rate, loop_step};
pub use self::spec::{DahlSpec, ExtensionError, ExtensionSpec, FrictionSpec, MAX_LOOP_SHAPE, PivotTerms, RATE_STEPS, Terms};

#[cfg(test)]
mod tests;
