//! The real HAL on a real Linux SocketCAN (`vcan0`), with can-utils as an independent peer.
//!
//! This machine's kernel has no CAN: run these inside the CAN VM, as CI does:
//!   CARGO_TARGET_X86_64_UNKNOWN_LINUX_GNU_RUNNER=../shared/tools/can-vm/run-in-vm.sh \
//!       cargo test -p jointctl-tests --test socketcan_vcan
//! They are `#[ignore]`d, so that a plain `cargo test` reports them as ignored instead of passing
//! without running; CI runs them in the VM with `-- --include-ignored`, where a missing `vcan0`
//! fails them.
//!
//! The tests live in modules by job: `lifecycle` (enable, follow, fault reset, start-up limits,
//! the stop sequence), `losses` (silence, bus-off, lost frames) and `peers` (can-utils, the
//! conformance suite, doctor), all against `sim_node`'s simulated drive; this file holds the
//! shared bus lock, the config and the HAL rig.

use std::sync::Mutex;
use std::time::Duration;

use jointctl_api::MotorSetpoint;
use jointctl_hal_socketcan::HardwareHal;
use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, SensorFrame};

mod lifecycle;
mod losses;
mod peers;
mod sim_node;

/// The tests share one bus: run them one at a time.
static BUS: Mutex<()> = Mutex::new(());

/// Why these tests are ignored outside the VM.
const NEEDS_VCAN: &str = "needs vcan0: run inside ../shared/tools/can-vm/run-in-vm.sh with --include-ignored (CI does)";

fn require_vcan() {
    assert!(std::path::Path::new("/sys/class/net/vcan0").exists(), "no vcan0 on this machine: {NEEDS_VCAN}");
}

/// The bus for this test alone (a test that panicked left the lock poisoned, not the bus), once
/// `vcan0` is known to be there.
fn on_the_bus() -> std::sync::MutexGuard<'static, ()> {
    let bus = BUS.lock().unwrap_or_else(|p| p.into_inner());
    require_vcan();
    bus
}

const COUNTS_PER_RAD: f64 = 1000.0;

fn config(node: u8) -> jointctl_config::ArmConfig {
    config_in(node, "cyclic_synchronous_position")
}

fn config_in(node: u8, mode: &str) -> jointctl_config::ArmConfig {
    let yaml = format!(
        "arm: vcan\nrate_hz: 100\nhal: {{backend: socketcan, canopen: {{mode: {mode}, sdo_timeout_s: 1.0, heartbeat_timeout_s: 0.5}}}}\n\
         buses:\n  can:\n    - interface: vcan0\n      drives: [{{name: m, node_id: {node}, counts_per_rad: {COUNTS_PER_RAD}, heartbeat_ms: 100, max_velocity_rad_s: 5.0}}]\n\
         joints: [{{name: q, plugin: rigid, drives: {{motor: m}}}}]\n"
    );
    jointctl_config::parse_str(&yaml, "vcan.yaml").unwrap().config
}

struct Rig {
    hal: HardwareHal,
    sensors: SensorFrame,
    out: ActuatorFrame,
}

impl Rig {
    fn new(node: u8) -> Self {
        Self::with(config(node))
    }

    fn with(cfg: jointctl_config::ArmConfig) -> Self {
        let devices = DeviceIndex::of(&cfg);
        let hal = HardwareHal::new(&cfg).expect("the HAL configures the drive over SDO");
        Rig { hal, sensors: SensorFrame::new(&devices), out: ActuatorFrame::new(&devices) }
    }

    fn cycle(&mut self, sp: MotorSetpoint) -> jointctl_api::DriveReading {
        self.out.drives[0] = sp;
        self.hal.write(&self.out, 0.01).unwrap();
        std::thread::sleep(Duration::from_millis(10));
        self.hal.read(&mut self.sensors).unwrap();
        self.sensors.drives[0]
    }

    fn until(&mut self, sp: MotorSetpoint, what: &str, mut ok: impl FnMut(&jointctl_api::DriveReading) -> bool) -> jointctl_api::DriveReading {
        for _ in 0..300 {
            let r = self.cycle(sp);
            if ok(&r) {
                return r;
            }
        }
        panic!("timed out waiting for {what}; health {:?}", self.hal.drive_health().collect::<Vec<_>>());
    }
}
