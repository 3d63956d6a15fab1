//! The simulated arm (the default backend) against the HAL contract: two drives, one of them
//! behind an elastic joint, and encoders on a drive and on a joint signal.

use jointctl_hal_conformance::{Subject, hal_conformance_tests};

fn sim() -> Subject {
    let yaml = "arm: s\nrate_hz: 100\nhal: {backend: sim}\nbuses:\n  can: [{interface: can0, drives: [{name: m0, node_id: 1}, {name: m1, node_id: 2}]}]\n  spi: [{device: /dev/spidev0, encoders: [{name: e0, chip_select: 0, sim: {drive: m0}}, {name: e1, chip_select: 1, sim: {drive: m1}}]}]\njoints:\n  - {name: a, plugin: rigid, encoders: {output: e0}, drives: {motor: m0}}\n  - {name: b, plugin: rigid, encoders: {output: e1}, drives: {motor: m1}}\n";
    let cfg = jointctl_config::parse_str(yaml, "sim.yaml").unwrap().config;
    Subject {
        hal: Box::new(jointctl_sim::SimHal::new(&cfg).unwrap()),
        devices: jointctl_hal::DeviceIndex::of(&cfg),
        settle: std::time::Duration::ZERO,
        has_feedback: true,
        keep_alive: Vec::new(),
    }
}

hal_conformance_tests!(sim);
