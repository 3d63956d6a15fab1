//! Force/torque sensors on ATI Net F/T boxes: RDT records over UDP (see
//! [`jointctl_hal::codec::netft`]). Each configured sensor axis reads the torque about its joint
//! axis from its box's newest record; several axes may share one box (one socket per box).
//! Non-blocking: a cycle takes what has arrived and never waits.

use std::net::{ToSocketAddrs, UdpSocket};

use jointctl_api::Reading;
use jointctl_config::ForceTorqueConfig;
use jointctl_hal::codec::netft::{self, RdtRecord};
use jointctl_hal::condition::{Conditioner, LossCounters, Plausibility, Sample};
use jointctl_hal::HalSetupError;

/// One Net F/T box.
struct NetFtBox {
    address: String,
    socket: UdpSocket,
    /// The newest record and when it arrived [s].
    newest: Option<(RdtRecord, f64)>,
    /// Whether `newest` arrived since the last read.
    fresh: bool,
    /// When streaming was last requested [s].
    requested_s: f64,
    /// Records lost on the way (gaps in the RDT sequence).
    lost: u64,
    timeout_s: f64,
}

/// One sensor axis: the torque about a joint axis from a box.
struct Axis {
    box_index: usize,
    counts_per_force: f64,
    counts_per_torque: f64,
    axis: [f64; 3],
    point_m: [f64; 3],
    range_nm: f64,
    conditioner: Conditioner,
}

/// Every force/torque sensor of an arm on Net F/T boxes.
pub struct NetFtSensors {
    boxes: Vec<NetFtBox>,
    axes: Vec<Axis>,
}

fn setup(field: String, message: String) -> HalSetupError {
    HalSetupError::Config { field, message }
}

impl NetFtSensors {
    /// Opens a UDP socket per box named under `netft` and asks each to stream, at `now_s`.
    /// A sensor without `netft` is an error here (the real backend cannot read it).
    pub fn new(sensors: &[ForceTorqueConfig], now_s: f64) -> Result<Self, HalSetupError> {
        let mut boxes: Vec<NetFtBox> = Vec::new();
        let mut axes = Vec::new();
        for (i, f) in sensors.iter().enumerate() {
            let field = format!("buses.force_torque[{i}].netft");
            let Some(n) = &f.netft else {
                return Err(setup(field, format!("sensor `{}` has no `netft: {{address: HOST:PORT}}`: the real backend reads force/torque sensors from ATI Net F/T boxes", f.name)));
            };
            let box_index = match boxes.iter().position(|b| b.address == n.address) {
                Some(b) => b,
                None => {
                    let target = n
                        .address
                        .to_socket_addrs()
                        .ok()
                        .and_then(|mut a| a.next())
                        .ok_or_else(|| setup(format!("{field}.address"), format!("cannot resolve `{}`", n.address)))?;
                    let bind = if target.is_ipv4() { "0.0.0.0:0" } else { "[::]:0" };
                    let socket = UdpSocket::bind(bind)
                        .and_then(|s| s.connect(target).map(|_| s))
                        .and_then(|s| s.set_nonblocking(true).map(|_| s))
                        .map_err(|e| setup(format!("{field}.address"), format!("cannot open a UDP socket to {target}: {e}")))?;
                    let mut b = NetFtBox { address: n.address.clone(), socket, newest: None, fresh: false, requested_s: f64::NEG_INFINITY, lost: 0, timeout_s: n.timeout_s };
                    b.request(now_s);
                    boxes.push(b);
                    boxes.len() - 1
                }
            };
            axes.push(Axis {
                box_index,
                counts_per_force: n.counts_per_force,
                counts_per_torque: n.counts_per_torque,
                axis: f.axis,
                point_m: f.axis_point_m,
                range_nm: f.range_nm,
                conditioner: Conditioner::new(Plausibility::torque_sensor()),
            });
        }
        Ok(NetFtSensors { boxes, axes })
    }

    /// Takes what arrived and fills one reading per sensor axis [Nm]. A box silent for its
    /// timeout is asked to stream again (once per timeout).
    pub fn read(&mut self, out: &mut [Reading], now_s: f64) {
        let mut buf = [0u8; 64];
        for b in &mut self.boxes {
            b.fresh = false;
            // A datagram of another length is not a record; it is skipped, not used.
            while let Ok(n) = b.socket.recv(&mut buf) {
                let Ok(record) = netft::decode(&buf[..n]) else { continue };
                let newer = b.newest.is_none_or(|(old, _)| record.rdt_sequence.wrapping_sub(old.rdt_sequence) as i32 > 0);
                if newer {
                    if let Some((old, _)) = b.newest {
                        b.lost += u64::from(record.rdt_sequence.wrapping_sub(old.rdt_sequence).saturating_sub(1));
                    }
                    b.newest = Some((record, now_s));
                    b.fresh = true;
                }
            }
            let silent = b.newest.is_none_or(|(_, t)| now_s - t > b.timeout_s);
            if silent && now_s - b.requested_s >= b.timeout_s {
                b.request(now_s);
            }
        }
        for (reading, a) in out.iter_mut().zip(&mut self.axes) {
            let b = &self.boxes[a.box_index];
            let sample = match b.newest {
                Some((r, _)) if b.fresh && r.status & netft::STATUS_ERROR != 0 => Sample::Invalid,
                Some((r, t)) if b.fresh => {
                    let tau = netft::torque_about_axis(&r, a.counts_per_force, a.counts_per_torque, a.axis, a.point_m);
                    if tau.abs() <= a.range_nm { Sample::Value { value: tau, age_s: now_s - t } } else { Sample::Invalid }
                }
                _ => Sample::Missing,
            };
            let r = a.conditioner.update(sample, now_s);
            // Older than the box's timeout: no longer a value to show.
            *reading = if r.age_s > b.timeout_s { Reading::MISSING } else { r };
        }
    }

    /// Loss counters per sensor axis, in configuration order; records lost between the box and
    /// this host count as missing too.
    pub fn counters(&self) -> impl Iterator<Item = LossCounters> + '_ {
        self.axes.iter().map(|a| {
            let mut c = a.conditioner.counters();
            c.missing += self.boxes[a.box_index].lost;
            c
        })
    }

    /// Stops every box's stream.
    pub fn stop(&mut self) {
        for b in &self.boxes {
            let _ = b.socket.send(&netft::request(netft::STOP_STREAMING, 0));
        }
    }
}

impl NetFtBox {
    fn request(&mut self, now_s: f64) {
        self.requested_s = now_s;
        let _ = self.socket.send(&netft::request(netft::START_REALTIME, 0));
    }
}

impl Drop for NetFtSensors {
    fn drop(&mut self) {
        self.stop();
    }
}
