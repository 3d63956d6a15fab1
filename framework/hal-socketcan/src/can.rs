//! One CAN bus and the CANopen drives on it: their health, the conversion between CANopen and
//! SocketCAN frames, the blocking SDO exchanges of start-up (writes, limits read back), the
//! frames the loop drains (TPDO1, heartbeats, EMCY, error frames), and what a drive's state says.

use std::io::ErrorKind;
use std::time::{Duration, Instant};

use jointctl_api::{Reading, ReadingStatus};
use jointctl_config::StopStep;
use socketcan::{CanFrame, CanSocket, EmbeddedFrame, Frame as _, Socket, StandardId};

use jointctl_hal::codec::canopen::{self as co, DriveState, Frame};
use jointctl_hal::condition::Conditioner;
use jointctl_hal::HalSetupError;

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

pub(crate) struct Drive {
    pub(crate) name: String,
    pub(crate) node: u8,
    pub(crate) counts_per_rad: f64,
    /// The unit of the torque actual value [Nm per 1000], when the drive's torque is read.
    pub(crate) rated_torque_nm: Option<f64>,
    /// This cycle's newest TPDO1's torque actual value [Nm], not yet trusted: it is taken when
    /// the same frame's position is (a zeroed frame's torque is as wrong as its position).
    pub(crate) torque_in_frame: Option<f64>,
    /// The last trusted torque actual value [Nm] and when its frame came [s].
    pub(crate) torque: Option<(f64, f64)>,
    pub(crate) conditioner: Conditioner,
    pub(crate) fresh: Option<(i32, f64)>,
    pub(crate) statusword: Option<u16>,
    pub(crate) last_heartbeat_s: Option<f64>,
    /// The NMT state in the drive's last heartbeat.
    pub(crate) nmt_state: Option<u8>,
    pub(crate) heartbeat_timeout_s: f64,
    /// Silent when no heartbeat has come this long after the HAL started [s].
    pub(crate) heartbeat_grace_s: f64,
    pub(crate) target_counts: Option<i32>,
    pub(crate) toggle: bool,
    pub(crate) reset_requested: bool,
    pub(crate) health: DriveHealth,
}

impl Drive {
    /// The drive's torque reading this cycle, given its conditioned position: valid from this
    /// cycle's TPDO1 when that frame's position was accepted, stale from the last accepted
    /// frame (its age says how old), invalid with an invalid position (a silent node), missing
    /// when the drive's torque is not read or none was accepted yet.
    pub(crate) fn torque_reading(&mut self, position: &Reading, now_s: f64) -> Reading {
        if self.rated_torque_nm.is_none() {
            return Reading::MISSING;
        }
        if position.status == ReadingStatus::INVALID {
            return Reading::invalid();
        }
        match (self.fresh, self.torque_in_frame.take()) {
            (Some((_, rx)), Some(nm)) if position.status == ReadingStatus::VALID => {
                self.torque = Some((nm, rx));
                Reading::valid_aged(nm, now_s - rx)
            }
            _ => self.torque.map_or(Reading::MISSING, |(nm, rx)| Reading::stale(nm, now_s - rx)),
        }
    }
}

pub(crate) struct CanBus {
    pub(crate) index: usize,
    pub(crate) socket: CanSocket,
    pub(crate) interface: String,
    pub(crate) drives: Vec<Drive>,
    pub(crate) sync_counter: u8,
    pub(crate) sync_overflow: u8,
    /// When the last SYNC went out [s since the HAL started]: a SYNC-triggered TPDO1
    /// (transmission type 1) carries what its drive sampled then, so a frame that came after it
    /// is dated there, not when the cycle drained it (section 2.3: a CAN reading is older than an
    /// SPI one read in the same cycle, and the observer aligns the two by their ages).
    pub(crate) last_sync_s: Option<f64>,
    pub(crate) health: BusHealth,
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
    pub(crate) fn send(&mut self, f: &Frame) {
        let ok = to_socketcan(f).is_some_and(|cf| self.socket.write_frame(&cf).is_ok());
        if !ok {
            self.health.tx_failures += 1;
        }
    }

    /// Sends a SYNC at `now_s` [s since the HAL started], with the next counter value when the
    /// bus counts them (`sync_counter_overflow` above 1), and notes when it went out.
    pub(crate) fn sync(&mut self, now_s: f64) {
        let counter = (self.sync_overflow > 1).then(|| {
            self.sync_counter = if self.sync_counter >= self.sync_overflow { 1 } else { self.sync_counter + 1 };
            self.sync_counter
        });
        self.last_sync_s = Some(now_s);
        self.send(&co::sync(counter));
    }

    /// Blocking SDO write with a timeout (start-up only).
    pub(crate) fn sdo_write(&mut self, d: usize, index: u16, sub: u8, value: &[u8], timeout: Duration) -> Result<(), HalSetupError> {
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

    /// Maps the torque actual value (0x6077) into TPDO1 behind the statusword and the position
    /// (CiA 301's procedure: the PDO off, its map emptied, three entries, their count, the PDO
    /// on), each entry read back. Its unit, the motor's rated torque (0x6076) at the gearbox
    /// output, is the bus entry's `rated_torque_nm` (the gear ratio is not in the config, so it
    /// cannot be checked against 0x6076 here).
    pub(crate) fn map_torque(&mut self, d: usize, timeout: Duration) -> Result<(), HalSetupError> {
        // The PDO's COB-ID entry as the drive has it (some hard-wire other bits, such as RTR):
        // only its valid bit (31) is turned off and on again.
        let cob_id = self.sdo_read(d, 0x1800, 1, timeout)? & !0x8000_0000;
        let what = "rated_torque_nm";
        self.write_limit(d, 0x1800, 1, &(cob_id | 0x8000_0000).to_le_bytes(), what, timeout)?;
        self.write_limit(d, 0x1A00, 0, &[0], what, timeout)?;
        for (sub, entry) in [(1u8, 0x6041_0010u32), (2, 0x6064_0020), (3, 0x6077_0010)] {
            self.write_limit(d, 0x1A00, sub, &entry.to_le_bytes(), what, timeout)?;
        }
        self.write_limit(d, 0x1A00, 0, &[3], what, timeout)?;
        self.write_limit(d, 0x1800, 1, &cob_id.to_le_bytes(), what, timeout)?;
        Ok(())
    }

    /// The drive's own limits of the config, each written and read back.
    pub(crate) fn write_limits(&mut self, d: usize, drive: &jointctl_config::DriveConfig, timeout: Duration) -> Result<(), HalSetupError> {
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

    pub(crate) fn handle(&mut self, frame: &CanFrame, now_s: f64) {
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
            // Sampled at the last SYNC (a frame before any SYNC: when it was drained). One that
            // came only after the next SYNC went out is dated a cycle late; that needs a bus
            // loaded past its cycle, which the losses' counters show.
            let sampled_s = self.last_sync_s.filter(|s| *s <= now_s).unwrap_or(now_s);
            if let Some(d) = self.drives.iter_mut().find(|d| d.node == t.node) {
                d.fresh = Some((t.position_counts, sampled_s));
                d.torque_in_frame = t.torque_nm(d.rated_torque_nm);
                // An operating drive never reports statusword 0: such a frame is appendix A's
                // zeroed frame, and its state is not the drive's: taken as "not ready to switch
                // on", the next cycle would send an enabled drive SHUTDOWN. (Before a drive
                // operates, an unknown state is handled as that one.)
                if t.statusword != 0 {
                    d.statusword = Some(t.statusword);
                    d.health.state = Some(co::state_of(t.statusword));
                }
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

impl Drive {
    /// Whether the drive reports the state a stop step leads to.
    pub(crate) fn reached(&self, step: StopStep) -> bool {
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
    pub(crate) fn is_silent(&self, now_s: f64) -> bool {
        match self.last_heartbeat_s {
            Some(t) => now_s - t > self.heartbeat_timeout_s,
            None => now_s > self.heartbeat_grace_s,
        }
    }

    pub(crate) fn conditioner_last_good(&self) -> Option<f64> {
        self.conditioner.last_good()
    }
}
