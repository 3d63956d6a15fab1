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

/// Why a command was refused. Every variant names what was wrong and where, so the client can
/// print it as the answer.
///
/// ```
/// use jointctl_runtime::commands::CommandError;
/// let e = CommandError::NotFinite { what: "the amplitude", value: f64::NAN };
/// assert_eq!(e.to_string(), "the amplitude must be a finite number, got NaN");
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// The command needs a joint name and has none.
    #[error("this command needs a joint name")]
    NoJoint,
    /// No DOF has this name.
    #[error("joint `{joint}` does not exist; the arm's joints are {known}")]
    UnknownJoint {
        /// The name asked for.
        joint: String,
        /// The arm's DOF names, comma-separated.
        known: String,
    },
    /// The DOF is disabled.
    #[error("joint `{joint}` is disabled; enable it first")]
    Disabled {
        /// The DOF.
        joint: String,
    },
    /// A value is NaN or infinite.
    #[error("{what} must be a finite number, got {value}")]
    NotFinite {
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A position beyond the DOF's limits.
    #[error("position {position_rad} rad is outside {joint}'s limits [{}, {}] rad", limits_rad[0], limits_rad[1])]
    PositionOutOfLimits {
        /// The DOF.
        joint: String,
        /// The position asked for [rad].
        position_rad: f64,
        /// The DOF's position limits [rad].
        limits_rad: [f64; 2],
    },
    /// A trajectory with no points or more than the request can carry.
    #[error("a trajectory needs 1 to {max} points, got {got}")]
    TrajectoryPointCount {
        /// Points claimed by the request.
        got: usize,
        /// Most points a request carries.
        max: usize,
    },
    /// One trajectory point is refused.
    #[error("point {index}: {source}")]
    TrajectoryPoint {
        /// The point's index.
        index: usize,
        /// Why.
        source: Box<CommandError>,
    },
    /// The points do not make a trajectory.
    #[error(transparent)]
    Trajectory(#[from] jointctl_modes::TrajectoryError),
    /// A waveform code this runtime does not know.
    #[error("unknown torque waveform {0} (step 0, sine 1, cosine 2)")]
    UnknownWaveform(u32),
    /// The torque reference's numbers are out of range.
    #[error(transparent)]
    Reference(#[from] jointctl_control::InvalidNumber),
    /// A periodic reference without a positive frequency.
    #[error("a {waveform:?} reference needs a frequency > 0 Hz")]
    NeedsFrequency {
        /// The waveform.
        waveform: Waveform,
    },
    /// A negative start delay.
    #[error("the start delay must be >= 0 s, got {delay_s} s")]
    NegativeDelay {
        /// The delay asked for [s].
        delay_s: f64,
    },
    /// The reference would exceed the DOF's torque limit.
    #[error("the reference reaches {peak_nm} Nm, beyond {joint}'s torque limit {limit_nm} Nm")]
    TorqueBeyondLimit {
        /// The DOF.
        joint: String,
        /// Largest torque the reference reaches [Nm].
        peak_nm: f64,
        /// The DOF's limit [Nm].
        limit_nm: f64,
    },
    /// Negative impedance gains.
    #[error("K and D must be >= 0, got K = {stiffness_nm_per_rad}, D = {damping_nms_per_rad}")]
    NegativeImpedance {
        /// K [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// D [Nms/rad].
        damping_nms_per_rad: f64,
    },
    /// A stiffness that is not positive.
    #[error("the stiffness must be > 0 Nm/rad, got {0}")]
    NonPositiveStiffness(f64),
    /// A stiffness beyond the DOF's range.
    #[error("stiffness {stiffness_nm_per_rad} Nm/rad is outside {joint}'s range [{}, {}] Nm/rad", range[0], range[1])]
    StiffnessOutOfRange {
        /// The DOF.
        joint: String,
        /// The stiffness asked for [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// The DOF's range [Nm/rad].
        range: [f64; 2],
    },
    /// A command kind this runtime does not know.
    #[error("unknown command kind {0}")]
    UnknownKind(u32),
}

/// Checks commands against the arm's joints and limits (outside the control thread).
#[derive(Clone, Debug)]
pub struct CommandValidator {
    names: Vec<String>,
    limits: Vec<Option<LimitsConfig>>,
    enabled: Vec<bool>,
}

fn finite(what: &'static str, value: f64) -> Result<f64, CommandError> {
    if value.is_finite() { Ok(value) } else { Err(CommandError::NotFinite { what, value }) }
}

impl CommandValidator {
    /// A validator for these DOFs.
    pub fn new(names: Vec<String>, limits: Vec<Option<LimitsConfig>>) -> Self {
        let enabled = vec![true; names.len()];
        CommandValidator { names, limits, enabled }
    }

    fn dof(&self, joint: &str) -> Result<usize, CommandError> {
        self.names.iter().position(|n| n == joint).ok_or_else(|| {
            if joint.is_empty() {
                CommandError::NoJoint
            } else {
                CommandError::UnknownJoint { joint: joint.into(), known: self.names.join(", ") }
            }
        })
    }

    fn within_position(&self, dof: usize, q: f64) -> Result<f64, CommandError> {
        let q = finite("the position", q)?;
        if let Some(l) = self.limits[dof]
            && !(l.position_rad[0]..=l.position_rad[1]).contains(&q)
        {
            return Err(CommandError::PositionOutOfLimits { joint: self.names[dof].clone(), position_rad: q, limits_rad: l.position_rad });
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
    /// assert!(e.to_string().contains("finite"));
    /// ```
    pub fn validate(&mut self, req: &CommandRequest) -> Result<(ArmCommand, String), CommandError> {
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
            _ if disabled => return Err(CommandError::Disabled { joint: name.clone() }),
            CommandKind::POSITION => ArmCommand::Mode { dof, mode: Mode::Position { target_rad: self.within_position(dof, v[0])? }, streamed },
            CommandKind::MANUAL => ArmCommand::Mode { dof, mode: Mode::Manual { target_rad: self.within_position(dof, v[0])? }, streamed },
            CommandKind::TRAJECTORY => {
                let n = req.point_count as usize;
                if n == 0 || n > req.points.len() {
                    return Err(CommandError::TrajectoryPointCount { got: n, max: req.points.len() });
                }
                let mut pts = [TrajectoryPoint { time_s: 0.0, position_rad: 0.0, velocity_rad_s: f64::NAN }; jointctl_ipc::MAX_COMMAND_POINTS];
                for (i, p) in req.points[..n].iter().enumerate() {
                    self.within_position(dof, p[1]).map_err(|e| CommandError::TrajectoryPoint { index: i, source: Box::new(e) })?;
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
                    TorqueWaveform(w) => return Err(CommandError::UnknownWaveform(w)),
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
                    return Err(CommandError::NeedsFrequency { waveform });
                }
                if reference.start_s < 0.0 {
                    return Err(CommandError::NegativeDelay { delay_s: reference.start_s });
                }
                if let Some(limit) = self.limits[dof].and_then(|l| l.torque_nm)
                    && reference.peak() > limit
                {
                    return Err(CommandError::TorqueBeyondLimit { joint: name.clone(), peak_nm: reference.peak(), limit_nm: limit });
                }
                ArmCommand::Mode { dof, mode: Mode::Torque { reference }, streamed }
            }
            CommandKind::IMPEDANCE => {
                let k = finite("K", v[0])?;
                let d = finite("D", v[1])?;
                if k < 0.0 || d < 0.0 {
                    return Err(CommandError::NegativeImpedance { stiffness_nm_per_rad: k, damping_nms_per_rad: d });
                }
                let target = if v[2].is_nan() { f64::NAN } else { self.within_position(dof, v[2])? };
                ArmCommand::Mode { dof, mode: Mode::Impedance { stiffness_nm_per_rad: k, damping_nms_per_rad: d, target_rad: target }, streamed }
            }
            CommandKind::STIFFNESS => {
                let k = finite("the stiffness", v[0])?;
                if k <= 0.0 {
                    return Err(CommandError::NonPositiveStiffness(k));
                }
                if let Some([lo, hi]) = self.limits[dof].and_then(|l| l.stiffness_nm_per_rad)
                    && !(lo..=hi).contains(&k)
                {
                    return Err(CommandError::StiffnessOutOfRange { joint: name.clone(), stiffness_nm_per_rad: k, range: [lo, hi] });
                }
                ArmCommand::Stiffness { dof, stiffness_nm_per_rad: k }
            }
            CommandKind(other) => return Err(CommandError::UnknownKind(other)),
        };
        let what = match &cmd {
            ArmCommand::Mode { mode, .. } => format!("{name}: {}", mode.name()),
            ArmCommand::Stiffness { stiffness_nm_per_rad, .. } => format!("{name}: stiffness {stiffness_nm_per_rad} Nm/rad"),
            _ => name.clone(),
        };
        Ok((cmd, what))
    }
}
