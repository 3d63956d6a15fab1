//! CANopen (CiA 301) framing and the CiA 402 drive profile, as far as the ELMO drives need it:
//! NMT, SYNC, PDOs, expedited SDO, heartbeat, EMCY; controlword/statusword state machine.

/// Function codes (COB-ID = function code + node id).
pub mod cob {
    /// NMT (broadcast, id 0).
    pub const NMT: u16 = 0x000;
    /// SYNC (id 0x80).
    pub const SYNC: u16 = 0x080;
    /// EMCY base.
    pub const EMCY: u16 = 0x080;
    /// TPDO1 base (drive → host).
    pub const TPDO1: u16 = 0x180;
    /// RPDO1 base (host → drive).
    pub const RPDO1: u16 = 0x200;
    /// SDO response base (drive → host).
    pub const SDO_TX: u16 = 0x580;
    /// SDO request base (host → drive).
    pub const SDO_RX: u16 = 0x600;
    /// Heartbeat base.
    pub const HEARTBEAT: u16 = 0x700;
}

/// A classic CAN frame: 11-bit id and up to 8 data bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Frame {
    /// 11-bit identifier.
    pub id: u16,
    /// Data length (0..=8).
    pub len: u8,
    /// Data.
    pub data: [u8; 8],
}

impl Frame {
    /// A frame from an id and data (truncated to 8 bytes).
    pub fn new(id: u16, data: &[u8]) -> Self {
        let mut d = [0u8; 8];
        let n = data.len().min(8);
        d[..n].copy_from_slice(&data[..n]);
        Frame { id: id & 0x7FF, len: n as u8, data: d }
    }

    /// The used data bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.data[..(self.len as usize).min(8)]
    }
}

/// NMT commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtCommand {
    /// Start (→ operational).
    Start = 0x01,
    /// Stop.
    Stop = 0x02,
    /// Enter pre-operational.
    PreOperational = 0x80,
    /// Reset node.
    ResetNode = 0x81,
    /// Reset communication.
    ResetCommunication = 0x82,
}

/// An NMT frame for one node (0 = all nodes).
///
/// ```
/// use jointctl_hal::codec::canopen::*;
/// assert_eq!(nmt(NmtCommand::Start, 0).bytes(), &[0x01, 0x00]);
/// ```
pub fn nmt(command: NmtCommand, node: u8) -> Frame {
    Frame::new(cob::NMT, &[command as u8, node])
}

/// A SYNC frame with the CiA 301 counter (0x1019 > 0: 1..=overflow).
pub fn sync(counter: Option<u8>) -> Frame {
    match counter {
        Some(c) => Frame::new(cob::SYNC, &[c]),
        None => Frame::new(cob::SYNC, &[]),
    }
}

/// CiA 402 controlwords (0x6040).
pub mod controlword {
    /// Shutdown: → ready to switch on.
    pub const SHUTDOWN: u16 = 0x0006;
    /// Switch on: → switched on.
    pub const SWITCH_ON: u16 = 0x0007;
    /// Enable operation: → operation enabled.
    pub const ENABLE_OPERATION: u16 = 0x000F;
    /// Disable voltage: → switch on disabled.
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    /// Quick stop (enable voltage set, quick stop bit clear): → quick stop active.
    pub const QUICK_STOP: u16 = 0x0002;
    /// Fault reset (on the rising edge of bit 7).
    pub const FAULT_RESET: u16 = 0x0080;
    /// Profile position: new set-point (bit 4).
    pub const NEW_SETPOINT: u16 = 0x0010;
    /// Profile position: change set immediately (bit 5).
    pub const CHANGE_IMMEDIATELY: u16 = 0x0020;
}

/// CiA 402 drive states, decoded from the statusword (0x6041).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveState {
    /// Not ready to switch on.
    NotReadyToSwitchOn,
    /// Switch on disabled.
    SwitchOnDisabled,
    /// Ready to switch on.
    ReadyToSwitchOn,
    /// Switched on.
    SwitchedOn,
    /// Operation enabled: following set-points.
    OperationEnabled,
    /// Quick stop active.
    QuickStopActive,
    /// Fault reaction active.
    FaultReactionActive,
    /// Fault.
    Fault,
    /// A statusword matching no state.
    Unknown,
}

/// Decodes the drive state from a statusword.
///
/// ```
/// use jointctl_hal::codec::canopen::{state_of, DriveState};
/// assert_eq!(state_of(0x0237), DriveState::OperationEnabled);
/// assert_eq!(state_of(0x0008), DriveState::Fault);
/// assert_eq!(state_of(0x0250), DriveState::SwitchOnDisabled);
/// ```
pub fn state_of(statusword: u16) -> DriveState {
    let s = statusword;
    if s & 0x4F == 0x00 {
        DriveState::NotReadyToSwitchOn
    } else if s & 0x4F == 0x40 {
        DriveState::SwitchOnDisabled
    } else if s & 0x6F == 0x21 {
        DriveState::ReadyToSwitchOn
    } else if s & 0x6F == 0x23 {
        DriveState::SwitchedOn
    } else if s & 0x6F == 0x27 {
        DriveState::OperationEnabled
    } else if s & 0x6F == 0x07 {
        DriveState::QuickStopActive
    } else if s & 0x4F == 0x0F {
        DriveState::FaultReactionActive
    } else if s & 0x4F == 0x08 {
        DriveState::Fault
    } else {
        DriveState::Unknown
    }
}

/// The controlword that moves a drive one step towards "operation enabled" (CiA 402 state
/// machine), or `None` when it is there. A fault needs [`controlword::FAULT_RESET`] first.
pub fn next_controlword(state: DriveState) -> Option<u16> {
    match state {
        DriveState::OperationEnabled => None,
        DriveState::Fault => Some(controlword::FAULT_RESET),
        DriveState::SwitchOnDisabled | DriveState::NotReadyToSwitchOn | DriveState::QuickStopActive => Some(controlword::SHUTDOWN),
        DriveState::ReadyToSwitchOn => Some(controlword::SWITCH_ON),
        DriveState::SwitchedOn => Some(controlword::ENABLE_OPERATION),
        DriveState::FaultReactionActive | DriveState::Unknown => Some(controlword::DISABLE_VOLTAGE),
    }
}

/// RPDO1 as mapped here: controlword (u16) + target position (i32 counts), little endian.
pub fn rpdo1(node: u8, controlword: u16, target_counts: i32) -> Frame {
    let mut d = [0u8; 6];
    d[..2].copy_from_slice(&controlword.to_le_bytes());
    d[2..6].copy_from_slice(&target_counts.to_le_bytes());
    Frame::new(cob::RPDO1 + node as u16, &d)
}

/// Decoded RPDO1 (for the simulated drive and tests).
pub fn decode_rpdo1(frame: &Frame) -> Option<(u8, u16, i32)> {
    let node = node_of(frame.id, cob::RPDO1)?;
    let b = frame.bytes();
    (b.len() == 6).then(|| (node, u16::from_le_bytes([b[0], b[1]]), i32::from_le_bytes([b[2], b[3], b[4], b[5]])))
}

/// TPDO1 as mapped here: statusword (u16) + actual position (i32 counts).
pub fn tpdo1(node: u8, statusword: u16, position_counts: i32) -> Frame {
    let mut d = [0u8; 6];
    d[..2].copy_from_slice(&statusword.to_le_bytes());
    d[2..6].copy_from_slice(&position_counts.to_le_bytes());
    Frame::new(cob::TPDO1 + node as u16, &d)
}

/// TPDO1 with the torque actual value mapped behind the position (the frame's last two bytes):
/// statusword (u16) + actual position (i32 counts) + torque actual value (0x6077, i16 per mille
/// of the motor's rated torque, 0x6076).
///
/// ```
/// use jointctl_hal::codec::canopen::*;
/// let f = tpdo1_with_torque(5, 0x0237, -1234, -250);
/// assert_eq!(decode_tpdo1(&f).and_then(|t| t.torque_permille), Some(-250));
/// assert_eq!(decode_tpdo1(&tpdo1(5, 0x0237, -1234)).unwrap().torque_permille, None);
/// ```
pub fn tpdo1_with_torque(node: u8, statusword: u16, position_counts: i32, torque_permille: i16) -> Frame {
    let mut d = [0u8; 8];
    d[..2].copy_from_slice(&statusword.to_le_bytes());
    d[2..6].copy_from_slice(&position_counts.to_le_bytes());
    d[6..].copy_from_slice(&torque_permille.to_le_bytes());
    Frame::new(cob::TPDO1 + node as u16, &d)
}

/// A decoded TPDO1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tpdo1 {
    /// Node id.
    pub node: u8,
    /// Statusword (0x6041).
    pub statusword: u16,
    /// Position actual value (0x6064) [counts].
    pub position_counts: i32,
    /// Torque actual value (0x6077) [per mille of the rated torque], when the drive maps it.
    pub torque_permille: Option<i16>,
}

impl Tpdo1 {
    /// The torque actual value [Nm] given its unit `rated_torque_nm` (0x6076 at the gearbox
    /// output); `None` when the frame has none, no unit is given, or the frame is appendix A's
    /// zeroed frame: an operating drive never reports statusword 0, and such a frame's torque
    /// is not one, even where its zero position passes as plausible (a drive resting at zero).
    ///
    /// ```
    /// use jointctl_hal::codec::canopen::*;
    /// let t = decode_tpdo1(&tpdo1_with_torque(5, 0x0237, 100, -250)).unwrap();
    /// assert_eq!(t.torque_nm(Some(40.0)), Some(-10.0));
    /// assert_eq!(t.torque_nm(None), None);
    /// let zeroed = decode_tpdo1(&tpdo1_with_torque(5, 0, 0, 0)).unwrap();
    /// assert_eq!(zeroed.torque_nm(Some(40.0)), None);
    /// ```
    pub fn torque_nm(&self, rated_torque_nm: Option<f64>) -> Option<f64> {
        let per_mille = self.torque_permille.filter(|_| self.statusword != 0)?;
        rated_torque_nm.map(|rated| f64::from(per_mille) / 1000.0 * rated)
    }
}

fn node_of(id: u16, base: u16) -> Option<u8> {
    let n = id.checked_sub(base)?;
    (1..=127).contains(&n).then_some(n as u8)
}

/// Decodes a TPDO1 (6 bytes, or 8 with the torque); `None` for any other frame or length.
///
/// ```
/// use jointctl_hal::codec::canopen::*;
/// let f = tpdo1(5, 0x0237, -1234);
/// assert_eq!(decode_tpdo1(&f), Some(Tpdo1 { node: 5, statusword: 0x0237, position_counts: -1234, torque_permille: None }));
/// assert_eq!(decode_tpdo1(&Frame::new(0x185, &[1, 2])), None);
/// assert_eq!(decode_tpdo1(&Frame::new(0x185, &[1, 2, 3, 4, 5, 6, 7])), None);
/// ```
pub fn decode_tpdo1(frame: &Frame) -> Option<Tpdo1> {
    let node = node_of(frame.id, cob::TPDO1)?;
    let b = frame.bytes();
    (b.len() == 6 || b.len() == 8).then(|| Tpdo1 {
        node,
        statusword: u16::from_le_bytes([b[0], b[1]]),
        position_counts: i32::from_le_bytes([b[2], b[3], b[4], b[5]]),
        torque_permille: (b.len() == 8).then(|| i16::from_le_bytes([b[6], b[7]])),
    })
}

/// Heartbeat NMT states.
pub mod nmt_state {
    /// Boot-up message.
    pub const BOOT_UP: u8 = 0x00;
    /// Stopped.
    pub const STOPPED: u8 = 0x04;
    /// Operational.
    pub const OPERATIONAL: u8 = 0x05;
    /// Pre-operational.
    pub const PRE_OPERATIONAL: u8 = 0x7F;
}

/// A heartbeat frame (producer side, for the simulated drive).
pub fn heartbeat(node: u8, state: u8) -> Frame {
    Frame::new(cob::HEARTBEAT + node as u16, &[state])
}

/// Decodes a heartbeat: (node, NMT state).
pub fn decode_heartbeat(frame: &Frame) -> Option<(u8, u8)> {
    let node = node_of(frame.id, cob::HEARTBEAT)?;
    (frame.len == 1).then_some((node, frame.data[0]))
}

/// A decoded emergency message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emcy {
    /// Node id.
    pub node: u8,
    /// Emergency error code (CiA 301 table; 0 = error reset).
    pub code: u16,
    /// Error register (0x1001).
    pub register: u8,
    /// Manufacturer-specific bytes.
    pub vendor: [u8; 5],
}

impl Emcy {
    /// A short description of the error code's class (CiA 301 table 21).
    pub fn class(&self) -> &'static str {
        match self.code >> 8 {
            0x00 => "error reset or no error",
            0x10 => "generic error",
            0x20..=0x23 => "current",
            0x30..=0x33 => "voltage",
            0x40..=0x42 => "temperature",
            0x50 => "device hardware",
            0x60..=0x63 => "device software",
            0x70 => "additional modules",
            0x80..=0x82 => "monitoring / communication",
            0x83..=0x8F => "monitoring / protocol",
            0x90 => "external error",
            0xF0 => "additional functions",
            0xFF => "device specific",
            _ => "unknown",
        }
    }
}

/// An EMCY frame (producer side).
pub fn emcy(node: u8, code: u16, register: u8) -> Frame {
    let c = code.to_le_bytes();
    Frame::new(cob::EMCY + node as u16, &[c[0], c[1], register, 0, 0, 0, 0, 0])
}

/// Decodes an EMCY frame (id 0x81..0xFF, 8 bytes). Id 0x80 is SYNC, not EMCY.
///
/// ```
/// use jointctl_hal::codec::canopen::*;
/// let e = decode_emcy(&emcy(3, 0x2310, 0x03)).unwrap();
/// assert_eq!((e.node, e.code, e.register, e.class()), (3, 0x2310, 3, "current"));
/// assert!(decode_emcy(&sync(Some(1))).is_none());
/// ```
pub fn decode_emcy(frame: &Frame) -> Option<Emcy> {
    let node = node_of(frame.id, cob::EMCY)?;
    let b = frame.bytes();
    (b.len() == 8).then(|| Emcy {
        node,
        code: u16::from_le_bytes([b[0], b[1]]),
        register: b[2],
        vendor: [b[3], b[4], b[5], b[6], b[7]],
    })
}

/// An expedited SDO download (write) request of 1, 2 or 4 bytes.
///
/// ```
/// use jointctl_hal::codec::canopen::*;
/// // Mode of operation (0x6060) = 1, profile position.
/// assert_eq!(sdo_write(2, 0x6060, 0, &[1]).bytes(), &[0x2F, 0x60, 0x60, 0x00, 1, 0, 0, 0]);
/// ```
pub fn sdo_write(node: u8, index: u16, sub: u8, value: &[u8]) -> Frame {
    let n = value.len().clamp(1, 4);
    let cmd = 0x23 | (((4 - n) as u8) << 2);
    let i = index.to_le_bytes();
    let mut d = [cmd, i[0], i[1], sub, 0, 0, 0, 0];
    d[4..4 + n].copy_from_slice(&value[..n]);
    Frame::new(cob::SDO_RX + node as u16, &d)
}

/// An SDO upload (read) request.
pub fn sdo_read(node: u8, index: u16, sub: u8) -> Frame {
    let i = index.to_le_bytes();
    Frame::new(cob::SDO_RX + node as u16, &[0x40, i[0], i[1], sub, 0, 0, 0, 0])
}

/// A decoded SDO answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoResponse {
    /// Download (write) confirmed.
    WriteOk {
        /// Node.
        node: u8,
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// Expedited upload (read) data: up to 4 bytes, little endian in `value`.
    Value {
        /// Node.
        node: u8,
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The value (unused bytes zero).
        value: u32,
        /// Bytes of the value.
        len: u8,
    },
    /// Abort with a CiA 301 abort code.
    Abort {
        /// Node.
        node: u8,
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Abort code.
        code: u32,
    },
}

/// Decodes an SDO response frame (0x581..0x5FF).
///
/// ```
/// use jointctl_hal::codec::canopen::*;
/// let ok = Frame::new(0x582, &[0x60, 0x60, 0x60, 0, 0, 0, 0, 0]);
/// assert_eq!(decode_sdo_response(&ok), Some(SdoResponse::WriteOk { node: 2, index: 0x6060, sub: 0 }));
/// let v = Frame::new(0x582, &[0x4B, 0x41, 0x60, 0, 0x37, 0x02, 0, 0]);
/// assert_eq!(decode_sdo_response(&v), Some(SdoResponse::Value { node: 2, index: 0x6041, sub: 0, value: 0x237, len: 2 }));
/// ```
pub fn decode_sdo_response(frame: &Frame) -> Option<SdoResponse> {
    let node = node_of(frame.id, cob::SDO_TX)?;
    let b = frame.bytes();
    if b.len() != 8 {
        return None;
    }
    let index = u16::from_le_bytes([b[1], b[2]]);
    let sub = b[3];
    let value = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
    match b[0] {
        0x60 => Some(SdoResponse::WriteOk { node, index, sub }),
        0x80 => Some(SdoResponse::Abort { node, index, sub, code: value }),
        // Expedited upload: with its size (0x43/47/4B/4F), or without (0x42: four bytes, CiA 301).
        c if c & 0xE2 == 0x42 => {
            let len = if c & 0x01 != 0 { 4 - ((c >> 2) & 0x3) } else { 4 };
            let mask = if len == 4 { u32::MAX } else { (1u32 << (8 * len)) - 1 };
            Some(SdoResponse::Value { node, index, sub, value: value & mask, len })
        }
        _ => None,
    }
}

/// Decodes an SDO request (for the simulated drive): (node, command byte, index, sub, data).
pub fn decode_sdo_request(frame: &Frame) -> Option<(u8, u8, u16, u8, u32)> {
    let node = node_of(frame.id, cob::SDO_RX)?;
    let b = frame.bytes();
    (b.len() == 8).then(|| (node, b[0], u16::from_le_bytes([b[1], b[2]]), b[3], u32::from_le_bytes([b[4], b[5], b[6], b[7]])))
}

/// Bits of a classic base-format data frame with `data_bytes` bytes, without stuffing and with
/// worst-case bit stuffing (the issue's "~111-135 bits" for 8 bytes).
///
/// ```
/// assert_eq!(jointctl_hal::codec::canopen::frame_bits(8), (111, 135));
/// ```
pub fn frame_bits(data_bytes: u8) -> (u32, u32) {
    let n = data_bytes.min(8) as u32;
    let plain = 47 + 8 * n;
    // Stuffing applies to the 34 + 8n bits from SOF to the CRC: at most one stuff bit per 4.
    (plain, plain + (34 + 8 * n - 1) / 4)
}

#[cfg(test)]
mod upload_tests {
    use super::*;

    #[test]
    fn a_tpdo1_of_another_length_than_six_or_eight_bytes_is_not_read() {
        // Six bytes: statusword and position; eight: with the torque actual value. A frame cut
        // short or padded is not half-read.
        for len in [0usize, 2, 5, 7] {
            let f = Frame::new(cob::TPDO1 + 3, &[0x37, 0x02, 1, 2, 3, 4, 5, 6][..len]);
            assert_eq!(decode_tpdo1(&f), None, "{len} bytes");
        }
        let f = tpdo1_with_torque(3, 0x0237, 70_000, i16::MIN);
        assert_eq!(decode_tpdo1(&f), Some(Tpdo1 { node: 3, statusword: 0x0237, position_counts: 70_000, torque_permille: Some(i16::MIN) }));
    }

    #[test]
    fn an_expedited_upload_without_its_size_is_four_bytes() {
        // CiA 301 allows 0x42 (expedited, size not indicated); a drive that answers so was not
        // read (every read-back timed out).
        let f = Frame::new(cob::SDO_TX + 3, &[0x42, 0x7F, 0x60, 0x00, 0xB8, 0x0B, 0x00, 0x00]);
        assert_eq!(decode_sdo_response(&f), Some(SdoResponse::Value { node: 3, index: 0x607F, sub: 0, value: 3000, len: 4 }));
        let sized = Frame::new(cob::SDO_TX + 3, &[0x4B, 0x72, 0x60, 0x00, 0x20, 0x03, 0xFF, 0xFF]);
        assert_eq!(decode_sdo_response(&sized), Some(SdoResponse::Value { node: 3, index: 0x6072, sub: 0, value: 800, len: 2 }));
    }
}
