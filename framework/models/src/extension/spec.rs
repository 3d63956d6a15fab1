//! The extension's parameters: the terms (and their specs), the terms per pivot setting, a
//! joint plugin's `model_extension` params with their defaults, and each term's range check.

use serde::{Deserialize, Serialize};

use crate::effect::Effect;

/// Eq. 3.5 friction `k_a atan(k_b w)`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    /// `k_a` [Nm].
    pub ka_nm: f64,
    /// `k_b` [s/rad].
    pub kb_s_per_rad: f64,
}

/// The largest hysteresis shape exponent accepted: beyond it the loop is all but a corner (an
/// assumption: published Bouc-Wen fits of joints and dampers lie between 1 and 3).
pub const MAX_LOOP_SHAPE: f64 = 8.0;

/// Dahl hysteresis.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DahlSpec {
    /// Rest stiffness sigma [Nm/rad], of the limit's sign.
    pub sigma_nm_per_rad: f64,
    /// Limit F_c [Nm]. Negative for a loop that runs the other way in the torque reading: a
    /// friction in a path beside the torque sensor (a bearing that carries torque past it)
    /// takes a loop's worth of the element's torque from the reading, rising as the element
    /// loads; such a loop is the reading's, observed and not simulated in the element (where
    /// a loop that runs the other way would give energy).
    pub limit_nm: f64,
    /// Width of a dead band between the deflection reading and the Dahl state [rad] (0: none):
    /// the state takes a reading only once it is more than half the width from the last one
    /// taken, or each flicker between encoder counts would walk the state off its limit
    /// (`identify` chooses the width from the reading's scatter).
    #[serde(default)]
    pub input_dead_band_rad: f64,
    /// The loop's shape exponent `n` (>= 1; 1, the default: Dahl's model): the state follows
    /// `du/dphi = (1 - sgn(dphi) u |u|^(n - 1)) / lambda` ([`super::loop_step`]), Bouc-Wen's form
    /// with `beta = 1`, `gamma = 0`; a larger `n` turns sharper at the limit.
    #[serde(default = "one")]
    pub shape: f64,
    /// The pre-sliding damping's time constant `tau_d` [s] (0, the default: none): the loop's
    /// torque is `F_c (u + tau_d du/dt)`, LuGre's `sigma0 z + sigma1 dz/dt` with `sigma1 =
    /// sigma tau_d`, a damping of the bristles while they deflect that stops once they slide
    /// (the rate `du/dt` from the loop's law at the deflection rate, [`super::loop_rate`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub presliding_damping_s: f64,
}

/// The terms of the sum in the module docs, without the rate estimate's settings: what changes
/// from one pivot setting to the next.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
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
    /// The model effects these terms carry, in [`Effect::ALL`]'s order: those with one of their
    /// [`Effect::observer_keys`] set ([`crate::effect::effects_set`]: a table, or a finite
    /// number off its default, a scale other than 1).
    ///
    /// ```
    /// use jointctl_models::{effect::Effect, extension::Terms};
    /// let t = Terms { torque_scale: 0.98, viscous_nms_per_rad: 0.3, ..Default::default() };
    /// assert_eq!(t.effects(), [Effect::ViscousFriction, Effect::StiffnessError]);
    /// assert!(Terms::default().effects().is_empty());
    /// assert!(Terms { viscous_nms_per_rad: f64::NAN, ..Default::default() }.effects().is_empty());
    /// ```
    pub fn effects(&self) -> Vec<Effect> {
        let (Ok(these), Ok(defaults)) = (serde_json::to_value(self), serde_json::to_value(Terms::default())) else { return Vec::new() };
        crate::effect::effects_set(Effect::observer_keys, &these, &defaults)
    }

    /// Each parameter in its range, the error naming the field under `prefix`.
    pub(super) fn check(&self, prefix: &str) -> Result<(), ExtensionError> {
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
            && !(h.sigma_nm_per_rad.is_finite() && h.limit_nm.is_finite() && h.limit_nm != 0.0 && h.limit_nm / h.sigma_nm_per_rad > 0.0)
        {
            return bad("hysteresis", format!("needs limit_nm != 0 and sigma_nm_per_rad of its sign (a loop's scale limit / sigma > 0), got sigma_nm_per_rad {} and limit_nm {}", h.sigma_nm_per_rad, h.limit_nm));
        }
        if let Some(h) = self.hysteresis
            && !(h.input_dead_band_rad >= 0.0 && h.input_dead_band_rad.is_finite())
        {
            return bad("hysteresis.input_dead_band_rad", format!("must be >= 0, got {}", h.input_dead_band_rad));
        }
        if let Some(h) = self.hysteresis
            && !(h.shape >= 1.0 && h.shape <= MAX_LOOP_SHAPE)
        {
            return bad("hysteresis.shape", format!("must be between 1 and {MAX_LOOP_SHAPE}, got {}", h.shape));
        }
        if let Some(h) = self.hysteresis
            && !(h.presliding_damping_s >= 0.0 && h.presliding_damping_s.is_finite())
        {
            return bad("hysteresis.presliding_damping_s", format!("must be >= 0, got {}", h.presliding_damping_s));
        }
        Ok(())
    }
}

/// The terms identified at one characterised pivot setting.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
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
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
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
    /// The model effects the observer models, at any pivot setting ([`Terms::effects`] of the
    /// flat terms and of each setting's), in [`Effect::ALL`]'s order, each once.
    pub fn effects(&self) -> Vec<Effect> {
        crate::effect::in_order(std::iter::once(self.terms()).chain(self.by_pivot.iter().map(|s| s.terms)).flat_map(|t| t.effects()))
    }

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

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

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
