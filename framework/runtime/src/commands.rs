//! Commands: validated where they arrive (the IPC thread), applied by the loop at the start of
//! its next cycle. An invalid command changes nothing and says why.

use std::sync::Arc;

use jointctl_config::{LimitsConfig, short_number};

use crate::status::LoopStatus;
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
    /// The DOF's joint is faulted and held until the runtime restarts.
    #[error("joint `{joint}` is faulted (code {code}{}) and held until the runtime restarts; see its diagnostics", fault_name(*.code))]
    Faulted {
        /// The DOF.
        joint: String,
        /// Its fault code.
        code: u32,
    },
    /// The DOF does not observe its torque, so torque and impedance control cannot run on it.
    #[error("joint `{joint}` does not observe its torque (plugin `{plugin}`), so it cannot run {mode} control")]
    NoTorque {
        /// The DOF.
        joint: String,
        /// Its plugin.
        plugin: String,
        /// The mode asked for.
        mode: &'static str,
    },
    /// The DOF's stiffness cannot be set.
    #[error("joint `{joint}` has no variable stiffness (plugin `{plugin}`)")]
    NoVariableStiffness {
        /// The DOF.
        joint: String,
        /// Its plugin.
        plugin: String,
    },
    /// The runtime accepted a stop and takes no more commands.
    #[error("the runtime is stopping and takes no more commands")]
    Stopping,
    /// A value is NaN or infinite.
    #[error("{what} must be a finite number, got {}", short_number(*value))]
    NotFinite {
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A position beyond the DOF's limits.
    #[error("position {} rad is outside {joint}'s limits [{}, {}] rad", short_number(*position_rad), short_number(limits_rad[0]), short_number(limits_rad[1]))]
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
    /// A periodic reference faster than the loop can sample: above half its rate, the loop
    /// reads it as another, slower sine (aliasing).
    #[error("a {waveform:?} reference of {} Hz is above the loop's Nyquist frequency ({} Hz: half its rate)", short_number(*frequency_hz), short_number(*nyquist_hz))]
    AboveNyquist {
        /// The waveform.
        waveform: Waveform,
        /// The frequency asked for [Hz].
        frequency_hz: f64,
        /// Half the loop's rate [Hz].
        nyquist_hz: f64,
    },
    /// A start delay below zero or beyond [`MAX_START_DELAY_S`].
    #[error("the start delay must be in [0, {}] s, got {} s", short_number(MAX_START_DELAY_S), short_number(*delay_s))]
    NegativeDelay {
        /// The delay asked for [s].
        delay_s: f64,
    },
    /// The reference would exceed the DOF's torque limit.
    #[error("the reference reaches {} Nm, beyond {joint}'s torque limit {} Nm", short_number(*peak_nm), short_number(*limit_nm))]
    TorqueBeyondLimit {
        /// The DOF.
        joint: String,
        /// Largest torque the reference reaches [Nm].
        peak_nm: f64,
        /// The DOF's limit [Nm].
        limit_nm: f64,
    },
    /// Negative impedance gains.
    #[error("K and D must be >= 0, got K = {}, D = {}", short_number(*stiffness_nm_per_rad), short_number(*damping_nms_per_rad))]
    NegativeImpedance {
        /// K [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// D [Nms/rad].
        damping_nms_per_rad: f64,
    },
    /// A stiffness that is not positive.
    #[error("the stiffness must be > 0 Nm/rad, got {}", short_number(*.0))]
    NonPositiveStiffness(f64),
    /// A stiffness beyond the DOF's range.
    #[error("stiffness {} Nm/rad is outside {joint}'s range [{}, {}] Nm/rad", short_number(*stiffness_nm_per_rad), short_number(range[0]), short_number(range[1]))]
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

/// A host fault's name, for messages.
fn fault_name(code: u32) -> &'static str {
    use jointctl_api::JointFault;
    match code {
        c if c == JointFault::PANICKED.code() => ": its plugin panicked",
        c if c == JointFault::BAD_STATUS.code() => ": its plugin returned an unknown status",
        c if c == JointFault::OVER_BUDGET.code() => ": its plugin took longer than its time budget",
        _ => ": reported by its plugin",
    }
}

/// What a command may ask of one DOF.
#[derive(Clone, Debug)]
pub struct DofSpec {
    /// Its name.
    pub name: String,
    /// Its plugin's name (for messages).
    pub plugin: String,
    /// Its limits.
    pub limits: Option<LimitsConfig>,
    /// It observes its torque (torque and impedance control possible).
    pub torque: bool,
    /// Its stiffness can be set.
    pub stiffness: bool,
}

impl DofSpec {
    /// A DOF that can do everything, with these limits (tests, examples).
    pub fn any(name: &str, limits: Option<LimitsConfig>) -> Self {
        DofSpec { name: name.into(), plugin: "any".into(), limits, torque: true, stiffness: true }
    }
}

/// Checks commands against the arm's joints, their limits and capabilities, and the loop's
/// status (enabled, faulted, stopping) as it publishes it (outside the control thread).
#[derive(Clone, Debug)]
pub struct CommandValidator {
    dofs: Vec<DofSpec>,
    status: Arc<LoopStatus>,
    stop_accepted: bool,
    /// Half the loop's rate [Hz] (infinite until [`CommandValidator::with_loop_rate`]).
    nyquist_hz: f64,
}

/// The longest start delay a reference may ask for [s] (an assumption: a day; a delay is a wait
/// before an experiment starts, and 1e300 s was accepted and never started).
pub const MAX_START_DELAY_S: f64 = 86_400.0;

fn finite(what: &'static str, value: f64) -> Result<f64, CommandError> {
    if value.is_finite() { Ok(value) } else { Err(CommandError::NotFinite { what, value }) }
}

impl CommandValidator {
    /// A validator for these DOFs, reading the loop's status.
    pub fn new(dofs: Vec<DofSpec>, status: Arc<LoopStatus>) -> Self {
        CommandValidator { dofs, status, stop_accepted: false, nyquist_hz: f64::INFINITY }
    }

    /// The same validator for a loop running at `rate_hz`: periodic references above half of it
    /// are refused (a 1 GHz sine was accepted on a 40 Hz loop).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use jointctl_runtime::commands::{CommandValidator, DofSpec};
    /// use jointctl_runtime::status::LoopStatus;
    /// let v = CommandValidator::new(vec![DofSpec::any("q1", None)], Arc::new(LoopStatus::new(1))).with_loop_rate(40.0);
    /// assert_eq!(v.nyquist_hz(), 20.0);
    /// ```
    pub fn with_loop_rate(self, rate_hz: f64) -> Self {
        CommandValidator { nyquist_hz: 0.5 * rate_hz, ..self }
    }

    /// Half the loop's rate [Hz]: the fastest periodic reference taken.
    pub fn nyquist_hz(&self) -> f64 {
        self.nyquist_hz
    }

    /// Refuses every command from now on: a stop was queued for the loop. Called once the stop
    /// is in the queue, not when it is validated, so that a stop the full queue refused does
    /// not leave a runtime that runs on but takes no command.
    pub fn stop_queued(&mut self) {
        self.stop_accepted = true;
    }

    /// The loop status this validator reads.
    pub fn status(&self) -> &Arc<LoopStatus> {
        &self.status
    }

    fn dof(&self, joint: &str) -> Result<usize, CommandError> {
        self.dofs.iter().position(|d| d.name == joint).ok_or_else(|| {
            if joint.is_empty() {
                CommandError::NoJoint
            } else {
                CommandError::UnknownJoint { joint: joint.into(), known: self.dofs.iter().map(|d| d.name.as_str()).collect::<Vec<_>>().join(", ") }
            }
        })
    }

    fn within_position(&self, dof: usize, q: f64) -> Result<f64, CommandError> {
        let q = finite("the position", q)?;
        if let Some(l) = self.dofs[dof].limits
            && !(l.position_rad[0]..=l.position_rad[1]).contains(&q)
        {
            return Err(CommandError::PositionOutOfLimits { joint: self.dofs[dof].name.clone(), position_rad: q, limits_rad: l.position_rad });
        }
        Ok(q)
    }

    /// Validates a request; on success returns the command and a confirmation text.
    ///
    /// ```
    /// use jointctl_ipc::{CommandKind, CommandRequest};
    /// use jointctl_runtime::commands::{CommandValidator, DofSpec};
    /// let status = std::sync::Arc::new(jointctl_runtime::status::LoopStatus::new(1));
    /// let mut v = CommandValidator::new(vec![DofSpec::any("q1", None)], status);
    /// assert!(v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[0.2])).is_ok());
    /// let e = v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[f64::NAN])).unwrap_err();
    /// assert!(e.to_string().contains("finite"));
    /// ```
    pub fn validate(&mut self, req: &CommandRequest) -> Result<(ArmCommand, String), CommandError> {
        let joint = decode_name(&req.joint);
        let v = &req.values;
        if self.stop_accepted || self.status.stopping() {
            return Err(CommandError::Stopping);
        }
        match req.kind {
            CommandKind::STOP => return Ok((ArmCommand::Stop, "stopping".into())),
            CommandKind::HOLD if joint.is_empty() => return Ok((ArmCommand::HoldAll, "holding every joint".into())),
            _ => {}
        }
        let dof = self.dof(joint)?;
        let spec = &self.dofs[dof];
        let name = &spec.name;
        let disabled = !self.status.enabled(dof);
        let fault = self.status.fault(dof);
        let streamed = req.streamed != 0;
        let cmd = match req.kind {
            // A faulted joint is held until the runtime restarts: enabling it would be answered
            // "enabled" and change nothing (disabling it is always safe).
            CommandKind::ENABLE if fault != 0 => return Err(CommandError::Faulted { joint: name.clone(), code: fault }),
            CommandKind::ENABLE | CommandKind::DISABLE => {
                let enabled = req.kind == CommandKind::ENABLE;
                return Ok((ArmCommand::Enable { dof, enabled }, format!("{name} {}", if enabled { "enabled (holding)" } else { "disabled (holding)" })));
            }
            CommandKind::HOLD => ArmCommand::Mode { dof, mode: Mode::Hold, streamed: false },
            _ if disabled => return Err(CommandError::Disabled { joint: name.clone() }),
            _ if fault != 0 => return Err(CommandError::Faulted { joint: name.clone(), code: fault }),
            CommandKind::TORQUE | CommandKind::IMPEDANCE if !spec.torque => {
                let mode = if req.kind == CommandKind::TORQUE { "torque" } else { "impedance" };
                return Err(CommandError::NoTorque { joint: name.clone(), plugin: spec.plugin.clone(), mode });
            }
            CommandKind::STIFFNESS if !spec.stiffness => {
                return Err(CommandError::NoVariableStiffness { joint: name.clone(), plugin: spec.plugin.clone() });
            }
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
                if waveform != Waveform::Step && reference.frequency_hz > self.nyquist_hz {
                    return Err(CommandError::AboveNyquist { waveform, frequency_hz: reference.frequency_hz, nyquist_hz: self.nyquist_hz });
                }
                if !(0.0..=MAX_START_DELAY_S).contains(&reference.start_s) {
                    return Err(CommandError::NegativeDelay { delay_s: reference.start_s });
                }
                if let Some(limit) = spec.limits.and_then(|l| l.torque_nm)
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
                if let Some([lo, hi]) = spec.limits.and_then(|l| l.stiffness_nm_per_rad)
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

#[cfg(test)]
mod tests {
    use super::*;
    use jointctl_ipc::CommandKind;

    fn validator() -> CommandValidator {
        let rigid = DofSpec { name: "q1".into(), plugin: "rigid".into(), limits: None, torque: false, stiffness: false };
        let elastic = DofSpec { name: "q4".into(), plugin: "elastic".into(), limits: None, torque: true, stiffness: false };
        let vsa = DofSpec { name: "q2".into(), plugin: "vsa_shoulder".into(), limits: None, torque: true, stiffness: true };
        CommandValidator::new(vec![rigid, elastic, vsa], Arc::new(LoopStatus::new(3)))
    }

    fn refused(v: &mut CommandValidator, kind: CommandKind, joint: &str, values: &[f64]) -> CommandError {
        v.validate(&CommandRequest::new(kind, joint, values)).map(|(c, _)| c).unwrap_err()
    }

    /// Issue 40, finding 17: `cmd enable q1` on a faulted joint answered "accepted: q1 enabled";
    /// the joint stayed faulted and the next command was refused.
    #[test]
    fn enabling_a_faulted_joint_is_refused_with_its_fault() {
        let status = Arc::new(LoopStatus::new(3));
        let rigid = DofSpec { name: "q1".into(), plugin: "rigid".into(), limits: None, torque: false, stiffness: false };
        let mut v = CommandValidator::new(vec![rigid], status.clone());
        status.set_dof(0, true, 1);
        let e = refused(&mut v, CommandKind::ENABLE, "q1", &[]);
        assert!(matches!(e, CommandError::Faulted { code: 1, .. }), "{e}");
        assert!(e.to_string().contains("is faulted"), "{e}");
        // Disabling it is still taken: it only makes it safer.
        assert!(v.validate(&CommandRequest::new(CommandKind::DISABLE, "q1", &[])).is_ok());
    }

    /// Issue 40, finding 7: on a 40 Hz loop a 1 GHz sine and a start delay of 1e300 s were
    /// accepted, and a step of 1e308 Nm was refused with a 309-digit number that the reply's
    /// 240 bytes cut before the reason.
    #[test]
    fn references_the_loop_cannot_follow_are_refused_with_short_numbers() {
        let limits = LimitsConfig { position_rad: [-2.0, 2.0], velocity_rad_s: None, torque_nm: Some(30.0), stiffness_nm_per_rad: None };
        let dof = DofSpec { name: "q2".into(), plugin: "vsa_shoulder".into(), limits: Some(limits), torque: true, stiffness: true };
        let mut v = CommandValidator::new(vec![dof], Arc::new(LoopStatus::new(1))).with_loop_rate(40.0);
        let torque = |v: &mut CommandValidator, w, values: &[f64]| v.validate(&CommandRequest::torque("q2", w, values)).map(|(c, _)| c);
        let e = torque(&mut v, jointctl_ipc::TorqueWaveform::SINE, &[5.0, 1e9, 0.0, 0.0]).unwrap_err();
        assert_eq!(e.to_string(), "a Sine reference of 1.000e9 Hz is above the loop's Nyquist frequency (20 Hz: half its rate)");
        assert!(torque(&mut v, jointctl_ipc::TorqueWaveform::SINE, &[5.0, 20.0, 0.0, 0.0]).is_ok());
        let e = torque(&mut v, jointctl_ipc::TorqueWaveform::SINE, &[5.0, 1.0, 0.0, 1e300]).unwrap_err();
        assert_eq!(e.to_string(), "the start delay must be in [0, 86400] s, got 1.000e300 s");
        let e = torque(&mut v, jointctl_ipc::TorqueWaveform::STEP, &[1e308, 0.0, 0.0, 0.0]).unwrap_err();
        assert_eq!(e.to_string(), "the reference reaches 1.000e308 Nm, beyond q2's torque limit 30 Nm");
        assert!(e.to_string().len() < 100);
    }

    /// Finding: torque on a rigid joint and stiffness on a non-VSA joint were accepted (exit 0,
    /// "accepted") and then nothing happened.
    #[test]
    fn commands_a_joint_cannot_carry_out_are_refused() {
        let mut v = validator();
        let torque = CommandRequest::torque("q1", jointctl_ipc::TorqueWaveform::STEP, &[1.0, 0.0, 0.0, 0.0]);
        let e = v.validate(&torque).map(|(c, _)| c).unwrap_err();
        assert_eq!(e.to_string(), "joint `q1` does not observe its torque (plugin `rigid`), so it cannot run torque control");
        assert!(matches!(refused(&mut v, CommandKind::IMPEDANCE, "q1", &[10.0, 1.0, f64::NAN]), CommandError::NoTorque { mode: "impedance", .. }));
        assert_eq!(refused(&mut v, CommandKind::STIFFNESS, "q4", &[50.0]).to_string(), "joint `q4` has no variable stiffness (plugin `elastic`)");
        assert!(v.validate(&CommandRequest::new(CommandKind::STIFFNESS, "q2", &[50.0])).is_ok());
        assert!(v.validate(&CommandRequest::torque("q4", jointctl_ipc::TorqueWaveform::STEP, &[1.0, 0.0, 0.0, 0.0])).is_ok());
        assert!(v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[0.1])).is_ok(), "position is for every joint");
    }

    /// Finding: commands for a faulted joint and after `stop` were accepted.
    #[test]
    fn a_faulted_joint_and_a_stopping_runtime_refuse_commands() {
        let mut v = validator();
        v.status().set_dof(1, true, jointctl_api::JointFault::OVER_BUDGET.code());
        let e = refused(&mut v, CommandKind::POSITION, "q4", &[0.1]);
        assert_eq!(e.to_string(), "joint `q4` is faulted (code 3: its plugin took longer than its time budget) and held until the runtime restarts; see its diagnostics");
        assert!(v.validate(&CommandRequest::new(CommandKind::HOLD, "q4", &[])).is_ok(), "holding a held joint is fine");
        assert!(v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[0.1])).is_ok(), "other joints are not affected");
        assert!(v.validate(&CommandRequest::new(CommandKind::STOP, "", &[])).is_ok());
        assert!(v.validate(&CommandRequest::new(CommandKind::POSITION, "q1", &[0.1])).is_ok(), "a stop not yet queued stops nothing");
        v.stop_queued();
        assert_eq!(refused(&mut v, CommandKind::POSITION, "q1", &[0.1]), CommandError::Stopping);
        assert_eq!(refused(&mut v, CommandKind::HOLD, "", &[]), CommandError::Stopping);
        let mut v = validator();
        v.status().set_stopping();
        assert_eq!(refused(&mut v, CommandKind::ENABLE, "q1", &[]), CommandError::Stopping, "a stop by signal counts too");
    }

    /// Finding: the validator kept its own "enabled" flags, set before the command was queued,
    /// so with a full command ring it believed a joint disabled that the loop never disabled.
    /// Now it reads the loop's published status only.
    #[test]
    fn enabled_has_one_source_of_truth_even_when_the_queue_is_full() {
        let v = validator();
        let status = Arc::clone(v.status());
        let mut desk = crate::command_desk::CommandDesk::new(v, 0.001);
        let (mut queue, _loop_end) = rtrb::RingBuffer::<ArmCommand>::new(1);
        queue.push(ArmCommand::HoldAll).unwrap();
        let answer = desk.answer(&CommandRequest::new(CommandKind::DISABLE, "q4", &[]), &mut queue);
        assert_eq!(answer.accepted, 0, "{}", answer.text());
        assert!(answer.text().contains("queue is full"));
        assert!(status.enabled(1));
        let (mut queue, _loop_end) = rtrb::RingBuffer::<ArmCommand>::new(4);
        let answer = desk.answer(&CommandRequest::new(CommandKind::POSITION, "q4", &[0.1]), &mut queue);
        assert_eq!(answer.accepted, 1, "the loop never disabled q4: {}", answer.text());
        // A disable the loop does apply: the desk waits for it, then refuses modes.
        let loop_side = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(5));
            status.set_dof(1, false, 0);
        });
        let answer = desk.answer(&CommandRequest::new(CommandKind::DISABLE, "q4", &[]), &mut queue);
        loop_side.join().unwrap();
        assert_eq!((answer.accepted, answer.text()), (1, "q4 disabled (holding)"));
        let answer = desk.answer(&CommandRequest::new(CommandKind::POSITION, "q4", &[0.1]), &mut queue);
        assert_eq!((answer.accepted, answer.text()), (0, "joint `q4` is disabled; enable it first"));
    }
}
