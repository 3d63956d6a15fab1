//! The null backend (what `jointctl check` builds) against the HAL contract.

use jointctl_hal_conformance::{Subject, hal_conformance_tests};

fn null() -> Subject {
    let cfg = jointctl_config::parse_str(
        "arm: n\nhal: {backend: sim}\nbuses:\n  can: [{interface: can0, drives: [{name: m, node_id: 1}]}]\n  spi: [{device: /dev/spidev0, encoders: [{name: e, chip_select: 0}]}]\njoints: [{name: q, plugin: rigid, encoders: {output: e}, drives: {motor: m}}]\n",
        "null.yaml",
    )
    .unwrap()
    .config;
    Subject {
        hal: Box::new(jointctl_hal::NullHal),
        devices: jointctl_hal::DeviceIndex::of(&cfg),
        settle: std::time::Duration::ZERO,
        has_feedback: false,
        keep_alive: Vec::new(),
    }
}

hal_conformance_tests!(null);

#[test]
fn the_null_backend_reads_every_device_as_missing() {
    let s = null();
    let mut frame = jointctl_hal::SensorFrame::new(&s.devices);
    let mut hal = s.hal;
    hal.read(&mut frame).unwrap();
    assert!(frame.encoders.iter().all(|r| r.status == jointctl_api::ReadingStatus::MISSING));
}
