//! Commands: validated where they arrive (the IPC thread), applied by the loop at the start of
//! its next cycle. An invalid command changes nothing and says why.

use jointctl_config::LimitsConfig;
use jointctl_modes::{Mode, Reference, Trajectory, TrajectoryPoint, Waveform};
use jointctl_ipc::{CommandKind, CommandRequest, TorqueWaveform, decode_name};

/// A validated command, ready for the loop. Times inside a mode (a reference's start, a
/// trajectory's start) are relative to the cycle that applies it.
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant, reason = "commands cross the wait-free hand-off by value: no allocation in the loop")]
pub enum ArmCommand {
    /// Switch one DOF's mode.
    Mode {
        /// DOF index.
        dof: usize,
        /// The mode.
        mode: Mode,
        /// Must be renewed within the watchdog time.
        streamed: bool,
    },
    /// Request a stiffness for one DOF [Nm/rad].
    Stiffness {
        /// DOF index.
        dof: usize,
        /// [Nm/rad]
        stiffness_nm_per_rad: f64,
    },
    /// Enable or disable one DOF.
    Enable {
        /// DOF index.
        dof: usize,
        /// New state.
        enabled: bool,
    },
    /// Hold every DOF.
    HoldAll,
    /// Stop the runtime.
    Stop,
}

/// Checks commands against the arm's joints and limits (outside the control thread).
#[derive(Clone, Debug)]
pub struct CommandValidator {
    names: Vec<String>,
    limits: Vec<Option<LimitsConfig>>,
    enabled: Vec<bool>,
}

fn finite(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() { Ok(v) } else { Err(format!("{name} must be a finite number, got {v}")) }
}

impl CommandValidator {
    /// A validator for these DOFs.
    pub fn new(names: Vec<String>, limits: Vec<Option<LimitsConfig>>) -> Self {
        let enabled = vec![true; names.len()];
        CommandValidator { names, limits, enabled }
    }

    fn dof(&self, joint: &str) -> Result<usize, String> {
        self.names.iter().position(|n| n == joint).ok_or_else(|| {
            if joint.is_empty() {
                "this command needs a joint name".to_string()
            } else {
                format!("joint `{joint}` does not exist; the arm's joints are {}", self.names.join(", "))
            }
        })
    }

    fn within_position(&self, dof: usize, q: f64) -> Result<f64, String> {
        let q = finite("the position", q)?;
        if let Some(l) = self.limits[dof]
            && !(l.position_rad[0]..=l.position_rad[1]).contains(&q)
        {
            return Err(format!(
                "position {q} rad is outside {}'s limits [{}, {}] rad",
                self.names[dof], l.position_rad[0], l.position_rad[1]
            ));
        }
        Ok(q)
    }

    /// Validates a request; on success returns the command and a confirmation text.
    ///
    /// ```
    /// use jointctl_ipc::{CommandKind, CommandRequest};
    /// let mut v = jointctl_runtime::commands::CommandValidator::new(vec!["q1".into()], vec![None]);
    /// assert!(v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[0.2])).is_ok());
    /// let e = v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[f64::NAN])).unwrap_err();
    /// assert!(e.contains("finite"));
    /// ```
    pub fn validate(&mut self, req: &CommandRequest) -> Result<(ArmCommand, String), String> {
        let joint = decode_name(&req.joint);
        let v = &req.values;
        match req.kind {
            CommandKind::STOP => return Ok((ArmCommand::Stop, "stopping".into())),
            CommandKind::HOLD if joint.is_empty() => return Ok((ArmCommand::HoldAll, "holding every joint".into())),
            _ => {}
        }
        let dof = self.dof(joint)?;
        let name = &self.names[dof];
        let disabled = !self.enabled[dof];
        let streamed = req.streamed != 0;
        let cmd = match req.kind {
            CommandKind::ENABLE | CommandKind::DISABLE => {
                let enabled = req.kind == CommandKind::ENABLE;
                self.enabled[dof] = enabled;
                return Ok((ArmCommand::Enable { dof, enabled }, format!("{name} {}", if enabled { "enabled (holding)" } else { "disabled (holding)" })));
            }
            CommandKind::HOLD => ArmCommand::Mode { dof, mode: Mode::Hold, streamed: false },
            _ if disabled => return Err(format!("joint `{name}` is disabled; enable it first")),
            CommandKind::POSITION => ArmCommand::Mode { dof, mode: Mode::Position { target_rad: self.within_position(dof, v[0])? }, streamed },
            CommandKind::MANUAL => ArmCommand::Mode { dof, mode: Mode::Manual { target_rad: self.within_position(dof, v[0])? }, streamed },
            CommandKind::TRAJECTORY => {
                let n = req.point_count as usize;
                if n == 0 || n > req.points.len() {
                    return Err(format!("a trajectory needs 1 to {} points, got {n}", req.points.len()));
                }
                let mut pts = [TrajectoryPoint { time_s: 0.0, position_rad: 0.0, velocity_rad_s: f64::NAN }; jointctl_ipc::MAX_COMMAND_POINTS];
                for (i, p) in req.points[..n].iter().enumerate() {
                    self.within_position(dof, p[1]).map_err(|e| format!("point {i}: {e}"))?;
                    pts[i] = TrajectoryPoint { time_s: p[0], position_rad: p[1], velocity_rad_s: p[2] };
                }
                let trajectory = Trajectory::new(&pts[..n])?;
                ArmCommand::Mode { dof, mode: Mode::Trajectory { trajectory, start_s: 0.0 }, streamed }
            }
            CommandKind::TORQUE => {
                let waveform = match req.waveform {
                    TorqueWaveform::STEP => Waveform::Step,
                    TorqueWaveform::SINE => Waveform::Sine,
                    TorqueWaveform::COSINE => Waveform::Cosine,
                    TorqueWaveform(w) => return Err(format!("unknown torque waveform {w} (step 0, sine 1, cosine 2)")),
                };
                let reference = Reference {
                    waveform,
                    amplitude: finite("the amplitude", v[0])?,
                    frequency_hz: if waveform == Waveform::Step { 0.0 } else { finite("the frequency", v[1])? },
                    offset: if v[2].is_nan() { 0.0 } else { finite("the offset", v[2])? },
                    start_s: if v[3].is_nan() { 0.0 } else { finite("the start delay", v[3])? },
                };
                reference.validate()?;
                if waveform != Waveform::Step && reference.frequency_hz <= 0.0 {
                    return Err(format!("a {waveform:?} reference needs a frequency > 0 Hz"));
                }
                if reference.start_s < 0.0 {
                    return Err("the start delay must be >= 0 s".into());
                }
                if let Some(limit) = self.limits[dof].and_then(|l| l.torque_nm)
                    && reference.peak() > limit
                {
                    return Err(format!("the reference reaches {} Nm, beyond {name}'s torque limit {limit} Nm", reference.peak()));
                }
                ArmCommand::Mode { dof, mode: Mode::Torque { reference }, streamed }
            }
            CommandKind::IMPEDANCE => {
                let k = finite("K", v[0])?;
                let d = finite("D", v[1])?;
                if k < 0.0 || d < 0.0 {
                    return Err(format!("K and D must be >= 0, got K = {k}, D = {d}"));
                }
                let target = if v[2].is_nan() { f64::NAN } else { self.within_position(dof, v[2])? };
                ArmCommand::Mode { dof, mode: Mode::Impedance { stiffness_nm_per_rad: k, damping_nms_per_rad: d, target_rad: target }, streamed }
            }
            CommandKind::STIFFNESS => {
                let k = finite("the stiffness", v[0])?;
                if k <= 0.0 {
                    return Err(format!("the stiffness must be > 0 Nm/rad, got {k}"));
                }
                if let Some([lo, hi]) = self.limits[dof].and_then(|l| l.stiffness_nm_per_rad)
                    && !(lo..=hi).contains(&k)
                {
                    return Err(format!("stiffness {k} Nm/rad is outside {name}'s range [{lo}, {hi}] Nm/rad"));
                }
                ArmCommand::Stiffness { dof, stiffness_nm_per_rad: k }
            }
            CommandKind(other) => return Err(format!("unknown command kind {other}")),
        };
        let what = match &cmd {
            ArmCommand::Mode { mode, .. } => format!("{name}: {}", mode.name()),
            ArmCommand::Stiffness { stiffness_nm_per_rad, .. } => format!("{name}: stiffness {stiffness_nm_per_rad} Nm/rad"),
            _ => name.clone(),
        };
        Ok((cmd, what))
    }
}
