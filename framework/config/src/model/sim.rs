//! The simulated arm: drives, joints, elastic elements, environments and plant effects.

use super::*;

/// Settings of the simulated backend.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    /// Seed of every random process in the simulation (noise, frame loss).
    #[serde(default)]
    pub seed: u64,
    /// Standard deviation of absolute-encoder noise [rad]. Assumption: 0.
    #[serde(default, deserialize_with = "finite")]
    pub encoder_noise_rad: f64,
    /// Pass encoder readings through the 14-bit AS5048A frame codec (section 2.2), so that
    /// they are quantised to 2 pi / 16384 rad as on the robot.
    #[serde(default = "yes")]
    pub quantize_encoders: bool,
    /// Fraction of drive TPDO frames lost on the simulated CAN bus (appendix A), 0-1.
    #[serde(default, deserialize_with = "finite")]
    pub can_loss_rate: f64,
    /// What a lost frame becomes: `missing` (nothing arrives) or `zero` (appendix A's failure:
    /// the host read a lost encoder value as zero).
    #[serde(default)]
    pub can_loss_mode: CanLossMode,
    /// SPI latency [s]: readings are this old (section 2.3: about 15 ms). Default 0.
    #[serde(default, deserialize_with = "finite")]
    pub spi_latency_s: f64,
    /// CAN latency [s] (section 2.3: about 30 ms): set-points reach the drives this late, and
    /// the drives' readings are this old unless `can_feedback_latency_s` says otherwise. Default 0.
    #[serde(default, deserialize_with = "finite")]
    pub can_latency_s: f64,
    /// Age of the drives' readings [s] when it differs from the set-points' latency (`jointctl
    /// identify` measures the two apart on a closed-loop recording). Default: `can_latency_s`.
    #[serde(default)]
    pub can_feedback_latency_s: Option<f64>,
    /// Integration step of the simulated physics [s]. Assumption: 0.5 ms.
    #[serde(default = "default_substep", deserialize_with = "finite")]
    pub substep_s: f64,
    /// The simulated ELMO drives (section 3.2).
    #[serde(default)]
    pub elmo: ElmoConfig,
    /// A drive's own position-loop gains, by drive name (the rest from `elmo`): section 3.3.2's
    /// q5 has no compliant element, its compliance is its ELMO's proportional gain.
    #[serde(default)]
    pub drive_gains: std::collections::BTreeMap<String, DriveGainsConfig>,
}

/// One simulated drive's position-loop gains at the gearbox output.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DriveGainsConfig {
    /// Proportional gain [Nm/rad].
    #[serde(deserialize_with = "finite")]
    pub kp: f64,
    /// Integral gain [Nm/(rad s)] (0: the load shows as following error, as a spring).
    #[serde(deserialize_with = "finite")]
    pub ki: f64,
    /// Derivative gain [Nms/rad].
    #[serde(deserialize_with = "finite")]
    pub kd: f64,
}

fn default_substep() -> f64 {
    0.0005
}

/// The simulated ELMO drive (thesis section 3.2: a trapezoidal motion profile from the maximal
/// acceleration and velocity, deceleration started in time to avoid overshoot, followed by a
/// PID on the motor encoder). The thesis gives no gains: every default is an assumption.
/// Positions are at the gearbox output [rad].
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ElmoConfig {
    /// Profile velocity limit [rad/s]. Assumption: 3 rad/s.
    #[serde(deserialize_with = "finite")]
    pub max_velocity_rad_s: f64,
    /// Profile acceleration limit [rad/s^2]. Assumption: 30 rad/s^2.
    #[serde(deserialize_with = "finite")]
    pub max_acceleration_rad_s2: f64,
    /// PID proportional gain [Nm/rad]. Assumption: 4000.
    #[serde(deserialize_with = "finite")]
    pub kp: f64,
    /// PID integral gain [Nm/(rad s)]. Assumption: 20000.
    #[serde(deserialize_with = "finite")]
    pub ki: f64,
    /// PID derivative gain [Nms/rad]. Assumption: 80.
    #[serde(deserialize_with = "finite")]
    pub kd: f64,
    /// Motor + gearbox inertia at the gearbox output [kg m^2]. Assumption: 0.5.
    #[serde(deserialize_with = "finite")]
    pub inertia_kgm2: f64,
    /// Torque (current) limit at the gearbox output [Nm]. Assumption: 150 Nm.
    #[serde(deserialize_with = "finite")]
    pub torque_limit_nm: f64,
    /// Eq. 3.5 gear friction `k_a atan(k_b omega)`: k_a [Nm]. Assumption: 0.5.
    #[serde(deserialize_with = "finite")]
    pub friction_ka_nm: f64,
    /// Eq. 3.5: k_b [s/rad]. Assumption: 50.
    #[serde(deserialize_with = "finite")]
    pub friction_kb_s_per_rad: f64,
}


impl Default for ElmoConfig {
    fn default() -> Self {
        ElmoConfig {
            max_velocity_rad_s: 3.0,
            max_acceleration_rad_s2: 30.0,
            kp: 4000.0,
            ki: 20000.0,
            kd: 80.0,
            inertia_kgm2: 0.5,
            torque_limit_nm: 150.0,
            friction_ka_nm: 0.5,
            friction_kb_s_per_rad: 50.0,
        }
    }
}

/// How a joint is simulated (YAML `sim:` of a joint). Without it, the joint's encoders follow
/// its drives kinematically (`buses.spi[].encoders[].sim`).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JointSimConfig {
    /// The drives moving this joint, in the columns' order of `matrix`.
    pub drives: Vec<String>,
    /// Per DOF, the motor-side joint angle `theta = sum(matrix[dof][i] * drive_i)` [rad/rad]: the
    /// joint's transmission (eq. 3.1 ratio 2 for the elbow, eq. 3.3 for the shoulder, eq. 3.7
    /// with the eq. 3.8 ratio for the wrist).
    pub matrix: Vec<Vec<f64>>,
    /// The elastic element between theta and the output, the same for every DOF...
    #[serde(default)]
    pub element: Option<ElementSimConfig>,
    /// ... or one per DOF (the shoulder: q2's VSA and rigid q3). A `wrist_table` covers both
    /// of its DOFs and stands alone.
    #[serde(default)]
    pub elements: Vec<ElementSimConfig>,
    /// Where the VSA's pivot is: `pivot_mm = offset_mm + mm_per_rad * drive`.
    #[serde(default)]
    pub pivot: Option<PivotSimConfig>,
    /// What the output is attached to, the same for every DOF...
    #[serde(default)]
    pub environment: Option<EnvironmentConfig>,
    /// ... or one per DOF.
    #[serde(default)]
    pub environments: Vec<EnvironmentConfig>,
    /// Plant effects the observer does not model, each off unless given...
    #[serde(default)]
    pub effects: EffectsConfig,
    /// ... or one set per DOF (the wrist's q6 and q7 each their own), in place of `effects`...
    #[serde(default)]
    pub effects_per_dof: Vec<EffectsConfig>,
    /// ... or, for a joint with a `pivot`, one set (or one set per DOF) per pivot setting in
    /// increasing `pivot_mm` order, in place of both: every DOF's effects at the current pivot are interpolated
    /// linearly between the two settings around it (the nearest beyond the first or last), as
    /// the characteristic's curves are. An effect at one setting and not the next fades out
    /// between them (its size to zero: a loop's limit and rest stiffness, a friction's `k_a`, a
    /// mode's gain). What `jointctl identify` writes for a cause whose size changes with the
    /// setting.
    #[serde(default)]
    pub effects_by_pivot: Vec<PivotEffectsConfig>,
}

/// The plant effects at one pivot setting (`sim.effects_by_pivot`).
#[derive(Clone, Debug, Deserialize, JsonSchema, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PivotEffectsConfig {
    /// The setting [mm].
    pub pivot_mm: f64,
    /// The effects there, for every DOF...
    #[serde(default)]
    pub effects: EffectsConfig,
    /// ... or one set per DOF there (the wrist's q6 and q7 each their own).
    #[serde(default)]
    pub effects_per_dof: Vec<EffectsConfig>,
}

impl PivotEffectsConfig {
    /// DOF `dof`'s set at this setting.
    pub fn of_dof(&self, dof: usize) -> EffectsConfig {
        self.effects_per_dof.get(dof).copied().unwrap_or(self.effects)
    }
}

/// The elastic element, e.g. `{kind: linear, stiffness_nm_per_rad: 113.78}` or `{kind: rigid}`.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ElementSimConfig {
    /// Rigid (theta is the output); a clamped output then holds the drives too.
    Rigid,
    /// `tau = K delta`.
    Linear {
        /// K [Nm/rad].
        stiffness_nm_per_rad: f64,
    },
    /// The characteristic in the joint's `params.characteristic` (the same table the observer
    /// uses), 1-DOF over pivot settings.
    PivotTable,
    /// The 2-DOF wrist characteristic in `params.characteristic` (q6, q7).
    WristTable,
    /// The lever-arm VSA itself (section 2.4): eq. 2.1-2.4 without eq. 2.5's small-deflection
    /// step, `tau = K(pivot) sin(delta) cos(delta)` with eq. 2.6's K, after a smooth play of
    /// `dead_zone_rad` and with the negative branch scaled (figures 3.14-3.16 show both). A
    /// plant that is not the observer's table: the table is fitted to recordings of it.
    LeverArm {
        /// Lever length l [m].
        lever_length_m: f64,
        /// Crank R [m].
        crank_radius_m: f64,
        /// Spring k_s [N/m].
        spring_n_per_m: f64,
        /// Pivot q at setting 0 mm [m].
        pivot_offset_m: f64,
        /// Half-width of the play around zero deflection [rad] (0: none).
        #[serde(default)]
        dead_zone_rad: f64,
        /// Negative-branch torque over the positive one's at the same |deflection| (1: symmetric).
        #[serde(default = "one")]
        negative_branch_scale: f64,
    },
    /// The wrist's lever-arm VSA acting on both DOFs (q6, q7; section 3.5): the deflection
    /// vector's length `r` along direction `theta` (0 = q7 only, 90 deg = q6 only) meets
    /// `K(pivot) (1 + anisotropy cos 2 theta) sin(r) cos(r)` after the play, along the same
    /// direction; the plant the wrist's table is fitted to.
    WristLeverArm {
        /// Lever length l [m].
        lever_length_m: f64,
        /// Crank R [m].
        crank_radius_m: f64,
        /// Spring k_s [N/m].
        spring_n_per_m: f64,
        /// Pivot q at setting 0 mm [m].
        pivot_offset_m: f64,
        /// Half-width of the play around zero deflection [rad] (0: none).
        #[serde(default)]
        dead_zone_rad: f64,
        /// Negative-branch torque over the positive one's (1: symmetric).
        #[serde(default = "one")]
        negative_branch_scale: f64,
        /// Relative stiffness change with the direction, `a` in `1 + a cos 2 theta` (0: isotropic).
        #[serde(default)]
        anisotropy: f64,
    },
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

fn one() -> f64 {
    1.0
}

/// Pivot position of a simulated VSA.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PivotSimConfig {
    /// The pivot drive.
    pub drive: String,
    /// [mm/rad]
    pub mm_per_rad: f64,
    /// [mm]
    pub offset_mm: f64,
}

/// What a simulated joint's output is attached to, e.g. `{kind: fixed, position_rad: 0}` or
/// `{kind: free, inertia_kgm2: 0.3}`.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum EnvironmentConfig {
    /// Clamped (the thesis' validation set-ups, figures 5.1, 5.14).
    Fixed {
        /// Where [rad].
        #[serde(default)]
        position_rad: f64,
    },
    /// A free link.
    Free {
        /// Output inertia [kg m^2].
        inertia_kgm2: f64,
        /// Output damping [Nms/rad].
        #[serde(default)]
        damping_nms_per_rad: f64,
        /// Gravity torque amplitude `m g l` [Nm] (torque `-mgl sin(q)`); 0: none.
        #[serde(default)]
        gravity_nm: f64,
    },
    /// A joint of the free arm: the arm of `kinematics.urdf`, its links loading each other under
    /// gravity and through their motion (coupled rigid-body dynamics, not one link per joint).
    /// The arm's joints that are not `free_arm` stay where their own environment puts them
    /// (clamped: `fixed`).
    FreeArm {
        /// Viscous damping at the joint's output [Nms/rad] (bearings, seals).
        #[serde(default)]
        damping_nms_per_rad: f64,
        /// Inertia added at the joint's output beyond its links' [kg m^2] (the gear's output
        /// side, Pinocchio's armature).
        #[serde(default)]
        armature_kgm2: f64,
    },
    /// A spring contact (the environment as a spring) on a link.
    Spring {
        /// Contact stiffness [Nm/rad].
        stiffness_nm_per_rad: f64,
        /// Where the contact is at rest [rad].
        rest_rad: f64,
        /// Output inertia [kg m^2].
        inertia_kgm2: f64,
        /// Damping [Nms/rad].
        #[serde(default)]
        damping_nms_per_rad: f64,
    },
    /// The output moved by a flow source (sections 3.3.1, 3.4.1, 3.5.1: characterisation), a
    /// sine of this amplitude [rad] and frequency [Hz] per DOF, along `angle_deg` for the wrist.
    Flow {
        /// Amplitude [rad].
        amplitude_rad: f64,
        /// Frequency [Hz].
        frequency_hz: f64,
        /// Deflection direction for a 2-DOF joint [deg] (0 = the second DOF only, 90 = the first).
        #[serde(default)]
        angle_deg: f64,
        /// The source starts moving at this simulated time [s] (the joint at rest before).
        #[serde(default)]
        start_s: f64,
    },
}

/// Plant effects the observer does not model (all off by default).
#[derive(Clone, Copy, Debug, Default, Deserialize, JsonSchema, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EffectsConfig {
    /// Viscous friction in the element [Nms/rad].
    #[serde(default)]
    pub viscous_nms_per_rad: f64,
    /// Eq. 3.5's arctan friction on the element's deflection rate: `k_a atan(k_b d(delta)/dt)`
    /// (Coulomb-like beyond `1 / k_b` rad/s, the gear friction the thesis models).
    #[serde(default)]
    pub arctan_friction: Option<ArctanFrictionConfig>,
    /// Dahl hysteresis: `dz/dt = sigma (1 - z/fc sgn(v)) v`, torque `z` [Nm] (with a `shape`, see
    /// [`DahlConfig`]).
    #[serde(default)]
    pub hysteresis: Option<DahlConfig>,
    /// Dead-zone (play) half-width around zero deflection [rad].
    #[serde(default)]
    pub dead_zone_rad: f64,
    /// The band on either side of `dead_zone_rad` over which the contact stiffens [rad], at most
    /// `dead_zone_rad` (0: the play is taken up at once; `jointctl_models::play`).
    #[serde(default)]
    pub dead_zone_ramp_rad: f64,
    /// Stiffness non-linearity: `+ k3 delta^3` [Nm/rad^3].
    #[serde(default)]
    pub cubic_nm_per_rad3: f64,
    /// A structural mode seen by the torque sensor [Hz, ratio, Nm per Nm of element torque].
    #[serde(default)]
    pub vibration: Option<VibrationConfig>,
    /// Offset of the torque sensor [Nm].
    #[serde(default)]
    pub torque_offset_nm: f64,
    /// Standard deviation of the torque sensor noise [Nm].
    #[serde(default)]
    pub torque_noise_nm: f64,
}

/// Eq. 3.5: `F = k_a atan(k_b w)`.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArctanFrictionConfig {
    /// `k_a` [Nm] (the friction torque tends to `k_a pi / 2`).
    pub k_a_nm: f64,
    /// `k_b` [s/rad].
    pub k_b_s_per_rad: f64,
}

/// Dahl hysteresis parameters.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DahlConfig {
    /// Rest stiffness sigma [Nm/rad].
    pub sigma_nm_per_rad: f64,
    /// Limit torque fc [Nm].
    pub limit_nm: f64,
    /// Shape exponent n (>= 1; 1, the default: Dahl's model): `z/fc` in the rate becomes
    /// `(z/fc) |z/fc|^(n-1)`, a loop that turns sharper at its limit (Bouc-Wen with beta = 1,
    /// gamma = 0; the observer's `model_extension.hysteresis.shape` is the same exponent).
    #[serde(default = "one")]
    pub shape: f64,
    /// The pre-sliding damping's time constant `tau_d` [s] (0, the default: none): the loop adds
    /// `tau_d dz/dt`, LuGre's `sigma1 dz/dt` with `sigma1 = sigma tau_d` (the observer's
    /// `model_extension.hysteresis.presliding_damping_s` is the same constant).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub presliding_damping_s: f64,
}

/// A structural vibration mode.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VibrationConfig {
    /// Mode frequency [Hz].
    pub frequency_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Excitation: mode torque per element torque change [-].
    pub gain: f64,
    /// When given, `frequency_hz` is the mode's frequency at this element stiffness [Nm/rad],
    /// and the mode follows the element as a spring with the link: `f = frequency_hz *
    /// sqrt(K / reference)`, K the element's stiffness at the current pivot setting (a VSA's
    /// softer settings ring lower, nearer the loop's band: the thesis saw the shoulder ring at low
    /// stiffness, section 3.4.2).
    #[serde(default)]
    pub reference_stiffness_nm_per_rad: Option<f64>,
}

/// What a lost simulated CAN frame becomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CanLossMode {
    /// Nothing arrives.
    #[default]
    Missing,
    /// A frame with an all-zero position arrives (thesis appendix A).
    Zero,
}



impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            seed: 0,
            encoder_noise_rad: 0.0,
            quantize_encoders: true,
            can_loss_rate: 0.0,
            can_loss_mode: CanLossMode::Missing,
            spi_latency_s: 0.0,
            can_latency_s: 0.0,
            can_feedback_latency_s: None,
            substep_s: default_substep(),
            elmo: ElmoConfig::default(),
            drive_gains: Default::default(),
        }
    }
}
