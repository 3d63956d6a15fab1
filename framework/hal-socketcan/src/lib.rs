//! # jointctl-hal-socketcan
//!
//! The real buses: the ELMO drives as CANopen nodes over SocketCAN, the absolute encoders over
//! Linux spidev. Lost or late frames are never data: every reading goes through a
//! [`Conditioner`], carries its age, and is stale or invalid rather than zero.
//!
//! Start-up (blocking, before the loop): per drive, SDO writes of the mode of operation
//! (0x6060), the heartbeat producer time (0x1017), SYNC-triggered TPDO1 (0x1800:02 = 1), the
//! consumer heartbeat of the host (0x1016:01) and what to do when it stops (0x6007, abort
//! connection option: quick stop by default) and the drive's own limits of the config (software
//! position limits 0x607D, max profile velocity 0x607F, max torque 0x6072, following error
//! window and time out 0x6065/0x6066, quick stop deceleration 0x6085), each read back; then NMT
//! start. So a host that stalls or dies
//! cannot leave a drive moving: the drive stops on its own after `comm_loss_timeout_ms`. The
//! write step sends the host's heartbeat every `host_heartbeat_ms`.
//!
//! Force/torque sensors are read from ATI Net F/T boxes over UDP ([`netft`]).
//!
//! In the loop (never blocking): read drains the socket (TPDO1 statusword +
//! position, heartbeats, EMCY, error frames) and each encoder's pipelined SPI answer; write sends
//! every drive's RPDO1 (controlword + target) and one SYNC with its counter. The CiA 402 enable
//! sequence advances one step per cycle, and only once the drive's actual position is known (the
//! first target is where the drive is). A faulted drive stays faulted until [`Hal::reset_faults`].
//!
//! Stop (blocking, after the loop): [`Hal::stop`] takes every drive through `safety.stop_sequence`
//! (quick stop, disable operation or voltage, NMT pre-operational), each step's controlword sent
//! with SYNC and the host's heartbeat until every drive reports the step's state or its timeout
//! passes.

pub mod netft;

use std::io::ErrorKind;
use std::time::{Duration, Instant};

use jointctl_api::{DriveAction, DriveReading, Reading};
use jointctl_config::{ArmConfig, DriveMode, StopStep};
use socketcan::{CanFrame, CanSocket, EmbeddedFrame, Frame as _, Socket, SocketOptions, StandardId};

use jointctl_hal::codec::as5048;
use jointctl_hal::codec::canopen::{self as co, DriveState, Frame};
use jointctl_hal::condition::{Conditioner, Plausibility, Sample};
use jointctl_hal::{ActuatorFrame, Hal, HalIoError, HalSetupError, SensorFrame, StopStepReport};

/// Health of one CAN bus.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BusHealth {
    /// The controller reported bus-off.
    pub bus_off: bool,
    /// The controller reported error-passive.
    pub error_passive: bool,
    /// Error frames received.
    pub error_frames: u64,
    /// Frames that could not be sent.
    pub tx_failures: u64,
}

/// Health of one drive.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriveHealth {
    /// CiA 402 state from the last statusword.
    pub state: Option<DriveState>,
    /// Emergency messages received.
    pub emcy_count: u64,
    /// The last emergency code.
    pub last_emcy_code: u16,
    /// No heartbeat within the timeout, or none at all within the grace time after start-up
    /// (`hal.canopen.heartbeat_grace_s`).
    pub silent: bool,
    /// Cycles without a TPDO, frames rejected, values rejected.
    pub losses: jointctl_hal::condition::LossCounters,
}

struct Drive {
    name: String,
    node: u8,
    counts_per_rad: f64,
    conditioner: Conditioner,
    fresh: Option<(i32, f64)>,
    statusword: Option<u16>,
    last_heartbeat_s: Option<f64>,
    /// The NMT state in the drive's last heartbeat.
    nmt_state: Option<u8>,
    heartbeat_timeout_s: f64,
    /// Silent when no heartbeat has come this long after the HAL started [s].
    heartbeat_grace_s: f64,
    target_counts: Option<i32>,
    toggle: bool,
    reset_requested: bool,
    health: DriveHealth,
}

struct CanBus {
    index: usize,
    socket: CanSocket,
    interface: String,
    drives: Vec<Drive>,
    sync_counter: u8,
    sync_overflow: u8,
    health: BusHealth,
}

struct Encoder {
    name: String,
    path: String,
    device: Option<spidev::Spidev>,
    offset_rad: f64,
    reversed: bool,
    conditioner: Conditioner,
}

/// The real hardware.
pub struct HardwareHal {
    t0: Instant,
    mode: DriveMode,
    host_node_id: u8,
    host_heartbeat_s: f64,
    last_host_heartbeat_s: f64,
    buses: Vec<CanBus>,
    encoders: Vec<Encoder>,
    torque_sensors: netft::NetFtSensors,
}

fn to_socketcan(f: &Frame) -> Option<CanFrame> {
    CanFrame::new(StandardId::new(f.id)?, f.bytes())
}

fn from_socketcan(f: &CanFrame) -> Option<Frame> {
    match f {
        CanFrame::Data(d) => match d.id() {
            socketcan::Id::Standard(id) => Some(Frame::new(id.as_raw(), d.data())),
            socketcan::Id::Extended(_) => None,
        },
        _ => None,
    }
}

impl CanBus {
    fn send(&mut self, f: &Frame) {
        let ok = to_socketcan(f).is_some_and(|cf| self.socket.write_frame(&cf).is_ok());
        if !ok {
            self.health.tx_failures += 1;
        }
    }

    /// Blocking SDO write with a timeout (start-up only).
    fn sdo_write(&mut self, d: usize, index: u16, sub: u8, value: &[u8], timeout: Duration) -> Result<(), HalSetupError> {
        let req = co::sdo_write(self.drives[d].node, index, sub, value);
        self.sdo_exchange(d, &req, "write", index, sub, timeout, |r| matches!(r, co::SdoResponse::WriteOk { .. }).then_some(()))
    }

    /// Blocking SDO read of an expedited value with a timeout (start-up only).
    fn sdo_read(&mut self, d: usize, index: u16, sub: u8, timeout: Duration) -> Result<u32, HalSetupError> {
        let req = co::sdo_read(self.drives[d].node, index, sub);
        self.sdo_exchange(d, &req, "read", index, sub, timeout, |r| match r {
            co::SdoResponse::Value { value, .. } => Some(value),
            _ => None,
        })
    }

    /// Sends an SDO request to drive `d` and waits for its answer about `index:sub`: what
    /// `answer` takes from it, or an error for an abort, a bus failure or no answer in time.
    #[allow(clippy::too_many_arguments)]
    fn sdo_exchange<T>(
        &mut self,
        d: usize,
        req: &Frame,
        what: &str,
        index: u16,
        sub: u8,
        timeout: Duration,
        answer: impl Fn(co::SdoResponse) -> Option<T>,
    ) -> Result<T, HalSetupError> {
        let node = self.drives[d].node;
        let name = self.drives[d].name.clone();
        let field = format!("buses.can[{}].drives[{d}]", self.index);
        let cf = to_socketcan(req).ok_or_else(|| HalSetupError::Config { field: field.clone(), message: "bad SDO frame".into() })?;
        self.socket.write_frame(&cf).map_err(|e| HalSetupError::Config { field: field.clone(), message: format!("cannot send on {}: {e}", self.interface) })?;
        let about = |r: &co::SdoResponse| match *r {
            co::SdoResponse::WriteOk { node: n, index: i, sub: s } | co::SdoResponse::Value { node: n, index: i, sub: s, .. } | co::SdoResponse::Abort { node: n, index: i, sub: s, .. } => {
                (n, i, s) == (node, index, sub)
            }
        };
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            match self.socket.read_frame_timeout(deadline.saturating_duration_since(Instant::now()).max(Duration::from_millis(1))) {
                Ok(frame) => match from_socketcan(&frame).and_then(|f| co::decode_sdo_response(&f)).filter(about) {
                    Some(co::SdoResponse::Abort { code, .. }) => {
                        return Err(HalSetupError::Config {
                            field,
                            message: format!("drive `{name}` (node {node} on {}) refused SDO {what} {index:#06x}:{sub:02x} (abort code {code:#010x})", self.interface),
                        });
                    }
                    Some(r) => {
                        if let Some(v) = answer(r) {
                            return Ok(v);
                        }
                    }
                    None => {}
                },
                Err(e) if e.kind() == ErrorKind::WouldBlock || e.kind() == ErrorKind::TimedOut => {}
                Err(e) => return Err(HalSetupError::Config { field, message: format!("cannot read from {}: {e}", self.interface) }),
            }
        }
        Err(HalSetupError::Config {
            field,
            message: format!(
                "drive `{name}` (node {node} on {}) did not answer SDO {what} {index:#06x}:{sub:02x} within {:.0} ms: is it powered and its node id right?",
                self.interface,
                timeout.as_secs_f64() * 1e3
            ),
        })
    }

    /// Writes a limit and reads it back: a drive that holds another value (out of its range,
    /// rounded, write-protected) is a start-up error naming the object and both values.
    fn write_limit(&mut self, d: usize, index: u16, sub: u8, value: &[u8], what: &str, timeout: Duration) -> Result<(), HalSetupError> {
        self.sdo_write(d, index, sub, value, timeout)?;
        let held = self.sdo_read(d, index, sub, timeout)?;
        let mut bytes = [0u8; 4];
        bytes[..value.len().min(4)].copy_from_slice(&value[..value.len().min(4)]);
        let wanted = u32::from_le_bytes(bytes);
        let mask = if value.len() >= 4 { u32::MAX } else { (1u32 << (8 * value.len())) - 1 };
        if held & mask != wanted {
            return Err(HalSetupError::Config {
                field: format!("buses.can[{}].drives[{d}].{what}", self.index),
                message: format!(
                    "drive `{}` (node {} on {}) holds {index:#06x}:{sub:02x} = {} after {wanted} was written to it: check the drive's range for this object",
                    self.drives[d].name,
                    self.drives[d].node,
                    self.interface,
                    held & mask
                ),
            });
        }
        Ok(())
    }

    /// The drive's own limits of the config, each written and read back.
    fn write_limits(&mut self, d: usize, drive: &jointctl_config::DriveConfig, timeout: Duration) -> Result<(), HalSetupError> {
        let counts = |rad: f64| (rad * drive.counts_per_rad).round();
        if let Some([lo, hi]) = drive.setpoint_window_rad {
            self.write_limit(d, 0x607D, 1, &(counts(lo) as i32).to_le_bytes(), "setpoint_window_rad", timeout)?;
            self.write_limit(d, 0x607D, 2, &(counts(hi) as i32).to_le_bytes(), "setpoint_window_rad", timeout)?;
        }
        let l = drive.limits;
        let unsigned = [
            (l.max_profile_velocity_rad_s, 0x607F, "limits.max_profile_velocity_rad_s"),
            (l.following_error_window_rad, 0x6065, "limits.following_error_window_rad"),
            (l.quick_stop_deceleration_rad_s2, 0x6085, "limits.quick_stop_deceleration_rad_s2"),
        ];
        for (value, index, what) in unsigned {
            if let Some(v) = value {
                self.write_limit(d, index, 0, &(counts(v) as u32).to_le_bytes(), what, timeout)?;
            }
        }
        if let Some(p) = l.max_torque_permille {
            self.write_limit(d, 0x6072, 0, &p.to_le_bytes(), "limits.max_torque_permille", timeout)?;
        }
        if let Some(ms) = l.following_error_timeout_ms {
            self.write_limit(d, 0x6066, 0, &ms.to_le_bytes(), "limits.following_error_timeout_ms", timeout)?;
        }
        Ok(())
    }

    fn handle(&mut self, frame: &CanFrame, now_s: f64) {
        if let CanFrame::Error(e) = frame {
            self.health.error_frames += 1;
            // linux/can/error.h: class bits in the id, controller details in data[1].
            let class = e.raw_id();
            if class & 0x0000_0040 != 0 {
                self.health.bus_off = true;
            }
            if class & 0x0000_0004 != 0 && e.data().get(1).is_some_and(|b| b & 0x30 != 0) {
                self.health.error_passive = true;
            }
            return;
        }
        let Some(f) = from_socketcan(frame) else { return };
        if let Some(t) = co::decode_tpdo1(&f) {
            if let Some(d) = self.drives.iter_mut().find(|d| d.node == t.node) {
                d.fresh = Some((t.position_counts, now_s));
                d.statusword = Some(t.statusword);
                d.health.state = Some(co::state_of(t.statusword));
            }
        } else if let Some((node, state)) = co::decode_heartbeat(&f) {
            if let Some(d) = self.drives.iter_mut().find(|d| d.node == node) {
                d.last_heartbeat_s = Some(now_s);
                d.nmt_state = Some(state);
            }
        } else if let Some(e) = co::decode_emcy(&f)
            && let Some(d) = self.drives.iter_mut().find(|d| d.node == e.node)
        {
            d.health.emcy_count += 1;
            d.health.last_emcy_code = e.code;
        }
    }
}

impl HardwareHal {
    /// Opens the buses, configures every drive over SDO and starts them (NMT). Blocks for the
    /// SDO answers; fails with the drive, node and bus named.
    pub fn new(config: &ArmConfig) -> Result<Self, HalSetupError> {
        let co_cfg = &config.hal.canopen;
        let timeout = Duration::from_secs_f64(co_cfg.sdo_timeout_s.max(0.001));
        let mut buses = Vec::new();
        for (b, bus) in config.buses.can.iter().enumerate() {
            let field = format!("buses.can[{b}].interface");
            let socket = CanSocket::open(&bus.interface).map_err(|e| HalSetupError::Config {
                field: field.clone(),
                message: format!(
                    "cannot open CAN interface `{}`: {e}. Is it up? (ip link set {} up type can bitrate {})",
                    bus.interface, bus.interface, bus.bitrate
                ),
            })?;
            let _ = socket.set_error_filter_accept_all();
            let drives = bus
                .drives
                .iter()
                .map(|d| Drive {
                    name: d.name.clone(),
                    node: d.node_id,
                    counts_per_rad: d.counts_per_rad,
                    conditioner: Conditioner::new(Plausibility::drive_position(d.max_velocity_rad_s)),
                    fresh: None,
                    statusword: None,
                    last_heartbeat_s: None,
                    nmt_state: None,
                    heartbeat_timeout_s: co_cfg.heartbeat_timeout_s.unwrap_or(3.0 * d.heartbeat_ms as f64 / 1000.0),
                    heartbeat_grace_s: co_cfg
                        .heartbeat_grace_s
                        .or(co_cfg.heartbeat_timeout_s)
                        .unwrap_or(3.0 * d.heartbeat_ms as f64 / 1000.0),
                    target_counts: None,
                    toggle: false,
                    reset_requested: false,
                    health: DriveHealth::default(),
                })
                .collect();
            let mut can = CanBus { index: b, socket, interface: bus.interface.clone(), drives, sync_counter: 0, sync_overflow: co_cfg.sync_counter_overflow, health: BusHealth::default() };
            can.send(&co::nmt(co::NmtCommand::PreOperational, 0));
            for (i, d) in bus.drives.iter().enumerate() {
                can.sdo_write(i, 0x6060, 0, &[co_cfg.mode.code()], timeout)?;
                can.sdo_write(i, 0x1017, 0, &d.heartbeat_ms.to_le_bytes(), timeout)?;
                can.sdo_write(i, 0x1800, 2, &[1], timeout)?;
                let consumer = (u32::from(co_cfg.host_node_id) << 16) | u32::from(co_cfg.comm_loss_timeout_ms);
                can.sdo_write(i, 0x1016, 1, &consumer.to_le_bytes(), timeout)?;
                can.sdo_write(i, 0x6007, 0, &co_cfg.on_comm_loss.code().to_le_bytes(), timeout)?;
                can.write_limits(i, d, timeout)?;
            }
            can.send(&co::nmt(co::NmtCommand::Start, 0));
            can.socket.set_nonblocking(true).map_err(|e| HalSetupError::Config { field, message: format!("cannot make the socket non-blocking: {e}") })?;
            buses.push(can);
        }
        let mut encoders = Vec::new();
        for bus in &config.buses.spi {
            for e in &bus.encoders {
                let path = format!("{}.{}", bus.device, e.chip_select);
                let device = match spidev::Spidev::open(&path) {
                    Ok(mut dev) => {
                        let opts = spidev::SpidevOptions::new()
                            .bits_per_word(8)
                            .max_speed_hz(bus.speed_hz)
                            .mode(spidev::SpiModeFlags::SPI_MODE_1)
                            .build();
                        dev.configure(&opts).map_err(|err| HalSetupError::Config {
                            field: format!("encoder `{}`", e.name),
                            message: format!("cannot configure {path}: {err}"),
                        })?;
                        Some(dev)
                    }
                    Err(err) => {
                        return Err(HalSetupError::Config {
                            field: format!("encoder `{}`", e.name),
                            message: format!("cannot open {path}: {err} (is spidev enabled for chip select {}?)", e.chip_select),
                        });
                    }
                };
                encoders.push(Encoder {
                    name: e.name.clone(),
                    path,
                    device,
                    offset_rad: e.offset_rad,
                    reversed: e.reversed,
                    conditioner: Conditioner::new(Plausibility::absolute_encoder(e.max_velocity_rad_s)),
                });
            }
        }
        let mut hal = HardwareHal {
            t0: Instant::now(),
            mode: co_cfg.mode,
            host_node_id: co_cfg.host_node_id,
            host_heartbeat_s: f64::from(co_cfg.host_heartbeat_ms) / 1000.0,
            last_host_heartbeat_s: f64::NEG_INFINITY,
            buses,
            encoders,
            torque_sensors: netft::NetFtSensors::new(&config.buses.force_torque, 0.0)?,
        };
        // Pipelined SPI: the first command's answer arrives with the first read.
        for e in &mut hal.encoders {
            let _ = spi_word(e, as5048::READ_ANGLE);
        }
        Ok(hal)
    }

    /// Health of each CAN bus, in YAML order.
    pub fn bus_health(&self) -> impl Iterator<Item = (&str, BusHealth)> {
        self.buses.iter().map(|b| (b.interface.as_str(), b.health))
    }

    /// Health of each drive, in device order.
    pub fn drive_health(&self) -> impl Iterator<Item = (&str, DriveHealth)> {
        self.buses.iter().flat_map(|b| b.drives.iter().map(|d| (d.name.as_str(), d.health)))
    }

    /// Loss counters of each encoder, in device order.
    pub fn encoder_health(&self) -> impl Iterator<Item = (&str, &str, jointctl_hal::condition::LossCounters)> {
        self.encoders.iter().map(|e| (e.name.as_str(), e.path.as_str(), e.conditioner.counters()))
    }
}

fn spi_word(e: &mut Encoder, command: u16) -> Option<u16> {
    let dev = e.device.as_ref()?;
    let tx = command.to_be_bytes();
    let mut rx = [0u8; 2];
    let mut t = spidev::SpidevTransfer::read_write(&tx, &mut rx);
    dev.transfer(&mut t).ok()?;
    Some(u16::from_be_bytes(rx))
}

impl Hal for HardwareHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        let now = self.t0.elapsed().as_secs_f64();
        let mut result = Ok(());
        let mut base = 0;
        for (b, bus) in self.buses.iter_mut().enumerate() {
            for d in &mut bus.drives {
                d.fresh = None;
            }
            loop {
                match bus.socket.read_frame() {
                    Ok(f) => bus.handle(&f, now),
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                    Err(_) => {
                        result = Err(HalIoError::BusFailed { bus: b as u16 });
                        break;
                    }
                }
            }
            for (i, d) in bus.drives.iter_mut().enumerate() {
                d.health.silent = d.is_silent(now);
                let sample = match d.fresh {
                    // A silent node's stale frames are not trusted either.
                    _ if d.health.silent => Sample::Invalid,
                    Some((counts, rx)) => Sample::Value { value: counts as f64 / d.counts_per_rad, age_s: now - rx },
                    None => Sample::Missing,
                };
                let conditioned = d.conditioner.update(sample, now);
                // A silent node (no heartbeat) gives no usable position at all, however recent.
                let position = if d.health.silent { Reading::invalid() } else { conditioned };
                d.health.losses = d.conditioner.counters();
                let state = d.health.state;
                frame.drives[base + i] = DriveReading::new(
                    position,
                    Reading::MISSING,
                    state == Some(DriveState::OperationEnabled) && !d.health.silent,
                    state == Some(DriveState::Fault),
                );
            }
            base += bus.drives.len();
        }
        for (i, e) in self.encoders.iter_mut().enumerate() {
            let sample = match spi_word(e, as5048::READ_ANGLE).map(as5048::decode) {
                Some(Ok(counts)) => Sample::Value { value: as5048::joint_angle_rad(counts, e.offset_rad, e.reversed), age_s: 0.0 },
                Some(Err(_)) => Sample::Invalid,
                None => Sample::Missing,
            };
            frame.encoders[i] = e.conditioner.update(sample, now);
        }
        self.torque_sensors.read(&mut frame.torque_sensors, now);
        result
    }

    fn write(&mut self, frame: &ActuatorFrame, _dt_s: f64) -> Result<(), HalIoError> {
        let mut base = 0;
        let profile = self.mode == DriveMode::ProfilePosition;
        let now = self.t0.elapsed().as_secs_f64();
        // The host's heartbeat, which every drive consumes (0x1016): it stops when the loop does.
        if now - self.last_host_heartbeat_s >= self.host_heartbeat_s {
            self.last_host_heartbeat_s = now;
            for bus in &mut self.buses {
                bus.send(&co::heartbeat(self.host_node_id, co::nmt_state::OPERATIONAL));
            }
        }
        for bus in &mut self.buses {
            for i in 0..bus.drives.len() {
                let sp = frame.drives[base + i];
                let d = &mut bus.drives[i];
                // The first target is where the drive is: never enable towards an unknown target.
                if d.target_counts.is_none()
                    && let Some(q) = d.conditioner_last_good()
                {
                    d.target_counts = Some((q * d.counts_per_rad).round() as i32);
                }
                if sp.action == DriveAction::MOVE && sp.position_rad.is_finite() && d.target_counts.is_some() {
                    d.target_counts = Some((sp.position_rad * d.counts_per_rad).round() as i32);
                }
                let state = d.health.state.unwrap_or(DriveState::NotReadyToSwitchOn);
                let controlword = match (d.target_counts, state) {
                    (None, _) => co::controlword::DISABLE_VOLTAGE,
                    (Some(_), DriveState::Fault) if d.reset_requested => {
                        d.reset_requested = false;
                        co::controlword::FAULT_RESET
                    }
                    (Some(_), DriveState::Fault) => co::controlword::DISABLE_VOLTAGE,
                    (Some(_), DriveState::OperationEnabled) => {
                        d.toggle = !d.toggle;
                        let handshake = if profile && d.toggle { co::controlword::NEW_SETPOINT | co::controlword::CHANGE_IMMEDIATELY } else { 0 };
                        co::controlword::ENABLE_OPERATION | handshake
                    }
                    (Some(_), s) => co::next_controlword(s).unwrap_or(co::controlword::ENABLE_OPERATION),
                };
                let node = d.node;
                let target = d.target_counts.unwrap_or(0);
                bus.send(&co::rpdo1(node, controlword, target));
            }
            let counter = (bus.sync_overflow > 1).then(|| {
                bus.sync_counter = if bus.sync_counter >= bus.sync_overflow { 1 } else { bus.sync_counter + 1 };
                bus.sync_counter
            });
            bus.send(&co::sync(counter));
            base += bus.drives.len();
        }
        Ok(())
    }

    fn device_health(&self, out: &mut [jointctl_hal::DeviceHealth]) {
        let mut i = 0;
        for bus in &self.buses {
            let bus_flags = if bus.health.bus_off { jointctl_hal::DeviceHealth::BUS_OFF } else { 0 }
                | if bus.health.error_passive { jointctl_hal::DeviceHealth::ERROR_PASSIVE } else { 0 };
            for d in &bus.drives {
                if let Some(h) = out.get_mut(i) {
                    let l = d.health.losses;
                    *h = jointctl_hal::DeviceHealth {
                        missing: l.missing,
                        invalid: l.invalid,
                        implausible: l.implausible,
                        emcy: d.health.emcy_count,
                        flags: bus_flags
                            | if d.health.silent { jointctl_hal::DeviceHealth::SILENT } else { 0 }
                            | if d.health.state == Some(DriveState::Fault) { jointctl_hal::DeviceHealth::FAULT } else { 0 },
                    };
                }
                i += 1;
            }
        }
        let encoders = self.encoders.iter().map(|e| e.conditioner.counters());
        for l in encoders.chain(self.torque_sensors.counters()) {
            if let Some(h) = out.get_mut(i) {
                *h = jointctl_hal::DeviceHealth { missing: l.missing, invalid: l.invalid, implausible: l.implausible, emcy: 0, flags: 0 };
            }
            i += 1;
        }
    }

    fn stop(&mut self, sequence: &[StopStep], step_timeout_s: f64) -> Vec<StopStepReport> {
        let mut reports = Vec::with_capacity(sequence.len());
        for &step in sequence {
            let deadline = Instant::now() + Duration::from_secs_f64(step_timeout_s.max(0.0));
            if step == StopStep::PreOperational {
                for bus in &mut self.buses {
                    bus.send(&co::nmt(co::NmtCommand::PreOperational, 0));
                }
            }
            let pending = loop {
                self.stop_exchange(step);
                std::thread::sleep(Duration::from_millis(5));
                let now = self.t0.elapsed().as_secs_f64();
                for bus in &mut self.buses {
                    while let Ok(f) = bus.socket.read_frame() {
                        bus.handle(&f, now);
                    }
                }
                let pending: Vec<String> = self.buses.iter().flat_map(|b| &b.drives).filter(|d| !d.reached(step)).map(|d| d.name.clone()).collect();
                if pending.is_empty() || Instant::now() >= deadline {
                    break pending;
                }
            };
            reports.push(StopStepReport { step, pending });
        }
        reports
    }

    fn reset_faults(&mut self) {
        for bus in &mut self.buses {
            for d in &mut bus.drives {
                d.reset_requested = true;
            }
        }
    }
}

impl HardwareHal {
    /// One exchange of a stop step: its controlword to every drive (a drive step), a SYNC so
    /// that the drives answer with their statusword, and the host's heartbeat, so that no drive
    /// takes the sequence's pauses for a dead host.
    fn stop_exchange(&mut self, step: StopStep) {
        let controlword = match step {
            StopStep::QuickStop => Some(co::controlword::QUICK_STOP),
            StopStep::DisableOperation => Some(co::controlword::SWITCH_ON),
            StopStep::DisableVoltage => Some(co::controlword::DISABLE_VOLTAGE),
            StopStep::PreOperational => None,
        };
        for bus in &mut self.buses {
            if let Some(cw) = controlword {
                for i in 0..bus.drives.len() {
                    let (node, target) = (bus.drives[i].node, bus.drives[i].target_counts.unwrap_or(0));
                    bus.send(&co::rpdo1(node, cw, target));
                }
                let counter = (bus.sync_overflow > 1).then(|| {
                    bus.sync_counter = if bus.sync_counter >= bus.sync_overflow { 1 } else { bus.sync_counter + 1 };
                    bus.sync_counter
                });
                bus.send(&co::sync(counter));
            }
            bus.send(&co::heartbeat(self.host_node_id, co::nmt_state::OPERATIONAL));
        }
    }
}

impl Drive {
    /// Whether the drive reports the state a stop step leads to.
    fn reached(&self, step: StopStep) -> bool {
        let state = self.health.state;
        match step {
            // A quick stop ends in "quick stop active", or in "switch on disabled" where the
            // drive's quick-stop option code (0x605A) says so.
            StopStep::QuickStop => matches!(state, Some(DriveState::QuickStopActive | DriveState::SwitchOnDisabled)),
            StopStep::DisableOperation => matches!(state, Some(DriveState::SwitchedOn | DriveState::ReadyToSwitchOn | DriveState::SwitchOnDisabled)),
            StopStep::DisableVoltage => state == Some(DriveState::SwitchOnDisabled),
            StopStep::PreOperational => self.nmt_state == Some(co::nmt_state::PRE_OPERATIONAL),
        }
    }

    /// No heartbeat within its timeout of the last one, or, when none has come yet, within the
    /// grace time of the HAL's start (`now_s` counts from it).
    fn is_silent(&self, now_s: f64) -> bool {
        match self.last_heartbeat_s {
            Some(t) => now_s - t > self.heartbeat_timeout_s,
            None => now_s > self.heartbeat_grace_s,
        }
    }

    fn conditioner_last_good(&self) -> Option<f64> {
        self.conditioner.last_good()
    }
}
