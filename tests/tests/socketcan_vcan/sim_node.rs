//! The simulated ELMO drive on vcan0 the tests talk to (CANopen NMT, SDO, heartbeat, PDOs,
//! CiA 402), with faults and frame loss on request.

use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use jointctl_hal::codec::canopen::{self as co, DriveState, Frame};
use socketcan::{CanFrame, CanSocket, EmbeddedFrame, Socket, StandardId};

fn send(sock: &CanSocket, f: &Frame) {
    let cf = CanFrame::new(StandardId::new(f.id).unwrap(), f.bytes()).unwrap();
    let _ = sock.write_frame(&cf);
}

/// A simulated ELMO drive on vcan0: NMT, expedited SDO, heartbeat, SYNC → TPDO1, RPDO1 →
/// CiA 402 state machine and position, faults and frame loss on request. In profile position
/// mode (0x6060 = 1) it moves to its target on its own, as a real drive does, SYNC or not; it
/// consumes the host's heartbeat (0x1016:01) and, when that stops, acts as 0x6007 says
/// (3: quick stop and hold, 2: disable voltage, 1: fault) with an EMCY 0x8130 (CiA 301).
pub(crate) struct SimNode {
    stop: Arc<AtomicBool>,
    pub(crate) fault: Arc<AtomicBool>,
    /// The drive produces its heartbeat (a drive whose producer is broken or off answers
    /// everything else but never sends one).
    pub(crate) heartbeats: Arc<AtomicBool>,
    /// An object index the drive stores one more than it is given (a drive that rounds or
    /// clamps a limit); 0: none.
    pub(crate) misstore: Arc<AtomicU32>,
    /// Every expedited SDO write received: (index, sub, data).
    pub(crate) sdo_log: Arc<Mutex<Vec<(u16, u8, u32)>>>,
    /// The last statusword.
    pub(crate) statusword: Arc<AtomicU32>,
    /// Per mille of TPDOs dropped, and of TPDOs sent with an all-zero position (appendix A).
    pub(crate) drop_per_mille: Arc<AtomicU32>,
    pub(crate) zero_per_mille: Arc<AtomicU32>,
    /// A zeroed TPDO is zero throughout, its statusword too (else it keeps the statusword).
    pub(crate) zero_whole_frame: Arc<AtomicBool>,
    /// The torque actual value (0x6077, per mille of the rated torque) the drive reports once
    /// the host has mapped it into TPDO1; `i32::MIN`: a drive that does not report it.
    pub(crate) torque_permille: Arc<AtomicI32>,
    /// True position [counts] as last sent, for comparing.
    pub(crate) truth: Arc<Mutex<Vec<(f64, i32)>>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl SimNode {
    pub(crate) fn start(node: u8) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let fault = Arc::new(AtomicBool::new(false));
        let heartbeats = Arc::new(AtomicBool::new(true));
        let misstore = Arc::new(AtomicU32::new(0));
        let drop_per_mille = Arc::new(AtomicU32::new(0));
        let zero_per_mille = Arc::new(AtomicU32::new(0));
        let truth = Arc::new(Mutex::new(Vec::new()));
        let torque_permille = Arc::new(AtomicI32::new(i32::MIN));
        let torque = torque_permille.clone();
        let zero_whole_frame = Arc::new(AtomicBool::new(false));
        let whole = zero_whole_frame.clone();
        let sdo_log = Arc::new(Mutex::new(Vec::new()));
        let status = Arc::new(AtomicU32::new(0));
        let (s, f, d, z, t) = (stop.clone(), fault.clone(), drop_per_mille.clone(), zero_per_mille.clone(), truth.clone());
        let (log, sw, beats, wrong) = (sdo_log.clone(), status.clone(), heartbeats.clone(), misstore.clone());
        let thread = std::thread::spawn(move || {
            let sock = CanSocket::open("vcan0").unwrap();
            sock.set_read_timeout(Duration::from_millis(2)).unwrap();
            let t0 = Instant::now();
            let mut statusword: u16 = 0x0250; // switch on disabled
            let mut position: i32 = 2000; // the drive does not start at 0
            let mut target: i32 = position;
            let mut operational = false;
            let mut last_hb = Instant::now();
            let mut profile_mode = false;
            let mut abort_option: i16 = 0;
            // (producer node, consumer time) from 0x1016:01, and when the producer was last heard.
            let mut consumer: Option<(u8, Duration)> = None;
            let mut host_heard: Option<Instant> = None;
            // The object dictionary as written: what an upload reads back.
            let mut objects = std::collections::HashMap::<(u16, u8), u32>::new();
            // TPDO1's COB-ID (CiA 301's default, the RTR bit set as many drives have it).
            objects.insert((0x1800, 1), 0x4000_0000 | (0x180 + u32::from(node)));
            let mut last_move = Instant::now();
            let mut rng = jointctl_test_support::XorShift64::new(0x2545_f491_4f6c_dd1d ^ node as u64);
            let mut roll = || (rng.next_u64() % 1000) as u32;
            while !s.load(Ordering::Relaxed) {
                sw.store(u32::from(statusword), Ordering::Relaxed);
                if f.swap(false, Ordering::Relaxed) {
                    statusword = 0x0218; // fault
                    send(&sock, &co::emcy(node, 0x2310, 0x03));
                }
                // Heartbeat consumer: the host fell silent.
                if let (Some((_, time)), Some(heard)) = (consumer, host_heard)
                    && heard.elapsed() > time
                {
                    host_heard = None;
                    send(&sock, &co::emcy(node, 0x8130, 0x11));
                    if co::state_of(statusword) == DriveState::OperationEnabled {
                        statusword = match abort_option {
                            1 => 0x0218,
                            2 => 0x0250,
                            3 => 0x0217,
                            _ => statusword,
                        };
                        if abort_option == 3 {
                            target = position; // decelerate (here: at once) and hold
                        }
                    }
                }
                // Profile position: the drive runs its profile by itself, 40 counts per 10 ms.
                if last_move.elapsed() >= Duration::from_millis(10) {
                    last_move = Instant::now();
                    if profile_mode && operational && co::state_of(statusword) == DriveState::OperationEnabled && target != position {
                        position += (target - position).clamp(-40, 40);
                        t.lock().unwrap().push((t0.elapsed().as_secs_f64(), position));
                    }
                }
                if last_hb.elapsed() > Duration::from_millis(100) && beats.load(Ordering::Relaxed) {
                    send(&sock, &co::heartbeat(node, if operational { co::nmt_state::OPERATIONAL } else { co::nmt_state::PRE_OPERATIONAL }));
                    last_hb = Instant::now();
                }
                let Ok(CanFrame::Data(df)) = sock.read_frame() else { continue };
                let socketcan::Id::Standard(id) = df.id() else { continue };
                let frame = Frame::new(id.as_raw(), df.data());
                if frame.id == co::cob::NMT && frame.len == 2 && (frame.data[1] == 0 || frame.data[1] == node) {
                    operational = frame.data[0] == co::NmtCommand::Start as u8;
                } else if let Some((producer, _)) = co::decode_heartbeat(&frame)
                    && consumer.is_some_and(|(p, _)| p == producer)
                {
                    host_heard = Some(Instant::now());
                } else if let Some((n, cmd, index, sub, data)) = co::decode_sdo_request(&frame) {
                    if n == node && cmd == 0x40 {
                        let i = index.to_le_bytes();
                        let reply = match objects.get(&(index, sub)) {
                            Some(v) => {
                                let b = v.to_le_bytes();
                                [0x43, i[0], i[1], sub, b[0], b[1], b[2], b[3]]
                            }
                            // Abort: the object does not exist (CiA 301 0x06020000).
                            None => [0x80, i[0], i[1], sub, 0x00, 0x00, 0x02, 0x06],
                        };
                        send(&sock, &Frame::new(co::cob::SDO_TX + node as u16, &reply));
                    } else if n == node && cmd & 0xE0 == 0x20 {
                        log.lock().unwrap().push((index, sub, data));
                        let len = 4 - ((cmd >> 2) & 0x3);
                        let mask = if len == 4 { u32::MAX } else { (1u32 << (8 * len)) - 1 };
                        let stored = if u32::from(index) == wrong.load(Ordering::Relaxed) { (data & mask).wrapping_add(1) } else { data & mask };
                        objects.insert((index, sub), stored);
                        match (index, sub) {
                            (0x6060, 0) => profile_mode = data & 0xFF == 1,
                            (0x6007, 0) => abort_option = (data & 0xFFFF) as u16 as i16,
                            (0x1016, 1) => consumer = Some(((data >> 16) as u8, Duration::from_millis(u64::from(data & 0xFFFF)))),
                            _ => {}
                        }
                        let i = index.to_le_bytes();
                        send(&sock, &Frame::new(co::cob::SDO_TX + node as u16, &[0x60, i[0], i[1], sub, 0, 0, 0, 0]));
                    }
                } else if let Some((n, cw, tgt)) = co::decode_rpdo1(&frame) {
                    if n != node {
                        continue;
                    }
                    let state = co::state_of(statusword);
                    statusword = match (state, cw & 0x8F) {
                        (DriveState::Fault, c) if c & 0x80 != 0 => 0x0250,
                        (DriveState::Fault, _) => statusword,
                        (_, 0x00) => 0x0250,
                        (DriveState::SwitchOnDisabled, 0x06) => 0x0231,
                        (DriveState::ReadyToSwitchOn, 0x07) => 0x0233,
                        (DriveState::SwitchedOn, 0x0F) | (DriveState::OperationEnabled, 0x0F) => 0x0237,
                        // Quick stop (0x605A = 6: stay in quick stop active, holding).
                        (DriveState::OperationEnabled, 0x02) => 0x0217,
                        // Disable operation (not from quick stop active: CiA 402 has no such
                        // transition; disable voltage, above, leaves it).
                        (DriveState::OperationEnabled, 0x07) => 0x0233,
                        (_, 0x06) => 0x0231,
                        _ => statusword,
                    };
                    if co::state_of(statusword) == DriveState::OperationEnabled {
                        target = tgt;
                    }
                } else if frame.id == co::cob::SYNC && operational {
                    // Cyclic synchronous position: at most 40 counts towards the target per SYNC.
                    if !profile_mode {
                        position += (target - position).clamp(-40, 40);
                        t.lock().unwrap().push((t0.elapsed().as_secs_f64(), position));
                    }
                    let r = roll();
                    if r < d.load(Ordering::Relaxed) {
                        continue; // lost
                    }
                    let sent = if roll() < z.load(Ordering::Relaxed) { 0 } else { position };
                    let statusword = if sent == 0 && whole.load(Ordering::Relaxed) { 0 } else { statusword };
                    // 0x6077 is in the frame once the host has mapped it (three entries, the
                    // third the torque actual value) and the PDO is on.
                    let mapped = objects.get(&(0x1A00, 0)) == Some(&3)
                        && objects.get(&(0x1A00, 3)) == Some(&0x6077_0010)
                        && objects.get(&(0x1800, 1)).is_some_and(|c| c & 0x8000_0000 == 0 && c & 0x7FF == 0x180 + u32::from(node));
                    match torque.load(Ordering::Relaxed) {
                        _ if !mapped => send(&sock, &co::tpdo1(node, statusword, sent)),
                        i32::MIN => send(&sock, &co::tpdo1(node, statusword, sent)),
                        // A zeroed frame is zero throughout (appendix A).
                        _ if sent == 0 => send(&sock, &co::tpdo1_with_torque(node, statusword, 0, 0)),
                        p => send(&sock, &co::tpdo1_with_torque(node, statusword, sent, p as i16)),
                    }
                }
            }
        });
        SimNode { stop, fault, heartbeats, misstore, sdo_log, statusword: status, drop_per_mille, zero_per_mille, zero_whole_frame, torque_permille, truth, thread: Some(thread) }
    }
}

impl Drop for SimNode {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
