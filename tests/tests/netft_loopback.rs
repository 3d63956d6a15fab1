//! The Net F/T reader of the real backend against a loopback RDT peer (a UDP socket that
//! answers as an ATI box does): streaming is requested, records become torques about the
//! configured axis, an error status or a torque beyond the range is invalid, a lost datagram and
//! a silent box are counted, and a box that stays silent is asked again.

use std::net::UdpSocket;
use std::time::Duration;

use jointctl_api::ReadingStatus;
use jointctl_hal::codec::netft::{self, RdtRecord};
use jointctl_hal_socketcan::netft::NetFtSensors;

fn peer() -> (UdpSocket, String) {
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let address = s.local_addr().unwrap().to_string();
    (s, address)
}

fn sensors(address: &str, axes: &[&str]) -> Vec<jointctl_config::ForceTorqueConfig> {
    let mut yaml = String::from("arm: a\nhal: {backend: socketcan}\nbuses:\n  force_torque:\n");
    for (i, axis) in axes.iter().enumerate() {
        yaml += &format!("    - {{name: ft{i}, axis: {axis}, axis_point_m: [0.0, 0.1, 0.0], range_nm: 5.0, netft: {{address: \"{address}\", timeout_s: 0.05}}}}\n");
    }
    yaml += "joints: [{name: q, plugin: rigid}]\n";
    jointctl_config::parse_str(&yaml, "a.yaml").unwrap().config.buses.force_torque
}

/// Waits for the start request; returns where to send the records.
fn started(peer: &UdpSocket) -> std::net::SocketAddr {
    let mut buf = [0u8; 16];
    let (n, from) = peer.recv_from(&mut buf).unwrap();
    assert_eq!(netft::decode_request(&buf[..n]), Some((netft::START_REALTIME, 0)), "RDT start of real-time streaming, without end");
    from
}

fn send(peer: &UdpSocket, to: std::net::SocketAddr, seq: u32, status: u32, counts: [i32; 6]) {
    peer.send_to(&netft::encode(&RdtRecord { rdt_sequence: seq, ft_sequence: seq * 4, status, counts }), to).unwrap();
}

fn read(s: &mut NetFtSensors, n: usize, now: f64) -> Vec<jointctl_api::Reading> {
    // Loopback delivery is quick but not instant.
    std::thread::sleep(Duration::from_millis(20));
    let mut out = vec![jointctl_api::Reading::MISSING; n];
    s.read(&mut out, now);
    out
}

#[test]
fn records_become_torques_about_each_configured_axis_of_one_box() {
    let (peer, address) = peer();
    // Two axes of one box (the wrist's q6 and q7): one socket, one request.
    let mut s = NetFtSensors::new(&sensors(&address, &["[0, 0, 1]", "[1, 0, 0]"]), 0.0).unwrap();
    let to = started(&peer);
    // Fx 10 N, Tx 0.3 Nm, Tz 1.5 Nm (10^6 counts per unit); the axes pass 0.1 m off along y:
    // about z, a . (T - p x F) = 1.5 - (-1.0) = 2.5 Nm; about x, 0.3 Nm.
    send(&peer, to, 1, 0, [10_000_000, 0, 0, 300_000, 0, 1_500_000]);
    let r = read(&mut s, 2, 0.001);
    assert_eq!(r[0].status, ReadingStatus::VALID);
    assert!((r[0].value - 2.5).abs() < 1e-9 && (r[1].value - 0.3).abs() < 1e-9, "{r:?}");

    // An error status is not a value: the last good one, stale.
    send(&peer, to, 2, netft::STATUS_ERROR | 0x0001, [0, 0, 0, 0, 0, 4_000_000]);
    let r = read(&mut s, 2, 0.026);
    assert_eq!((r[0].status, r[0].value), (ReadingStatus::STALE, 2.5));
    // Beyond the 5 Nm range: invalid too.
    send(&peer, to, 3, 0, [0, 0, 0, 0, 0, 7_000_000]);
    assert_eq!(read(&mut s, 2, 0.030)[0].status, ReadingStatus::STALE);
    // A datagram lost on the way (sequence 4 never sent) counts as missing.
    send(&peer, to, 5, 0, [0, 0, 0, 0, 0, -1_000_000]);
    let r = read(&mut s, 2, 0.040);
    assert_eq!((r[0].status, r[0].value), (ReadingStatus::VALID, -1.0));
    let counters: Vec<_> = s.counters().collect();
    assert_eq!((counters[0].invalid, counters[0].missing), (2, 1), "{counters:?}");
    // A datagram that is not a record is skipped.
    peer.send_to(b"not a record", to).unwrap();
    assert_eq!(read(&mut s, 2, 0.045)[0].status, ReadingStatus::STALE, "nothing new arrived");
}

#[test]
fn a_silent_box_reads_missing_after_its_timeout_and_is_asked_again() {
    let (peer, address) = peer();
    let mut s = NetFtSensors::new(&sensors(&address, &["[0, 0, 1]"]), 0.0).unwrap();
    let to = started(&peer);
    send(&peer, to, 1, 0, [0, 0, 0, 0, 0, 500_000]);
    assert_eq!(read(&mut s, 1, 0.01)[0].status, ReadingStatus::VALID);
    assert_eq!(read(&mut s, 1, 0.03)[0].status, ReadingStatus::STALE, "within the 50 ms timeout");
    let r = read(&mut s, 1, 0.2);
    assert_eq!(r[0].status, ReadingStatus::MISSING, "older than the timeout: {r:?}");
    assert_eq!(started(&peer), to, "a silent box is asked to stream again");
}

#[test]
fn a_sensor_without_a_box_is_an_error_that_names_it() {
    let cfg = jointctl_config::parse_str("arm: a\nhal: {backend: socketcan}\nbuses:\n  force_torque:\n    - {name: ft_q2, sim: {dof: q2}}\njoints: [{name: q, plugin: rigid}]\n", "a.yaml").unwrap();
    let e = NetFtSensors::new(&cfg.config.buses.force_torque, 0.0).err().expect("an error");
    assert!(e.to_string().contains("buses.force_torque[0].netft") && e.to_string().contains("ft_q2"), "{e}");
}
