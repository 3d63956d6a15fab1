//! From a request (which hidden causes, which record variant) to a record: draw the joint's
//! physics and the test program, size the hidden effects against the noise, simulate on a fine
//! grid, sample like a data logger (uniform or irregular time stamps, repetitions, binning),
//! add noise, quantise the deflection, and write down the answer.
//!
//! By stage: `request` (what to generate), `draw` (the set-up), `timeline` (the motion and its
//! simulation), `sizing` (effect sizes against the noise), `logging` (the record), `answer`
//! (the truth and the answer's parameters) and `drive` (the drive amplitudes of a test at
//! several levels). Shared here: the fixed steps and rates, and `Setup`.

use crate::excitation::Program;
use crate::model::Physics;
use std::collections::BTreeMap;
use std::f64::consts::PI;

mod answer;
mod draw;
mod drive;
mod logging;
mod request;
mod sizing;
mod timeline;

pub use answer::Truth;
pub use draw::{SetupError, draw_setup, draw_setup_retrying};
pub use drive::drive_levels;
pub use logging::{Meta, record};
pub use request::{ALL_CAUSES, Cause, Flags, Request, default_amplitudes, parse_effects};
pub use sizing::{lstsq, unexplained_rms};
pub use timeline::Timeline;

/// Internal simulation step [s] (4 kHz): at least twice the fastest sampling rate, and fine
/// enough that linear interpolation of the smooth motion is far below one encoder count.
pub const FINE_DT_S: f64 = 2.5e-4;
/// Step of the grid the effect sizes are computed on [s].
const SIZING_DT_S: f64 = 2.0e-3;
/// 14-bit absolute encoder count [rad].
pub const ENC14_STEP: f64 = 2.0 * PI / 16384.0;
/// 17-bit absolute encoder count [rad].
pub const ENC17_STEP: f64 = 2.0 * PI / 131072.0;
/// Linear encoder count [rad].
pub const LINEAR_STEP: f64 = 2.0e-6;
/// Uniform logger rates [Hz]: all have a whole number of microseconds per step.
const RATES_HZ: [f64; 8] = [200.0, 250.0, 400.0, 500.0, 800.0, 1000.0, 1250.0, 2000.0];
const EPOCH_BASE_US: i64 = 1_700_000_000_000_000;
/// Range of the median step of the test rig's logger (`rig550`) [s]: about 550 Hz.
const RIG_MEDIAN_DT_S: (f64, f64) = (1.75e-3, 1.85e-3);

/// The physical set-up of one device and one test program: everything but the logging.
#[derive(Clone, Debug)]
pub struct Setup {
    pub physics: Physics,
    pub program: Program,
    /// Motion amplitude [rad] and rest position [rad] (non-zero only for friction_position).
    pub amp_rad: f64,
    pub centre_rad: f64,
    pub v_max: f64,
    /// Uniform logger rate [Hz] (raw rate before binning).
    pub fs_hz: f64,
    /// Median step of irregular time stamps [s].
    pub irregular_dt_s: f64,
    /// Torque noise per raw sample: white std, coloured (Ornstein-Uhlenbeck) std and its
    /// time constant [Nm, Nm, s].
    pub noise_white: f64,
    pub noise_col: f64,
    pub noise_tau_s: f64,
    pub encoder_step: f64,
    /// Std of the sub-count dither before rounding, in counts (linear encoder flicker).
    pub flicker_counts: f64,
    pub causes: Vec<Cause>,
    pub models: BTreeMap<String, String>,
    /// Torque span [Nm] the noise and effects are scaled to (spring or friction span).
    pub span_nm: f64,
    pub friction_position: bool,
}

impl Setup {
    /// This set-up as a logging with `flags` reads it, for a device drawn without them: a
    /// linear encoder (2e-6 rad, 0.35-0.7 counts of flicker as `linear2e-6` draws) in place of
    /// the device's own, and the rig logger's median step. The physics, motion and noise stay.
    /// Draws nothing and changes nothing for other flags.
    pub fn relogged(&self, flags: &Flags, rng: &mut crate::rng::Rng) -> Setup {
        let mut s = self.clone();
        if flags.linear && s.encoder_step != LINEAR_STEP {
            s.encoder_step = LINEAR_STEP;
            s.flicker_counts = rng.range(0.35, 0.7);
        }
        if flags.rig_logger {
            s.irregular_dt_s = rng.range(RIG_MEDIAN_DT_S.0, RIG_MEDIAN_DT_S.1);
        }
        s
    }
}
