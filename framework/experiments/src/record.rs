//! Characterisation recordings (thesis sections 3.3.1, 3.4.1, 3.5.1): the joint's output moved
//! by a flow source (a sine) while its drives hold their positions; the deflection is what the
//! joint's own observer measures from its encoders, the torque what the torque sensor reads.

use std::io::Write;

use jointctl_config::{EnvironmentConfig, LoadedConfig};
use jointctl_runtime::{Arm, PluginLoader};
use jointctl_sim::{SharedSim, SimHal};

use crate::{ExperimentError, arm_dof, locate, set_environment};

/// What to record.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// The DOF to deflect (e.g. `q4`).
    pub joint: String,
    /// Flow-source amplitude [rad].
    pub amplitude_rad: f64,
    /// Flow-source frequency [Hz].
    pub frequency_hz: f64,
    /// Duration [s].
    pub duration_s: f64,
    /// Pivot setting to hold [mm] (VSA joints).
    pub pivot_mm: Option<f64>,
    /// Deflection direction [deg] (the 2-DOF wrist: 0 = q7 only, 90 = q6 only).
    pub angle_deg: f64,
    /// Sample rate [Hz]; the loop runs at this rate.
    pub rate_hz: f64,
}

/// One sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time [s].
    pub t: f64,
    /// Deflection along the recorded direction [rad] (the observer's).
    pub deflection: f64,
    /// Torque along the recorded direction [Nm] (the torque sensor's).
    pub torque: f64,
    /// Pivot setting [mm] (NaN for joints without one).
    pub pivot_mm: f64,
    /// Drive (gearbox output) position of the joint's first drive [rad].
    pub motor_position: f64,
    /// Deflection direction [deg] of a 2-DOF joint's recording (NaN for a 1-DOF joint).
    pub angle_deg: f64,
}

/// Runs a characterisation on the simulated arm.
pub fn record(loaded: &LoadedConfig, loader: &PluginLoader, opts: &RecordOptions) -> Result<Vec<Sample>, ExperimentError> {
    let mut cfg = loaded.clone();
    let (j, i) = locate(&cfg, &opts.joint)?;
    let n = cfg.config.joints[j].dof_names().len();
    cfg.config.rate_hz = opts.rate_hz;
    // The pivot settles first (3 s), with the joint at rest; the flow starts when the recording does.
    let settle_s = if opts.pivot_mm.is_some() { 3.0 } else { 0.0 };
    let flow = EnvironmentConfig::Flow { amplitude_rad: opts.amplitude_rad, frequency_hz: opts.frequency_hz, angle_deg: opts.angle_deg, start_s: settle_s };
    // The 2-DOF wrist is deflected along a direction (both DOFs move); any other joint's DOF alone.
    let directional = n == 2 && is_directional(&cfg.config.joints[j]);
    if directional {
        // The wrist is deflected along a direction: both DOFs move.
        if let Some(sim) = cfg.config.joints[j].sim.as_mut() {
            sim.environment = Some(flow);
            sim.environments.clear();
        }
    } else {
        set_environment(&mut cfg, j, i, flow, EnvironmentConfig::Fixed { position_rad: 0.0 });
    }
    let mut sim_hal = SimHal::load(&cfg).map_err(|e| ExperimentError(e.to_string()))?;
    if let (Some(p), Some(pivot)) = (opts.pivot_mm, cfg.config.joints[j].sim.as_ref().and_then(|s| s.pivot.clone())) {
        let d = jointctl_hal_index(&cfg, &pivot.drive)?;
        sim_hal.set_drive_target(d, (p - pivot.offset_mm) / pivot.mm_per_rad);
        sim_hal.settle_drives(settle_s);
    }
    let first_drive = cfg.config.joints[j].sim.as_ref().and_then(|s| s.drives.first().cloned()).unwrap_or_default();
    let first_drive = jointctl_hal_index(&cfg, &first_drive)?;
    let sim = SharedSim::new(sim_hal);
    let mut arm = Arm::build(&cfg, loader, Box::new(sim.clone()))?;
    arm.run_in_simulated_time();
    arm.activate().map_err(|e| ExperimentError(e.to_string()))?;
    let dof = arm_dof(&arm, &opts.joint);
    let two = directional;
    let (sa, ca) = (opts.angle_deg.to_radians().sin(), opts.angle_deg.to_radians().cos());
    let steps = (opts.duration_s * opts.rate_hz).round() as usize;
    let mut out = Vec::with_capacity(steps);
    for k in 0..steps {
        let t = k as f64 / opts.rate_hz;
        // The sensor and the motor are sampled at the instant the observer reads, between
        // observe and control: after `control` the simulation has advanced one period, and the
        // torque led the deflection by it (10 ms at 100 Hz, a delay identify then reported).
        // The torque is the sensor's reading from when the encoders were read (the SPI bus's
        // latency ago), so that a bus latency does not shift one channel against the other.
        arm.observe(t);
        let (torque, motor) = sim.with(|s| {
            let age = s.spi_latency_s();
            let tq = |name: &str| s.sensor_torque_aged(name, age).unwrap_or(f64::NAN);
            let torque = if two {
                let first = arm.slots.iter().find(|s| s.dofs().contains(&dof)).map(|s| s.dofs().start).unwrap_or(dof);
                tq(&arm.dof_names[first]) * sa + tq(&arm.dof_names[first + 1]) * ca
            } else {
                tq(&opts.joint)
            };
            (torque, s.drives()[first_drive].position)
        });
        arm.control();
        let st = &arm.states;
        let deflection = if two {
            let first = arm.slots.iter().find(|s| s.dofs().contains(&dof)).map(|s| s.dofs().start).unwrap_or(dof);
            st[first].deflection().unwrap_or(f64::NAN) * sa + st[first + 1].deflection().unwrap_or(f64::NAN) * ca
        } else {
            st[dof].deflection().unwrap_or(f64::NAN)
        };
        // A cycle whose deflection the observer could not form (a reading not usable this
        // cycle) is not a measurement.
        if deflection.is_finite() && torque.is_finite() {
            out.push(Sample { t, deflection, torque, pivot_mm: st[dof].pivot().unwrap_or(f64::NAN), motor_position: motor, angle_deg: if two { opts.angle_deg } else { f64::NAN } });
        }
    }
    Ok(out)
}

/// Whether a joint's element couples its two DOFs along a deflection direction (the wrist),
/// rather than one element per DOF (the shoulder's VSA q2 beside rigid q3).
///
/// ```
/// let loaded = jointctl_config::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml"))).unwrap();
/// let by_name = |n: &str| loaded.config.joints.iter().find(|j| j.name == n).unwrap();
/// assert!(jointctl_experiments::record::is_directional(by_name("wrist")));
/// assert!(!jointctl_experiments::record::is_directional(by_name("shoulder")));
/// ```
pub fn is_directional(joint: &jointctl_config::JointConfig) -> bool {
    matches!(
        joint.sim.as_ref().and_then(|s| s.element.as_ref()),
        Some(jointctl_config::ElementSimConfig::WristTable | jointctl_config::ElementSimConfig::WristLeverArm { .. })
    )
}

fn jointctl_hal_index(loaded: &LoadedConfig, drive: &str) -> Result<usize, ExperimentError> {
    loaded
        .config
        .buses
        .can
        .iter()
        .flat_map(|b| b.drives.iter())
        .position(|d| d.name == drive)
        .ok_or_else(|| ExperimentError(format!("no drive `{drive}`")))
}

/// Writes samples as the CSV `jointctl fit` and `jointctl identify` read: `t, deflection,
/// torque, pivot_mm, angle_deg, motor_position` (SI units; pivot in mm, angle in degrees). The
/// angle is `angle_deg` when given, else each sample's own (empty for a 1-DOF joint).
pub fn write_csv(samples: &[Sample], angle_deg: Option<f64>, mut w: impl Write) -> std::io::Result<()> {
    writeln!(w, "t,deflection,torque,pivot_mm,angle_deg,motor_position")?;
    for s in samples {
        let pivot = if s.pivot_mm.is_finite() { format!("{}", s.pivot_mm) } else { String::new() };
        let angle = angle_deg.or(Some(s.angle_deg).filter(|a| a.is_finite())).map_or(String::new(), |a| format!("{a}"));
        writeln!(w, "{},{},{},{},{},{}", s.t, s.deflection, s.torque, pivot, angle, s.motor_position)?;
    }
    Ok(())
}
