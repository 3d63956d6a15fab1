//! What a DOF can be asked to do: the modes a command selects.

use crate::{Reference, Trajectory};

/// What a DOF is asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant, reason = "a trajectory lives inline so that switching modes never allocates in the loop")]
pub enum Mode {
    /// Keep the drives where they are.
    Hold,
    /// Go to a joint position with the position feedback PI (section 4.3).
    Position {
        /// [rad]
        target_rad: f64,
    },
    /// Direct joint set-points (the thesis' dynamic-reconfigure GUI), through the feedback PI
    /// unless `controller.manual_position_feedback` is false (section 4.3).
    Manual {
        /// [rad]
        target_rad: f64,
    },
    /// Follow a time-stamped trajectory started at `start_s`.
    Trajectory {
        /// The points.
        trajectory: Trajectory,
        /// Runtime time at which the trajectory's time 0 is [s].
        start_s: f64,
    },
    /// Figure 4.6: regulate the deflection so that the observed torque follows `reference` [Nm].
    Torque {
        /// The torque reference.
        reference: Reference,
    },
    /// Section 1.2: `tau_ref = K (q_d - q) - D dq/dt`, realised through the torque mode.
    Impedance {
        /// K_d [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// D_d [Nms/rad].
        damping_nms_per_rad: f64,
        /// q_d [rad].
        target_rad: f64,
    },
}

impl Mode {
    /// A short name.
    pub fn name(&self) -> &'static str {
        match self {
            Mode::Hold => "hold",
            Mode::Position { .. } => "position",
            Mode::Manual { .. } => "manual",
            Mode::Trajectory { .. } => "trajectory",
            Mode::Torque { .. } => "torque",
            Mode::Impedance { .. } => "impedance",
        }
    }
}
