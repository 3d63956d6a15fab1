//! The buses and their devices: CAN drives, SPI encoders, and what each reads in simulation.

use super::*;

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
    /// Force/torque sensors, each read as the torque about one joint axis (chapter 5 validates
    /// the observed torque against an ATI Mini40). Joints wire them with `torque_sensor`; the
    /// observers never use them: they are for validation and recording.
    #[serde(default)]
    pub force_torque: Vec<ForceTorqueConfig>,
}

/// One force/torque sensor axis: the torque about a joint axis from a 6-axis sensor, `a . (T -
/// p x F)` with `a` the axis and `p` a point of it, in the sensor frame. Two entries may name the
/// same physical sensor (the wrist's q6 and q7 about two axes).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ForceTorqueConfig {
    /// Device name, referenced by joints (`torque_sensor`).
    pub name: String,
    /// The real sensor: an ATI Net F/T box streaming RDT over UDP (the Mini40's usual interface).
    #[serde(default)]
    pub netft: Option<NetFtConfig>,
    /// The joint axis in the sensor frame (normalised when loaded). Default: the sensor's z.
    #[serde(default = "z_axis", deserialize_with = "finite_triple")]
    pub axis: [f64; 3],
    /// A point of the joint axis in the sensor frame [m]. Default: the sensor's origin.
    #[serde(default, deserialize_with = "finite_triple")]
    pub axis_point_m: [f64; 3],
    /// Largest plausible |torque| about the axis [Nm]; beyond it a reading is invalid.
    /// Assumption: 50 Nm, above the shoulder's 40 Nm limit.
    #[serde(default = "default_ft_range", deserialize_with = "finite")]
    pub range_nm: f64,
    /// What the simulated backend makes this sensor read: a simulated DOF's torque sensor
    /// (`{dof: q2}`: the element's torque with the configured plant effects and F/T noise).
    #[serde(default)]
    pub sim: Option<ForceTorqueSimConfig>,
}

fn z_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}
fn default_ft_range() -> f64 {
    50.0
}

/// An ATI Net F/T box.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NetFtConfig {
    /// `host:port` of its RDT server (ATI's defaults: 192.168.1.1:49152).
    pub address: String,
    /// Counts per N in its RDT records (the box's calibration page; ATI's usual 1 000 000).
    #[serde(default = "million", deserialize_with = "finite")]
    pub counts_per_force: f64,
    /// Counts per Nm in its RDT records.
    #[serde(default = "million", deserialize_with = "finite")]
    pub counts_per_torque: f64,
    /// A reading older than this is missing rather than stale [s]. Assumption: 0.1 s.
    #[serde(default = "default_ft_timeout", deserialize_with = "finite")]
    pub timeout_s: f64,
}

fn million() -> f64 {
    1_000_000.0
}
fn default_ft_timeout() -> f64 {
    0.1
}

/// A simulated force/torque sensor.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ForceTorqueSimConfig {
    /// The simulated DOF whose torque sensor this is.
    pub dof: String,
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
    /// The unit of the drive's torque actual value (0x6077, per mille): the motor's rated torque
    /// (0x6076) times the gear ratio [Nm at the gearbox output]. Given, the HAL maps 0x6077 into
    /// TPDO1 behind the statusword and the position at start-up (8 bytes; `jointctl check`'s bus
    /// budget counts them) and reads it into the drive's `torque_nm` reading. None: TPDO1 is left
    /// as the drive has it and no torque is read (the shoulder's loop causes need it).
    #[serde(default, deserialize_with = "finite_opt")]
    pub rated_torque_nm: Option<f64>,
    /// Heartbeat producer time written to 0x1017 [ms]. Assumption: 100 ms.
    #[serde(default = "default_heartbeat_ms")]
    pub heartbeat_ms: u16,
    /// Fastest the reported position can change [rad/s] (plausibility). Assumption: 10 rad/s.
    #[serde(default = "default_drive_rate", deserialize_with = "finite")]
    pub max_velocity_rad_s: f64,
    /// Motor positions a set-point may name [rad], as the drive reports them (`[low, high]`).
    /// The runtime checks every set-point a plugin writes against it before the HAL sees it: one
    /// outside holds the joint with a fault that names the plugin, the drive and the value (with
    /// `safety.check_setpoints`). The drive is told it too, as its software position limits
    /// (0x607D, written and read back at start-up), and the simulated drive keeps its target
    /// inside it: a second guard below the host's. None: unchecked, since the motor's range
    /// follows from the joint's transmission, which only the plugin knows.
    #[serde(default, deserialize_with = "finite_pair_opt")]
    pub setpoint_window_rad: Option<[f64; 2]>,
    /// Fastest a set-point may move [rad/s]: from the drive's target (the last move written,
    /// which a hold keeps), or from its position before the first move. In cyclic synchronous position mode a step beyond what the drive
    /// follows in a cycle is a following error; in profile position mode (the thesis') the drive
    /// profiles a far target itself, so a far step may be legitimate there. None: unchecked.
    #[serde(default, deserialize_with = "finite_opt")]
    #[schemars(range(min = 0.0, max = 1000.0))]
    pub max_setpoint_rate_rad_s: Option<f64>,
    /// The drive's own limits, written over SDO at start-up and read back (a drive that holds
    /// another value is a start-up error naming the object and both values). None given: the
    /// drive keeps its own settings.
    #[serde(default)]
    pub limits: DriveLimitsConfig,
}

/// Limits a CiA 402 drive enforces itself, below the host: what stops a bad set-point when
/// nothing above does. Each is optional; positions and rates at the gearbox output, converted
/// with `counts_per_rad`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DriveLimitsConfig {
    /// Max profile velocity (0x607F) [rad/s].
    #[serde(default, deserialize_with = "finite_opt")]
    pub max_profile_velocity_rad_s: Option<f64>,
    /// Max torque (0x6072) [per mille of the motor's rated torque].
    #[serde(default)]
    pub max_torque_permille: Option<u16>,
    /// Following error window (0x6065) [rad]: a larger error for `following_error_timeout_ms`
    /// faults the drive.
    #[serde(default, deserialize_with = "finite_opt")]
    pub following_error_window_rad: Option<f64>,
    /// Following error time out (0x6066) [ms].
    #[serde(default)]
    pub following_error_timeout_ms: Option<u16>,
    /// Quick stop deceleration (0x6085) [rad/s^2]: the ramp of `safety.stop_sequence`'s quick stop.
    #[serde(default, deserialize_with = "finite_opt")]
    pub quick_stop_deceleration_rad_s2: Option<f64>,
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
    /// Subtracted from the raw angle [rad]: the calibrated position zero.
    #[serde(default, deserialize_with = "finite")]
    pub offset_rad: f64,
    /// The encoder is mounted to count against the joint's positive direction: its raw angle is
    /// negated before `offset_rad` is subtracted (the position's sign; default false). The
    /// simulated encoders model the mounting and this correction together, so a simulated
    /// arm reads the same either way.
    #[serde(default)]
    pub reversed: bool,
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
