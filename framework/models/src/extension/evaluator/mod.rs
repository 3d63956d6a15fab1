//! The online evaluator: [`ModelExtension`], the extension with its state (the Dahl state, the
//! low-passed dynamic terms, the rate's history), evaluated once per control cycle, and the
//! input dead band in front of the Dahl state.

use super::pivot::bracket;
use super::spec::{ExtensionError, ExtensionSpec, Terms};

mod hysteresis_loop;
mod rate;

pub use hysteresis_loop::{loop_rate, loop_step};

/// Samples the deflection-rate window holds (at most; fewer when the window is shorter).
const RATE_CAPACITY: usize = 256;

/// The extension with its state: the Dahl state and the recent deflections for the rate.
#[derive(Clone, Debug)]
pub struct ModelExtension {
    spec: ExtensionSpec,
    /// The terms in force: the flat ones, or those at the last pivot given to
    /// [`ModelExtension::at_pivot`].
    live: Terms,
    /// Unit Dahl state `u` and the deflection it was last updated at.
    dahl: (f64, Option<f64>),
    /// The low-passed history- and rate-driven terms [Nm] and the time of their last update [s].
    filtered: Option<(f64, f64)>,
    /// Recent (time [s], deflection [rad]), oldest first, in a fixed ring.
    ring: [(f64, f64); RATE_CAPACITY],
    head: usize,
    len: usize,
}

impl ModelExtension {
    /// Checks `spec`'s ranges.
    ///
    /// ```
    /// use jointctl_models::extension::{ExtensionSpec, ModelExtension};
    /// assert!(ModelExtension::new(ExtensionSpec { dead_zone_rad: -0.1, ..Default::default() }).is_err());
    /// // The contact band is at most the play's half width.
    /// assert!(ModelExtension::new(ExtensionSpec { dead_zone_rad: 0.01, dead_zone_ramp_rad: 0.02, ..Default::default() }).is_err());
    /// ```
    pub fn new(spec: ExtensionSpec) -> Result<Self, ExtensionError> {
        let bad = |field: &str, message: String| Err(ExtensionError { field: field.into(), message });
        spec.terms().check("")?;
        if !(spec.rate_window_s > 0.0 && spec.rate_window_s.is_finite()) {
            return bad("rate_window_s", format!("must be > 0, got {}", spec.rate_window_s));
        }
        if !(spec.rate_window_max_s >= spec.rate_window_s && spec.rate_window_max_s.is_finite()) {
            return bad("rate_window_max_s", format!("must be at least rate_window_s ({}), got {}", spec.rate_window_s, spec.rate_window_max_s));
        }
        if !(spec.rate_resolution_rad >= 0.0 && spec.rate_resolution_rad.is_finite()) {
            return bad("rate_resolution_rad", format!("must be >= 0, got {}", spec.rate_resolution_rad));
        }
        if !(spec.dynamic_terms_filter_s >= 0.0 && spec.dynamic_terms_filter_s.is_finite()) {
            return bad("dynamic_terms_filter_s", format!("must be >= 0, got {}", spec.dynamic_terms_filter_s));
        }
        if !spec.by_pivot.is_empty() && spec.terms() != Terms::default() {
            return bad("by_pivot", "give the terms either flat or by_pivot, not both: by_pivot replaces the flat terms".into());
        }
        for (i, setting) in spec.by_pivot.iter().enumerate() {
            if !setting.pivot_mm.is_finite() {
                return bad(&format!("by_pivot[{i}].pivot_mm"), format!("must be a finite number, got {}", setting.pivot_mm));
            }
            if i > 0 && !(setting.pivot_mm > spec.by_pivot[i - 1].pivot_mm) {
                return bad(&format!("by_pivot[{i}].pivot_mm"), format!("settings must be in increasing pivot order, got {} after {}", setting.pivot_mm, spec.by_pivot[i - 1].pivot_mm));
            }
            setting.terms.check(&format!("by_pivot[{i}].terms."))?;
        }
        let live = spec.by_pivot.first().map_or(spec.terms(), |s| s.terms);
        Ok(ModelExtension { spec, live, filtered: None, dahl: (0.0, None), ring: [(0.0, 0.0); RATE_CAPACITY], head: 0, len: 0 })
    }

    /// The parameters.
    pub fn spec(&self) -> &ExtensionSpec {
        &self.spec
    }

    /// The terms in force.
    pub fn terms(&self) -> &Terms {
        &self.live
    }

    /// Puts the terms at pivot setting `pivot_mm` in force (see the module docs); nothing
    /// without `by_pivot`. Allocation-free: a call per control cycle.
    ///
    /// ```
    /// use jointctl_models::extension::{ExtensionSpec, ModelExtension, PivotTerms, Terms};
    /// let at = |pivot_mm: f64, cubic_nm_per_rad3: f64| PivotTerms { pivot_mm, terms: Terms { cubic_nm_per_rad3, ..Default::default() } };
    /// let spec = ExtensionSpec { by_pivot: vec![at(10.0, 100.0), at(20.0, 300.0)], ..Default::default() };
    /// let mut e = ModelExtension::new(spec).unwrap();
    /// e.at_pivot(15.0);
    /// assert_eq!(e.terms().cubic_nm_per_rad3, 200.0);
    /// e.at_pivot(35.0);
    /// assert_eq!(e.terms().cubic_nm_per_rad3, 300.0, "outside the settings, the nearest one's");
    /// ```
    pub fn at_pivot(&mut self, pivot_mm: f64) {
        let settings = &self.spec.by_pivot;
        match settings.len() {
            0 => {}
            1 => self.live = settings[0].terms,
            _ => {
                let (i, w) = bracket(settings, pivot_mm);
                self.live = settings[i].terms.blend(&settings[i + 1].terms, w);
            }
        }
    }

    /// Forgets the state (the Dahl state, the rate's history): on activation, and when the
    /// deflection is not known (a gap is not a motion).
    pub fn reset(&mut self) {
        self.dahl = (0.0, None);
        self.filtered = None;
        self.len = 0;
    }

    /// The play: `phi_e = sgn(phi) max(|phi| - w, 0)` (with its contact band, [`crate::play`]),
    /// the deflection the element transmits torque for; the characteristic is evaluated at it.
    pub fn elastic_deflection(&self, phi: f64) -> f64 {
        crate::play::elastic_deflection(phi, self.live.dead_zone_rad, self.live.dead_zone_ramp_rad)
    }

    /// The loop's unit state one step on ([`loop_step`]: Dahl's model, exact per step, or its
    /// generalisation with a shape exponent), `phi` through the loop's input dead band first;
    /// returns `F_c u` [Nm] (0 without hysteresis).
    pub fn dahl_torque(&mut self, phi: f64) -> f64 {
        let Some(h) = self.live.hysteresis else {
            // Kept up to date: terms weighed at a pivot can switch the loop on later.
            self.dahl.1 = Some(phi);
            return 0.0;
        };
        let lambda = h.limit_nm / h.sigma_nm_per_rad;
        let (u, last) = self.dahl;
        let phi = dead_band_step(last, phi, h.input_dead_band_rad);
        let u = match last {
            Some(prev) if phi != prev => loop_step(u, phi - prev, lambda, h.shape),
            _ => u,
        };
        self.dahl = (u, Some(phi));
        h.limit_nm * u
    }

    /// The loop's pre-sliding damping at the unit state's rate `du/dt` [1/s]: `F_c tau_d du/dt`
    /// [Nm] (0 without hysteresis or damping). [`ModelExtension::torque`] gives it the state's
    /// own step over the time step; see there why not the loop's law at the rate estimate.
    ///
    /// ```
    /// use jointctl_models::extension::{DahlSpec, ExtensionSpec, ModelExtension};
    /// let h = DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0, shape: 1.0, presliding_damping_s: 0.01 };
    /// let e = ModelExtension::new(ExtensionSpec { hysteresis: Some(h), ..Default::default() }).unwrap();
    /// assert!((e.presliding_damping_torque(50.0) - 1.2 * 0.01 * 50.0).abs() < 1e-12);
    /// ```
    pub fn presliding_damping_torque(&self, state_rate_per_s: f64) -> f64 {
        match self.live.hysteresis {
            Some(h) if h.presliding_damping_s > 0.0 => h.limit_nm * h.presliding_damping_s * state_rate_per_s,
            _ => 0.0,
        }
    }

    /// Eq. 3.5 and viscous friction at rate `w`: `b w + k_a atan(k_b w)` [Nm].
    pub fn friction_torque(&self, w: f64) -> f64 {
        let arctan = self.live.friction.map_or(0.0, |f| f.ka_nm * (f.kb_s_per_rad * w).atan());
        self.live.viscous_nms_per_rad * w + arctan
    }

    /// The stiffness's non-linearity at the element's deflection: `k3 phi_e^3` [Nm].
    pub fn cubic_torque(&self, phi_e: f64) -> f64 {
        self.live.cubic_nm_per_rad3 * phi_e.powi(3)
    }

    /// The observed torque at time `t_s` and deflection `phi`, given the characteristic's torque
    /// at [`ModelExtension::elastic_deflection`]: the whole sum of the module docs [Nm].
    ///
    /// ```
    /// use jointctl_models::extension::{ExtensionSpec, ModelExtension};
    /// let mut e = ModelExtension::new(ExtensionSpec { torque_scale: 0.97, torque_offset_nm: 0.1, ..Default::default() }).unwrap();
    /// let phi_e = e.elastic_deflection(0.1);
    /// let tau = e.torque(0.0, 0.1, 117.47 * phi_e);
    /// assert!((tau - (0.97 * 11.747 + 0.1)).abs() < 1e-12);
    /// ```
    pub fn torque(&mut self, t_s: f64, phi: f64, curve_torque_nm: f64) -> f64 {
        let phi_e = self.elastic_deflection(phi);
        let previous_t_s = (self.len > 0).then(|| self.ring[(self.head + self.len - 1) % RATE_CAPACITY].0);
        let u_before = self.dahl.0;
        let w = self.deflection_rate(t_s, phi);
        let mut dynamic = self.friction_torque(w) + self.dahl_torque(phi);
        // The state's rate from its own step, not the loop's law at the rate estimate `w`: that
        // estimate is causal and lags, and for a while after a turn it still points the old way
        // while the state already runs the new branch (the law at it was off by 0.58 of the
        // term's RMS along a 1 Hz sine; the step, 0.01). The dynamic terms' low-pass smooths the
        // step's count-by-count jumps on a quantised reading (on a 14-bit one, 0.45 -> 0.07 at
        // 1 Hz, but 0.20 -> 0.26 at 0.2 Hz, where a count is a step of its own).
        let state_rate_per_s = match previous_t_s {
            Some(t0) if t_s > t0 => (self.dahl.0 - u_before) / (t_s - t0),
            _ => 0.0,
        };
        dynamic += self.presliding_damping_torque(state_rate_per_s);
        if self.spec.dynamic_terms_filter_s > 0.0 {
            dynamic = match self.filtered {
                Some((y, t0)) => {
                    let dt = (t_s - t0).max(0.0);
                    y + (dynamic - y) * dt / (self.spec.dynamic_terms_filter_s + dt)
                }
                None => dynamic,
            };
            self.filtered = Some((dynamic, t_s));
        }
        self.live.torque_scale * curve_torque_nm + self.cubic_torque(phi_e) + dynamic + self.live.torque_offset_nm
    }
}

/// One step of a dead band of `width_rad` in front of a Dahl state: the reading when it is more
/// than half the width from the value last taken (`held`; none at the start), else that value.
/// A flicker between encoder counts inside the band is not a motion. `identify` filters a record
/// with the same step, so the observer runs the band its parameters were fitted with.
///
/// ```
/// use jointctl_models::extension::dead_band_step;
/// assert_eq!(dead_band_step(None, 0.3, 0.5), 0.3);
/// assert_eq!(dead_band_step(Some(1.0), 0.8, 0.5), 1.0);
/// assert_eq!(dead_band_step(Some(1.0), 1.3, 0.5), 1.3);
/// ```
pub fn dead_band_step(held: Option<f64>, reading: f64, width_rad: f64) -> f64 {
    match held {
        Some(prev) if (reading - prev).abs() <= 0.5 * width_rad => prev,
        _ => reading,
    }
}
