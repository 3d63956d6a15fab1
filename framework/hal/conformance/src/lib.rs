//! # jointctl-hal-conformance
//!
//! The [`Hal`] trait's contract as tests, generic over the backend, in the way iceoryx2's
//! `iceoryx2-cal/conformance-tests` test every implementation of a trait: a backend is
//! conformant when [`hal_conformance_tests!`] passes for it. The null and simulated backends
//! run it in this crate's tests; the SocketCAN backend runs it inside the CAN VM
//! (`tests/tests/socketcan_vcan/`) against a simulated ELMO drive on `vcan0`.
//!
//! The contract (each a function here, each a test per backend):
//! - [`frames_keep_their_sizes`]: `read` and `write` never resize a frame;
//! - [`valid_readings_are_finite`]: a reading marked valid is a finite number; a device that
//!   did not answer is stale or missing, never a zero;
//! - [`hold_keeps_the_drives_still`]: a HOLD frame leaves every drive where it is;
//! - [`a_move_is_followed`]: a position set-point reaches the drive;
//! - [`the_cycle_allocates_nothing`]: `read`, `write` and `device_health` allocate nothing;
//! - [`reset_and_health_are_harmless`]: `reset_faults` and `device_health` may be called any
//!   cycle without disturbing the readings.

use std::time::Duration;

use jointctl_api::{MotorSetpoint, ReadingStatus};
use jointctl_hal::{ActuatorFrame, DeviceHealth, DeviceIndex, Hal, SensorFrame};

pub use jointctl_test_support::{CountingAlloc, count_allocations};

/// A backend under test, as a factory makes it for each test.
pub struct Subject {
    /// The backend.
    pub hal: Box<dyn Hal>,
    /// Its devices.
    pub devices: DeviceIndex,
    /// Time between `write` and `read` in one cycle: 0 for simulated backends, a bus period for
    /// real ones, whose answers take time.
    pub settle: Duration,
    /// Whether drives report positions (false for the null backend).
    pub has_feedback: bool,
    /// Whatever must live as long as the backend (a simulated drive on the bus, a bus lock).
    pub keep_alive: Vec<Box<dyn std::any::Any>>,
}

/// Cycles allowed for a backend to bring its drives up (CANopen: NMT, CiA 402 enable).
const WARM_UP_CYCLES: usize = 300;

struct Rig {
    s: Subject,
    sensors: SensorFrame,
    out: ActuatorFrame,
    health: Vec<DeviceHealth>,
}

impl Rig {
    fn new(s: Subject) -> Self {
        let sensors = SensorFrame::new(&s.devices);
        let out = ActuatorFrame::new(&s.devices);
        let health = vec![DeviceHealth::default(); s.devices.drives.len() + s.devices.encoders.len()];
        Rig { s, sensors, out, health }
    }

    fn cycle(&mut self) {
        self.s.hal.write(&self.out, 0.01).expect("write");
        if !self.s.settle.is_zero() {
            std::thread::sleep(self.s.settle);
        }
        self.s.hal.read(&mut self.sensors).expect("read");
    }

    fn drive_positions(&self) -> Vec<Option<f64>> {
        self.sensors.drives.iter().map(|d| (d.position_rad.status == ReadingStatus::VALID).then_some(d.position_rad.value)).collect()
    }

    /// Holds until every drive reports a valid position and is enabled (or the warm-up ends).
    fn warm_up(&mut self) {
        self.out.drives.fill(MotorSetpoint::HOLD);
        for _ in 0..WARM_UP_CYCLES {
            self.cycle();
            let ready = self.sensors.drives.iter().all(|d| d.position_rad.status == ReadingStatus::VALID && d.enabled == 1);
            if ready {
                break;
            }
        }
    }
}

/// `read` and `write` keep the frames the size the device index gave them.
pub fn frames_keep_their_sizes(make: impl FnOnce() -> Subject) {
    let mut rig = Rig::new(make());
    let (e, d) = (rig.s.devices.encoders.len(), rig.s.devices.drives.len());
    for _ in 0..20 {
        rig.cycle();
        assert_eq!((rig.sensors.encoders.len(), rig.sensors.drives.len(), rig.out.drives.len()), (e, d, d));
    }
}

/// Every reading marked valid is finite; a missing reading has no valid status.
pub fn valid_readings_are_finite(make: impl FnOnce() -> Subject) {
    let mut rig = Rig::new(make());
    for _ in 0..100 {
        rig.cycle();
        for (i, r) in rig.sensors.encoders.iter().enumerate() {
            assert!(r.status != ReadingStatus::VALID || r.value.is_finite(), "encoder {}: {r:?}", rig.s.devices.encoders[i]);
        }
        for (i, d) in rig.sensors.drives.iter().enumerate() {
            for r in [d.position_rad, d.velocity_rad_s] {
                assert!(r.status != ReadingStatus::VALID || r.value.is_finite(), "drive {}: {d:?}", rig.s.devices.drives[i]);
            }
        }
    }
}

/// After warm-up, 50 HOLD cycles move no drive by more than 1 mrad.
pub fn hold_keeps_the_drives_still(make: impl FnOnce() -> Subject) {
    let mut rig = Rig::new(make());
    if !rig.s.has_feedback {
        return;
    }
    rig.warm_up();
    let start = rig.drive_positions();
    assert!(start.iter().all(Option::is_some), "every drive reports a position after warm-up: {:?}", rig.sensors.drives);
    for _ in 0..50 {
        rig.cycle();
    }
    for (i, (a, b)) in start.iter().zip(rig.drive_positions()).enumerate() {
        let (a, b) = (a.unwrap(), b.expect("the position stays valid while holding"));
        assert!((a - b).abs() < 1e-3, "drive {} moved from {a} to {b} rad while holding", rig.s.devices.drives[i]);
    }
}

/// A set-point 0.1 rad from where each drive is arrives within 1 mrad in 300 cycles.
pub fn a_move_is_followed(make: impl FnOnce() -> Subject) {
    let mut rig = Rig::new(make());
    if !rig.s.has_feedback {
        return;
    }
    rig.warm_up();
    let target: Vec<f64> = rig.drive_positions().iter().map(|p| p.expect("position after warm-up") + 0.1).collect();
    for (o, t) in rig.out.drives.iter_mut().zip(&target) {
        *o = MotorSetpoint::move_to(*t);
    }
    let reached = (0..WARM_UP_CYCLES).any(|_| {
        rig.cycle();
        rig.drive_positions().iter().zip(&target).all(|(p, t)| p.is_some_and(|p| (p - t).abs() < 1e-3))
    });
    assert!(reached, "targets {target:?} not reached: {:?}", rig.sensors.drives);
}

/// After warm-up, 200 cycles of read, write and device health allocate nothing. Needs
/// [`CountingAlloc`] as the test binary's global allocator ([`hal_conformance_tests!`] installs it).
pub fn the_cycle_allocates_nothing(make: impl FnOnce() -> Subject) {
    let mut rig = Rig::new(make());
    rig.warm_up();
    let ((), n) = count_allocations(|| {
        for _ in 0..200 {
            rig.cycle();
            rig.s.hal.device_health(&mut rig.health);
        }
    });
    assert_eq!(n, 0, "{n} allocations in 200 HAL cycles");
    let (v, n) = count_allocations(|| std::hint::black_box(Vec::<u8>::with_capacity(1)));
    drop(v);
    assert_eq!(n, 1, "the counting allocator is installed and counts");
}

/// `reset_faults` and `device_health` on a healthy backend change no reading's validity.
pub fn reset_and_health_are_harmless(make: impl FnOnce() -> Subject) {
    let mut rig = Rig::new(make());
    rig.warm_up();
    let valid = |rig: &Rig| rig.sensors.drives.iter().map(|d| d.position_rad.status == ReadingStatus::VALID).collect::<Vec<_>>();
    let before = valid(&rig);
    for _ in 0..20 {
        rig.s.hal.reset_faults();
        rig.s.hal.device_health(&mut rig.health);
        rig.cycle();
    }
    assert_eq!(valid(&rig), before);
    if rig.s.has_feedback {
        assert!(rig.health[..rig.s.devices.drives.len()].iter().all(|h| h.flags & DeviceHealth::FAULT == 0), "{:?}", rig.health);
    }
}

/// Emits one `#[test]` per contract function for a backend, and installs [`CountingAlloc`] as
/// the test binary's global allocator. `$make` is a `fn() -> Subject`; attributes after it (e.g.
/// `#[ignore = "needs vcan0"]`) go on every test.
///
/// ```ignore
/// fn null() -> jointctl_hal_conformance::Subject { /* ... */ }
/// jointctl_hal_conformance::hal_conformance_tests!(null);
/// ```
#[macro_export]
macro_rules! hal_conformance_tests {
    ($make:path $(, #[$attr:meta])*) => {
        #[global_allocator]
        static CONFORMANCE_ALLOC: $crate::CountingAlloc = $crate::CountingAlloc;

        $(#[$attr])*
        #[test]
        fn hal_frames_keep_their_sizes() {
            $crate::frames_keep_their_sizes($make)
        }
        $(#[$attr])*
        #[test]
        fn hal_valid_readings_are_finite() {
            $crate::valid_readings_are_finite($make)
        }
        $(#[$attr])*
        #[test]
        fn hal_hold_keeps_the_drives_still() {
            $crate::hold_keeps_the_drives_still($make)
        }
        $(#[$attr])*
        #[test]
        fn hal_a_move_is_followed() {
            $crate::a_move_is_followed($make)
        }
        $(#[$attr])*
        #[test]
        fn hal_the_cycle_allocates_nothing() {
            $crate::the_cycle_allocates_nothing($make)
        }
        $(#[$attr])*
        #[test]
        fn hal_reset_and_health_are_harmless() {
            $crate::reset_and_health_are_harmless($make)
        }
    };
}
