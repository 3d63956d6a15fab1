//! One simulated joint (a plugin instance's hardware): its drives move the motor-side angles
//! `theta = M a` (the transmission), an elastic element joins each theta to its output, and the
//! output meets its environment. The element's torque acts back on the drives through `M^T`
//! (virtual work).

use jointctl_config::{EffectsConfig, ElementSimConfig, EnvironmentConfig, PivotEffectsConfig};
use jointctl_models::characteristic::{CharacteristicSpec, PivotCharacteristic, WristCharacteristic};
use jointctl_models::assumed::smooth_dead_zone;
use jointctl_models::play::elastic_deflection;
use jointctl_models::lever_arm::LeverArm;

use crate::rng::SplitMix64;

pub use crate::effect_checks::{check_effects, check_effects_by_pivot};

/// Section 3.1: the harmonic drive stiffness used for a "rigid" element [Nm/rad].
pub const HARMONIC_DRIVE_STIFFNESS: f64 = 8.3e4;

/// The elastic element of a unit.
#[derive(Clone, Debug)]
pub enum Element {
    /// A linear spring [Nm/rad].
    Linear(f64),
    /// A 1-DOF characteristic over pivot settings.
    Pivot(PivotCharacteristic),
    /// The 2-DOF wrist characteristic.
    Wrist(WristCharacteristic),
    /// The lever-arm VSA (eq. 2.1-2.4), its play [rad] and its negative branch's scale.
    LeverArm(LeverArm, f64, f64),
    /// The wrist's lever-arm VSA on both DOFs: lever, play [rad], negative branch's scale,
    /// anisotropy.
    WristLever(LeverArm, f64, f64, f64),
}

/// A problem building a unit.
pub type UnitError = (String, String);

impl Element {
    /// Builds an element; tables come from the joint's `params.characteristic`.
    pub fn from_config(cfg: &ElementSimConfig, params: &serde_json::Value, dof: usize) -> Result<Element, UnitError> {
        let table = || -> Result<CharacteristicSpec, UnitError> {
            serde_json::from_value(params.get("characteristic").cloned().unwrap_or_default())
                .map_err(|e| ("sim.element".into(), format!("needs the joint's params.characteristic: {e}")))
        };
        Ok(match cfg {
            ElementSimConfig::Rigid => Element::Linear(HARMONIC_DRIVE_STIFFNESS),
            ElementSimConfig::Linear { stiffness_nm_per_rad } if *stiffness_nm_per_rad > 0.0 => Element::Linear(*stiffness_nm_per_rad),
            ElementSimConfig::Linear { .. } => return Err(("sim.element.linear.stiffness_nm_per_rad".into(), "must be > 0".into())),
            ElementSimConfig::PivotTable => Element::Pivot(
                PivotCharacteristic::from_spec(&table()?).map_err(|e| (format!("params.characteristic.{}", e.field), e.message))?,
            ),
            ElementSimConfig::WristTable if dof == 2 => Element::Wrist(
                WristCharacteristic::from_spec(&table()?).map_err(|e| (format!("params.characteristic.{}", e.field), e.message))?,
            ),
            ElementSimConfig::WristTable => return Err(("sim.element".into(), "wrist_table needs a 2-DOF joint".into())),
            ElementSimConfig::LeverArm { lever_length_m, crank_radius_m, spring_n_per_m, pivot_offset_m, dead_zone_rad, negative_branch_scale } => {
                let lever = lever_arm("lever_arm", [*lever_length_m, *crank_radius_m, *spring_n_per_m, *pivot_offset_m], *dead_zone_rad, *negative_branch_scale)?;
                Element::LeverArm(lever, *dead_zone_rad, *negative_branch_scale)
            }
            ElementSimConfig::WristLeverArm { lever_length_m, crank_radius_m, spring_n_per_m, pivot_offset_m, dead_zone_rad, negative_branch_scale, anisotropy } => {
                if dof != 2 {
                    return Err(("sim.element".into(), "wrist_lever_arm needs a 2-DOF joint".into()));
                }
                let lever = lever_arm("wrist_lever_arm", [*lever_length_m, *crank_radius_m, *spring_n_per_m, *pivot_offset_m], *dead_zone_rad, *negative_branch_scale)?;
                if !(anisotropy.is_finite() && anisotropy.abs() < 1.0) {
                    return Err(("sim.element.wrist_lever_arm.anisotropy".into(), format!("must be within (-1, 1), got {anisotropy}")));
                }
                Element::WristLever(lever, *dead_zone_rad, *negative_branch_scale, *anisotropy)
            }
        })
    }

    /// The element's stiffness near zero deflection at a pivot setting [Nm/rad] (a 2-DOF
    /// element's along its first DOF).
    fn stiffness(&self, pivot_mm: f64) -> f64 {
        match self {
            Element::Linear(k) => *k,
            Element::Pivot(c) => c.stiffness(pivot_mm),
            Element::Wrist(c) => c.evaluate(pivot_mm, 0.0, 0.0).stiffness_q6_nm_per_rad,
            Element::LeverArm(lever, ..) => lever.stiffness_at(pivot_mm),
            Element::WristLever(lever, _, _, anisotropy) => lever.stiffness_at(pivot_mm) * (1.0 - anisotropy),
        }
    }

    /// Element torque per DOF for the (effective) deflections, at a pivot setting.
    fn torques(&self, pivot_mm: f64, d: &[f64], out: &mut [f64]) {
        match self {
            Element::Linear(k) => out.iter_mut().zip(d).for_each(|(t, d)| *t = k * d),
            Element::Pivot(c) => out.iter_mut().zip(d).for_each(|(t, d)| *t = c.evaluate(pivot_mm, *d).torque_nm),
            Element::LeverArm(lever, play_rad, negative_scale) => out.iter_mut().zip(d).for_each(|(t, d)| {
                let torque = lever.torque_at(pivot_mm, smooth_dead_zone(*d, *play_rad));
                *t = if *d < 0.0 { negative_scale * torque } else { torque };
            }),
            Element::WristLever(lever, play_rad, negative_scale, anisotropy) => {
                // The deflection (q6, q7) as a signed length along a direction in [0, pi)
                // (0 = q7 only), as the wrist's table reads it (appendix B's polar form).
                let (q6, q7) = (d[0], d[1]);
                let (mut r, mut theta) = (q6.hypot(q7), q6.atan2(q7));
                if theta < 0.0 {
                    theta += std::f64::consts::PI;
                    r = -r;
                }
                if theta >= std::f64::consts::PI {
                    theta -= std::f64::consts::PI;
                    r = -r;
                }
                let along = lever.torque_at(pivot_mm, smooth_dead_zone(r, *play_rad)) * (1.0 + anisotropy * (2.0 * theta).cos());
                let along = if r < 0.0 { negative_scale * along } else { along };
                out[0] = along * theta.sin();
                out[1] = along * theta.cos();
            }
            Element::Wrist(c) => {
                let e = c.evaluate(pivot_mm, d[0], d[1]);
                out[0] = e.torque_q6_nm;
                out[1] = e.torque_q7_nm;
            }
        }
    }
}

/// A lever arm from its four lengths and constants, checked: every one positive, the play not
/// negative, the negative branch's scale positive.
fn lever_arm(kind: &str, [l, r, k, q]: [f64; 4], play_rad: f64, negative_scale: f64) -> Result<LeverArm, UnitError> {
    for (name, v) in [("lever_length_m", l), ("crank_radius_m", r), ("spring_n_per_m", k), ("pivot_offset_m", q)] {
        if !(v.is_finite() && v > 0.0) {
            return Err((format!("sim.element.{kind}.{name}"), format!("must be > 0, got {v}")));
        }
    }
    if !(play_rad.is_finite() && play_rad >= 0.0) {
        return Err((format!("sim.element.{kind}.dead_zone_rad"), format!("must be >= 0, got {play_rad}")));
    }
    if !(negative_scale.is_finite() && negative_scale > 0.0) {
        return Err((format!("sim.element.{kind}.negative_branch_scale"), format!("must be > 0, got {negative_scale}")));
    }
    Ok(LeverArm { lever_length_m: l, crank_radius_m: r, spring_n_per_m: k, pivot_offset_m: q })
}

/// Most DOFs of one unit.
pub const MAX_UNIT_DOF: usize = 4;

/// Per-DOF effect state.
#[derive(Clone, Copy, Debug, Default)]
struct EffectState {
    dahl_z: f64,
    /// The Dahl state's share of its limit while a loop given by setting is off.
    dahl_share_off: f64,
    mode_y: f64,
    mode_v: f64,
    sensor_noise: f64,
}

/// One simulated joint.
#[derive(Clone, Debug)]
pub struct Unit {
    /// DOF names (as published).
    pub dof_names: Vec<String>,
    /// Drive indices (columns of `matrix`).
    pub drives: Vec<usize>,
    matrix: Vec<Vec<f64>>,
    elements: Vec<Element>,
    pivot: Option<(usize, f64, f64)>,
    environments: Vec<EnvironmentConfig>,
    /// Per DOF (the same set for every DOF unless [`Unit::set_effects`] says otherwise).
    effects: [EffectsConfig; MAX_UNIT_DOF],
    /// Every DOF's effects by pivot setting (empty: `effects` as given), see
    /// [`Unit::set_effects_by_pivot`].
    effects_by_pivot: Vec<PivotEffectsConfig>,
    /// Output positions [rad].
    pub output: [f64; MAX_UNIT_DOF],
    output_velocity: [f64; MAX_UNIT_DOF],
    /// Motor-side angles [rad].
    pub theta: [f64; MAX_UNIT_DOF],
    theta_velocity: [f64; MAX_UNIT_DOF],
    /// Element torques (what the joint really carries) [Nm].
    pub torque: [f64; MAX_UNIT_DOF],
    /// What the torque sensor reads [Nm].
    pub sensor_torque: [f64; MAX_UNIT_DOF],
    /// The pivot setting [mm].
    pub pivot_mm: f64,
    state: [EffectState; MAX_UNIT_DOF],
    time_s: f64,
}

impl Unit {
    /// A unit from its parts (drive indices resolved by the caller).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        dof_names: Vec<String>,
        drives: Vec<usize>,
        matrix: Vec<Vec<f64>>,
        elements: Vec<Element>,
        pivot: Option<(usize, f64, f64)>,
        environments: Vec<EnvironmentConfig>,
        effects: EffectsConfig,
    ) -> Self {
        Unit {
            dof_names,
            drives,
            matrix,
            elements,
            pivot,
            environments,
            effects: [effects; MAX_UNIT_DOF],
            effects_by_pivot: Vec::new(),
            output: [0.0; MAX_UNIT_DOF],
            output_velocity: [0.0; MAX_UNIT_DOF],
            theta: [0.0; MAX_UNIT_DOF],
            theta_velocity: [0.0; MAX_UNIT_DOF],
            torque: [0.0; MAX_UNIT_DOF],
            sensor_torque: [0.0; MAX_UNIT_DOF],
            pivot_mm: 0.0,
            state: [EffectState::default(); MAX_UNIT_DOF],
            time_s: 0.0,
        }
    }

    fn dof(&self) -> usize {
        self.dof_names.len()
    }

    /// Where a flow-source environment puts output `i` at time `t`.
    fn flow(&self, i: usize, t: f64) -> Option<f64> {
        match self.environments[i] {
            EnvironmentConfig::Flow { amplitude_rad, frequency_hz, angle_deg, start_s } => {
                let s = if t < start_s { 0.0 } else { amplitude_rad * (std::f64::consts::TAU * frequency_hz * (t - start_s)).sin() };
                // A direction only when both DOFs are moved (the wrist); a flow on one DOF of a
                // unit (the shoulder's q2) moves that DOF alone.
                let directional = self.dof() == 2 && self.environments.iter().all(|e| matches!(e, EnvironmentConfig::Flow { .. }));
                Some(if directional {
                    // Direction angle_deg: 0 = the second DOF (q7) only, 90 = the first (q6).
                    let a = angle_deg.to_radians();
                    if i == 0 { s * a.sin() } else { s * a.cos() }
                } else {
                    s
                })
            }
            _ => None,
        }
    }

    /// Sets the outputs where the environment holds them at the start (drive positions given).
    pub fn start(&mut self, drive_positions: &[f64]) {
        self.update_theta(drive_positions, &vec![0.0; drive_positions.len()]);
        for i in 0..self.dof() {
            // At rest: a free link (or the free arm) starts still wherever it was.
            self.output_velocity[i] = 0.0;
            self.output[i] = match self.environments[i] {
                EnvironmentConfig::Fixed { position_rad } => position_rad,
                EnvironmentConfig::Flow { .. } => self.flow(i, 0.0).unwrap_or(0.0),
                _ => self.theta[i],
            };
        }
    }

    fn update_theta(&mut self, positions: &[f64], velocities: &[f64]) {
        for (i, row) in self.matrix.iter().enumerate() {
            self.theta[i] = row.iter().zip(&self.drives).map(|(m, d)| m * positions[*d]).sum();
            self.theta_velocity[i] = row.iter().zip(&self.drives).map(|(m, d)| m * velocities[*d]).sum();
        }
        if let Some((d, mm_per_rad, offset)) = self.pivot {
            self.pivot_mm = offset + mm_per_rad * positions[d];
            self.effects_at_pivot();
        }
    }

    /// Every DOF's effects at the current pivot setting, when they are given by setting.
    /// No allocation: the cycle calls it.
    fn effects_at_pivot(&mut self) {
        if self.effects_by_pivot.is_empty() {
            return;
        }
        for i in 0..self.dof() {
            let now = crate::pivot_effects::effects_at(&self.effects_by_pivot, self.pivot_mm, i);
            // A loop whose size changes with the setting keeps its state's share of its limit
            // (the same loop scaled); one that fades out keeps that share for when it returns,
            // as the observer's extension keeps its loop's unit state.
            let limit = |fx: &EffectsConfig| fx.hysteresis.map_or(0.0, |h| h.limit_nm);
            let (was, is) = (limit(&self.effects[i]), limit(&now));
            let st = &mut self.state[i];
            match (was > 0.0, is > 0.0) {
                (true, true) => st.dahl_z *= is / was,
                (true, false) => (st.dahl_share_off, st.dahl_z) = (st.dahl_z / was, 0.0),
                (false, true) => st.dahl_z = st.dahl_share_off * is,
                (false, false) => {}
            }
            self.effects[i] = now;
        }
    }

    /// One step: element torques from the drives' state, the outputs' motion, and the reaction
    /// torque added into `loads` (per drive).
    pub fn step(&mut self, positions: &[f64], velocities: &[f64], loads: &mut [f64], dt: f64, rng: &mut SplitMix64) {
        self.time_s += dt;
        self.update_theta(positions, velocities);
        let n = self.dof();
        let mut d_eff = [0.0; MAX_UNIT_DOF];
        let mut rate = [0.0; MAX_UNIT_DOF];
        for i in 0..n {
            let fx = self.effects[i];
            let d = self.theta[i] - self.output[i];
            rate[i] = self.theta_velocity[i] - self.output_velocity[i];
            // Dead-zone (play): no torque until the play is taken up.
            d_eff[i] = elastic_deflection(d, fx.dead_zone_rad, fx.dead_zone_ramp_rad);
        }
        self.element_step(&d_eff, &rate, dt, Some(rng));
        // Reaction on the drives: loads = M^T tau.
        for (i, row) in self.matrix.iter().enumerate() {
            for (m, d) in row.iter().zip(&self.drives) {
                loads[*d] += m * self.torque[i];
            }
        }
        // The outputs.
        let t_now = self.time_s;
        for i in 0..n {
            match self.environments[i] {
                EnvironmentConfig::Fixed { position_rad } => {
                    self.output[i] = position_rad;
                    self.output_velocity[i] = 0.0;
                }
                EnvironmentConfig::Flow { .. } => {
                    let q = self.flow(i, t_now).unwrap_or(0.0);
                    self.output_velocity[i] = (q - self.output[i]) / dt;
                    self.output[i] = q;
                }
                EnvironmentConfig::Free { inertia_kgm2, damping_nms_per_rad, gravity_nm } => {
                    let a = (self.torque[i] - damping_nms_per_rad * self.output_velocity[i] - gravity_nm * self.output[i].sin()) / inertia_kgm2;
                    self.output_velocity[i] += a * dt;
                    self.output[i] += self.output_velocity[i] * dt;
                }
                // The free arm moves it, all joints together (`SimHal::advance`).
                EnvironmentConfig::FreeArm { .. } => {}
                EnvironmentConfig::Spring { stiffness_nm_per_rad, rest_rad, inertia_kgm2, damping_nms_per_rad } => {
                    let a = (self.torque[i] - stiffness_nm_per_rad * (self.output[i] - rest_rad) - damping_nms_per_rad * self.output_velocity[i]) / inertia_kgm2;
                    self.output_velocity[i] += a * dt;
                    self.output[i] += self.output_velocity[i] * dt;
                }
            }
        }
    }

    /// The elements' and effects' torques for the effective deflections `d_eff` (after the
    /// play) and the deflection rates, and what the torque sensor reads (`rng` draws its noise;
    /// `None`: the noise-free expectation).
    fn element_step(&mut self, d_eff: &[f64; MAX_UNIT_DOF], rate: &[f64; MAX_UNIT_DOF], dt: f64, mut rng: Option<&mut SplitMix64>) {
        let n = self.dof();
        let mut base = [0.0; MAX_UNIT_DOF];
        if self.elements.len() == 1 && n > 1 {
            // One element for every DOF (a 2-DOF wrist table couples them).
            self.elements[0].torques(self.pivot_mm, &d_eff[..n], &mut base[..n]);
        } else {
            for (i, e) in self.elements.iter().enumerate().take(n) {
                e.torques(self.pivot_mm, &d_eff[i..i + 1], &mut base[i..i + 1]);
            }
        }
        for i in 0..n {
            let fx = self.effects[i];
            let st = &mut self.state[i];
            let mut t = base[i] + fx.cubic_nm_per_rad3 * d_eff[i].powi(3) + fx.viscous_nms_per_rad * rate[i];
            if let Some(f) = fx.arctan_friction {
                t += f.k_a_nm * (f.k_b_s_per_rad * rate[i]).atan();
            }
            if let Some(h) = fx.hysteresis {
                // Dahl: dz/dt = sigma (1 - z/fc sgn(v)) v; with a shape n, (z/fc) |z/fc|^(n-1)
                // in place of z/fc (Bouc-Wen with beta = 1, gamma = 0; the same at n = 1).
                let v = rate[i];
                let r = st.dahl_z / h.limit_nm;
                let dz_dt = h.sigma_nm_per_rad * (1.0 - r * r.abs().powf(h.shape - 1.0) * v.signum()) * v;
                let z_before = st.dahl_z;
                st.dahl_z = (st.dahl_z + dz_dt * dt).clamp(-h.limit_nm, h.limit_nm);
                // LuGre's bristle damping, sigma1 dz/dt with sigma1 = sigma tau_d, at the step the
                // state took: a stiff loop's Euler rate overshoots the limit in one step (then
                // clamped), and that rate was a spike the state never made.
                let taken_dz_dt = if dt > 0.0 { (st.dahl_z - z_before) / dt } else { 0.0 };
                t += st.dahl_z + h.presliding_damping_s * taken_dz_dt;
            }
            self.torque[i] = t;
            // The torque sensor: a structural mode rings on changes of the torque.
            let mut sensed = t;
            if let Some(m) = fx.vibration {
                let scale = m.reference_stiffness_nm_per_rad.map_or(1.0, |k_ref| {
                    let element = self.elements.get(i).unwrap_or(&self.elements[0]);
                    (element.stiffness(self.pivot_mm) / k_ref).max(0.0).sqrt()
                });
                let w = std::f64::consts::TAU * m.frequency_hz * scale;
                let acc = -w * w * (st.mode_y - t) - 2.0 * m.damping_ratio * w * st.mode_v;
                st.mode_v += acc * dt;
                st.mode_y += st.mode_v * dt;
                sensed += m.gain * (st.mode_y - t);
            }
            // A replay predicts the sensor's expectation: no noise.
            st.sensor_noise = match rng.as_deref_mut() {
                Some(rng) if fx.torque_noise_nm > 0.0 => fx.torque_noise_nm * rng.normal(),
                _ => 0.0,
            };
            self.sensor_torque[i] = sensed + fx.torque_offset_nm + st.sensor_noise;
        }
    }

    /// The simulated torque sensor's noise-free reading of DOF `dof` along a recorded motion:
    /// the element and its effects (Dahl state from the first sample, the structural mode)
    /// driven by the recorded deflection [rad] at the recorded pivot settings [mm] (NaN: the
    /// unit's own), its rate a centred least-squares slope over `rate_window_s`. The other DOFs
    /// stay undeflected. What the simulation says the sensor read, to compare with what it did.
    ///
    /// ```
    /// use jointctl_config::{EffectsConfig, EnvironmentConfig};
    /// use jointctl_sim::unit::{Element, Unit};
    /// let fx = EffectsConfig { torque_offset_nm: 0.5, ..Default::default() };
    /// let mut unit = Unit::new(vec!["q4".into()], vec![0], vec![vec![1.0]], vec![Element::Linear(100.0)], None,
    ///     vec![EnvironmentConfig::Fixed { position_rad: 0.0 }], fx);
    /// let t = [0.0, 0.01, 0.02];
    /// let tau = unit.replay(0, &t, &[0.0, 0.01, 0.02], &[f64::NAN; 3], 0.02);
    /// assert!((tau[2] - 2.5).abs() < 1e-12);
    /// ```
    pub fn replay(&mut self, dof: usize, t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64], rate_window_s: f64) -> Vec<f64> {
        let mut along = [0.0; MAX_UNIT_DOF];
        if let Some(w) = along.get_mut(dof) {
            *w = 1.0;
        }
        self.replay_along(&along, t_s, deflection_rad, pivot_mm, rate_window_s)
    }

    /// [`Unit::replay`] along a direction of several DOFs: DOF `i` deflected by `direction[i]`
    /// times the recorded deflection, and the sensors' readings projected back onto the
    /// direction (`sum direction[i] torque[i]`), as a record along that direction projects them
    /// (section 3.5.2's wrist: q6 by `sin a`, q7 by `cos a` of a deflection along `a`).
    ///
    /// ```
    /// use jointctl_config::{EffectsConfig, EnvironmentConfig};
    /// use jointctl_sim::unit::{Element, Unit};
    /// let mut unit = Unit::new(vec!["a".into(), "b".into()], vec![0, 1], vec![vec![1.0, 0.0], vec![0.0, 1.0]],
    ///     vec![Element::Linear(100.0), Element::Linear(300.0)], None,
    ///     vec![EnvironmentConfig::Fixed { position_rad: 0.0 }; 2], EffectsConfig::default());
    /// unit.set_effects(1, EffectsConfig { torque_offset_nm: 0.5, ..Default::default() });
    /// let r = std::f64::consts::FRAC_1_SQRT_2;
    /// let tau = unit.replay_along(&[r, r], &[0.0, 0.01], &[0.0, 0.01], &[f64::NAN; 2], 0.02);
    /// // (100 + 300) / 2 Nm/rad along the diagonal, and b's offset projected onto it.
    /// assert!((tau[1] - (2.0 + 0.5 * r)).abs() < 1e-12);
    /// ```
    pub fn replay_along(&mut self, direction: &[f64], t_s: &[f64], deflection_rad: &[f64], pivot_mm: &[f64], rate_window_s: f64) -> Vec<f64> {
        let n = t_s.len().min(deflection_rad.len());
        let dofs = direction.len().min(MAX_UNIT_DOF);
        self.state = [EffectState::default(); MAX_UNIT_DOF];
        let mut out = Vec::with_capacity(n);
        let mut lo = 0;
        let mut hi = 0;
        for k in 0..n {
            if let Some(p) = pivot_mm.get(k).filter(|p| p.is_finite()) {
                self.pivot_mm = *p;
            }
            self.effects_at_pivot();
            // The centred window [t - w/2, t + w/2], at least one neighbour each side.
            while lo < k && t_s[k] - t_s[lo] > rate_window_s / 2.0 && lo + 1 < k {
                lo += 1;
            }
            hi = hi.max(k);
            while hi + 1 < n && (t_s[hi + 1] - t_s[k] <= rate_window_s / 2.0 || hi == k) {
                hi += 1;
            }
            let rate = slope(&t_s[lo..=hi], &deflection_rad[lo..=hi]);
            let dt = if k == 0 { 0.0 } else { t_s[k] - t_s[k - 1] };
            let (mut d_eff, mut w) = ([0.0; MAX_UNIT_DOF], [0.0; MAX_UNIT_DOF]);
            let d = deflection_rad[k];
            for i in (0..dofs).filter(|i| direction[*i] != 0.0) {
                d_eff[i] = elastic_deflection(d * direction[i], self.effects[i].dead_zone_rad, self.effects[i].dead_zone_ramp_rad);
                w[i] = rate * direction[i];
            }
            self.element_step(&d_eff, &w, dt, None);
            out.push((0..dofs).filter(|i| direction[*i] != 0.0).map(|i| direction[i] * self.sensor_torque[i]).sum());
        }
        out
    }

    /// DOF `dof`'s plant effects in place of those [`Unit::new`] gave every DOF (the wrist's q6
    /// and q7 each their own).
    pub fn set_effects(&mut self, dof: usize, effects: EffectsConfig) {
        if let Some(fx) = self.effects.get_mut(dof) {
            *fx = effects;
        }
    }

    /// Every DOF's effects by pivot setting (`sim.effects_by_pivot`) in place of those
    /// [`Unit::new`] gave: from now on, those at the unit's pivot, the loops' states from rest.
    ///
    /// # Errors
    /// A unit without a pivot, or what [`check_effects_by_pivot`] refuses (the unit is left as
    /// it was).
    pub fn set_effects_by_pivot(&mut self, settings: Vec<PivotEffectsConfig>) -> Result<(), UnitError> {
        if self.pivot.is_none() {
            return Err(("effects_by_pivot".into(), "the unit has no pivot: give its effects as one set".into()));
        }
        check_effects_by_pivot(&settings, self.dof())?;
        self.effects_by_pivot = settings;
        self.effects = [EffectsConfig::default(); MAX_UNIT_DOF];
        self.state.iter_mut().for_each(|st| (st.dahl_z, st.dahl_share_off) = (0.0, 0.0));
        self.effects_at_pivot();
        Ok(())
    }

    /// DOF `i`'s output position [rad] and velocity [rad/s].
    pub fn output_state(&self, i: usize) -> (f64, f64) {
        (self.output[i], self.output_velocity[i])
    }

    /// Moves DOF `i`'s output (the free arm integrates the outputs it owns).
    pub(crate) fn set_output_state(&mut self, i: usize, position_rad: f64, velocity_rad_s: f64) {
        self.output[i] = position_rad;
        self.output_velocity[i] = velocity_rad_s;
    }

    /// DOF `i`'s environment.
    pub fn environment(&self, i: usize) -> &EnvironmentConfig {
        &self.environments[i]
    }

    /// A named signal of DOF `i`.
    pub fn signal(&self, i: usize, kind: SignalKind) -> f64 {
        match kind {
            SignalKind::Output => self.output[i],
            SignalKind::Theta => self.theta[i],
            SignalKind::Deflection => self.theta[i] - self.output[i],
            SignalKind::Torque => self.sensor_torque[i],
            SignalKind::Pivot => self.pivot_mm,
        }
    }
}

/// What a simulated signal measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// Output position [rad].
    Output,
    /// Motor-side joint angle [rad].
    Theta,
    /// Deflection theta - output [rad].
    Deflection,
    /// The torque sensor [Nm].
    Torque,
    /// Pivot setting [mm].
    Pivot,
}

impl SignalKind {
    /// Parses `output`, `theta`, `deflection`, `torque`, `pivot_mm`.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "output" => SignalKind::Output,
            "theta" => SignalKind::Theta,
            "deflection" => SignalKind::Deflection,
            "torque" => SignalKind::Torque,
            "pivot_mm" => SignalKind::Pivot,
            _ => return None,
        })
    }
}

/// The least-squares slope of `y` over `t` (0 for fewer than two distinct times).
fn slope(t: &[f64], y: &[f64]) -> f64 {
    let n = t.len() as f64;
    if t.len() < 2 {
        return 0.0;
    }
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (a, b) in t.iter().zip(y) {
        sxy += (a - mt) * (b - my);
        sxx += (a - mt) * (a - mt);
    }
    if sxx > 0.0 { sxy / sxx } else { 0.0 }
}
