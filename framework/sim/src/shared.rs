//! [`SharedSim`]: a [`SimHal`] shared with the code that reads its ground truth.

use jointctl_hal::{ActuatorFrame, DeviceHealth, Hal, HalIoError, SensorFrame};

use crate::sim_hal::SimHal;

/// A [`SimHal`] shared with the code that runs an experiment or a test, to read the ground
/// truth (the torque sensor, the true element torque) next to what the arm observes. It locks a
/// mutex in `read` and `write`: for experiments and tests, never for `jointctl run`.
#[derive(Clone)]
pub struct SharedSim(pub std::sync::Arc<std::sync::Mutex<SimHal>>);

impl SharedSim {
    /// Wraps a simulator.
    pub fn new(sim: SimHal) -> Self {
        SharedSim(std::sync::Arc::new(std::sync::Mutex::new(sim)))
    }

    /// Runs `f` on the simulator.
    pub fn with<R>(&self, f: impl FnOnce(&SimHal) -> R) -> R {
        f(&self.0.lock().unwrap_or_else(|p| p.into_inner()))
    }
}

impl Hal for SharedSim {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).read(frame)
    }

    fn write(&mut self, frame: &ActuatorFrame, dt_s: f64) -> Result<(), HalIoError> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).write(frame, dt_s)
    }

    fn device_health(&self, out: &mut [DeviceHealth]) {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).device_health(out)
    }
}
