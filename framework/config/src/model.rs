//! The typed arm description. Every field documents its unit; every default says where it comes
//! from (a thesis section, or "assumption").

use std::collections::BTreeMap;
use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Deserializer, de};

use crate::num::{finite, finite_opt, finite_pair};
pub use jointctl_control::PiGains;
pub use jointctl_modes::{ControllerConfig, GainPoint};

/// One robot arm: its loop, its hardware and its joints.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ArmConfig {
    /// Arm name: letters, digits, `_` and `-` (at most 32). Shared-memory service names are
    /// derived from it (`<arm>/joint_state`, `<arm>/diagnostics`).
    pub arm: String,
    /// Control loop rate [Hz]. Default 40 Hz, the thesis' loop rate (sections 2.3 and 4.1).
    #[serde(default = "default_rate_hz", deserialize_with = "finite")]
    pub rate_hz: f64,
    /// Which hardware backend the loop talks to.
    pub hal: HalConfig,
    /// Extra folders searched for plugin libraries, relative to this file.
    #[serde(default)]
    pub plugin_dirs: Vec<PathBuf>,
    /// Loop timing.
    #[serde(default)]
    pub timing: TimingConfig,
    /// Shared-memory (iceoryx2) settings.
    #[serde(default)]
    pub ipc: IpcConfig,
    /// CAN and SPI buses with the devices on them.
    #[serde(default)]
    pub buses: BusesConfig,
    /// The joints, each served by one plugin instance.
    pub joints: Vec<JointConfig>,
}

fn default_rate_hz() -> f64 {
    40.0
}

/// The hardware backend.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HalConfig {
    /// `sim`: the simulated arm, the default; runs anywhere without hardware or root rights.
    /// `socketcan`: the real buses: the drives over SocketCAN (CANopen), the encoders over spidev.
    pub backend: HalBackend,
    /// Settings of the simulated backend.
    #[serde(default)]
    pub sim: SimConfig,
    /// Settings of the CANopen drives on the real buses.
    #[serde(default)]
    pub canopen: CanopenConfig,
}

/// Available hardware backends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum HalBackend {
    /// The simulated arm.
    Sim,
    /// SocketCAN for the drives, spidev for the encoders.
    Socketcan,
}

/// CANopen settings of the drives (CiA 301/402).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CanopenConfig {
    /// Mode of operation (0x6060): `profile_position` as in the thesis (section 3.2; a new
    /// set-point is taken every second cycle, on the rising edge of controlword bit 4) or
    /// `cyclic_synchronous_position` (every SYNC), where the drive supports it.
    #[serde(default)]
    pub mode: DriveMode,
    /// Answer time of an SDO at start-up [s]. Assumption: 0.2 s.
    #[serde(default = "default_sdo_timeout", deserialize_with = "finite")]
    pub sdo_timeout_s: f64,
    /// A drive whose heartbeat is older than this is silent: its readings are invalid [s].
    /// Assumption: 3 heartbeat periods.
    #[serde(default, deserialize_with = "finite_opt")]
    pub heartbeat_timeout_s: Option<f64>,
    /// SYNC counter overflow (0x1019); 0 sends SYNC without a counter. Assumption: 240.
    #[serde(default = "default_sync_overflow")]
    pub sync_counter_overflow: u8,
}

fn default_sdo_timeout() -> f64 {
    0.2
}
fn default_sync_overflow() -> u8 {
    240
}

impl Default for CanopenConfig {
    fn default() -> Self {
        CanopenConfig {
            mode: DriveMode::default(),
            sdo_timeout_s: default_sdo_timeout(),
            heartbeat_timeout_s: None,
            sync_counter_overflow: default_sync_overflow(),
        }
    }
}

/// CiA 402 position modes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DriveMode {
    /// Profile position (0x6060 = 1).
    #[default]
    ProfilePosition,
    /// Cyclic synchronous position (0x6060 = 8).
    CyclicSynchronousPosition,
}

impl DriveMode {
    /// The 0x6060 value.
    pub fn code(self) -> u8 {
        match self {
            DriveMode::ProfilePosition => 1,
            DriveMode::CyclicSynchronousPosition => 8,
        }
    }
}

/// Settings of the simulated backend.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    /// Seed of every random process in the simulation (noise, frame loss).
    #[serde(default)]
    pub seed: u64,
    /// Standard deviation of absolute-encoder noise [rad]. Assumption: 0.
    #[serde(default, deserialize_with = "finite")]
    pub encoder_noise_rad: f64,
    /// Pass encoder readings through the 14-bit AS5048A frame codec (section 2.2), so that
    /// they are quantised to 2 pi / 16384 rad as on the robot.
    #[serde(default = "yes")]
    pub quantize_encoders: bool,
    /// Fraction of drive TPDO frames lost on the simulated CAN bus (appendix A), 0-1.
    #[serde(default, deserialize_with = "finite")]
    pub can_loss_rate: f64,
    /// What a lost frame becomes: `missing` (nothing arrives) or `zero` (appendix A's failure:
    /// the host read a lost encoder value as zero).
    #[serde(default)]
    pub can_loss_mode: CanLossMode,
    /// SPI latency [s]: readings are this old (section 2.3: about 15 ms). Default 0.
    #[serde(default, deserialize_with = "finite")]
    pub spi_latency_s: f64,
    /// CAN latency [s] (section 2.3: about 30 ms). Default 0.
    #[serde(default, deserialize_with = "finite")]
    pub can_latency_s: f64,
    /// Integration step of the simulated physics [s]. Assumption: 0.5 ms.
    #[serde(default = "default_substep", deserialize_with = "finite")]
    pub substep_s: f64,
    /// The simulated ELMO drives (section 3.2).
    #[serde(default)]
    pub elmo: ElmoConfig,
}

fn default_substep() -> f64 {
    0.0005
}

/// The simulated ELMO drive (thesis section 3.2: a trapezoidal motion profile from the maximal
/// acceleration and velocity, deceleration started in time to avoid overshoot, followed by a
/// PID on the motor encoder). The thesis gives no gains: every default is an assumption.
/// Positions are at the gearbox output [rad].
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ElmoConfig {
    /// Profile velocity limit [rad/s]. Assumption: 3 rad/s.
    #[serde(default = "elmo_v", deserialize_with = "finite")]
    pub max_velocity_rad_s: f64,
    /// Profile acceleration limit [rad/s^2]. Assumption: 30 rad/s^2.
    #[serde(default = "elmo_a", deserialize_with = "finite")]
    pub max_acceleration_rad_s2: f64,
    /// PID proportional gain [Nm/rad]. Assumption: 4000.
    #[serde(default = "elmo_kp", deserialize_with = "finite")]
    pub kp: f64,
    /// PID integral gain [Nm/(rad s)]. Assumption: 20000.
    #[serde(default = "elmo_ki", deserialize_with = "finite")]
    pub ki: f64,
    /// PID derivative gain [Nms/rad]. Assumption: 80.
    #[serde(default = "elmo_kd", deserialize_with = "finite")]
    pub kd: f64,
    /// Motor + gearbox inertia at the gearbox output [kg m^2]. Assumption: 0.5.
    #[serde(default = "elmo_j", deserialize_with = "finite")]
    pub inertia_kgm2: f64,
    /// Torque (current) limit at the gearbox output [Nm]. Assumption: 150 Nm.
    #[serde(default = "elmo_tau", deserialize_with = "finite")]
    pub torque_limit_nm: f64,
    /// Eq. 3.5 gear friction `k_a atan(k_b omega)`: k_a [Nm]. Assumption: 0.5.
    #[serde(default = "elmo_ka", deserialize_with = "finite")]
    pub friction_ka_nm: f64,
    /// Eq. 3.5: k_b [s/rad]. Assumption: 50.
    #[serde(default = "elmo_kb", deserialize_with = "finite")]
    pub friction_kb_s_per_rad: f64,
}

fn elmo_v() -> f64 {
    3.0
}
fn elmo_a() -> f64 {
    30.0
}
fn elmo_kp() -> f64 {
    4000.0
}
fn elmo_ki() -> f64 {
    20000.0
}
fn elmo_kd() -> f64 {
    80.0
}
fn elmo_j() -> f64 {
    0.5
}
fn elmo_tau() -> f64 {
    150.0
}
fn elmo_ka() -> f64 {
    0.5
}
fn elmo_kb() -> f64 {
    50.0
}

impl Default for ElmoConfig {
    fn default() -> Self {
        ElmoConfig {
            max_velocity_rad_s: elmo_v(),
            max_acceleration_rad_s2: elmo_a(),
            kp: elmo_kp(),
            ki: elmo_ki(),
            kd: elmo_kd(),
            inertia_kgm2: elmo_j(),
            torque_limit_nm: elmo_tau(),
            friction_ka_nm: elmo_ka(),
            friction_kb_s_per_rad: elmo_kb(),
        }
    }
}

/// How a joint is simulated (YAML `sim:` of a joint). Without it, the joint's encoders follow
/// its drives kinematically (`buses.spi[].encoders[].sim`).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JointSimConfig {
    /// The drives moving this joint, in the columns' order of `matrix`.
    pub drives: Vec<String>,
    /// Per DOF, the motor-side joint angle `theta = sum(matrix[dof][i] * drive_i)` [rad/rad]: the
    /// joint's transmission (eq. 3.1 ratio 2 for the elbow, eq. 3.3 for the shoulder, eq. 3.7
    /// with the eq. 3.8 ratio for the wrist).
    pub matrix: Vec<Vec<f64>>,
    /// The elastic element between theta and the output, the same for every DOF...
    #[serde(default)]
    pub element: Option<ElementSimConfig>,
    /// ... or one per DOF (the shoulder: q2's VSA and rigid q3). A `wrist_table` covers both
    /// of its DOFs and stands alone.
    #[serde(default)]
    pub elements: Vec<ElementSimConfig>,
    /// Where the VSA's pivot is: `pivot_mm = offset_mm + mm_per_rad * drive`.
    #[serde(default)]
    pub pivot: Option<PivotSimConfig>,
    /// What the output is attached to, the same for every DOF...
    #[serde(default)]
    pub environment: Option<EnvironmentConfig>,
    /// ... or one per DOF.
    #[serde(default)]
    pub environments: Vec<EnvironmentConfig>,
    /// Plant effects the observer does not model, each off unless given.
    #[serde(default)]
    pub effects: EffectsConfig,
}

/// The elastic element, e.g. `{kind: linear, stiffness_nm_per_rad: 113.78}` or `{kind: rigid}`.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ElementSimConfig {
    /// Rigid (theta is the output); a clamped output then holds the drives too.
    Rigid,
    /// `tau = K delta`.
    Linear {
        /// K [Nm/rad].
        stiffness_nm_per_rad: f64,
    },
    /// The characteristic in the joint's `params.characteristic` (the same table the observer
    /// uses), 1-DOF over pivot settings.
    PivotTable,
    /// The 2-DOF wrist characteristic in `params.characteristic` (q6, q7).
    WristTable,
    /// Eq. 2.6 with these lever-arm parameters, `tau = K(pivot) delta`.
    LeverArm {
        /// Lever length l [m].
        lever_length_m: f64,
        /// Crank R [m].
        crank_radius_m: f64,
        /// Spring k_s [N/m].
        spring_n_per_m: f64,
        /// Pivot q at setting 0 mm [m].
        pivot_offset_m: f64,
    },
}

/// Pivot position of a simulated VSA.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PivotSimConfig {
    /// The pivot drive.
    pub drive: String,
    /// [mm/rad]
    pub mm_per_rad: f64,
    /// [mm]
    pub offset_mm: f64,
}

/// What a simulated joint's output is attached to, e.g. `{kind: fixed, position_rad: 0}` or
/// `{kind: free, inertia_kgm2: 0.3}`.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum EnvironmentConfig {
    /// Clamped (the thesis' validation set-ups, figures 5.1, 5.14).
    Fixed {
        /// Where [rad].
        #[serde(default)]
        position_rad: f64,
    },
    /// A free link.
    Free {
        /// Output inertia [kg m^2].
        inertia_kgm2: f64,
        /// Output damping [Nms/rad].
        #[serde(default)]
        damping_nms_per_rad: f64,
        /// Gravity torque amplitude `m g l` [Nm] (torque `-mgl sin(q)`); 0: none.
        #[serde(default)]
        gravity_nm: f64,
    },
    /// A spring contact (the environment as a spring) on a link.
    Spring {
        /// Contact stiffness [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// Where the contact is at rest [rad].
        rest_rad: f64,
        /// Output inertia [kg m^2].
        inertia_kgm2: f64,
        /// Damping [Nms/rad].
        #[serde(default)]
        damping_nms_per_rad: f64,
    },
    /// The output moved by a flow source (sections 3.3.1, 3.4.1, 3.5.1: characterisation), a
    /// sine of this amplitude [rad] and frequency [Hz] per DOF, along `angle_deg` for the wrist.
    Flow {
        /// Amplitude [rad].
        amplitude_rad: f64,
        /// Frequency [Hz].
        frequency_hz: f64,
        /// Deflection direction for a 2-DOF joint [deg] (0 = the second DOF only, 90 = the first).
        #[serde(default)]
        angle_deg: f64,
        /// The source starts moving at this simulated time [s] (the joint at rest before).
        #[serde(default)]
        start_s: f64,
    },
}

/// Plant effects the observer does not model (all off by default).
#[derive(Clone, Copy, Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EffectsConfig {
    /// Viscous friction in the element [Nms/rad].
    #[serde(default)]
    pub viscous_nms_per_rad: f64,
    /// Dahl hysteresis: `dz/dt = sigma (1 - z/fc sgn(v)) v`, torque `z` [Nm].
    #[serde(default)]
    pub hysteresis: Option<DahlConfig>,
    /// Dead-zone (play) half-width around zero deflection [rad].
    #[serde(default)]
    pub dead_zone_rad: f64,
    /// Stiffness non-linearity: `+ k3 delta^3` [Nm/rad^3].
    #[serde(default)]
    pub cubic_nm_per_rad3: f64,
    /// A structural mode seen by the torque sensor [Hz, ratio, Nm per Nm of element torque].
    #[serde(default)]
    pub vibration: Option<VibrationConfig>,
    /// Offset of the torque sensor [Nm].
    #[serde(default)]
    pub torque_offset_nm: f64,
    /// Standard deviation of the torque sensor noise [Nm].
    #[serde(default)]
    pub torque_noise_nm: f64,
}

/// Dahl hysteresis parameters.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DahlConfig {
    /// Rest stiffness sigma [Nm/rad].
    pub sigma_nm_per_rad: f64,
    /// Limit torque fc [Nm].
    pub limit_nm: f64,
}

/// A structural vibration mode.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VibrationConfig {
    /// Mode frequency [Hz].
    pub frequency_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Excitation: mode torque per element torque change [-].
    pub gain: f64,
}

/// What a lost simulated CAN frame becomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CanLossMode {
    /// Nothing arrives.
    #[default]
    Missing,
    /// A frame with an all-zero position arrives (thesis appendix A).
    Zero,
}

fn yes() -> bool {
    true
}


impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            seed: 0,
            encoder_noise_rad: 0.0,
            quantize_encoders: true,
            can_loss_rate: 0.0,
            can_loss_mode: CanLossMode::Missing,
            spi_latency_s: 0.0,
            can_latency_s: 0.0,
            substep_s: default_substep(),
            elmo: ElmoConfig::default(),
        }
    }
}

/// Loop timing.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TimingConfig {
    /// The loop sleeps until this long before each deadline, then spins [us], trading CPU for
    /// jitter. Assumption: 200 us.
    #[serde(default = "default_spin_us")]
    pub spin_us: u32,
    /// Run the loop thread with SCHED_FIFO at this priority (1-99) when permitted.
    #[serde(default)]
    pub realtime_priority: Option<u8>,
    /// Pin the loop thread to this CPU.
    #[serde(default)]
    pub cpu: Option<usize>,
}

fn default_spin_us() -> u32 {
    200
}

impl Default for TimingConfig {
    fn default() -> Self {
        TimingConfig { spin_us: default_spin_us(), realtime_priority: None, cpu: None }
    }
}

/// Shared-memory settings.
#[derive(Clone, Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IpcConfig {
    /// iceoryx2 domain (its file prefix). All processes of one arm must use the same; default:
    /// iceoryx2's own default, which its other-language clients also use.
    #[serde(default)]
    pub domain: Option<String>,
}

/// The buses and their devices.
#[derive(Clone, Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BusesConfig {
    /// CAN buses with their motor drives (thesis section 2.2: 9 ELMO Whistle drives).
    #[serde(default)]
    pub can: Vec<CanBusConfig>,
    /// SPI buses with their absolute encoders (section 2.2: 13 14-bit magnetic encoders).
    #[serde(default)]
    pub spi: Vec<SpiBusConfig>,
}

/// One CAN bus.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CanBusConfig {
    /// Network interface name (e.g. `can0`).
    pub interface: String,
    /// Bit rate [bit/s]. Assumption: 1 Mbit/s.
    #[serde(default = "default_bitrate")]
    pub bitrate: u32,
    /// The drives on this bus.
    pub drives: Vec<DriveConfig>,
}

fn default_bitrate() -> u32 {
    1_000_000
}

/// One motor drive.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DriveConfig {
    /// Device name, referenced by joints.
    pub name: String,
    /// CANopen node id, 1-127.
    pub node_id: u8,
    /// Position counts per radian of the reported (gearbox output) position. Assumption when
    /// not given: a 2048-line quadrature encoder behind a 100:1 gear, 8192 * 100 / (2 pi).
    #[serde(default = "default_counts_per_rad", deserialize_with = "finite")]
    pub counts_per_rad: f64,
    /// Heartbeat producer time written to 0x1017 [ms]. Assumption: 100 ms.
    #[serde(default = "default_heartbeat_ms")]
    pub heartbeat_ms: u16,
    /// Fastest the reported position can change [rad/s] (plausibility). Assumption: 10 rad/s.
    #[serde(default = "default_drive_rate", deserialize_with = "finite")]
    pub max_velocity_rad_s: f64,
}

fn default_counts_per_rad() -> f64 {
    8192.0 * 100.0 / std::f64::consts::TAU
}
fn default_heartbeat_ms() -> u16 {
    100
}
fn default_drive_rate() -> f64 {
    10.0
}

/// One SPI bus.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpiBusConfig {
    /// spidev bus: encoder `chip_select` N is the device file `<device>.N` (e.g. `/dev/spidev0`).
    pub device: String,
    /// Clock [Hz]. Assumption: 1 MHz (the AS5048A allows up to 10 MHz).
    #[serde(default = "default_spi_speed")]
    pub speed_hz: u32,
    /// The encoders on this bus.
    pub encoders: Vec<EncoderConfig>,
}

fn default_spi_speed() -> u32 {
    1_000_000
}

/// One absolute encoder.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EncoderConfig {
    /// Device name, referenced by joints.
    pub name: String,
    /// Chip-select line, 0-15.
    pub chip_select: u8,
    /// Subtracted from the raw angle [rad].
    #[serde(default, deserialize_with = "finite")]
    pub offset_rad: f64,
    /// Fastest the measured angle can change [rad/s] (plausibility). Assumption: 10 rad/s.
    #[serde(default = "default_drive_rate", deserialize_with = "finite")]
    pub max_velocity_rad_s: f64,
    /// What the simulated backend makes this encoder read.
    #[serde(default)]
    pub sim: Option<EncoderSimConfig>,
}

/// A simulated encoder reads a drive's position times a gain (a free joint), a weighted sum of
/// drives (behind a differential), or a fixed angle (a joint whose output is clamped, as in the
/// thesis' characterisation set-ups).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EncoderSimConfig {
    /// Drive whose position this encoder follows.
    #[serde(default)]
    pub drive: Option<String>,
    /// Drives whose weighted positions this encoder sums (e.g. a tendon differential).
    #[serde(default)]
    pub sum: Vec<SimTerm>,
    /// A simulated joint's signal this encoder reads (`q4.output`, `q2.deflection`, ...).
    #[serde(default)]
    pub signal: Option<String>,
    /// Read through the 14-bit encoder codec (default) or as an exact value (a torque sensor).
    #[serde(default = "yes")]
    pub quantized: bool,
    /// Encoder rad per drive rad.
    #[serde(default = "one", deserialize_with = "finite")]
    pub gain: f64,
    /// Reading at drive position 0 [rad].
    #[serde(default, deserialize_with = "finite")]
    pub offset_rad: f64,
    /// A fixed reading [rad] instead of following a drive.
    #[serde(default, deserialize_with = "finite_opt")]
    pub fixed_rad: Option<f64>,
}

fn one() -> f64 {
    1.0
}

/// One term of a simulated encoder's sum: `gain * position(drive)` or `gain * signal`.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimTerm {
    /// Drive name.
    #[serde(default)]
    pub drive: Option<String>,
    /// A simulated joint's signal: `<dof>.output`, `<dof>.theta`, `<dof>.deflection`,
    /// `<dof>.torque` (the F/T sensor) or `<dof>.pivot_mm`.
    #[serde(default)]
    pub signal: Option<String>,
    /// Encoder rad per drive rad.
    #[serde(deserialize_with = "finite")]
    pub gain: f64,
}

/// One joint plugin instance: one joint, or several coupled DOFs (the wrist's q6 and q7).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JointConfig {
    /// Name of the instance; also the joint's name when `dofs` is not given.
    pub name: String,
    /// The plugin: a name (`rigid`, looked up as `libjointctl_plugin_rigid.so` or `librigid.so`),
    /// or `{name, path}` for a library anywhere (path relative to this file).
    pub plugin: PluginRef,
    /// For a multi-DOF plugin: each DOF's name and limits. Empty for a 1-DOF joint.
    #[serde(default)]
    pub dofs: Vec<DofConfig>,
    /// Limits of a 1-DOF joint.
    #[serde(default)]
    pub limits: Option<LimitsConfig>,
    /// Encoder role → encoder device name (roles are the plugin's).
    #[serde(default)]
    pub encoders: BTreeMap<String, String>,
    /// Drive role → drive device name.
    #[serde(default)]
    pub drives: BTreeMap<String, String>,
    /// Parameters for the plugin, checked by the plugin.
    #[serde(default)]
    pub params: Params,
    /// Controller of a 1-DOF joint (torque PI, gain schedule, rate limit, watchdog).
    #[serde(default)]
    pub controller: Option<ControllerConfig>,
    /// How the simulated backend models this joint.
    #[serde(default)]
    pub sim: Option<JointSimConfig>,
}

/// One DOF of a multi-DOF joint.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DofConfig {
    /// Joint name (as published).
    pub name: String,
    /// Its limits.
    #[serde(default)]
    pub limits: Option<LimitsConfig>,
    /// Its controller.
    #[serde(default)]
    pub controller: Option<ControllerConfig>,
}

/// Limits enforced by the runtime on every command.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LimitsConfig {
    /// `[lower, upper]` joint position [rad].
    #[serde(deserialize_with = "finite_pair")]
    pub position_rad: [f64; 2],
    /// Largest |joint velocity| [rad/s].
    #[serde(default, deserialize_with = "finite_opt")]
    pub velocity_rad_s: Option<f64>,
    /// Largest |joint torque| [Nm].
    #[serde(default, deserialize_with = "finite_opt")]
    pub torque_nm: Option<f64>,
    /// `[lowest, highest]` stiffness a command may request [Nm/rad] (variable stiffness joints).
    #[serde(default)]
    pub stiffness_nm_per_rad: Option<[f64; 2]>,
}

/// Where a plugin comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PluginRef {
    /// The plugin's name (its descriptor must carry the same).
    pub name: String,
    /// An explicit library path, relative to the config file.
    pub path: Option<PathBuf>,
}

impl<'de> Deserialize<'de> for PluginRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct ByPath {
            name: String,
            path: PathBuf,
        }
        impl<'de> de::Visitor<'de> for V {
            type Value = PluginRef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a plugin name, or a mapping {name, path}")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<PluginRef, E> {
                Ok(PluginRef { name: v.to_string(), path: None })
            }
            fn visit_map<A: de::MapAccess<'de>>(self, map: A) -> Result<PluginRef, A::Error> {
                let p = ByPath::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(PluginRef { name: p.name, path: Some(p.path) })
            }
        }
        d.deserialize_any(V)
    }
}

impl JsonSchema for PluginRef {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "PluginRef".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "A plugin name, or {name, path} for a library anywhere (path relative to the config file).",
            "oneOf": [
                {"type": "string"},
                {"type": "object", "additionalProperties": false, "required": ["name", "path"],
                 "properties": {"name": {"type": "string"}, "path": {"type": "string"}}}
            ]
        })
    }
}

/// A plugin's parameters: any YAML mapping whose numbers are all finite, handed to the plugin
/// as JSON.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params(pub serde_json::Value);

impl<'de> Deserialize<'de> for Params {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let yaml = serde_yaml::Value::deserialize(d)?;
        to_json(&yaml, "").map(Params).map_err(|(path, msg)| {
            de::Error::custom(if path.is_empty() { msg } else { format!("{path}: {msg}") })
        })
    }
}

fn to_json(v: &serde_yaml::Value, path: &str) -> Result<serde_json::Value, (String, String)> {
    use serde_yaml::Value as Y;
    Ok(match v {
        Y::Null => serde_json::Value::Null,
        Y::Bool(b) => serde_json::Value::Bool(*b),
        Y::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into()
            } else if let Some(u) = n.as_u64() {
                u.into()
            } else {
                let f = n.as_f64().unwrap_or(f64::NAN);
                match serde_json::Number::from_f64(f) {
                    Some(num) => serde_json::Value::Number(num),
                    None => return Err((path.to_string(), format!("must be a finite number, got {f}"))),
                }
            }
        }
        Y::String(s) => serde_json::Value::String(s.clone()),
        Y::Sequence(items) => serde_json::Value::Array(
            items.iter().enumerate().map(|(i, x)| to_json(x, &format!("{path}[{i}]"))).collect::<Result<_, _>>()?,
        ),
        Y::Mapping(m) => {
            let mut out = serde_json::Map::new();
            for (k, x) in m {
                let key = match k {
                    Y::String(s) => s.clone(),
                    other => return Err((path.to_string(), format!("keys must be strings, got {other:?}"))),
                };
                let child = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
                out.insert(key, to_json(x, &child)?);
            }
            serde_json::Value::Object(out)
        }
        Y::Tagged(t) => to_json(&t.value, path)?,
    })
}

impl JsonSchema for Params {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Params".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "Plugin parameters; each plugin documents its own.",
            "type": "object"
        })
    }
}

impl JointConfig {
    /// The names of the DOFs this instance serves, in order.
    pub fn dof_names(&self) -> Vec<&str> {
        if self.dofs.is_empty() { vec![self.name.as_str()] } else { self.dofs.iter().map(|d| d.name.as_str()).collect() }
    }

    /// The limits of each DOF, in order.
    pub fn dof_limits(&self) -> Vec<Option<LimitsConfig>> {
        if self.dofs.is_empty() { vec![self.limits] } else { self.dofs.iter().map(|d| d.limits).collect() }
    }

    /// The controller settings of each DOF (defaults where not given), with their field paths
    /// relative to the joint.
    pub fn dof_controllers(&self) -> Vec<(String, ControllerConfig)> {
        if self.dofs.is_empty() {
            vec![("controller".into(), self.controller.clone().unwrap_or_default())]
        } else {
            self.dofs.iter().enumerate().map(|(i, d)| (format!("dofs[{i}].controller"), d.controller.clone().unwrap_or_default())).collect()
        }
    }
}
