//! [`HardwareHal`], the real hardware: start-up of every bus and device, the non-blocking read
//! and write of each cycle, device health, and the blocking stop sequence.

use std::io::ErrorKind;
use std::time::{Duration, Instant};

use jointctl_api::{DriveAction, DriveReading, Reading};
use jointctl_config::{ArmConfig, DriveMode, StopStep};
use socketcan::{CanSocket, Socket, SocketOptions};

use jointctl_hal::codec::as5048;
use jointctl_hal::codec::canopen::{self as co, DriveState};
use jointctl_hal::condition::{Conditioner, Plausibility, Sample};
use jointctl_hal::{ActuatorFrame, Hal, HalIoError, HalSetupError, SensorFrame, StopStepReport};

use crate::can::{BusHealth, CanBus, Drive, DriveHealth};
use crate::encoder::{Encoder, spi_word};
use crate::netft;

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
                    rated_torque_nm: d.rated_torque_nm,
                    torque_in_frame: None,
                    torque: None,
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
            let mut can = CanBus { index: b, socket, interface: bus.interface.clone(), drives, sync_counter: 0, sync_overflow: co_cfg.sync_counter_overflow, last_sync_s: None, health: BusHealth::default() };
            can.send(&co::nmt(co::NmtCommand::PreOperational, 0));
            for (i, d) in bus.drives.iter().enumerate() {
                can.sdo_write(i, 0x6060, 0, &[co_cfg.mode.code()], timeout)?;
                can.sdo_write(i, 0x1017, 0, &d.heartbeat_ms.to_le_bytes(), timeout)?;
                can.sdo_write(i, 0x1800, 2, &[1], timeout)?;
                let consumer = (u32::from(co_cfg.host_node_id) << 16) | u32::from(co_cfg.comm_loss_timeout_ms);
                can.sdo_write(i, 0x1016, 1, &consumer.to_le_bytes(), timeout)?;
                can.sdo_write(i, 0x6007, 0, &co_cfg.on_comm_loss.code().to_le_bytes(), timeout)?;
                can.write_limits(i, d, timeout)?;
                if d.rated_torque_nm.is_some() {
                    can.map_torque(i, timeout)?;
                }
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

impl Hal for HardwareHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        let now = self.t0.elapsed().as_secs_f64();
        let mut result = Ok(());
        let mut base = 0;
        for (b, bus) in self.buses.iter_mut().enumerate() {
            for d in &mut bus.drives {
                d.fresh = None;
                d.torque_in_frame = None;
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
                )
                .with_torque(d.torque_reading(&position, now));
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
            bus.sync(self.t0.elapsed().as_secs_f64());
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
                bus.sync(self.t0.elapsed().as_secs_f64());
            }
            bus.send(&co::heartbeat(self.host_node_id, co::nmt_state::OPERATIONAL));
        }
    }
}
