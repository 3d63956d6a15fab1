//! Recordings replayed (`jointctl replay`, `jointctl sim replay`).
//!
//! - [`replay_observers`]: the recorded raw readings, cycle by cycle, through a config's joint
//!   plugins (the arm's own, or a changed model such as a newly fitted table), with the recorded
//!   commands applied at the cycles that applied them: the observed torque the config gives
//!   against the one recorded and against the F/T sensor.
//! - [`replay_on_sim`]: the recorded commands on the simulated arm of a config, from the
//!   recorded drive positions: per joint and channel, how far the simulation is from the
//!   recording. What the simulation gets wrong, as a table.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use jointctl_config::LoadedConfig;
use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, HalIoError, SensorFrame};
use jointctl_record::reader::{JointSeries, RawSample, RecordedCommand, Recording};
use jointctl_runtime::commands::CommandValidator;
use jointctl_runtime::status::LoopStatus;
use jointctl_runtime::{Arm, PluginLoader};
use jointctl_sim::SimHal;

use crate::ExperimentError;

/// How far one signal is from another over a replay.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChannelError {
    /// DOF, or drive for a motor position.
    pub joint: String,
    /// `position`, `deflection`, `observed_torque`, `ft_torque` or `motor_position`.
    pub channel: String,
    /// RMS difference [unit].
    pub rmse: f64,
    /// Largest difference [unit].
    pub max_abs: f64,
    /// SI unit.
    pub unit: &'static str,
    /// Samples where both were known.
    #[serde(skip)]
    pub samples: usize,
}

impl ChannelError {
    fn of(joint: &str, channel: &str, unit: &'static str, a: &[f64], b: &[f64]) -> ChannelError {
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).filter(|e| e.is_finite()).collect();
        let n = d.len();
        let rmse = if n == 0 { f64::NAN } else { (d.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt() };
        let max_abs = d.iter().fold(if n == 0 { f64::NAN } else { 0.0 }, |m, e| m.max(e.abs()));
        ChannelError { joint: joint.into(), channel: channel.into(), rmse, max_abs, unit, samples: n }
    }
}

/// A recorded signal beside its replayed one, for plots: (t [s], recorded, replayed, F/T).
pub type Trace = Vec<(f64, f64, f64, f64)>;

/// What a replay found.
#[derive(Clone, Debug, Default)]
pub struct ReplayReport {
    /// Per DOF (and drive) and channel.
    pub channels: Vec<ChannelError>,
    /// Per DOF: the observed torque recorded and replayed, and the F/T torque.
    pub torque_traces: Vec<(String, Trace)>,
    /// Recorded cycles replayed.
    pub cycles: usize,
    /// What did not match between the recording and the config (devices, joints), said once.
    pub notes: Vec<String>,
}

/// Serves recorded readings, one frame per `read`; writes go nowhere.
struct ReplayHal {
    frames: std::vec::IntoIter<SensorFrame>,
}

impl Hal for ReplayHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        if let Some(f) = self.frames.next() {
            frame.clone_from(&f);
        }
        Ok(())
    }

    fn write(&mut self, _: &ActuatorFrame, _: f64) -> Result<(), HalIoError> {
        Ok(())
    }
}

/// The recorded readings in the config's device order; a device the recording lacks reads
/// missing (and is named in `notes`).
fn frames(samples: &[RawSample], devices: &DeviceIndex, notes: &mut Vec<String>) -> Vec<SensorFrame> {
    let mut absent: Vec<&str> = Vec::new();
    let out = samples
        .iter()
        .map(|s| {
            let mut f = SensorFrame::new(devices);
            for (slot, name) in f.encoders.iter_mut().zip(&devices.encoders) {
                match s.encoders.iter().find(|(n, _)| n == name) {
                    Some((_, r)) => *slot = *r,
                    None if !absent.contains(&name.as_str()) => absent.push(name),
                    None => {}
                }
            }
            for (slot, name) in f.drives.iter_mut().zip(&devices.drives) {
                match s.drives.iter().find(|(n, ..)| n == name) {
                    Some((_, r, _)) => *slot = *r,
                    None if !absent.contains(&name.as_str()) => absent.push(name),
                    None => {}
                }
            }
            for (slot, name) in f.torque_sensors.iter_mut().zip(&devices.torque_sensors) {
                match s.torque_sensors.iter().find(|(n, _)| n == name) {
                    Some((_, r)) => *slot = *r,
                    None if !absent.contains(&name.as_str()) => absent.push(name),
                    None => {}
                }
            }
            f
        })
        .collect();
    if !absent.is_empty() {
        notes.push(format!("not in the recording, read as missing: {}", absent.join(", ")));
    }
    out
}

/// Applies, in order, the recorded commands the recorded loop had applied by a frame (its
/// `commands_applied`; in a recording without it, those accepted before the frame's stamp); a
/// command the config refuses is noted, not applied.
struct CommandFeed {
    commands: Vec<RecordedCommand>,
    next: usize,
    validator: CommandValidator,
    status: Arc<LoopStatus>,
}

impl CommandFeed {
    fn new(commands: Vec<RecordedCommand>, arm: &Arm) -> Self {
        let status = Arc::new(LoopStatus::new(arm.dof_names.len()));
        CommandFeed { commands, next: 0, validator: CommandValidator::new(arm.dof_specs(), Arc::clone(&status)).with_loop_rate(1.0 / arm.dt_s), status }
    }

    fn apply_due(&mut self, arm: &mut Arm, frame: &RawSample, notes: &mut Vec<String>) {
        for i in 0..arm.dof_names.len() {
            self.status.set_dof(i, arm.enabled[i], 0);
        }
        // The answer's stamp alone cannot tell whether the loop took a command in the cycle that
        // woke just before it or in the next one: a replay a cycle off followed a 1 Hz sine
        // 25 ms late.
        let due = |c: &&RecordedCommand| match frame.commands_applied {
            Some(applied) => c.sequence <= applied,
            None => c.stamp_ns < frame.stamp_ns,
        };
        while let Some(c) = self.commands.get(self.next).filter(due) {
            match self.validator.validate(&c.request) {
                Ok((command, _)) => arm.apply(command),
                Err(e) => notes.push(format!("a recorded command was refused by this config: {e}")),
            }
            self.next += 1;
        }
    }
}

/// The recorded joint states by DOF; a DOF of the config the recording lacks is noted.
fn recorded_joints(recording: &mut Recording, arm: &Arm, notes: &mut Vec<String>) -> HashMap<String, JointSeries> {
    for name in arm.dof_names.iter().filter(|n| !recording.joints.contains_key(*n)) {
        notes.push(format!("joint `{name}` is not in the recording"));
    }
    std::mem::take(&mut recording.joints)
}


/// Index of each recorded joint-state sample by cycle.
fn by_cycle(series: &JointSeries) -> HashMap<u64, usize> {
    series.cycle.iter().enumerate().map(|(i, c)| (*c, i)).collect()
}

/// The recording, and the frame to activate the joints with (the recorded activation, else
/// the first frame, with a note).
fn read_recording(path: &Path, notes: &mut Vec<String>) -> Result<(Recording, RawSample), ExperimentError> {
    let recording = jointctl_record::reader::read(path).map_err(|e| ExperimentError(e.to_string()))?;
    let Some(first) = recording.raw.first() else {
        return Err(ExperimentError(format!("{}: no raw readings in the recording", path.display())));
    };
    let activation = match &recording.activation {
        Some(a) => a.clone(),
        None => {
            notes.push("the recording has no activation readings: the joints were activated on its first frame, so observers that take their zero at activation may differ".into());
            first.clone()
        }
    };
    Ok((recording, activation))
}

/// The recorded raw readings through `loaded`'s joint plugins, with the recorded commands.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let loaded = jointctl_config::load(std::path::Path::new("configs/sherpa_arm.yaml"))?;
/// let loader = jointctl_runtime::loader_for(&loaded);
/// let report = jointctl_experiments::replay::replay_observers(std::path::Path::new("r.mcap"), &loaded, &loader)?;
/// assert!(report.cycles > 0);
/// # Ok(()) }
/// ```
pub fn replay_observers(path: &Path, loaded: &LoadedConfig, loader: &PluginLoader) -> Result<ReplayReport, ExperimentError> {
    let mut report = ReplayReport::default();
    let (mut recording, activation) = read_recording(path, &mut report.notes)?;
    let (raw, commands) = (std::mem::take(&mut recording.raw), std::mem::take(&mut recording.commands));
    report.cycles = raw.len();
    let devices = DeviceIndex::of(&loaded.config);
    // The first frame read is activation's.
    let all: Vec<RawSample> = std::iter::once(activation).chain(raw.iter().cloned()).collect();
    let hal = ReplayHal { frames: frames(&all, &devices, &mut report.notes).into_iter() };
    let mut arm = Arm::build(loaded, loader, Box::new(hal))?;
    arm.run_in_simulated_time();
    arm.activate().map_err(|e| ExperimentError(e.to_string()))?;
    let recorded = recorded_joints(&mut recording, &arm, &mut report.notes);
    let mut feed = CommandFeed::new(commands, &arm);
    let n = arm.dof_names.len();
    let mut replayed: Vec<Vec<(u64, f64, f64, f64)>> = vec![Vec::new(); n];
    let t0 = raw[0].stamp_ns;
    for s in &raw {
        let t = s.stamp_ns.saturating_sub(t0) as f64 * 1e-9;
        arm.observe(t);
        feed.apply_due(&mut arm, s, &mut report.notes);
        arm.control();
        for (dof, out) in replayed.iter_mut().enumerate() {
            let st = &arm.states[dof];
            out.push((s.cycle, st.torque().unwrap_or(f64::NAN), st.deflection().unwrap_or(f64::NAN), st.position().unwrap_or(f64::NAN)));
        }
    }
    for (dof, name) in arm.dof_names.iter().enumerate() {
        let Some(rec) = recorded.get(name) else { continue };
        let index = by_cycle(rec);
        let (mut rec_tau, mut rep_tau, mut ft, mut rec_defl, mut rep_defl, mut trace) = (vec![], vec![], vec![], vec![], vec![], Trace::new());
        for (cycle, tau, defl, _) in &replayed[dof] {
            let Some(&i) = index.get(cycle) else { continue };
            rec_tau.push(rec.observed_torque_nm[i]);
            rep_tau.push(*tau);
            ft.push(rec.sensor_torque_nm[i]);
            rec_defl.push(rec.deflection_rad[i]);
            rep_defl.push(*defl);
            trace.push((rec.t_s[i], rec.observed_torque_nm[i], *tau, rec.sensor_torque_nm[i]));
        }
        // A channel the DOF does not have in the recording (a rigid joint observes no torque or
        // deflection) is left out, not a row of NaN; one the recording has and the replay does
        // not give is kept (its NaN is a finding) and said.
        for (channel, unit, replayed, recorded) in [("observed_torque", "Nm", &rep_tau, &rec_tau), ("deflection", "rad", &rep_defl, &rec_defl)] {
            if !recorded.iter().any(|x| x.is_finite()) {
                continue;
            }
            let c = ChannelError::of(name, channel, unit, replayed, recorded);
            if c.samples == 0 {
                report.notes.push(format!("`{name}`: the recording has its {channel}, the config's observer gives none"));
            }
            report.channels.push(c);
        }
        if ft.iter().any(|x| x.is_finite()) {
            report.channels.push(ChannelError::of(name, "recorded_observer_vs_ft", "Nm", &rec_tau, &ft));
            report.channels.push(ChannelError::of(name, "replayed_observer_vs_ft", "Nm", &rep_tau, &ft));
        }
        report.torque_traces.push((name.clone(), trace));
    }
    report.notes.dedup();
    Ok(report)
}

/// The recorded commands on `loaded`'s simulated arm, from the recorded drive positions; per
/// DOF and channel (position, deflection, observed torque, F/T torque) and per drive (motor
/// position), simulation minus recording.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let loaded = jointctl_config::load(std::path::Path::new("configs/sherpa_arm.yaml"))?;
/// let loader = jointctl_runtime::loader_for(&loaded);
/// let report = jointctl_experiments::replay::replay_on_sim(std::path::Path::new("r.mcap"), &loaded, &loader)?;
/// for c in &report.channels { println!("{} {} {:.4} {}", c.joint, c.channel, c.rmse, c.unit); }
/// # Ok(()) }
/// ```
pub fn replay_on_sim(path: &Path, loaded: &LoadedConfig, loader: &PluginLoader) -> Result<ReplayReport, ExperimentError> {
    let mut report = ReplayReport::default();
    let (mut recording, activation) = read_recording(path, &mut report.notes)?;
    let (raw, commands) = (std::mem::take(&mut recording.raw), std::mem::take(&mut recording.commands));
    report.cycles = raw.len();
    let devices = DeviceIndex::of(&loaded.config);
    // The recording's rate must be the config's: the loop is re-run cycle by cycle.
    if raw.len() > 2 {
        let period_s = (raw[raw.len() - 1].stamp_ns - raw[0].stamp_ns) as f64 * 1e-9 / (raw.len() - 1) as f64;
        let rate = 1.0 / period_s;
        if (rate - loaded.config.rate_hz).abs() / loaded.config.rate_hz > 0.05 {
            return Err(ExperimentError(format!("{}: recorded at {rate:.1} Hz, the config runs at {} Hz: set rate_hz to the recording's", path.display(), loaded.config.rate_hz)));
        }
    }
    let mut sim = SimHal::load(loaded).map_err(|e| ExperimentError(e.to_string()))?;
    // From the recorded initial state: each drive where it was when the joints were activated
    // (the observers' zeros; a recording that starts later continues from there).
    let start: Vec<Option<f64>> = devices.drives.iter().map(|name| activation.drives.iter().find(|(n, ..)| n == name).and_then(|(_, r, _)| r.position_rad.usable(f64::INFINITY))).collect();
    sim.start_at(&start);
    let mut arm = Arm::build(loaded, loader, Box::new(sim))?;
    arm.run_in_simulated_time();
    arm.activate().map_err(|e| ExperimentError(e.to_string()))?;
    let recorded = recorded_joints(&mut recording, &arm, &mut report.notes);
    for name in &arm.dof_names {
        if let Some(mode) = recorded.get(name).and_then(|r| r.mode.first()).filter(|m| *m != "hold") {
            report.notes.push(format!(
                "`{name}` was in {mode} mode when the recording started: the command that put it there is not in the recording, and the simulation starts it in hold (start `jointctl record` before commanding the arm)"
            ));
        }
    }
    let mut feed = CommandFeed::new(commands, &arm);
    let n = arm.dof_names.len();
    // Per DOF: (cycle, position, deflection, observed torque, F/T torque); per drive: positions.
    let mut simulated: Vec<Vec<(u64, [f64; 4])>> = vec![Vec::new(); n];
    let mut motors: Vec<Vec<f64>> = vec![Vec::new(); devices.drives.len()];
    let t0 = raw[0].stamp_ns;
    for s in &raw {
        let t = s.stamp_ns.saturating_sub(t0) as f64 * 1e-9;
        arm.observe(t);
        feed.apply_due(&mut arm, s, &mut report.notes);
        // What the simulated arm's own sensors read, as the recording holds the real ones'.
        for (dof, out) in simulated.iter_mut().enumerate() {
            let st = &arm.states[dof];
            let ft = arm.sensor_torque(dof).unwrap_or(f64::NAN);
            out.push((s.cycle, [st.position().unwrap_or(f64::NAN), st.deflection().unwrap_or(f64::NAN), st.torque().unwrap_or(f64::NAN), ft]));
        }
        for (m, d) in motors.iter_mut().zip(&arm.last_readings().drives) {
            m.push(d.position_rad.usable(f64::INFINITY).unwrap_or(f64::NAN));
        }
        arm.control();
    }
    for (dof, name) in arm.dof_names.iter().enumerate() {
        let Some(rec) = recorded.get(name) else { continue };
        let index = by_cycle(rec);
        let mut cols: [(Vec<f64>, Vec<f64>); 4] = Default::default();
        let mut trace = Trace::new();
        for (cycle, v) in &simulated[dof] {
            let Some(&i) = index.get(cycle) else { continue };
            let r = [rec.position_rad[i], rec.deflection_rad[i], rec.observed_torque_nm[i], rec.sensor_torque_nm[i]];
            for k in 0..4 {
                cols[k].0.push(v[k]);
                cols[k].1.push(r[k]);
            }
            trace.push((rec.t_s[i], rec.sensor_torque_nm[i], v[3], rec.reference_torque_nm[i]));
        }
        for (k, (channel, unit)) in [("position", "rad"), ("deflection", "rad"), ("observed_torque", "Nm"), ("ft_torque", "Nm")].into_iter().enumerate() {
            let c = ChannelError::of(name, channel, unit, &cols[k].0, &cols[k].1);
            if c.samples > 0 {
                report.channels.push(c);
            }
        }
        report.torque_traces.push((name.clone(), trace));
    }
    for (d, name) in devices.drives.iter().enumerate() {
        let recorded: Vec<f64> = raw.iter().map(|s| s.drives.iter().find(|(n, ..)| n == name).and_then(|(_, r, _)| r.position_rad.usable(f64::INFINITY)).unwrap_or(f64::NAN)).collect();
        let c = ChannelError::of(name, "motor_position", "rad", &motors[d], &recorded);
        if c.samples > 0 {
            report.channels.push(c);
        }
    }
    report.notes.dedup();
    Ok(report)
}
