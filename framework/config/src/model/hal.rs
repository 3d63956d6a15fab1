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
    #[schemars(range(min = 0.001, max = 60.0))]
    pub heartbeat_timeout_s: Option<f64>,
    /// A drive that has sent no heartbeat at all this long after the HAL started the bus is
    /// silent too [s] (before, silence was measured from the last heartbeat seen, so a drive
    /// that never sent one was never silent). Default: the drive's heartbeat timeout, since a
    /// drive produces heartbeats from the moment 0x1017 is written at start-up (CiA 301), before
    /// the loop's first cycle; a longer grace suits a drive that is slow to start producing.
    #[serde(deserialize_with = "finite_opt")]
    #[schemars(range(min = 0.001, max = 60.0))]
    pub heartbeat_grace_s: Option<f64>,
    /// SYNC counter overflow (0x1019); 0 sends SYNC without a counter. Assumption: 240.
    pub sync_counter_overflow: u8,
    /// The host's own CANopen node id: it produces a heartbeat under this id, which every drive
    /// consumes (0x1016). Assumption: 127, the highest id, which no drive uses.
    pub host_node_id: u8,
    /// Period of the host's heartbeat [ms] (sent from the loop's write step). Assumption: 50 ms,
    /// two cycles at the thesis' 40 Hz.
    pub host_heartbeat_ms: u16,
    /// A drive that hears no host heartbeat for this long acts on its own (`on_comm_loss`) [ms]:
    /// a host that stalls or dies cannot leave a drive moving. Assumption: 150 ms, three host
    /// heartbeats (CiA 301 practice: the consumer time well above the producer period).
    pub comm_loss_timeout_ms: u16,
    /// What a drive does on its own when the host falls silent (0x6007, abort connection
    /// option code): `quick_stop` (decelerate and hold, the default), `disable_voltage` or `fault`.
    pub on_comm_loss: CommLossAction,
}

impl Default for CanopenConfig {
    fn default() -> Self {
        CanopenConfig {
            mode: DriveMode::default(),
            sdo_timeout_s: 0.2,
            heartbeat_timeout_s: None,
            heartbeat_grace_s: None,
            sync_counter_overflow: 240,
            host_node_id: 127,
            host_heartbeat_ms: 50,
            comm_loss_timeout_ms: 150,
            on_comm_loss: CommLossAction::default(),
        }
    }
}

/// A drive's own reaction when the host falls silent (CiA 402 object 0x6007).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CommLossAction {
    /// Fault (0x6007 = 1).
    Fault,
    /// Disable voltage: the motor coasts (0x6007 = 2).
    DisableVoltage,
    /// Quick stop: decelerate and hold (0x6007 = 3).
    #[default]
    QuickStop,
}

impl CommLossAction {
    /// The 0x6007 value.
    pub fn code(self) -> i16 {
        match self {
            CommLossAction::Fault => 1,
            CommLossAction::DisableVoltage => 2,
            CommLossAction::QuickStop => 3,
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
