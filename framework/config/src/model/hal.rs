//! Which HAL backend runs the arm, and how the real one drives CANopen.

use super::*;

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
#[serde(deny_unknown_fields, default)]
pub struct CanopenConfig {
    /// Mode of operation (0x6060): `profile_position` as in the thesis (section 3.2; a new
    /// set-point is taken every second cycle, on the rising edge of controlword bit 4) or
    /// `cyclic_synchronous_position` (every SYNC), where the drive supports it.
    pub mode: DriveMode,
    /// Answer time of an SDO at start-up [s]. Assumption: 0.2 s.
    #[serde(deserialize_with = "finite")]
    pub sdo_timeout_s: f64,
    /// A drive whose heartbeat is older than this is silent: its readings are invalid [s].
    /// Assumption: 3 heartbeat periods.
    #[serde(deserialize_with = "finite_opt")]
    pub heartbeat_timeout_s: Option<f64>,
    /// SYNC counter overflow (0x1019); 0 sends SYNC without a counter. Assumption: 240.
    pub sync_counter_overflow: u8,
}

impl Default for CanopenConfig {
    fn default() -> Self {
        CanopenConfig {
            mode: DriveMode::default(),
            sdo_timeout_s: 0.2,
            heartbeat_timeout_s: None,
            sync_counter_overflow: 240,
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
