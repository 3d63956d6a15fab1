//! How much of a CAN bus one control cycle uses: per drive an RPDO (controlword + target, 6
//! bytes) and a TPDO (statusword + position, 6 bytes; 8 with the torque actual value of a drive
//! whose entry has `rated_torque_nm`), one SYNC per cycle, and every drive's
//! heartbeat at its own period plus the host's (which the drives consume). Bit counts are for base-format data frames, without stuffing and
//! with worst-case stuffing ([`frame_bits`]); the load and the highest loop rate use the worst
//! case.

use jointctl_config::{ArmConfig, CanBusConfig};

use crate::codec::canopen::frame_bits;

/// The budget of one CAN bus at the configured loop rate.
#[derive(Clone, Debug, PartialEq)]
pub struct BusBudget {
    /// Interface name.
    pub interface: String,
    /// Bit rate [bit/s].
    pub bitrate: u32,
    /// Drives on the bus.
    pub drives: usize,
    /// Frames every cycle (PDOs and SYNC).
    pub frames_per_cycle: usize,
    /// Heartbeat frames per second (all drives).
    pub heartbeats_per_s: f64,
    /// Bits every cycle, worst-case stuffing.
    pub bits_per_cycle: u32,
    /// Bits every cycle without stuffing.
    pub bits_per_cycle_min: u32,
    /// Bus load at the loop rate, worst case [%].
    pub load_percent: f64,
    /// Highest loop rate at 100 % worst-case load [Hz].
    pub max_rate_hz: f64,
}

/// The budget of one bus at `rate_hz`.
///
/// ```
/// let yaml = "arm: a\nrate_hz: 40\nhal: {backend: sim}\nbuses: {can: [{interface: can0, drives: [{name: m, node_id: 1}]}]}\njoints: [{name: q, plugin: rigid}]\n";
/// let cfg = jointctl_config::parse_str(yaml, "a.yaml").unwrap().config;
/// let b = jointctl_hal::budget::bus_budget(&cfg.buses.can[0], cfg.rate_hz, 50);
/// // RPDO + TPDO (6 bytes: 95..115 bits) + SYNC with counter (1 byte: 55..65 bits).
/// assert_eq!((b.frames_per_cycle, b.bits_per_cycle, b.bits_per_cycle_min), (3, 295, 245));
/// // The drive's torque read too: its TPDO carries 8 bytes (111..135 bits).
/// let mut bus = cfg.buses.can[0].clone();
/// bus.drives[0].rated_torque_nm = Some(50.0);
/// let b = jointctl_hal::budget::bus_budget(&bus, cfg.rate_hz, 50);
/// assert_eq!((b.frames_per_cycle, b.bits_per_cycle, b.bits_per_cycle_min), (3, 315, 261));
/// ```
pub fn bus_budget(bus: &CanBusConfig, rate_hz: f64, host_heartbeat_ms: u16) -> BusBudget {
    let (pdo_min, pdo_max) = frame_bits(6);
    let (sync_min, sync_max) = frame_bits(1);
    let (_, hb_max) = frame_bits(1);
    let n = bus.drives.len();
    // Each drive's RPDO and TPDO.
    let (drive_min, drive_max) = bus.drives.iter().fold((0, 0), |(lo, hi), d| {
        let (tpdo_min, tpdo_max) = frame_bits(if d.rated_torque_nm.is_some() { 8 } else { 6 });
        (lo + pdo_min + tpdo_min, hi + pdo_max + tpdo_max)
    });
    let bits_per_cycle = drive_max + sync_max;
    let bits_per_cycle_min = drive_min + sync_min;
    let heartbeats_per_s: f64 =
        bus.drives.iter().map(|d| 1000.0 / d.heartbeat_ms.max(1) as f64).sum::<f64>() + 1000.0 / f64::from(host_heartbeat_ms.max(1));
    let heartbeat_bits_per_s = heartbeats_per_s * hb_max as f64;
    let bitrate = bus.bitrate as f64;
    let load = (bits_per_cycle as f64 * rate_hz + heartbeat_bits_per_s) / bitrate * 100.0;
    BusBudget {
        interface: bus.interface.clone(),
        bitrate: bus.bitrate,
        drives: n,
        frames_per_cycle: 2 * n + 1,
        heartbeats_per_s,
        bits_per_cycle,
        bits_per_cycle_min,
        load_percent: load,
        max_rate_hz: ((bitrate - heartbeat_bits_per_s) / bits_per_cycle as f64).max(0.0),
    }
}

/// The budgets of every CAN bus of an arm.
pub fn budgets(config: &ArmConfig) -> Vec<BusBudget> {
    config.buses.can.iter().map(|b| bus_budget(b, config.rate_hz, config.hal.canopen.host_heartbeat_ms)).collect()
}

impl std::fmt::Display for BusBudget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} drives at {} kbit/s: {} frames per cycle ({}-{} bits) + {:.0} heartbeats/s; load {:.1} % at the loop rate (worst-case stuffing); highest loop rate {:.0} Hz",
            self.interface,
            self.drives,
            self.bitrate / 1000,
            self.frames_per_cycle,
            self.bits_per_cycle_min,
            self.bits_per_cycle,
            self.heartbeats_per_s,
            self.load_percent,
            self.max_rate_hz
        )
    }
}
