//! Torque-deflection characteristics, in the YAML form that `jointctl fit` writes and the joint
//! plugins load:
//!
//! ```yaml
//! characteristic:
//!   source: assumed          # or: measured
//!   curves:
//!     - {pivot_mm: 0.0, positive: [c1, c2, c3], negative: [c1, c2, c3], stiffness_nm_per_rad: 412.0}
//!     - {pivot_mm: 5.0, angle_deg: 45, coefficients: [c1, c2, c3, c4], stiffness_nm_per_rad: 30.0}
//! ```
//!
//! A curve is a polynomial through zero, `tau = c1 x + c2 x^2 + ... ` (the thesis forces zero
//! torque at zero deflection, sections 3.4.2 and 3.5.2), either continuous (`coefficients`) or
//! with separate branches for positive and negative deflection (`positive`, `negative`: the
//! shoulder's best fit, section 3.4.2). `stiffness_nm_per_rad` is the first-order fit used as the
//! joint stiffness, because the derivative of the polynomial destabilised the controller
//! (section 4.2). Between characterised pivot settings the torque and stiffness of the two
//! nearest curves are averaged with a linear weight (sections 3.4.2, 4.2); outside them the pivot
//! is clamped to the nearest setting and the result flagged, never extrapolated.

use serde::{Deserialize, Serialize};

/// Highest polynomial order a curve may have.
pub const MAX_ORDER: usize = 6;

/// Whether a characteristic was measured or generated as a stand-in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Fitted on measurements.
    Measured,
    /// Generated (e.g. from the lever-arm model) until measurements replace it.
    Assumed,
}

/// One fitted curve, as written in YAML.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    /// Pivot setting [mm] (VSA joints).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pivot_mm: Option<f64>,
    /// Deflection direction [deg] (the 2-DOF wrist: 0 = q7 only, 90 = q6 only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angle_deg: Option<f64>,
    /// Continuous polynomial coefficients `[c1, c2, ...]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coefficients: Option<Vec<f64>>,
    /// Coefficients for deflection >= 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positive: Option<Vec<f64>>,
    /// Coefficients for deflection < 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub negative: Option<Vec<f64>>,
    /// Torque at zero deflection [Nm], for a fit not forced through zero (the thesis forces it
    /// through zero: leave it out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_nm: Option<f64>,
    /// First-order fit [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// Deflections the curve holds for, `[lowest, highest]` [rad] (`fit` writes the data's
    /// range): the curve must rise over it. Without it, [`DEFAULT_RANGE_RAD`] either side.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range_rad: Option<[f64; 2]>,
}

/// The deflection either side of zero over which a curve without `range_rad` must rise [rad]:
/// the largest the project's characterisation drives an element to (`sim characterise`'s
/// `max_deflection_rad`), an assumption for a file that does not say.
pub const DEFAULT_RANGE_RAD: f64 = 0.35;

/// Points at which a curve's rise is checked over its range (an assumption: a polynomial of at
/// most [`MAX_ORDER`] turns at most `MAX_ORDER - 1` times, far fewer than this).
const RISE_POINTS: usize = 256;

/// The fall below the torque already reached that a curve may show over its range, as a share
/// of the range's torque span (an assumption: a polynomial fitted through a dead zone wiggles by
/// a fraction of a percent there; a curve that turns back falls by far more).
const RISE_TOLERANCE: f64 = 0.01;

/// A characteristic as written in YAML.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CharacteristicSpec {
    /// Measured or assumed.
    pub source: Source,
    /// The curves.
    pub curves: Vec<CurveSpec>,
}

impl CharacteristicSpec {
    /// Whether its curves have deflection directions: a 2-DOF table (the wrist, section 3.5.2).
    pub fn is_two_dof(&self) -> bool {
        self.curves.iter().any(|c| c.angle_deg.is_some())
    }

    /// The distinct pivot settings of its curves [mm], increasing (none for a curve without).
    ///
    /// ```
    /// let spec: jointctl_models::characteristic::CharacteristicSpec = serde_json::from_str(
    ///     r#"{"source": "assumed", "curves": [{"pivot_mm": 10, "coefficients": [50], "stiffness_nm_per_rad": 50},
    ///        {"pivot_mm": 0, "coefficients": [90], "stiffness_nm_per_rad": 90}, {"pivot_mm": 10, "angle_deg": 45, "coefficients": [50], "stiffness_nm_per_rad": 50}]}"#).unwrap();
    /// assert_eq!(spec.pivot_settings_mm(), vec![0.0, 10.0]);
    /// assert!(spec.is_two_dof());
    /// ```
    pub fn pivot_settings_mm(&self) -> Vec<f64> {
        let mut pivots: Vec<f64> = self.curves.iter().filter_map(|c| c.pivot_mm).collect();
        pivots.sort_by(f64::total_cmp);
        pivots.dedup();
        pivots
    }
}

/// A problem in a characteristic, with the field it concerns (relative to the characteristic).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpecError {
    /// Field path, e.g. `curves[3].positive`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

fn err(field: String, message: impl Into<String>) -> SpecError {
    SpecError { field, message: message.into() }
}

/// A polynomial through zero with separate branches, evaluated without allocating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curve {
    positive: [f64; MAX_ORDER],
    negative: [f64; MAX_ORDER],
    offset_nm: f64,
    /// First-order fit [Nm/rad].
    pub stiffness_nm_per_rad: f64,
}

fn horner_through_zero(c: &[f64; MAX_ORDER], x: f64) -> f64 {
    let mut acc = 0.0;
    for k in c.iter().rev() {
        acc = acc * x + k;
    }
    acc * x
}

impl Curve {
    /// A continuous curve `c1 x + c2 x^2 + ...`.
    ///
    /// ```
    /// let c = jointctl_models::characteristic::Curve::continuous(&[2.0, 0.0, 1.0], 2.0);
    /// assert_eq!(c.torque(0.5), 2.0 * 0.5 + 0.125);
    /// ```
    pub fn continuous(coefficients: &[f64], stiffness_nm_per_rad: f64) -> Self {
        Self::branched(coefficients, coefficients, stiffness_nm_per_rad)
    }

    /// A curve with separate positive and negative branches.
    pub fn branched(positive: &[f64], negative: &[f64], stiffness_nm_per_rad: f64) -> Self {
        let mut p = [0.0; MAX_ORDER];
        let mut n = [0.0; MAX_ORDER];
        p[..positive.len().min(MAX_ORDER)].copy_from_slice(&positive[..positive.len().min(MAX_ORDER)]);
        n[..negative.len().min(MAX_ORDER)].copy_from_slice(&negative[..negative.len().min(MAX_ORDER)]);
        Curve { positive: p, negative: n, offset_nm: 0.0, stiffness_nm_per_rad }
    }

    /// Torque [Nm] at a deflection [rad]. The offset (zero unless fitted) at zero, continuous
    /// across the branches.
    pub fn torque(&self, deflection_rad: f64) -> f64 {
        self.offset_nm
            + if deflection_rad >= 0.0 {
                horner_through_zero(&self.positive, deflection_rad)
            } else {
                horner_through_zero(&self.negative, deflection_rad)
            }
    }

    fn from_spec(s: &CurveSpec, i: usize) -> Result<Curve, SpecError> {
        let at = |f: &str| format!("curves[{i}].{f}");
        let check = |name: &str, c: &Vec<f64>| -> Result<(), SpecError> {
            if c.is_empty() || c.len() > MAX_ORDER {
                return Err(err(at(name), format!("needs 1 to {MAX_ORDER} coefficients, got {}", c.len())));
            }
            if let Some(j) = c.iter().position(|v| !v.is_finite()) {
                return Err(err(format!("{}[{j}]", at(name)), "must be finite"));
            }
            Ok(())
        };
        if !(s.stiffness_nm_per_rad.is_finite() && s.stiffness_nm_per_rad > 0.0) {
            return Err(err(at("stiffness_nm_per_rad"), format!("must be finite and > 0, got {}", s.stiffness_nm_per_rad)));
        }
        let offset_nm = match s.offset_nm {
            Some(o) if !o.is_finite() => return Err(err(at("offset_nm"), "must be finite")),
            o => o.unwrap_or(0.0),
        };
        let curve = match (&s.coefficients, &s.positive, &s.negative) {
            (Some(c), None, None) => {
                check("coefficients", c)?;
                Curve::continuous(c, s.stiffness_nm_per_rad)
            }
            (None, Some(p), Some(n)) => {
                check("positive", p)?;
                check("negative", n)?;
                Curve::branched(p, n, s.stiffness_nm_per_rad)
            }
            _ => return Err(err(format!("curves[{i}]"), "give either `coefficients`, or both `positive` and `negative`")),
        };
        let curve = Curve { offset_nm, ..curve };
        let [lo, hi] = s.range_rad.unwrap_or([-DEFAULT_RANGE_RAD, DEFAULT_RANGE_RAD]);
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(err(at("range_rad"), format!("must be two finite deflections, the lower first, got [{lo}, {hi}]")));
        }
        // Torque must rise with deflection over the range: a spring whose torque falls as it
        // deflects further would make the observer read the load backwards there. A fitted
        // polynomial wiggles where the element is flat (a dead zone): a fall below the torque
        // reached before of more than RISE_TOLERANCE of the range's torque span counts.
        let at_point = |k: usize| lo + (hi - lo) * k as f64 / (RISE_POINTS - 1) as f64;
        let span = curve.torque(hi) - curve.torque(lo);
        let mut highest = curve.torque(lo);
        let falls = (1..RISE_POINTS).find(|k| {
            let torque = curve.torque(at_point(*k));
            highest = highest.max(torque);
            !(span > 0.0) || highest - torque > RISE_TOLERANCE * span
        });
        if let Some(k) = falls {
            return Err(err(
                format!("curves[{i}]"),
                format!("torque does not rise with deflection at {:.4} rad (range [{lo}, {hi}] rad{}): not a spring's characteristic", at_point(k), if s.range_rad.is_none() { ", the default; give `range_rad` with the deflections the curve was fitted over" } else { "" }),
            ));
        }
        Ok(curve)
    }
}

/// The lowest and highest of the deflections a curve is fitted to, `[lowest, highest]` [rad]:
/// its `range_rad`.
///
/// ```
/// assert_eq!(jointctl_models::characteristic::deflection_range(&[0.02, -0.05, 0.04]), [-0.05, 0.04]);
/// ```
pub fn deflection_range(deflections_rad: &[f64]) -> [f64; 2] {
    deflections_rad.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| [lo.min(*v), hi.max(*v)])
}

/// The checks a loaded curve passes (finite coefficients, positive stiffness, a torque that rises
/// over `range_rad`), for a writer that wants to refuse what the runtime would.
///
/// ```
/// use jointctl_models::characteristic::{CurveSpec, check_curve};
/// let line = CurveSpec { pivot_mm: None, angle_deg: None, coefficients: Some(vec![100.0]), positive: None, negative: None, offset_nm: None, stiffness_nm_per_rad: 100.0, range_rad: Some([-0.1, 0.1]) };
/// assert!(check_curve(&line).is_ok());
/// let turning = CurveSpec { coefficients: Some(vec![100.0, 0.0, -2.0e4]), ..line };
/// assert!(check_curve(&turning).unwrap_err().message.contains("does not rise"));
/// ```
pub fn check_curve(curve: &CurveSpec) -> Result<(), SpecError> {
    Curve::from_spec(curve, 0).map(|_| ())
}

/// The result of evaluating a characteristic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// Torque [Nm].
    pub torque_nm: f64,
    /// Stiffness [Nm/rad] (interpolated first-order fits).
    pub stiffness_nm_per_rad: f64,
    /// The pivot setting was outside the characterised range and was clamped.
    pub clamped: bool,
}

/// Section 4.2: the stiffness setting `i` (lower of the two nearest characterised settings) and
/// the scale factor `q` in [0, 1] between setting `i` and `i + 1`; clamped outside the range.
///
/// ```
/// use jointctl_models::characteristic::pivot_bracket;
/// let p = [0.0, 5.0, 10.0];
/// assert_eq!(pivot_bracket(&p, 7.5), (1, 0.5, false));
/// assert_eq!(pivot_bracket(&p, 10.0), (1, 1.0, false));
/// assert_eq!(pivot_bracket(&p, 12.0), (1, 1.0, true));
/// assert_eq!(pivot_bracket(&p, -1.0), (0, 0.0, true));
/// ```
pub fn pivot_bracket(pivots_mm: &[f64], pivot_mm: f64) -> (usize, f64, bool) {
    let n = pivots_mm.len();
    if n < 2 {
        return (0, 0.0, n == 0 || pivot_mm != pivots_mm[0]);
    }
    if pivot_mm.is_nan() || pivot_mm <= pivots_mm[0] {
        return (0, 0.0, !(pivot_mm == pivots_mm[0]));
    }
    if pivot_mm >= pivots_mm[n - 1] {
        return (n - 2, 1.0, pivot_mm > pivots_mm[n - 1]);
    }
    let i = pivots_mm.partition_point(|p| *p <= pivot_mm) - 1;
    let i = i.min(n - 2);
    (i, (pivot_mm - pivots_mm[i]) / (pivots_mm[i + 1] - pivots_mm[i]), false)
}

/// The pivot setting [mm] at which a piecewise-linear, monotonic table `values` over `pivots_mm`
/// reaches `target`, clamped to the table's range (the inverse of the stiffness table, used to
/// turn a requested stiffness into a pivot set-point).
///
/// ```
/// use jointctl_models::characteristic::invert_table;
/// assert_eq!(invert_table(&[0.0, 10.0, 20.0], &[400.0, 200.0, 100.0], 150.0), Some(15.0));
/// assert_eq!(invert_table(&[0.0, 10.0, 20.0], &[400.0, 200.0, 100.0], 1000.0), Some(0.0));
/// ```
pub fn invert_table(pivots_mm: &[f64], values: &[f64], target: f64) -> Option<f64> {
    let n = values.len().min(pivots_mm.len());
    if n == 0 || !target.is_finite() {
        return None;
    }
    if n == 1 {
        return Some(pivots_mm[0]);
    }
    let (lo, hi) = (values[..n].iter().copied().fold(f64::INFINITY, f64::min), values[..n].iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let t = target.clamp(lo, hi);
    (0..n - 1).find_map(|i| {
        let (a, b) = (values[i], values[i + 1]);
        ((a.min(b)..=a.max(b)).contains(&t) && a != b).then(|| pivots_mm[i] + (t - a) / (b - a) * (pivots_mm[i + 1] - pivots_mm[i]))
    })
    .or_else(|| values[..n].iter().position(|v| *v == t).map(|i| pivots_mm[i]))
}

/// A 1-DOF characteristic over pivot settings (the shoulder q2; a single curve for an elastic joint).
#[derive(Clone, Debug, PartialEq)]
pub struct PivotCharacteristic {
    /// Measured or assumed.
    pub source: Source,
    pivots_mm: Vec<f64>,
    curves: Vec<Curve>,
    stiffness: Vec<f64>,
}

fn sorted_strictly(v: &[f64]) -> bool {
    v.windows(2).all(|w| w[0] < w[1])
}

impl PivotCharacteristic {
    /// Builds from a spec: curves with distinct `pivot_mm` (or one curve without), no `angle_deg`.
    pub fn from_spec(spec: &CharacteristicSpec) -> Result<Self, SpecError> {
        if spec.curves.is_empty() {
            return Err(err("curves".into(), "needs at least one curve"));
        }
        let mut rows = Vec::new();
        for (i, c) in spec.curves.iter().enumerate() {
            if c.angle_deg.is_some() {
                return Err(err(format!("curves[{i}].angle_deg"), "a 1-DOF joint has no deflection directions"));
            }
            let pivot = match (c.pivot_mm, spec.curves.len()) {
                (Some(p), _) if p.is_finite() => p,
                (None, 1) => 0.0,
                _ => return Err(err(format!("curves[{i}].pivot_mm"), "each of several curves needs a finite pivot_mm")),
            };
            rows.push((pivot, Curve::from_spec(c, i)?));
        }
        rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        let pivots_mm: Vec<f64> = rows.iter().map(|r| r.0).collect();
        if !sorted_strictly(&pivots_mm) {
            return Err(err("curves".into(), "two curves have the same pivot_mm"));
        }
        let curves: Vec<Curve> = rows.into_iter().map(|r| r.1).collect();
        let stiffness = curves.iter().map(|c| c.stiffness_nm_per_rad).collect();
        Ok(PivotCharacteristic { source: spec.source, pivots_mm, curves, stiffness })
    }

    /// The characterised pivot settings [mm], ascending.
    pub fn pivots_mm(&self) -> &[f64] {
        &self.pivots_mm
    }

    /// Torque and stiffness at a pivot setting and deflection (section 4.2 interpolation).
    pub fn evaluate(&self, pivot_mm: f64, deflection_rad: f64) -> Evaluation {
        let (i, w, clamped) = pivot_bracket(&self.pivots_mm, pivot_mm);
        let a = &self.curves[i];
        let (t, k) = match self.curves.get(i + 1) {
            Some(b) if w > 0.0 => (
                (1.0 - w) * a.torque(deflection_rad) + w * b.torque(deflection_rad),
                (1.0 - w) * a.stiffness_nm_per_rad + w * b.stiffness_nm_per_rad,
            ),
            _ => (a.torque(deflection_rad), a.stiffness_nm_per_rad),
        };
        Evaluation { torque_nm: t, stiffness_nm_per_rad: k, clamped }
    }

    /// The stiffness [Nm/rad] at a pivot setting.
    pub fn stiffness(&self, pivot_mm: f64) -> f64 {
        self.evaluate(pivot_mm, 0.0).stiffness_nm_per_rad
    }

    /// The pivot setting [mm] that gives a stiffness (inverse of the interpolated stiffness
    /// table), clamped to the characterised range. Allocation-free.
    pub fn pivot_for_stiffness(&self, stiffness_nm_per_rad: f64) -> Option<f64> {
        invert_table(&self.pivots_mm, &self.stiffness, stiffness_nm_per_rad)
    }

    /// Stiffness range [Nm/rad] over the characterised pivot settings.
    pub fn stiffness_range(&self) -> (f64, f64) {
        self.curves.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| (lo.min(c.stiffness_nm_per_rad), hi.max(c.stiffness_nm_per_rad)))
    }
}

/// Evaluation of the 2-DOF wrist characteristic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WristEvaluation {
    /// Torque about the q6 axis [Nm].
    pub torque_q6_nm: f64,
    /// Torque about the q7 axis [Nm].
    pub torque_q7_nm: f64,
    /// Stiffness along the q6 axis (direction 90 deg) [Nm/rad].
    pub stiffness_q6_nm_per_rad: f64,
    /// Stiffness along the q7 axis (direction 0 deg) [Nm/rad].
    pub stiffness_q7_nm_per_rad: f64,
    /// The pivot setting was clamped to the characterised range.
    pub clamped: bool,
}

/// Polar coordinates of a wrist deflection: `x` = q7 deflection (direction 0 deg), `y` = q6
/// deflection (90 deg). Appendix B's eq. B.2 writes `theta = tanh(y/r)`; the intended angle with
/// its quadrant is `atan2(y, x)` (section 4.2 takes the quadrant into account).
///
/// ```
/// use jointctl_models::characteristic::eq_b_2_polar;
/// let (r, th) = eq_b_2_polar(-1.0, -1.0);
/// assert!((r - 2f64.sqrt()).abs() < 1e-12 && (th + 3.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-12);
/// ```
pub fn eq_b_2_polar(x: f64, y: f64) -> (f64, f64) {
    (x.hypot(y), y.atan2(x))
}

/// Eq. B.3: back to Cartesian, `x = r cos(theta)`, `y = r sin(theta)`.
pub fn eq_b_3_cartesian(r: f64, theta: f64) -> (f64, f64) {
    (r * theta.cos(), r * theta.sin())
}

/// The 2-DOF wrist characteristic (q6 + q7, section 3.5.2): curves along measured deflection
/// directions (0 = q7 only, 45, 90 = q6 only, 135 deg) at each characterised pivot setting.
#[derive(Clone, Debug, PartialEq)]
pub struct WristCharacteristic {
    /// Measured or assumed.
    pub source: Source,
    pivots_mm: Vec<f64>,
    angles_rad: Vec<f64>,
    // curves[pivot * angles + angle]
    curves: Vec<Curve>,
}

impl WristCharacteristic {
    /// Builds from a spec: every pivot setting has curves for the same set of directions in
    /// [0, 180) deg (a direction and its opposite are one line).
    pub fn from_spec(spec: &CharacteristicSpec) -> Result<Self, SpecError> {
        let mut rows = Vec::new();
        for (i, c) in spec.curves.iter().enumerate() {
            let p = c.pivot_mm.filter(|p| p.is_finite()).ok_or_else(|| err(format!("curves[{i}].pivot_mm"), "required and finite"))?;
            let a = c
                .angle_deg
                .filter(|a| (0.0..180.0).contains(a))
                .ok_or_else(|| err(format!("curves[{i}].angle_deg"), "required, in [0, 180) deg"))?;
            rows.push((p, a, Curve::from_spec(c, i)?));
        }
        rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut pivots: Vec<f64> = rows.iter().map(|r| r.0).collect();
        pivots.dedup();
        let angles: Vec<f64> = rows.iter().filter(|r| r.0 == pivots[0]).map(|r| r.1).collect();
        if rows.is_empty() || !sorted_strictly(&angles) {
            return Err(err("curves".into(), "needs curves with distinct angle_deg per pivot_mm"));
        }
        for (k, p) in pivots.iter().enumerate() {
            let here: Vec<f64> = rows.iter().filter(|r| r.0 == *p).map(|r| r.1).collect();
            if here != angles {
                return Err(err(
                    "curves".into(),
                    format!("pivot_mm {p} has directions {here:?} but pivot_mm {} has {angles:?}; every setting needs the same directions", pivots[0]),
                ));
            }
            let _ = k;
        }
        Ok(WristCharacteristic {
            source: spec.source,
            angles_rad: angles.iter().map(|a| a.to_radians()).collect(),
            pivots_mm: pivots,
            curves: rows.into_iter().map(|r| r.2).collect(),
        })
    }

    /// The characterised pivot settings [mm].
    pub fn pivots_mm(&self) -> &[f64] {
        &self.pivots_mm
    }

    fn curve(&self, pivot: usize, angle: usize) -> &Curve {
        &self.curves[pivot * self.angles_rad.len() + angle]
    }

    /// Signed torque along the line at measured direction `angle` (index; `n` = 180 deg, the
    /// first direction with its sign flipped), interpolated over the pivot.
    fn along(&self, i: usize, w: f64, angle: usize, rho: f64) -> (f64, f64) {
        let n = self.angles_rad.len();
        let eval = |p: usize| {
            if angle == n {
                // Direction 180 deg is direction 0 with the deflection reversed.
                let c = self.curve(p, 0);
                (-c.torque(-rho), c.stiffness_nm_per_rad)
            } else {
                let c = self.curve(p, angle);
                (c.torque(rho), c.stiffness_nm_per_rad)
            }
        };
        let (t0, k0) = eval(i);
        if w > 0.0 && i + 1 < self.pivots_mm.len() {
            let (t1, k1) = eval(i + 1);
            ((1.0 - w) * t0 + w * t1, (1.0 - w) * k0 + w * k1)
        } else {
            (t0, k0)
        }
    }

    fn stiffness_along(&self, i: usize, w: f64, theta: f64) -> f64 {
        self.interpolate_direction(i, w, theta, 0.0).1
    }

    /// Torque and stiffness along direction `theta` in [0, pi) at signed radius `rho`.
    fn interpolate_direction(&self, i: usize, w: f64, theta: f64, rho: f64) -> (f64, f64) {
        let n = self.angles_rad.len();
        // Bracketing measured directions; beyond the last one, towards 180 deg (= the first, reversed).
        let j = self.angles_rad.partition_point(|a| *a <= theta).saturating_sub(1);
        let (a0, a1) = (self.angles_rad[j], if j + 1 < n { self.angles_rad[j + 1] } else { self.angles_rad[0] + std::f64::consts::PI });
        let v = if a1 > a0 { ((theta - a0) / (a1 - a0)).clamp(0.0, 1.0) } else { 0.0 };
        let (t0, k0) = self.along(i, w, j, rho);
        let (t1, k1) = self.along(i, w, j + 1, rho);
        ((1.0 - v) * t0 + v * t1, (1.0 - v) * k0 + v * k1)
    }

    /// The stiffness along the q6 axis (`q6 = true`) or the q7 axis at each characterised pivot
    /// setting; with [`invert_table`] it turns a requested stiffness into a pivot setting.
    pub fn axis_stiffness_table(&self, q6: bool) -> Vec<f64> {
        let theta = if q6 { std::f64::consts::FRAC_PI_2 } else { 0.0 };
        (0..self.pivots_mm.len()).map(|i| self.stiffness_along(i, 0.0, theta)).collect()
    }

    /// DOF `dof`'s torque [Nm] (0: q6, 1: q7) at deflection `deflection_rad` with the other DOF
    /// undeflected: the wrist characterised along one DOF (0 deg for q7, 90 deg for q6).
    pub fn torque_of_dof(&self, pivot_mm: f64, dof: usize, deflection_rad: f64) -> f64 {
        if dof == 0 { self.evaluate(pivot_mm, deflection_rad, 0.0).torque_q6_nm } else { self.evaluate(pivot_mm, 0.0, deflection_rad).torque_q7_nm }
    }

    /// Section 4.2 / figure 4.3: deflection (q6, q7) → polar, torque along the two nearest
    /// measured directions and the two nearest pivot settings, interpolated, back to q6/q7 torques.
    pub fn evaluate(&self, pivot_mm: f64, deflection_q6_rad: f64, deflection_q7_rad: f64) -> WristEvaluation {
        let (i, w, clamped) = pivot_bracket(&self.pivots_mm, pivot_mm);
        let (r, mut theta) = eq_b_2_polar(deflection_q7_rad, deflection_q6_rad);
        // Fold onto [0, pi): the opposite direction is the same line with a negative radius.
        let mut rho = r;
        if !(0.0..std::f64::consts::PI).contains(&theta) {
            theta = if theta < 0.0 { theta + std::f64::consts::PI } else { theta - std::f64::consts::PI };
            rho = -r;
        }
        let (t, _) = self.interpolate_direction(i, w, theta, rho);
        let (tx, ty) = eq_b_3_cartesian(t, theta);
        WristEvaluation {
            torque_q6_nm: ty,
            torque_q7_nm: tx,
            stiffness_q6_nm_per_rad: self.stiffness_along(i, w, std::f64::consts::FRAC_PI_2),
            stiffness_q7_nm_per_rad: self.stiffness_along(i, w, 0.0),
            clamped,
        }
    }
}
