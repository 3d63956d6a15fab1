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

use serde::Deserialize;

/// Eq. 3.5 friction `k_a atan(k_b w)`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    /// `k_a` [Nm].
    pub ka_nm: f64,
    /// `k_b` [s/rad].
    pub kb_s_per_rad: f64,
}

/// Dahl hysteresis.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DahlSpec {
    /// Rest stiffness sigma [Nm/rad].
    pub sigma_nm_per_rad: f64,
    /// Limit F_c [Nm].
    pub limit_nm: f64,
    /// Width of a dead band between the deflection reading and the Dahl state [rad] (0: none):
    /// the state takes a reading only once it is more than half the width from the last one
    /// taken, or each flicker between encoder counts would walk the state off its limit
    /// (`identify` chooses the width from the reading's scatter).
    #[serde(default)]
    pub input_dead_band_rad: f64,
}

/// The terms of the sum in the module docs, without the rate estimate's settings: what changes
/// from one pivot setting to the next.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Terms {
    /// The characteristic's scale `s`.
    #[serde(default = "one")]
    pub torque_scale: f64,
    /// `k3` [Nm/rad^3].
    #[serde(default)]
    pub cubic_nm_per_rad3: f64,
    /// Play `w` [rad].
    #[serde(default)]
    pub dead_zone_rad: f64,
    /// The play's contact band [rad], at most `w`.
    #[serde(default)]
    pub dead_zone_ramp_rad: f64,
    /// `b` [Nms/rad].
    #[serde(default)]
    pub viscous_nms_per_rad: f64,
    /// Eq. 3.5 friction.
    #[serde(default)]
    pub friction: Option<FrictionSpec>,
    /// Dahl hysteresis.
    #[serde(default)]
    pub hysteresis: Option<DahlSpec>,
    /// `c` [Nm].
    #[serde(default)]
    pub torque_offset_nm: f64,
}

impl Default for Terms {
    fn default() -> Self {
        Terms {
            torque_scale: 1.0,
            cubic_nm_per_rad3: 0.0,
            dead_zone_rad: 0.0,
            dead_zone_ramp_rad: 0.0,
            viscous_nms_per_rad: 0.0,
            friction: None,
            hysteresis: None,
            torque_offset_nm: 0.0,
        }
    }
}

impl Terms {
    /// Each parameter weighted linearly between `self` (weight `1 - w`) and `other` (`w`). A
    /// friction or hysteresis that one side lacks weighs in with its torque scale (`k_a`, `F_c`)
    /// at zero and the other side's shape (`k_b`, `sigma`), so that it fades in over the span
    /// (none where its weight is zero).
    ///
    /// ```
    /// use jointctl_models::extension::{DahlSpec, Terms};
    /// let a = Terms { cubic_nm_per_rad3: 100.0, ..Default::default() };
    /// let b = Terms { cubic_nm_per_rad3: 300.0, hysteresis: Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.4, input_dead_band_rad: 0.0 }), ..Default::default() };
    /// let mid = a.blend(&b, 0.5);
    /// assert_eq!(mid.cubic_nm_per_rad3, 200.0);
    /// assert_eq!(mid.hysteresis, Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.2, input_dead_band_rad: 0.0 }));
    /// ```
    pub fn blend(&self, other: &Terms, w: f64) -> Terms {
        let mix = |a: f64, b: f64| a + (b - a) * w;
        let friction = match (self.friction, other.friction) {
            (None, None) => None,
            (a, b) => {
                let (a, b) = (a.unwrap_or(FrictionSpec { ka_nm: 0.0, ..b.unwrap_or(FrictionSpec { ka_nm: 0.0, kb_s_per_rad: 1.0 }) }), b.unwrap_or(FrictionSpec { ka_nm: 0.0, ..a.unwrap_or(FrictionSpec { ka_nm: 0.0, kb_s_per_rad: 1.0 }) }));
                Some(FrictionSpec { ka_nm: mix(a.ka_nm, b.ka_nm), kb_s_per_rad: mix(a.kb_s_per_rad, b.kb_s_per_rad) }).filter(|f| f.ka_nm != 0.0)
            }
        };
        let hysteresis = match (self.hysteresis, other.hysteresis) {
            (None, None) => None,
            (a, b) => {
                let (a, b) = (a.unwrap_or(DahlSpec { limit_nm: 0.0, ..b.unwrap_or(DahlSpec { limit_nm: 0.0, sigma_nm_per_rad: 1.0, input_dead_band_rad: 0.0 }) }), b.unwrap_or(DahlSpec { limit_nm: 0.0, ..a.unwrap_or(DahlSpec { limit_nm: 0.0, sigma_nm_per_rad: 1.0, input_dead_band_rad: 0.0 }) }));
                Some(DahlSpec { sigma_nm_per_rad: mix(a.sigma_nm_per_rad, b.sigma_nm_per_rad), limit_nm: mix(a.limit_nm, b.limit_nm), input_dead_band_rad: mix(a.input_dead_band_rad, b.input_dead_band_rad) }).filter(|h| h.limit_nm > 0.0)
            }
        };
        Terms {
            torque_scale: mix(self.torque_scale, other.torque_scale),
            cubic_nm_per_rad3: mix(self.cubic_nm_per_rad3, other.cubic_nm_per_rad3),
            dead_zone_rad: mix(self.dead_zone_rad, other.dead_zone_rad),
            dead_zone_ramp_rad: mix(self.dead_zone_ramp_rad, other.dead_zone_ramp_rad),
            viscous_nms_per_rad: mix(self.viscous_nms_per_rad, other.viscous_nms_per_rad),
            friction,
            hysteresis,
            torque_offset_nm: mix(self.torque_offset_nm, other.torque_offset_nm),
        }
    }

    /// Each parameter in its range, the error naming the field under `prefix`.
    fn check(&self, prefix: &str) -> Result<(), ExtensionError> {
        let bad = |field: &str, message: String| Err(ExtensionError { field: format!("{prefix}{field}"), message });
        let finite = [
            ("torque_scale", self.torque_scale),
            ("cubic_nm_per_rad3", self.cubic_nm_per_rad3),
            ("viscous_nms_per_rad", self.viscous_nms_per_rad),
            ("torque_offset_nm", self.torque_offset_nm),
        ];
        if let Some((f, v)) = finite.iter().find(|(_, v)| !v.is_finite()) {
            return bad(f, format!("must be a finite number, got {v}"));
        }
        if !(self.torque_scale > 0.0) {
            return bad("torque_scale", format!("must be > 0 (a curve turned over is not an error of fit), got {}", self.torque_scale));
        }
        if !(self.dead_zone_rad >= 0.0 && self.dead_zone_rad.is_finite()) {
            return bad("dead_zone_rad", format!("must be >= 0, got {}", self.dead_zone_rad));
        }
        if !(self.dead_zone_ramp_rad >= 0.0 && self.dead_zone_ramp_rad <= self.dead_zone_rad) {
            return bad("dead_zone_ramp_rad", format!("must be between 0 and dead_zone_rad ({}), got {}", self.dead_zone_rad, self.dead_zone_ramp_rad));
        }
        if let Some(f) = self.friction
            && !(f.ka_nm.is_finite() && f.kb_s_per_rad > 0.0 && f.kb_s_per_rad.is_finite())
        {
            return bad("friction", format!("needs a finite ka_nm and kb_s_per_rad > 0, got {} and {}", f.ka_nm, f.kb_s_per_rad));
        }
        if let Some(h) = self.hysteresis
            && !(h.sigma_nm_per_rad > 0.0 && h.limit_nm > 0.0 && h.sigma_nm_per_rad.is_finite() && h.limit_nm.is_finite())
        {
            return bad("hysteresis", format!("needs sigma_nm_per_rad > 0 and limit_nm > 0, got {} and {}", h.sigma_nm_per_rad, h.limit_nm));
        }
        if let Some(h) = self.hysteresis
            && !(h.input_dead_band_rad >= 0.0 && h.input_dead_band_rad.is_finite())
        {
            return bad("hysteresis.input_dead_band_rad", format!("must be >= 0, got {}", h.input_dead_band_rad));
        }
        Ok(())
    }
}

/// The terms identified at one characterised pivot setting.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PivotTerms {
    /// The setting [mm] (the characteristic's `pivot_mm`).
    pub pivot_mm: f64,
    /// The terms there.
    pub terms: Terms,
}

/// A joint plugin's `model_extension` params: the observer keys of `identify`'s causes. Every
/// term is off unless given.
///
/// ```
/// let s: jointctl_models::extension::ExtensionSpec = serde_json::from_str(r#"{"hysteresis": {"sigma_nm_per_rad": 300, "limit_nm": 1.2}}"#).unwrap();
/// assert_eq!(s.torque_scale, 1.0);
/// ```
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtensionSpec {
    /// The characteristic's scale `s` (`stiffness_error`: 1 + the relative error).
    #[serde(default = "one")]
    pub torque_scale: f64,
    /// `k3` [Nm/rad^3] (`stiffness_nonlinearity`).
    #[serde(default)]
    pub cubic_nm_per_rad3: f64,
    /// Play `w` [rad] (`dead_zone`).
    #[serde(default)]
    pub dead_zone_rad: f64,
    /// The band on either side of `w` over which the play's contact stiffens [rad], at most `w`
    /// (`dead_zone`; see [`crate::play`]).
    #[serde(default)]
    pub dead_zone_ramp_rad: f64,
    /// `b` [Nms/rad] (`viscous_friction`).
    #[serde(default)]
    pub viscous_nms_per_rad: f64,
    /// Eq. 3.5 friction (`coulomb_friction`).
    #[serde(default)]
    pub friction: Option<FrictionSpec>,
    /// Dahl hysteresis (`hysteresis`).
    #[serde(default)]
    pub hysteresis: Option<DahlSpec>,
    /// `c` [Nm] (`sensor_offset`).
    #[serde(default)]
    pub torque_offset_nm: f64,
    /// The shortest window of the deflection rate's causal least-squares slope [s]. Assumption:
    /// 20 ms, short against the thesis' references (a fiftieth of a 1 Hz period).
    #[serde(default = "default_rate_window")]
    pub rate_window_s: f64,
    /// The deflection's resolution [rad]: the window grows beyond `rate_window_s` (up to
    /// `rate_window_max_s`) until the deflection in it spans [`RATE_STEPS`] of these, so that a
    /// slow motion, a staircase of encoder counts, reads as a slope and not as a count now and
    /// then (a steep eq. 3.5 friction, `k_b` = 50 s/rad, turns that noise into a torque that
    /// flips sign). Default: one count of section 2.2's 14-bit encoders, 2 pi / 2^14.
    #[serde(default = "default_resolution")]
    pub rate_resolution_rad: f64,
    /// The longest window [s]. Assumption: 100 ms, where the rate near a reversal is small
    /// anyway.
    #[serde(default = "default_rate_window_max")]
    pub rate_window_max_s: f64,
    /// The terms per pivot setting, pivots increasing (a joint with pivot settings; see the
    /// module docs). When given, the flat terms above must be left out: these replace them.
    #[serde(default)]
    pub by_pivot: Vec<PivotTerms>,
    /// The time constant of a first-order low-pass on the terms driven by the deflection's
    /// history and rate (Dahl hysteresis, eq. 3.5 and viscous friction) [s]; 0: none. Those terms
    /// are steep (a Dahl loop's slope is up to `2 sigma` after a reversal) or driven by a lagging
    /// causal rate, and the torque loop divides its error by the characteristic's slope alone: fed
    /// back unfiltered they raised the shoulder's loop gain at 44 mm (23 Nm/rad, an identified
    /// sigma of 258 Nm/rad) until it rang at 21-31 Hz (issue 32). Assumption: 50 ms, a corner at
    /// 3.2 Hz, above the thesis' references (up to 1 Hz, section 5) and far below that ring.
    #[serde(default = "default_dynamic_terms_filter")]
    pub dynamic_terms_filter_s: f64,
}

impl ExtensionSpec {
    /// The flat terms (those a joint without pivot settings uses).
    pub fn terms(&self) -> Terms {
        Terms {
            torque_scale: self.torque_scale,
            cubic_nm_per_rad3: self.cubic_nm_per_rad3,
            dead_zone_rad: self.dead_zone_rad,
            dead_zone_ramp_rad: self.dead_zone_ramp_rad,
            viscous_nms_per_rad: self.viscous_nms_per_rad,
            friction: self.friction,
            hysteresis: self.hysteresis,
            torque_offset_nm: self.torque_offset_nm,
        }
    }
}

/// Resolution steps the deflection must span in the rate's window (see
/// [`ExtensionSpec::rate_resolution_rad`]). Assumption: 4, so that one count more or less
/// changes the slope by a quarter at most.
pub const RATE_STEPS: f64 = 4.0;

fn one() -> f64 {
    1.0
}
fn default_rate_window() -> f64 {
    0.02
}
fn default_resolution() -> f64 {
    std::f64::consts::TAU / 16384.0
}
fn default_dynamic_terms_filter() -> f64 {
    0.05
}
fn default_rate_window_max() -> f64 {
    0.1
}

impl Default for ExtensionSpec {
    fn default() -> Self {
        ExtensionSpec {
            torque_scale: 1.0,
            cubic_nm_per_rad3: 0.0,
            dead_zone_rad: 0.0,
            dead_zone_ramp_rad: 0.0,
            viscous_nms_per_rad: 0.0,
            friction: None,
            hysteresis: None,
            torque_offset_nm: 0.0,
            rate_window_s: default_rate_window(),
            rate_resolution_rad: default_resolution(),
            rate_window_max_s: default_rate_window_max(),
            by_pivot: Vec::new(),
            dynamic_terms_filter_s: default_dynamic_terms_filter(),
        }
    }
}

/// A parameter out of its range: which, and why.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ExtensionError {
    /// Field path under `model_extension`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

/// The setting below `pivot_mm` (or the first) and the weight of the one above, clamped to
/// the settings' range (at least two settings, pivots increasing), as
/// [`crate::characteristic::pivot_bracket`] brackets the curves; no allocation.
fn bracket(settings: &[PivotTerms], pivot_mm: f64) -> (usize, f64) {
    let n = settings.len();
    if pivot_mm.is_nan() || pivot_mm <= settings[0].pivot_mm {
        return (0, 0.0);
    }
    if pivot_mm >= settings[n - 1].pivot_mm {
        return (n - 2, 1.0);
    }
    let i = settings.partition_point(|s| s.pivot_mm <= pivot_mm) - 1;
    (i, (pivot_mm - settings[i].pivot_mm) / (settings[i + 1].pivot_mm - settings[i].pivot_mm))
}

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

    /// Dahl's model, exact per step: `u <- sgn(dphi) + (u - sgn(dphi)) exp(-|dphi| / lambda)`,
    /// `phi` through the loop's input dead band first; returns `F_c u` [Nm] (0 without hysteresis).
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
            Some(prev) if phi != prev => {
                let step = phi - prev;
                let target = step.signum();
                target + (u - target) * (-step.abs() / lambda).exp()
            }
            _ => u,
        };
        self.dahl = (u, Some(phi));
        h.limit_nm * u
    }

    /// The deflection rate [rad/s]: the slope of a least-squares line through the last
    /// `rate_window_s` of samples, or more (up to `rate_window_max_s`) until the deflection in
    /// them spans [`RATE_STEPS`] resolution steps (causal: the observer has no future samples).
    pub fn deflection_rate(&mut self, t_s: f64, phi: f64) -> f64 {
        let tail = (self.head + self.len) % RATE_CAPACITY;
        self.ring[tail] = (t_s, phi);
        if self.len == RATE_CAPACITY {
            self.head = (self.head + 1) % RATE_CAPACITY;
        } else {
            self.len += 1;
        }
        while self.len > 2 && t_s - self.ring[self.head].0 > self.spec.rate_window_max_s {
            self.head = (self.head + 1) % RATE_CAPACITY;
            self.len -= 1;
        }
        // Newest first: how many samples the window takes.
        let span = RATE_STEPS * self.spec.rate_resolution_rad;
        let (mut lo, mut hi) = (phi, phi);
        let mut take = self.len;
        for k in 0..self.len {
            let (t, d) = self.ring[(self.head + self.len - 1 - k) % RATE_CAPACITY];
            (lo, hi) = (lo.min(d), hi.max(d));
            if k >= 1 && t_s - t >= self.spec.rate_window_s && hi - lo >= span {
                take = k + 1;
                break;
            }
        }
        if take < 2 {
            return 0.0;
        }
        let n = take as f64;
        let (mut st, mut sd, mut stt, mut std_) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..take {
            let (t, d) = self.ring[(self.head + self.len - take + k) % RATE_CAPACITY];
            let x = t - t_s;
            (st, sd, stt, std_) = (st + x, sd + d, stt + x * x, std_ + x * d);
        }
        let den = n * stt - st * st;
        if den.abs() < 1e-18 { 0.0 } else { (n * std_ - st * sd) / den }
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
        let w = self.deflection_rate(t_s, phi);
        let mut dynamic = self.friction_torque(w) + self.dahl_torque(phi);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dahl_state_follows_identifys_per_step_solution_and_resets() {
        let mut e = ModelExtension::new(ExtensionSpec { hysteresis: Some(DahlSpec { sigma_nm_per_rad: 300.0, limit_nm: 1.2, input_dead_band_rad: 0.0 }), ..Default::default() }).unwrap();
        // Up by far more than lambda (4 mrad): the limit; back down: the other limit.
        assert_eq!(e.dahl_torque(0.0), 0.0);
        assert!((e.dahl_torque(0.1) - 1.2).abs() < 1e-9);
        assert!((e.dahl_torque(-0.1) + 1.2).abs() < 1e-9);
        // One lambda up from -1: u = 1 - 2 e^-1.
        let lambda = 1.2 / 300.0;
        let expected = 1.2 * (1.0 - 2.0 * (-1.0f64).exp());
        assert!((e.dahl_torque(-0.1 + lambda) - expected).abs() < 1e-12);
        e.reset();
        assert_eq!(e.dahl_torque(0.3), 0.0, "a reset state starts at zero, where it is");
    }

    #[test]
    fn a_reading_that_flickers_inside_the_input_dead_band_leaves_the_dahl_state_at_its_limit() {
        // A stiff loop (lambda 1.3 mrad) read by a 2 um encoder that flickers one count: each
        // flicker steps the state back by 2 s / lambda and the next step returns almost nothing
        // near the limit, so without a band the flicker walks the state towards zero.
        let spec = |band: f64| ExtensionSpec { hysteresis: Some(DahlSpec { sigma_nm_per_rad: 1800.0, limit_nm: 2.4, input_dead_band_rad: band }), ..Default::default() };
        let (mut bare, mut banded) = (ModelExtension::new(spec(0.0)).unwrap(), ModelExtension::new(spec(8e-6)).unwrap());
        // Loaded to the limit (20 mrad, 15 lambda), then the reading flickers between two counts.
        let (mut a, mut b) = (0.0, 0.0);
        for k in 0..=100 {
            (a, b) = (bare.dahl_torque(k as f64 * 2e-4), banded.dahl_torque(k as f64 * 2e-4));
        }
        assert!((b - 2.4).abs() < 1e-3 && (a - 2.4).abs() < 1e-3, "{a} {b}");
        for k in 0..400 {
            let phi = 0.02 - (k % 2) as f64 * 2e-6;
            (a, b) = (bare.dahl_torque(phi), banded.dahl_torque(phi));
        }
        assert!((b - 2.4).abs() < 1e-3, "behind the band the state holds its limit: {b}");
        assert!(a < 1.5, "without it the flicker walks the state off its limit: {a}");
        // A real reversal passes the band: the state turns once the reading has moved half the
        // width back, and reaches the other limit.
        for k in 0..=200 {
            b = banded.dahl_torque(0.02 - k as f64 * 2e-4);
        }
        assert!((b + 2.4).abs() < 1e-3, "{b}");
        assert!(ModelExtension::new(spec(-1e-6)).is_err(), "a negative band is refused");
    }

    #[test]
    fn the_rate_is_a_causal_least_squares_slope_over_its_window() {
        let mut e = ModelExtension::new(ExtensionSpec { rate_window_s: 0.02, ..Default::default() }).unwrap();
        let mut w = 0.0;
        for k in 0..100 {
            let t = k as f64 * 1e-3;
            w = e.deflection_rate(t, 0.5 * t + 0.01);
        }
        assert!((w - 0.5).abs() < 1e-9, "{w}");
        // Quantised to 14 bits, a slow ramp still reads its slope to a few per cent.
        let q = std::f64::consts::TAU / 16384.0;
        e.reset();
        for k in 0..200 {
            let t = k as f64 * 1e-3;
            w = e.deflection_rate(t, ((0.2 * t) / q).round() * q);
        }
        assert!((w - 0.2).abs() < 0.03, "{w}");
    }

    /// A slow motion seen through 14-bit counts is a staircase: a 20 ms window holds one count
    /// or none, and its slope jumps between 0 and twice the rate. The window grows until the
    /// deflection spans a few counts.
    #[test]
    fn a_slow_staircase_of_counts_reads_as_its_slope() {
        let q = std::f64::consts::TAU / 16384.0;
        let worst = |spec: ExtensionSpec| {
            let mut e = ModelExtension::new(spec).unwrap();
            let mut worst: f64 = 0.0;
            for k in 0..2000 {
                let t = k as f64 * 1e-3;
                let w = e.deflection_rate(t, ((0.02 * t) / q).round() * q);
                if t > 0.5 {
                    worst = worst.max((w - 0.02).abs());
                }
            }
            worst
        };
        let fixed = worst(ExtensionSpec { rate_resolution_rad: 0.0, ..Default::default() });
        let adaptive = worst(ExtensionSpec::default());
        assert!(fixed > 0.015, "a fixed 20 ms window misreads a count staircase by {fixed} rad/s");
        assert!(adaptive < 0.006, "the growing window reads 0.02 rad/s within {adaptive} rad/s");
    }

    #[test]
    fn each_term_is_the_one_identify_fits() {
        let spec = ExtensionSpec {
            torque_scale: 0.9,
            cubic_nm_per_rad3: 200.0,
            dead_zone_rad: 0.01,
            viscous_nms_per_rad: 0.5,
            friction: Some(FrictionSpec { ka_nm: 0.3, kb_s_per_rad: 80.0 }),
            torque_offset_nm: -0.2,
            dynamic_terms_filter_s: 0.0,
            ..Default::default()
        };
        let mut e = ModelExtension::new(spec).unwrap();
        assert_eq!(e.elastic_deflection(0.005), 0.0, "inside the play");
        assert!((e.elastic_deflection(-0.05) + 0.04).abs() < 1e-15);
        // A ramp of 0.2 rad/s: its friction and viscous terms, the cubic and the scale.
        let mut tau = 0.0;
        let mut phi = 0.0;
        for k in 0..50 {
            let t = k as f64 * 1e-3;
            phi = 0.05 + 0.2 * t;
            tau = e.torque(t, phi, 100.0 * e.elastic_deflection(phi));
        }
        let phi_e = phi - 0.01;
        let expected = 0.9 * 100.0 * phi_e + 200.0 * phi_e.powi(3) + 0.5 * 0.2 + 0.3 * (80.0f64 * 0.2).atan() - 0.2;
        assert!((tau - expected).abs() < 1e-9, "{tau} vs {expected}");
    }

    /// Terms per pivot setting: at a setting the extension is that setting's flat one, sample for
    /// sample; between two it weighs each parameter linearly; bad settings are errors at their field.
    #[test]
    fn terms_by_pivot_are_each_settings_own_and_weighted_between() {
        let a = Terms { cubic_nm_per_rad3: 300.0, hysteresis: Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.4, input_dead_band_rad: 0.0 }), friction: Some(FrictionSpec { ka_nm: 0.1, kb_s_per_rad: 50.0 }), ..Default::default() };
        let b = Terms { torque_scale: 0.95, dead_zone_rad: 0.002, viscous_nms_per_rad: 0.3, torque_offset_nm: -0.1, ..Default::default() };
        let flat = |t: Terms| ExtensionSpec {
            torque_scale: t.torque_scale,
            cubic_nm_per_rad3: t.cubic_nm_per_rad3,
            dead_zone_rad: t.dead_zone_rad,
            dead_zone_ramp_rad: t.dead_zone_ramp_rad,
            viscous_nms_per_rad: t.viscous_nms_per_rad,
            friction: t.friction,
            hysteresis: t.hysteresis,
            torque_offset_nm: t.torque_offset_nm,
            ..Default::default()
        };
        let by_pivot = ExtensionSpec { by_pivot: vec![PivotTerms { pivot_mm: 10.0, terms: a }, PivotTerms { pivot_mm: 35.0, terms: b }], ..Default::default() };
        let run = |spec: ExtensionSpec, pivot_mm: f64| {
            let mut e = ModelExtension::new(spec).unwrap();
            (0..500)
                .map(|k| {
                    let t = k as f64 * 1e-3;
                    let phi = 0.05 * (6.0 * t).sin();
                    e.at_pivot(pivot_mm);
                    let curve = 90.0 * e.elastic_deflection(phi);
                    e.torque(t, phi, curve)
                })
                .collect::<Vec<f64>>()
        };
        assert_eq!(run(by_pivot.clone(), 10.0), run(flat(a), 10.0));
        assert_eq!(run(by_pivot.clone(), 35.0), run(flat(b), 35.0));
        assert_eq!(run(by_pivot.clone(), 50.0), run(flat(b), 50.0), "beyond the last setting, its terms");
        assert_eq!(run(by_pivot.clone(), 20.0), run(flat(a.blend(&b, 0.4)), 20.0));
        let mid = a.blend(&b, 0.4);
        assert!((mid.cubic_nm_per_rad3 - 180.0).abs() < 1e-9 && (mid.dead_zone_rad - 0.0008).abs() < 1e-12);
        assert_eq!(mid.hysteresis, Some(DahlSpec { sigma_nm_per_rad: 200.0, limit_nm: 0.4 * 0.6, input_dead_band_rad: 0.0 }));

        let err = |spec: ExtensionSpec| ModelExtension::new(spec).unwrap_err();
        let both = ExtensionSpec { cubic_nm_per_rad3: 1.0, ..by_pivot.clone() };
        assert_eq!(err(both).field, "by_pivot");
        let mut backwards = by_pivot.clone();
        backwards.by_pivot.reverse();
        let e = err(backwards);
        assert_eq!(e.field, "by_pivot[1].pivot_mm");
        assert!(e.message.contains("increasing"), "{e}");
        let mut bad = by_pivot;
        bad.by_pivot[1].terms.hysteresis = Some(DahlSpec { sigma_nm_per_rad: -1.0, limit_nm: 0.2, input_dead_band_rad: 0.0 });
        assert_eq!(err(bad).field, "by_pivot[1].terms.hysteresis");
    }

    #[test]
    fn terms_by_pivot_read_from_yaml_like_json() {
        let s: ExtensionSpec = serde_json::from_str(r#"{"by_pivot": [{"pivot_mm": 10, "terms": {"cubic_nm_per_rad3": 318}}, {"pivot_mm": 20, "terms": {}}]}"#).unwrap();
        assert_eq!(s.by_pivot.len(), 2);
        assert_eq!(s.by_pivot[1].terms, Terms::default());
        assert!(serde_json::from_str::<ExtensionSpec>(r#"{"by_pivot": [{"pivot_mm": 10, "terms": {"cubic": 1}}]}"#).is_err(), "an unknown term is refused");
    }

    /// The history- and rate-driven terms reach the torque through a first-order low-pass: a
    /// Dahl loop reversed at once moves the torque by 63 % of its swing in one time constant, the
    /// static terms at once; with no filter, the swing is there at once.
    #[test]
    fn the_dynamic_terms_are_low_passed_and_the_static_ones_are_not() {
        let hysteresis = Some(DahlSpec { sigma_nm_per_rad: 1e6, limit_nm: 1.0, input_dead_band_rad: 0.0 });
        let run = |filter_s: f64| {
            let mut e = ModelExtension::new(ExtensionSpec { hysteresis, torque_offset_nm: 0.5, dynamic_terms_filter_s: filter_s, ..Default::default() }).unwrap();
            // Up (u = +1, settled), then one step down (u = -1 at once: sigma is huge).
            let mut t = 0.0;
            for k in 0..1000 {
                t = k as f64 * 1e-3;
                e.torque(t, 1e-3 * k as f64, 0.0);
            }
            let start = e.torque(t + 1e-3, 0.998, 0.0);
            let mut at_tau = start;
            for k in 2..=51 {
                at_tau = e.torque(t + k as f64 * 1e-3, 0.998, 0.0);
            }
            (start, at_tau)
        };
        let (start, _) = run(0.0);
        assert!((start - (0.5 - 1.0)).abs() < 1e-9, "unfiltered: the reversed loop at once, {start}");
        let (start, after) = run(0.05);
        assert!(start > 0.5 + 1.0 - 2.0 * 0.05, "filtered: a millisecond in, the torque has barely moved: {start}");
        let moved = (0.5 + 1.0 - after) / 2.0;
        assert!((moved - 0.63).abs() < 0.03, "one time constant later, {moved} of the swing");
        assert!(ModelExtension::new(ExtensionSpec { dynamic_terms_filter_s: -1.0, ..Default::default() }).is_err());
    }
}
