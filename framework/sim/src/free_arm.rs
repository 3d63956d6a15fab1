//! The free arm: the simulated joints whose environment is `free_arm` move as one rigid-body
//! system, the arm of `kinematics.urdf`, its links loading each other under gravity and through
//! their motion. Each step the elements' torques drive it: `M(q) q'' + C q' + g(q) = tau - D q'`.

use jointctl_config::EnvironmentConfig;
use jointctl_kinematics::{Chain, Dynamics, DynamicsError};

use crate::unit::Unit;

/// Why the free arm cannot be built: the field and the reason.
pub type FreeArmError = (String, String);

/// The coupled outputs of the units' `free_arm` DOFs.
#[derive(Clone, Debug)]
pub struct FreeArm {
    dynamics: Dynamics,
    /// For each joint of the URDF, the simulated unit and DOF that is it.
    at: Vec<(usize, usize)>,
    /// Joints that are not `free_arm`: their own environment moves them, the arm takes them as
    /// still (their acceleration is not fed to the links they carry).
    locked: Vec<bool>,
    damping_nms_per_rad: Vec<f64>,
    q: Vec<f64>,
    qd: Vec<f64>,
    tau: Vec<f64>,
    qdd: Vec<f64>,
    failures: u64,
}

impl FreeArm {
    /// The free arm of `chain` under gravity `g_m_s2` (down the URDF's -z), over `units`; `None`
    /// when no DOF is `free_arm`.
    pub fn new(chain: Option<&Chain>, g_m_s2: f64, units: &[Unit], field_of: impl Fn(usize) -> String) -> Result<Option<FreeArm>, FreeArmError> {
        let mut first = None;
        for (u, unit) in units.iter().enumerate() {
            if let Some(i) = (0..unit.dof_names.len()).find(|i| matches!(unit.environment(*i), EnvironmentConfig::FreeArm { .. })) {
                first = Some((u, i));
                break;
            }
        }
        let Some((u, i)) = first else { return Ok(None) };
        let Some(chain) = chain else {
            return Err((field_of(u), format!("`{}` is a joint of the free arm, which needs the arm's URDF (`kinematics: {{urdf: FILE}}`)", units[u].dof_names[i])));
        };
        let n = chain.dof_names().len();
        let (mut at, mut locked, mut damping, mut armature) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for dof in chain.dof_names() {
            let Some((u, i)) = units.iter().enumerate().find_map(|(u, unit)| unit.dof_names.iter().position(|d| d == dof).map(|i| (u, i))) else {
                return Err(("kinematics.urdf".into(), format!("joint `{dof}` of the free arm's URDF is not simulated: give it a `sim:` section (`environment: {{kind: fixed}}` clamps it)")));
            };
            at.push((u, i));
            match *units[u].environment(i) {
                EnvironmentConfig::FreeArm { damping_nms_per_rad, armature_kgm2 } => {
                    locked.push(false);
                    damping.push(damping_nms_per_rad);
                    armature.push(armature_kgm2);
                }
                _ => {
                    locked.push(true);
                    damping.push(0.0);
                    armature.push(0.0);
                }
            }
        }
        let dynamics = Dynamics::downward(chain.clone(), g_m_s2).with_armature(&armature).map_err(|e| (field_of(u), e.to_string()))?;
        let mut arm = FreeArm { dynamics, at, locked, damping_nms_per_rad: damping, q: vec![0.0; n], qd: vec![0.0; n], tau: vec![0.0; n], qdd: vec![0.0; n], failures: 0 };
        // A joint that moves no inertia has no acceleration: said now, not as a frozen joint later.
        arm.gather(units);
        if let Err(e) = arm.dynamics.forward(&arm.q, &arm.qd, &arm.tau, &arm.locked, &mut arm.qdd) {
            let culprit = match &e {
                DynamicsError::Singular { dof } => chain.dof_names().iter().position(|d| d == dof).map(|k| arm.at[k].0).unwrap_or(u),
                DynamicsError::Pose(_) | DynamicsError::Armature { .. } => u,
            };
            return Err((field_of(culprit), e.to_string()));
        }
        Ok(Some(arm))
    }

    fn gather(&mut self, units: &[Unit]) {
        for (k, &(u, i)) in self.at.iter().enumerate() {
            (self.q[k], self.qd[k]) = units[u].output_state(i);
            self.tau[k] = units[u].torque[i] - self.damping_nms_per_rad[k] * self.qd[k];
        }
    }

    /// One step of `dt` [s]: the elements' torques (computed by the units this step) accelerate
    /// the free joints; their outputs move (semi-implicit Euler, as the units' own free links).
    /// Allocation-free. If the arm has no answer (a state gone non-finite), the outputs stay
    /// where they are, at rest, and [`FreeArm::failures`] counts it.
    pub fn step(&mut self, units: &mut [Unit], dt: f64) {
        self.gather(units);
        if self.dynamics.forward(&self.q, &self.qd, &self.tau, &self.locked, &mut self.qdd).is_err() {
            self.failures += 1;
            self.qdd.iter_mut().for_each(|a| *a = 0.0);
            self.qd.iter_mut().for_each(|v| *v = 0.0);
        }
        for (k, &(u, i)) in self.at.iter().enumerate() {
            if self.locked[k] {
                continue;
            }
            let v = self.qd[k] + self.qdd[k] * dt;
            units[u].set_output_state(i, self.q[k] + v * dt, v);
        }
    }

    /// Steps in which the arm had no answer.
    pub fn failures(&self) -> u64 {
        self.failures
    }

    /// The arm's dynamics.
    pub fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }
}

/// Output damping of a joint released by [`release`] whose configured environment gives none
/// [Nms/rad]. Assumption: bearing and seal friction of the order of the configured links'
/// (0.1-5 Nms/rad in `configs/sherpa_arm.yaml`).
pub const DEFAULT_DAMPING_NMS_PER_RAD: f64 = 1.0;

/// Armature of a joint released by [`release`] [kg m^2]. Assumption: the output side of the
/// joint's gear; chosen so that every joint moves at least this inertia, which keeps the stiffest
/// element (a harmonic drive, 8.3e4 Nm/rad, section 3.1) ringing at most at sqrt(8.3e4 / 0.02) =
/// 2037 rad/s, within what the default 0.5 ms physics step integrates stably (< 4000 rad/s).
pub const DEFAULT_ARMATURE_KGM2: f64 = 0.02;

/// Takes the arm off its clamps: every simulated DOF that is a joint of `chain` becomes a joint
/// of the free arm (`{kind: free_arm}`), keeping its configured output damping where it has one
/// ([`DEFAULT_DAMPING_NMS_PER_RAD`] otherwise) and with [`DEFAULT_ARMATURE_KGM2`] (a DOF already
/// `free_arm` keeps both). Returns the
/// DOFs released.
///
/// ```
/// let mut loaded = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
/// let chain = loaded.chain.clone().unwrap();
/// let released = jointctl_sim::free_arm::release(&mut loaded.config, &chain);
/// assert_eq!(released, ["q1", "q2", "q3", "q4", "q5", "q6", "q7"]);
/// let sim = jointctl_sim::SimHal::load(&loaded).unwrap();
/// assert!(sim.free_arm().is_some());
/// ```
pub fn release(config: &mut jointctl_config::ArmConfig, chain: &Chain) -> Vec<String> {
    let mut released = Vec::new();
    for joint in &mut config.joints {
        let names: Vec<String> = joint.dof_names().iter().map(|d| d.to_string()).collect();
        let Some(sim) = joint.sim.as_mut() else { continue };
        let mut envs: Vec<EnvironmentConfig> = match sim.environment.take() {
            Some(e) => vec![e; names.len()],
            None => std::mem::take(&mut sim.environments),
        };
        for (env, name) in envs.iter_mut().zip(&names) {
            if !chain.dof_names().contains(name) {
                continue;
            }
            let (damping_nms_per_rad, armature_kgm2) = match env {
                EnvironmentConfig::Free { damping_nms_per_rad, .. } | EnvironmentConfig::Spring { damping_nms_per_rad, .. } => (*damping_nms_per_rad, DEFAULT_ARMATURE_KGM2),
                EnvironmentConfig::FreeArm { damping_nms_per_rad, armature_kgm2 } => (*damping_nms_per_rad, *armature_kgm2),
                _ => (DEFAULT_DAMPING_NMS_PER_RAD, DEFAULT_ARMATURE_KGM2),
            };
            *env = EnvironmentConfig::FreeArm { damping_nms_per_rad, armature_kgm2 };
            released.push(name.clone());
        }
        sim.environments = envs;
    }
    released
}
