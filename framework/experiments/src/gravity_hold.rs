//! Impedance hold on the free arm (appendix C's future work): the arm off its clamps, its links
//! loading each other under gravity through the URDF, each torque-controlled DOF in impedance
//! mode at a pose, with and without gravity feed-forward. What the steady state misses by, and
//! the torques it takes.

use jointctl_config::LoadedConfig;
use jointctl_modes::Mode;
use jointctl_runtime::commands::ArmCommand;
use jointctl_runtime::{Arm, PluginLoader};
use jointctl_sim::{SharedSim, SimHal};

use crate::tracking::Scenario;
use crate::ExperimentError;

/// One pose to hold: a name and the target of every DOF the pose names [rad] (the others: 0).
#[derive(Clone, Debug)]
pub struct Pose {
    /// What the pose is (`appendix-c`, ...).
    pub name: String,
    /// (DOF, target [rad]).
    pub targets: Vec<(String, f64)>,
}

/// Impedance gains of one DOF.
#[derive(Clone, Debug)]
pub struct Gains {
    /// The DOF.
    pub dof: String,
    /// K_d [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// D_d [Nms/rad].
    pub damping_nms_per_rad: f64,
}

/// The experiment: poses, the impedance DOFs and their gains, the stiffness settings of the
/// VSAs, how long the arm is brought to each pose and held there, and over how much of the
/// hold's end the steady state is averaged.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The poses.
    pub poses: Vec<Pose>,
    /// The DOFs in impedance mode during the hold; every other DOF holds its target in
    /// position mode.
    pub impedance: Vec<Gains>,
    /// Stiffness requests (DOF, [Nm/rad]) for variable-stiffness DOFs.
    pub stiffness: Vec<(String, f64)>,
    /// Simulated time in position mode that brings the arm from upright to the pose [s].
    pub approach_s: f64,
    /// Simulated time in impedance mode at the pose [s].
    pub hold_s: f64,
    /// The steady state: the mean over the hold's last `average_s` [s].
    pub average_s: f64,
    /// Loop rate and bus latencies.
    pub scenario: Scenario,
}

impl Plan {
    /// Three poses of the SHERPA arm (figure C.1's, one bent forward, one folded back) held in
    /// impedance by the pitch DOFs that observe their torque, q2, q4 and q7. q5 observes its
    /// torque only while its drive's set-point stands still (its compliance is the drive's gain,
    /// section 3.3.2): it cannot be torque-controlled, and holds its target in position mode, as
    /// do the roll DOFs (q1, q3, q6), which gravity does not load at these planar poses.
    ///
    /// Assumptions: the poses; the gains, an impedance below each joint's element stiffness
    /// with damping for a damping ratio of about 0.3-0.5 on the links the DOF carries; q2's
    /// VSA at its stiffest (320 Nm/rad, its limit), where it carries the arm with the least
    /// deflection; the `modern` scenario (1 kHz, 1 ms latencies), see [`Plan::scenario`].
    pub fn sherpa() -> Plan {
        let pose = |name: &str, t: &[(&str, f64)]| Pose { name: name.into(), targets: t.iter().map(|(d, q)| (d.to_string(), *q)).collect() };
        let gains = |dof: &str, k: f64, d: f64| Gains { dof: dof.into(), stiffness_nm_per_rad: k, damping_nms_per_rad: d };
        Plan {
            poses: vec![
                pose("appendix-c", &[("q2", std::f64::consts::FRAC_PI_4)]),
                pose("bent-forward", &[("q2", 0.3), ("q4", 0.6), ("q5", 0.3), ("q7", 0.3)]),
                pose("folded-back", &[("q2", -0.4), ("q4", -0.8), ("q5", 0.5), ("q7", -0.4)]),
            ],
            impedance: vec![gains("q2", 150.0, 15.0), gains("q4", 60.0, 4.0), gains("q7", 10.0, 0.3)],
            stiffness: vec![("q2".into(), 320.0)],
            approach_s: 5.0,
            // 30 s: q2 at appendix-c with feed-forward wandered by up to 0.12 rad for 16 s before it
            // came to rest (measured after a 0.05 % change of the elbow's fitted line); 15 s
            // averaged its swing.
            hold_s: 30.0,
            average_s: 2.0,
            scenario: Scenario::Modern,
        }
    }
}

/// One DOF's steady state in one hold.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Row {
    /// The pose.
    pub pose: String,
    /// Gravity feed-forward on.
    pub feedforward: bool,
    /// The DOF.
    pub dof: String,
    /// Its impedance stiffness [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// Its target [rad].
    pub target_rad: f64,
    /// Mean observed position minus target over the steady state [rad].
    pub error_rad: f64,
    /// Standard deviation of the observed position over the steady state [rad].
    pub ripple_rad: f64,
    /// The holding torque the host computed from the URDF [Nm] (mean).
    pub gravity_nm: f64,
    /// The torque reference beyond gravity [Nm] (mean).
    pub reference_nm: f64,
    /// The torque the joint's observer estimated [Nm] (mean).
    pub observed_nm: f64,
    /// What the joint's torque sensor read (the simulated truth, noise included) [Nm] (mean).
    pub sensed_nm: f64,
    /// Steady-state cycles in which the DOF's position was unknown (left out of the means, never
    /// taken as a value).
    pub unknown_cycles: usize,
}

/// One DOF's position error over a hold.
#[derive(Clone, Debug)]
pub struct Trace {
    /// The pose.
    pub pose: String,
    /// Gravity feed-forward on.
    pub feedforward: bool,
    /// The DOF.
    pub dof: String,
    /// (t [s], observed - target [rad]).
    pub points: Vec<(f64, f64)>,
}

/// Runs every pose with and without feed-forward on the free arm of `loaded` (its URDF's DOFs
/// all released, [`jointctl_sim::free_arm::release`]).
pub fn run(loaded: &LoadedConfig, loader: &PluginLoader, plan: &Plan) -> Result<(Vec<Row>, Vec<Trace>), ExperimentError> {
    let chain = loaded.chain.clone().ok_or_else(|| ExperimentError(format!("{}: the free arm needs the arm's URDF (`kinematics: {{urdf: FILE}}`)", loaded.source.file.display())))?;
    let (mut rows, mut traces) = (Vec::new(), Vec::new());
    for pose in &plan.poses {
        for feedforward in [false, true] {
            let mut cfg = loaded.clone();
            jointctl_sim::free_arm::release(&mut cfg.config, &chain);
            plan.scenario.apply(&mut cfg);
            for g in &plan.impedance {
                set_feedforward(&mut cfg, &g.dof, feedforward)?;
            }
            let (r, t) = hold(&cfg, loader, plan, pose, feedforward)?;
            rows.extend(r);
            traces.extend(t);
        }
    }
    Ok((rows, traces))
}

fn set_feedforward(cfg: &mut LoadedConfig, dof: &str, on: bool) -> Result<(), ExperimentError> {
    let (j, i) = crate::locate(cfg, dof)?;
    let joint = &mut cfg.config.joints[j];
    let controller = if joint.dofs.is_empty() { &mut joint.controller } else { &mut joint.dofs[i].controller };
    controller.get_or_insert_with(Default::default).gravity_feedforward = on;
    Ok(())
}

fn hold(cfg: &LoadedConfig, loader: &PluginLoader, plan: &Plan, pose: &Pose, feedforward: bool) -> Result<(Vec<Row>, Vec<Trace>), ExperimentError> {
    let sim = SharedSim::new(SimHal::load(cfg).map_err(|e| ExperimentError(e.to_string()))?);
    let mut arm = Arm::build(cfg, loader, Box::new(sim.clone()))?;
    arm.run_in_simulated_time();
    arm.activate().map_err(|e| ExperimentError(e.to_string()))?;
    let dt = 1.0 / arm.rate_hz;
    let mut t = 0.0;
    arm.observe(t);
    let target_of = |dof: &str| pose.targets.iter().find(|(d, _)| d == dof).map_or(0.0, |(_, q)| *q);
    let names = arm.dof_names.clone();
    let dof_of = |name: &str| names.iter().position(|d| d == name).ok_or_else(|| ExperimentError(format!("the plan names `{name}`, which is no DOF of the arm")));
    let impedance = plan.impedance.iter().map(|g| Ok((dof_of(&g.dof)?, g))).collect::<Result<Vec<(usize, &Gains)>, ExperimentError>>()?;
    for (dof, k) in &plan.stiffness {
        arm.apply(ArmCommand::Stiffness { dof: dof_of(dof)?, stiffness_nm_per_rad: *k });
    }
    // From upright to the pose in position mode, then the torque DOFs hold it in impedance.
    for dof in 0..arm.dof_names.len() {
        arm.apply(ArmCommand::Mode { dof, mode: Mode::Position { target_rad: target_of(&arm.dof_names[dof]) }, streamed: false });
    }
    for _ in 0..(plan.approach_s / dt).round() as usize {
        arm.control();
        t += dt;
        arm.observe(t);
    }
    for (dof, g) in &impedance {
        let mode = Mode::Impedance { stiffness_nm_per_rad: g.stiffness_nm_per_rad, damping_nms_per_rad: g.damping_nms_per_rad, target_rad: target_of(&g.dof) };
        arm.apply(ArmCommand::Mode { dof: *dof, mode, streamed: false });
    }
    let start = t;
    let steps = (plan.hold_s / dt).round() as usize;
    let from = plan.hold_s - plan.average_s;
    let mut traces: Vec<Trace> = impedance.iter().map(|(_, g)| Trace { pose: pose.name.clone(), feedforward, dof: g.dof.clone(), points: Vec::with_capacity(steps) }).collect();
    // Per impedance DOF: (sum, count) of the known error, error^2, gravity, reference, observed
    // torque and sensor over the steady state, and the cycles with the position unknown.
    let mut sums = vec![[(0.0f64, 0usize); 6]; impedance.len()];
    let mut unknown = vec![0usize; impedance.len()];
    for _ in 0..steps {
        arm.control();
        t += dt;
        arm.observe(t);
        for (k, (dof, g)) in impedance.iter().enumerate() {
            let error = arm.states[*dof].position().map_or(f64::NAN, |q| q - target_of(&g.dof));
            traces[k].points.push((t - start, error));
            if t - start < from {
                continue;
            }
            unknown[k] += usize::from(!error.is_finite());
            let sensed = sim.with(|s| s.joint_torque(&g.dof).map_or(f64::NAN, |x| x.1));
            let observed = arm.states[*dof].torque().unwrap_or(f64::NAN);
            for (acc, v) in sums[k].iter_mut().zip([error, error * error, arm.gravity_torques[*dof], arm.torque_references[*dof], observed, sensed]) {
                if v.is_finite() {
                    *acc = (acc.0 + v, acc.1 + 1);
                }
            }
        }
    }
    if let Some(n) = sim.with(|s| s.free_arm().map(|a| a.failures())).filter(|n| *n > 0) {
        return Err(ExperimentError(format!("pose {}: the free arm had no answer in {n} physics steps (a state went non-finite)", pose.name)));
    }
    let mean = |(sum, n): (f64, usize)| if n > 0 { sum / n as f64 } else { f64::NAN };
    let rows = impedance
        .iter()
        .zip(sums.into_iter().zip(unknown))
        .map(|((_, g), (s, unknown_cycles))| {
            let error = mean(s[0]);
            Row {
                pose: pose.name.clone(),
                feedforward,
                dof: g.dof.clone(),
                stiffness_nm_per_rad: g.stiffness_nm_per_rad,
                target_rad: target_of(&g.dof),
                error_rad: error,
                ripple_rad: (mean(s[1]) - error * error).max(0.0).sqrt(),
                gravity_nm: mean(s[2]),
                reference_nm: mean(s[3]),
                observed_nm: mean(s[4]),
                sensed_nm: mean(s[5]),
                unknown_cycles,
            }
        })
        .collect();
    Ok((rows, traces))
}
