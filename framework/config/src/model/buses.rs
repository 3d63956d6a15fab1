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
