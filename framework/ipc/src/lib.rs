//! # jointctl-ipc
//!
//! The shared-memory contract of a running arm, used by the runtime (publisher) and by every
//! inspector (subscribers), so that both sides always agree on types, names and QoS.
//!
//! Services per arm (`<arm>` is the YAML `arm:` name):
//! - `<arm>/joint_state`: one [`ArmState`] per cycle;
//! - `<arm>/diagnostics`: one [`Diagnostics`] per cycle;
//! - `<arm>/raw`, `<arm>/raw_descriptor`, `<arm>/commands`: what the loop read and wrote, and the
//!   commands it accepted ([`raw`]);
//! - `<arm>/command`: requests (request-response).
//!
//! Payloads are `#[repr(C)]` with a versioned iceoryx2 type name (`jointctl.ArmState.v4`), so that
//! iceoryx2 clients in other languages (its Python package) can open them: iceoryx2 compares type
//! name, size and alignment but not field order, hence the version in the name. Every process of
//! one arm builds its iceoryx2 config with [`iceoryx2_config_in`] rather than looking for a config
//! file relative to its working directory, so that all of them meet in one domain.

#![forbid(unsafe_code)]

pub mod access;

use iceoryx2::config::Config;
use iceoryx2::node::NodeCreationFailure;
use iceoryx2::service::service_name::ServiceNameError;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError;
use iceoryx2::service::builder::request_response::{RequestResponseOpenError, RequestResponseOpenOrCreateError};
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

pub use jointctl_api::FieldMask;

/// Most joint DOFs in one sample: the most DOFs an arm description may have (the config
/// validates against the same constant, so the two cannot drift apart).
pub const MAX_JOINTS: usize = jointctl_api::MAX_ARM_DOF;
/// Bytes of a joint name in a sample (NUL-padded).
pub const NAME_LEN: usize = 16;

// A joint name the config accepts always fits its field with the NUL.
const _: () = assert!(jointctl_api::MAX_JOINT_NAME < NAME_LEN);

/// Bytes of a device name field (NUL-padded).
pub const DEVICE_NAME_LEN: usize = 48;

// A device name the config accepts always fits its field with the NUL.
const _: () = assert!(jointctl_api::MAX_DEVICE_NAME < DEVICE_NAME_LEN);

/// Declares a `#[repr(C)]` `u32` newtype with named values, `ALL` (every value with its name,
/// for clients in other languages too), `name()` and `from_name()`.
///
/// Newtypes rather than Rust `enum`s: a subscriber reads them from memory another process
/// wrote, and an `enum` holding a value outside its variants would be undefined behaviour;
/// here an unknown value is just named `"unknown"`.
macro_rules! named_codes {
    ($(#[$doc:meta])* $ty:ident { $($(#[$vdoc:meta])* $konst:ident = $value:literal, $name:literal;)+ }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, ZeroCopySend)]
        #[repr(C)]
        pub struct $ty(pub u32);

        impl $ty {
            $($(#[$vdoc])* pub const $konst: $ty = $ty($value);)+
            /// Every value with its name, in code order.
            pub const ALL: &'static [($ty, &'static str)] = &[$(($ty::$konst, $name)),+];

            /// The value's lower-case name, `"unknown"` for a value outside `ALL`.
            pub fn name(self) -> &'static str {
                Self::ALL.iter().find(|(m, _)| *m == self).map_or("unknown", |(_, n)| n)
            }

            /// The value with this name.
            pub fn from_name(name: &str) -> Option<$ty> {
                Self::ALL.iter().find(|(_, n)| *n == name).map(|(m, _)| *m)
            }
        }
    };
}

pub mod raw;

named_codes! {
    /// A joint DOF's control mode, as published in [`JointSample::mode`].
    ///
    /// ```
    /// use jointctl_ipc::JointMode;
    /// assert_eq!(JointMode::TORQUE.name(), "torque");
    /// assert_eq!(JointMode::from_name("impedance"), Some(JointMode::IMPEDANCE));
    /// assert_eq!(JointMode(99).name(), "unknown");
    /// ```
    JointMode {
        /// Holding the drives where they are.
        HOLD = 0, "hold";
        /// Position control with the feedback PI (section 4.3).
        POSITION = 1, "position";
        /// A direct joint set-point.
        MANUAL = 2, "manual";
        /// Following a time-stamped trajectory.
        TRAJECTORY = 3, "trajectory";
        /// Torque control (figure 4.6).
        TORQUE = 4, "torque";
        /// Impedance control through the torque mode.
        IMPEDANCE = 5, "impedance";
    }
}

named_codes! {
    /// The waveform of a torque reference in a [`CommandRequest`] (chapter 5's step, sine and
    /// cosine).
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::TorqueWaveform::COSINE.name(), "cosine");
    /// ```
    TorqueWaveform {
        /// A step of `amplitude` at the start time.
        STEP = 0, "step";
        /// `amplitude * sin(2 pi f t)`.
        SINE = 1, "sine";
        /// `amplitude * cos(2 pi f t)`.
        COSINE = 2, "cosine";
    }
}

named_codes! {
    /// What a [`CommandRequest`] asks for.
    ///
    /// ```
    /// assert_eq!(jointctl_ipc::CommandKind::STIFFNESS.name(), "stiffness");
    /// ```
    CommandKind {
        /// Hold one joint (`joint` set) or all joints (`joint` empty).
        HOLD = 1, "hold";
        /// Position control to `values[0]` [rad], with the position feedback PI.
        POSITION = 2, "position";
        /// Direct joint set-point `values[0]` [rad] (no feedback PI).
        MANUAL = 3, "manual";
        /// Follow `points[..point_count]` = (time [s], position [rad], velocity [rad/s] or NaN).
        TRAJECTORY = 4, "trajectory";
        /// Torque reference of [`CommandRequest::waveform`]: `values` = [amplitude [Nm],
        /// frequency [Hz], offset [Nm], start delay [s]].
        TORQUE = 5, "torque";
        /// Impedance: `values` = [K [Nm/rad], D [Nms/rad], target [rad] or NaN for "where it is"].
        IMPEDANCE = 6, "impedance";
        /// Requested stiffness `values[0]` [Nm/rad] (variable stiffness joints).
        STIFFNESS = 7, "stiffness";
        /// Enable a joint (it accepts commands again, starting in hold).
        ENABLE = 8, "enable";
        /// Disable a joint: it holds and refuses commands until enabled.
        DISABLE = 9, "disable";
        /// Stop the runtime (as SIGINT: joints held, final state published).
        STOP = 10, "stop";
    }
}

/// Upper bounds [us] of the cycle-jitter histogram buckets in [`Diagnostics`].
pub const JITTER_BUCKET_UPPER_US: [u64; 16] =
    [1, 2, 5, 10, 20, 50, 100, 200, 500, 1_000, 2_000, 5_000, 10_000, 20_000, 50_000, u64::MAX];

/// A name in a fixed-size, NUL-padded field of `N` bytes ([`NAME_LEN`] for joints,
/// [`DEVICE_NAME_LEN`] for devices); at most `N - 1` bytes are kept.
///
/// ```
/// let n: [u8; jointctl_ipc::NAME_LEN] = jointctl_ipc::encode_name("q2");
/// assert_eq!(jointctl_ipc::decode_name(&n), "q2");
/// let d: [u8; jointctl_ipc::DEVICE_NAME_LEN] = jointctl_ipc::encode_name("enc_shoulder_pulley_a");
/// assert_eq!(jointctl_ipc::decode_name(&d), "enc_shoulder_pulley_a");
/// ```
pub fn encode_name<const N: usize>(name: &str) -> [u8; N] {
    let mut out = [0u8; N];
    // The last byte stays NUL: readers may treat the field as a C string.
    jointctl_api::abi::copy_utf8_prefix(&mut out[..N - 1], name);
    out
}

/// The text of a fixed-size name field.
pub fn decode_name<const N: usize>(bytes: &[u8; N]) -> &str {
    let end = bytes.iter().position(|b| *b == 0).unwrap_or(N);
    core::str::from_utf8(&bytes[..end]).unwrap_or("?")
}

/// One joint DOF's observed state in SI units. A field whose bit in `valid_mask` is clear is
/// unknown (its value is NaN).
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct JointSample {
    /// NUL-padded joint name.
    pub name: [u8; NAME_LEN],
    /// Joint position [rad].
    pub position_rad: f64,
    /// Joint velocity [rad/s].
    pub velocity_rad_s: f64,
    /// Deflection of the elastic element [rad].
    pub deflection_rad: f64,
    /// Joint torque [Nm].
    pub torque_nm: f64,
    /// Joint stiffness [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// VSA pivot position [mm].
    pub pivot_mm: f64,
    /// The torque reference in use [Nm] (torque and impedance modes), NaN otherwise.
    pub reference_torque_nm: f64,
    /// The torque its force/torque sensor measures [Nm] (the joint's `torque_sensor`; for
    /// validation and recording, never used by the observer), NaN when it has none or the
    /// reading is not usable this cycle.
    pub sensor_torque_nm: f64,
    /// The torque that holds the arm against gravity at the observed pose [Nm] (the arm's URDF,
    /// `kinematics`; appendix C), NaN when the arm has none or a position of the chain is
    /// unknown. Torque and impedance references are beyond it when the DOF's controller has
    /// `gravity_feedforward`.
    pub gravity_nm: f64,
    /// [`FieldMask`] bits of the observed fields.
    pub valid_mask: u32,
    /// 0, or the fault that holds this joint (1 = its plugin panicked; >= 16 plugin codes).
    pub fault_code: u32,
    /// Control mode.
    pub mode: JointMode,
    /// 1 when the joint accepts commands (not disabled).
    pub enabled: u32,
}

impl JointSample {
    /// An unnamed, unobserved joint.
    pub const EMPTY: JointSample = JointSample {
        name: [0; NAME_LEN],
        position_rad: f64::NAN,
        velocity_rad_s: f64::NAN,
        deflection_rad: f64::NAN,
        torque_nm: f64::NAN,
        stiffness_nm_per_rad: f64::NAN,
        pivot_mm: f64::NAN,
        reference_torque_nm: f64::NAN,
        sensor_torque_nm: f64::NAN,
        gravity_nm: f64::NAN,
        valid_mask: 0,
        fault_code: 0,
        mode: JointMode::HOLD,
        enabled: 1,
    };

    /// The value of a field if its bit is set in `valid_mask`.
    ///
    /// ```
    /// use jointctl_ipc::{FieldMask, JointSample};
    /// let mut s = JointSample::EMPTY;
    /// s.torque_nm = 2.0;
    /// assert_eq!(s.get(FieldMask::TORQUE, s.torque_nm), None);
    /// s.valid_mask = FieldMask::TORQUE;
    /// assert_eq!(s.get(FieldMask::TORQUE, s.torque_nm), Some(2.0));
    /// ```
    pub fn get(&self, bit: u32, value: f64) -> Option<f64> {
        (self.valid_mask & bit != 0).then_some(value)
    }
}

/// Every joint of the arm, once per cycle.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.ArmState.v4")]
pub struct ArmState {
    /// Cycle counter, from 0 at start.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// Number of valid entries in `joints`.
    pub joint_count: u32,
    /// 1 in the final sample published at shutdown.
    pub final_sample: u32,
    /// The joints, in YAML order.
    pub joints: [JointSample; MAX_JOINTS],
}

impl ArmState {
    /// An empty sample.
    pub const EMPTY: ArmState =
        ArmState { cycle: 0, stamp_ns: 0, joint_count: 0, final_sample: 0, joints: [JointSample::EMPTY; MAX_JOINTS] };

    /// The valid joints.
    pub fn joints(&self) -> &[JointSample] {
        &self.joints[..(self.joint_count as usize).min(MAX_JOINTS)]
    }
}

/// Health of one joint DOF.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct JointDiagnostics {
    /// NUL-padded joint name.
    pub name: [u8; NAME_LEN],
    /// [`FieldMask`] bits observed this cycle.
    pub valid_mask: u32,
    /// Current fault code (0 = none).
    pub fault_code: u32,
    /// 1 when the runtime held this joint this cycle (fault or unusable state).
    pub held: u32,
    _reserved: u32,
    /// Cycles in which the joint's state was unusable and the joint was held.
    pub invalid_cycles: u64,
    /// Faults raised by the joint's plugin (panics, fault codes).
    pub fault_count: u64,
    /// Joint set-points clamped into the position limits.
    pub setpoint_clamps: u64,
    /// Torque references clamped into the torque limit.
    pub torque_clamps: u64,
    /// Cycles whose set-point change the rate limit cut.
    pub rate_limited: u64,
    /// Streamed commands that timed out (the joint fell back to holding).
    pub watchdog_trips: u64,
    /// Cycles held because the mode needed an unknown value (torque, stiffness, velocity).
    pub missing_inputs: u64,
    /// The joint's plugin: its time budget per cycle [ns].
    pub plugin_budget_ns: u64,
    /// The joint's plugin: most time it took in one cycle (observe + control) [ns].
    pub plugin_max_ns: u64,
    /// Cycles the joint's plugin was over its budget (faulting or not).
    pub over_budget_cycles: u64,
    /// Cycles whose motor set-points the runtime's check refused (not finite, outside the
    /// drive's window, too fast); the first faults the joint.
    pub setpoint_rejections: u64,
    /// NUL-padded reason of the fault that holds the joint (its plugin's message, or the
    /// runtime's), empty when none.
    pub fault_message: [u8; FAULT_MESSAGE_LEN],
}

/// Longest fault reason in [`JointDiagnostics`] [bytes, NUL included].
pub const FAULT_MESSAGE_LEN: usize = 128;

impl JointDiagnostics {
    /// An unnamed entry.
    pub const EMPTY: JointDiagnostics = JointDiagnostics {
        name: [0; NAME_LEN],
        valid_mask: 0,
        fault_code: 0,
        held: 0,
        _reserved: 0,
        invalid_cycles: 0,
        fault_count: 0,
        setpoint_clamps: 0,
        torque_clamps: 0,
        rate_limited: 0,
        watchdog_trips: 0,
        missing_inputs: 0,
        plugin_budget_ns: 0,
        plugin_max_ns: 0,
        over_budget_cycles: 0,
        setpoint_rejections: 0,
        fault_message: [0; FAULT_MESSAGE_LEN],
    };
}

/// Most devices (drives and encoders) in diagnostics.
pub const MAX_DEVICES: usize = 32;

/// Health of one device (drive or encoder): what the HAL did not use, and why.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct DeviceDiagnostics {
    /// NUL-padded device name, whole (see [`jointctl_api::MAX_DEVICE_NAME`]).
    pub name: [u8; DEVICE_NAME_LEN],
    /// Cycles in which nothing arrived (lost or late frames).
    pub missing: u64,
    /// Frames that failed their checks (parity, error flag, silent node).
    pub invalid: u64,
    /// Values rejected as implausible (jumps, zeros after non-zero readings).
    pub implausible: u64,
    /// Emergency messages.
    pub emcy: u64,
    /// 1 silent, 2 fault, 4 bus-off, 8 error-passive.
    pub flags: u32,
    _reserved: u32,
}

impl DeviceDiagnostics {
    /// An unnamed entry.
    pub const EMPTY: DeviceDiagnostics =
        DeviceDiagnostics { name: [0; DEVICE_NAME_LEN], missing: 0, invalid: 0, implausible: 0, emcy: 0, flags: 0, _reserved: 0 };
}

/// Loop health, once per cycle.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.Diagnostics.v4")]
pub struct Diagnostics {
    /// Cycle counter.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle [ns].
    pub stamp_ns: u64,
    /// Nominal period [ns].
    pub period_ns: u64,
    /// Cycles whose work ended after the next deadline.
    pub overruns: u64,
    /// Deadlines skipped because a cycle overran.
    pub missed_deadlines: u64,
    /// HAL read/write failures.
    pub hal_errors: u64,
    /// Cycle records the publisher thread could not keep up with (dropped, never blocking the loop).
    pub publish_drops: u64,
    /// Compute time (read to write) of the last cycle [ns].
    pub last_compute_ns: u64,
    /// Longest compute time so far [ns].
    pub max_compute_ns: u64,
    /// Largest wake-up lateness so far [ns].
    pub max_jitter_ns: u64,
    /// Wake-up lateness histogram, buckets bounded by [`JITTER_BUCKET_UPPER_US`].
    pub jitter_histogram: [u64; 16],
    /// Number of valid entries in `joints`.
    pub joint_count: u32,
    _reserved: u32,
    /// Per-joint health, in the order of [`ArmState::joints`].
    pub joints: [JointDiagnostics; MAX_JOINTS],
    /// Number of valid entries in `devices`.
    pub device_count: u32,
    _reserved2: u32,
    /// Per-device health: drives, then encoders, in YAML order.
    pub devices: [DeviceDiagnostics; MAX_DEVICES],
}

impl Diagnostics {
    /// An empty sample.
    pub const EMPTY: Diagnostics = Diagnostics {
        cycle: 0,
        stamp_ns: 0,
        period_ns: 0,
        overruns: 0,
        missed_deadlines: 0,
        hal_errors: 0,
        publish_drops: 0,
        last_compute_ns: 0,
        max_compute_ns: 0,
        max_jitter_ns: 0,
        jitter_histogram: [0; 16],
        joint_count: 0,
        _reserved: 0,
        joints: [JointDiagnostics::EMPTY; MAX_JOINTS],
        device_count: 0,
        _reserved2: 0,
        devices: [DeviceDiagnostics::EMPTY; MAX_DEVICES],
    };
}

/// Longest plugin name or version in a [`JointDescriptor`] [bytes, NUL included].
pub const LABEL_LEN: usize = 64;

/// One plugin instance of the arm: what `ros2 control list_controllers` would list.
#[derive(Clone, Copy, Debug, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct JointDescriptor {
    /// NUL-padded instance name (the YAML's `joints[].name`).
    pub name: [u8; NAME_LEN],
    /// NUL-padded plugin name.
    pub plugin: [u8; LABEL_LEN],
    /// NUL-padded plugin crate version.
    pub version: [u8; LABEL_LEN],
    /// NUL-padded path of the plugin's library; empty when it is linked into the host.
    pub library: [u8; raw::PATH_LEN],
    /// Index of its first DOF in [`ArmState::joints`].
    pub first_dof: u32,
    /// Number of DOFs it serves.
    pub dof_count: u32,
    /// Time its plugin may take per cycle, observe and control together [ns].
    pub budget_ns: u64,
}

impl JointDescriptor {
    /// An unnamed entry.
    pub const EMPTY: JointDescriptor =
        JointDescriptor { name: [0; NAME_LEN], plugin: [0; LABEL_LEN], version: [0; LABEL_LEN], library: [0; raw::PATH_LEN], first_dof: 0, dof_count: 0, budget_ns: 0 };
}

/// The arm's plugin instances, published once at start and kept for late readers.
///
/// ```
/// use jointctl_ipc::{JointDescriptor, JointsDescriptor, decode_name, encode_name};
/// let mut d = JointsDescriptor::EMPTY;
/// d.joints[0] = JointDescriptor { name: encode_name("q4"), plugin: encode_name("elastic"), dof_count: 1, ..JointDescriptor::EMPTY };
/// d.joint_count = 1;
/// assert_eq!(decode_name(&d.joints()[0].plugin), "elastic");
/// ```
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.JointsDescriptor.v1")]
pub struct JointsDescriptor {
    /// Nominal loop rate [Hz].
    pub rate_hz: f64,
    /// Number of valid entries in `joints`.
    pub joint_count: u32,
    _reserved: u32,
    /// The plugin instances, in YAML order (at most one per DOF).
    pub joints: [JointDescriptor; MAX_JOINTS],
}

impl JointsDescriptor {
    /// An empty descriptor.
    pub const EMPTY: JointsDescriptor = JointsDescriptor { rate_hz: 0.0, joint_count: 0, _reserved: 0, joints: [JointDescriptor::EMPTY; MAX_JOINTS] };

    /// The valid entries.
    pub fn joints(&self) -> &[JointDescriptor] {
        &self.joints[..(self.joint_count as usize).min(MAX_JOINTS)]
    }
}

/// The service names of one arm.
///
/// ```
/// let n = jointctl_ipc::ServiceNames::for_arm("sherpa");
/// assert_eq!(n.joint_state, "sherpa/joint_state");
/// assert_eq!(n.raw, "sherpa/raw");
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ServiceNames {
    /// [`ArmState`] publish-subscribe service.
    pub joint_state: String,
    /// [`Diagnostics`] publish-subscribe service.
    pub diagnostics: String,
    /// [`raw::RawFrame`] publish-subscribe service.
    pub raw: String,
    /// [`raw::RawDescriptor`] publish-subscribe service (one sample, kept).
    pub raw_descriptor: String,
    /// [`raw::CommandRecord`] publish-subscribe service: the accepted commands.
    pub commands: String,
    /// [`JointsDescriptor`] publish-subscribe service (one sample, kept).
    pub joints: String,
}

impl ServiceNames {
    /// Names derived from the arm's name.
    pub fn for_arm(arm: &str) -> Self {
        ServiceNames {
            joint_state: format!("{arm}/joint_state"),
            diagnostics: format!("{arm}/diagnostics"),
            raw: format!("{arm}/raw"),
            raw_descriptor: format!("{arm}/raw_descriptor"),
            commands: format!("{arm}/commands"),
            joints: format!("{arm}/joints"),
        }
    }
}

/// Failure to set up shared memory; iceoryx2's own error is kept as the source.
///
/// ```
/// let e = jointctl_ipc::create_node(Some("bad/domain"), "n").unwrap_err();
/// assert!(matches!(e, jointctl_ipc::IpcSetupError::Domain { .. }));
/// assert!(std::error::Error::source(&e).is_some());
/// ```
#[derive(Debug, thiserror::Error)]
pub enum IpcSetupError {
    /// The iceoryx2 domain name is not usable as a file prefix.
    #[error("iceoryx2 domain `{domain}` is not valid")]
    Domain {
        /// The domain.
        domain: String,
        /// iceoryx2's reason.
        source: SemanticStringError,
    },
    /// The node name is not valid.
    #[error("`{node}` is not a valid iceoryx2 node name")]
    NodeName {
        /// Node name.
        node: String,
        /// iceoryx2's reason.
        source: SemanticStringError,
    },
    /// The iceoryx2 node could not be created.
    #[error("cannot create the iceoryx2 node `{node}`{}", .segment.as_ref().map(|s| format!(" (the domain's management segment {s})")).unwrap_or_default())]
    Node {
        /// Node name.
        node: String,
        /// The domain's management segment with its owner and mode, when it exists (what a
        /// permission failure is about).
        segment: Option<String>,
        /// iceoryx2's reason.
        source: NodeCreationFailure,
    },
    /// The domain's files are not safe or not accessible to this user.
    #[error(transparent)]
    Access(#[from] access::AccessError),
    /// `ipc.root` is not a path iceoryx2 accepts.
    #[error("`{}` is not a usable shared-memory root (ipc.root)", .root.display())]
    Root {
        /// The root.
        root: std::path::PathBuf,
        /// iceoryx2's reason.
        source: iceoryx2::prelude::SemanticStringError,
    },
    /// The service name is not valid.
    #[error("`{service}` is not a valid iceoryx2 service name")]
    ServiceName {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: ServiceNameError,
    },
    /// A publish-subscribe service could not be created or opened.
    #[error("cannot open service `{service}`")]
    PublishSubscribe {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: PublishSubscribeOpenOrCreateError,
    },
    /// A published service could not be opened by a reader (usually: no runtime runs the arm).
    #[error("cannot open service `{service}` (is `jointctl run` running this arm in this domain?)")]
    OpenPublishSubscribe {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError,
    },
    /// The command service could not be created.
    #[error("cannot create service `{service}`")]
    CreateRequestResponse {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: RequestResponseOpenOrCreateError,
    },
    /// The command service could not be opened (usually: no runtime serves it).
    #[error("cannot open service `{service}`")]
    OpenRequestResponse {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: RequestResponseOpenError,
    },
}

/// Where an arm's shared memory lives: its iceoryx2 domain (file prefix), the root folder of
/// its files (`None`: iceoryx2's default, `/tmp/iceoryx2/`) and the group given that folder
/// when it is created. Every process of one arm must use the same (the YAML's `ipc` section).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IpcScope {
    /// iceoryx2 domain; `None`: iceoryx2's default prefix `iox2_`.
    pub domain: Option<String>,
    /// Root folder of the domain's files.
    pub root: Option<std::path::PathBuf>,
    /// Group given the root folder when it is created (mode 0750 instead of 0700).
    pub group: Option<String>,
}

impl IpcScope {
    /// The default root with this domain.
    pub fn domain(domain: Option<&str>) -> Self {
        IpcScope { domain: domain.map(str::to_string), ..Default::default() }
    }
}

/// The iceoryx2 configuration of a scope: iceoryx2's defaults, with the file prefix set to the
/// domain and the root path to the root when given. Built in code so that no process depends on
/// its working directory.
pub fn iceoryx2_config_in(scope: &IpcScope) -> Result<Config, IpcSetupError> {
    let mut config = Config::default();
    if let Some(d) = &scope.domain {
        config.global.prefix = d.as_str().try_into().map_err(|source| IpcSetupError::Domain { domain: d.to_string(), source })?;
    }
    if let Some(root) = &scope.root {
        let text = root.to_string_lossy();
        let path = iceoryx2::prelude::Path::new(text.as_bytes()).map_err(|source| IpcSetupError::Root { root: root.clone(), source })?;
        config.global.set_root_path(&path);
    }
    Ok(config)
}

/// Where the runtimes of a domain keep their single-runtime locks: `jointctl/<prefix>` under
/// the domain's iceoryx2 root.
///
/// ```
/// let dir = jointctl_ipc::lock_dir_in(&jointctl_ipc::IpcScope::domain(Some("lab"))).unwrap();
/// assert!(dir.ends_with("jointctl/lab"));
/// ```
pub fn lock_dir_in(scope: &IpcScope) -> Result<std::path::PathBuf, IpcSetupError> {
    let config = iceoryx2_config_in(scope)?;
    let prefix = config.global.prefix.to_string();
    Ok(std::path::PathBuf::from(config.global.root_path().to_string()).join("jointctl").join(prefix.trim_end_matches('_')))
}

/// Creates the scope's root folder closed to other users, or checks the one that exists (see
/// [`access::secure_root`]); returns it. The runtime calls it before anything else of the arm is
/// created; [`create_node_in`] calls it too.
pub fn prepare_root(scope: &IpcScope) -> Result<std::path::PathBuf, IpcSetupError> {
    let config = iceoryx2_config_in(scope)?;
    let root = std::path::PathBuf::from(config.global.root_path().to_string());
    access::secure_root(&root, scope.group.as_deref())?;
    Ok(root)
}

/// An iceoryx2 node in the arm's domain, with iceoryx2's own signal handling off (the runtime
/// owns its signals and timing). Dead nodes of crashed processes are cleaned up.
///
/// ```
/// let e = jointctl_ipc::create_node(Some("bad/domain"), "n").unwrap_err();
/// assert!(e.to_string().contains("bad/domain"));
/// ```
pub fn create_node(domain: Option<&str>, name: &str) -> Result<Node<ipc::Service>, IpcSetupError> {
    create_node_in(&IpcScope::domain(domain), name)
}

/// [`create_node`] in a whole scope. The root folder and the domain's management segment are
/// checked and closed to other users around iceoryx2 (see [`access`]).
pub fn create_node_in(scope: &IpcScope, name: &str) -> Result<Node<ipc::Service>, IpcSetupError> {
    // iceoryx2 warns that it found no config file, which is by design here (the config is built
    // in code); its own `IOX2_LOG_LEVEL` still overrides this.
    set_log_level_from_env_or(LogLevel::Error);
    let config = iceoryx2_config_in(scope)?;
    prepare_root(scope)?;
    let prefix = config.global.prefix.to_string();
    access::check_management_segment(&prefix)?;
    let node_name = NodeName::new(name).map_err(|source| IpcSetupError::NodeName { node: name.to_string(), source })?;
    let node = NodeBuilder::new()
        .name(&node_name)
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|source| {
            // iceoryx2 says "InternalError" or "UnableToGenerateUniqueNodeId" without a path; the
            // management segment is the file a failing node creation could not use.
            let segment = access::management_segment(&prefix).map(|p| {
                use std::os::unix::fs::MetadataExt;
                let (owner, mode) = std::fs::metadata(&p).map(|m| (m.uid(), m.mode() & 0o7777)).unwrap_or((u32::MAX, 0));
                let me = access::effective_uid();
                let hint = if owner != me && me != 0 { ": permission denied, run as that user" } else { "" };
                format!("{} belongs to uid {owner} (mode {mode:04o}), this process is uid {me}{hint}", p.display())
            });
            IpcSetupError::Node { node: name.to_string(), segment, source }
        })?;
    access::close_management_segment(&prefix)?;
    let _ = node.try_cleanup_dead_nodes();
    Ok(node)
}

/// Subscriber buffer per inspector: a slow inspector loses the oldest samples, it never slows
/// the publisher.
pub const SUBSCRIBER_BUFFER: usize = 64;

fn service_name(name: &str) -> Result<ServiceName, IpcSetupError> {
    ServiceName::new(name).map_err(|source| IpcSetupError::ServiceName { service: name.to_string(), source })
}

/// How many ports the runtime's services admit (the YAML `ipc` section).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PortLimits {
    /// Subscribers of each published service.
    pub max_subscribers: usize,
    /// Clients of the command service.
    pub max_clients: usize,
}

impl Default for PortLimits {
    fn default() -> Self {
        PortLimits { max_subscribers: 16, max_clients: 16 }
    }
}

macro_rules! service_opener {
    ($open:ident, $create:ident, $ty:ty, $what:literal) => {
        #[doc = concat!("Opens an arm's ", $what, " service as a reader: it must exist (a runtime created it), and")]
        /// nothing is required of its limits, so a reader works with whatever the arm's YAML set.
        pub fn $open(node: &Node<ipc::Service>, name: &str) -> Result<PortFactory<ipc::Service, $ty, ()>, IpcSetupError> {
            node.service_builder(&service_name(name)?)
                .publish_subscribe::<$ty>()
                .open()
                .map_err(|source| IpcSetupError::OpenPublishSubscribe { service: name.to_string(), source })
        }

        #[doc = concat!("Creates (or re-opens) an arm's ", $what, " service for the runtime: one publisher (a")]
        /// second runtime of the same arm is refused), `limits.max_subscribers` subscribers, the
        /// last sample kept for late subscribers, and overflow that drops the oldest sample in a
        /// slow subscriber's buffer.
        pub fn $create(node: &Node<ipc::Service>, name: &str, limits: PortLimits) -> Result<PortFactory<ipc::Service, $ty, ()>, IpcSetupError> {
            node.service_builder(&service_name(name)?)
                .publish_subscribe::<$ty>()
                .max_publishers(1)
                .max_subscribers(limits.max_subscribers)
                .history_size(1)
                .subscriber_max_buffer_size(SUBSCRIBER_BUFFER)
                .enable_safe_overflow(true)
                .open_or_create()
                .map_err(|source| IpcSetupError::PublishSubscribe { service: name.to_string(), source })
        }
    };
}

service_opener!(joint_state_service, create_joint_state_service, ArmState, "joint-state");
service_opener!(diagnostics_service, create_diagnostics_service, Diagnostics, "diagnostics");
service_opener!(raw_service, create_raw_service, raw::RawFrame, "raw-readings");
service_opener!(raw_descriptor_service, create_raw_descriptor_service, raw::RawDescriptor, "raw-descriptor");
service_opener!(commands_service, create_commands_service, raw::CommandRecord, "accepted-commands");
service_opener!(joints_service, create_joints_service, JointsDescriptor, "plugin-instance");

/// Most trajectory points one command carries.
pub const MAX_COMMAND_POINTS: usize = 64;

/// A command to a running arm, sent on `<arm>/command` (request-response).
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.CommandRequest.v2")]
pub struct CommandRequest {
    /// What is asked.
    pub kind: CommandKind,
    /// 1: a streamed command that must be renewed within the joint's watchdog time.
    pub streamed: u32,
    /// NUL-padded joint name; empty for all joints (hold, stop).
    pub joint: [u8; NAME_LEN],
    /// The torque reference's waveform ([`CommandKind::TORQUE`] only).
    pub waveform: TorqueWaveform,
    _reserved0: u32,
    /// Kind-specific numbers (see [`CommandKind`]).
    pub values: [f64; 8],
    /// Valid entries in `points`.
    pub point_count: u32,
    _reserved: u32,
    /// Trajectory points (time [s], position [rad], velocity [rad/s] or NaN).
    pub points: [[f64; 3]; MAX_COMMAND_POINTS],
}

impl CommandRequest {
    /// A torque reference for `joint`: `waveform` with [amplitude [Nm], frequency [Hz], offset
    /// [Nm], start delay [s]].
    ///
    /// ```
    /// use jointctl_ipc::{CommandRequest, TorqueWaveform};
    /// let r = CommandRequest::torque("q2", TorqueWaveform::SINE, &[5.0, 0.1, 0.0, 0.0]);
    /// assert_eq!((r.waveform, r.values[1]), (TorqueWaveform::SINE, 0.1));
    /// ```
    pub fn torque(joint: &str, waveform: TorqueWaveform, values: &[f64]) -> Self {
        CommandRequest { waveform, ..Self::new(CommandKind::TORQUE, joint, values) }
    }

    /// A request of `kind` for `joint` ("" for all) with `values`.
    ///
    /// ```
    /// use jointctl_ipc::{CommandKind, CommandRequest};
    /// let r = CommandRequest::new(CommandKind::POSITION, "q1", &[0.5]);
    /// assert_eq!((jointctl_ipc::decode_name(&r.joint), r.values[0]), ("q1", 0.5));
    /// ```
    pub fn new(kind: CommandKind, joint: &str, values: &[f64]) -> Self {
        let mut v = [f64::NAN; 8];
        for (d, s) in v.iter_mut().zip(values) {
            *d = *s;
        }
        CommandRequest {
            kind,
            streamed: 0,
            joint: encode_name(joint),
            waveform: TorqueWaveform::STEP,
            _reserved0: 0,
            values: v,
            point_count: 0,
            _reserved: 0,
            points: [[f64::NAN; 3]; MAX_COMMAND_POINTS],
        }
    }
}

/// The runtime's answer to a [`CommandRequest`].
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.CommandResponse.v2")]
pub struct CommandResponse {
    /// 1 when the command was accepted and queued for the next cycle.
    pub accepted: u32,
    /// Bytes of `message` used.
    pub message_len: u32,
    /// Why it was refused, or what was done.
    pub message: [u8; 240],
}

impl CommandResponse {
    /// A response with a message (truncated to 240 bytes at a character boundary).
    ///
    /// ```
    /// let r = jointctl_ipc::CommandResponse::new(false, "joint `q9` does not exist");
    /// assert_eq!(r.text(), "joint `q9` does not exist");
    /// ```
    pub fn new(accepted: bool, message: &str) -> Self {
        let mut m = [0u8; 240];
        let n = jointctl_api::abi::copy_utf8_prefix(&mut m, message);
        CommandResponse { accepted: accepted as u32, message_len: n as u32, message: m }
    }

    /// The message.
    pub fn text(&self) -> &str {
        core::str::from_utf8(&self.message[..(self.message_len as usize).min(240)]).unwrap_or("?")
    }
}

/// Name of an arm's command service.
pub fn command_service_name(arm: &str) -> String {
    format!("{arm}/command")
}

/// Opens an arm's command service. The runtime creates it (`Some(limits)`); a client only opens
/// it (`None`), requiring nothing of its limits, so that "no runtime is running" is an error
/// instead of a service nobody serves.
pub fn command_service(
    node: &Node<ipc::Service>,
    name: &str,
    create: Option<PortLimits>,
) -> Result<iceoryx2::service::port_factory::request_response::PortFactory<ipc::Service, CommandRequest, (), CommandResponse, ()>, IpcSetupError> {
    let builder = node.service_builder(&service_name(name)?).request_response::<CommandRequest, CommandResponse>();
    let service = || name.to_string();
    match create {
        Some(limits) => builder
            .max_servers(1)
            .max_clients(limits.max_clients)
            .max_active_requests_per_client(4)
            .max_response_buffer_size(4)
            .open_or_create()
            .map_err(|source| IpcSetupError::CreateRequestResponse { service: service(), source }),
        None => builder.open().map_err(|source| IpcSetupError::OpenRequestResponse { service: service(), source }),
    }
}

/// Why a command got no answer from the runtime.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The node could not be created.
    #[error(transparent)]
    Setup(#[from] IpcSetupError),
    /// No runtime serves the arm.
    #[error("no runtime is running arm `{arm}` (no service `{service}`): start `jointctl run`")]
    NoRuntime {
        /// The arm.
        arm: String,
        /// The command service.
        service: String,
    },
    /// Every client slot is taken.
    #[error("every client slot of `{service}` is taken (the YAML's ipc.max_clients)")]
    SlotsTaken {
        /// The command service.
        service: String,
    },
    /// iceoryx2 refused the client, the request or the response.
    #[error("cannot talk to `{service}`: {reason}")]
    Port {
        /// The command service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The runtime did not answer in time.
    #[error("no answer from arm `{arm}` within {timeout_s} s (is its runtime running?)")]
    NoAnswer {
        /// The arm.
        arm: String,
        /// How long it waited [s].
        timeout_s: f64,
    },
}

/// A client of an arm's command service: `jointctl cmd` and the network bridges send through it.
pub struct CommandClient {
    arm: String,
    service: String,
    client: iceoryx2::port::client::Client<ipc::Service, CommandRequest, (), CommandResponse, ()>,
    // Last: the port above must be dropped before its node.
    _node: Node<ipc::Service>,
}

impl CommandClient {
    /// Connects to the command service of `arm` as `node_name`.
    ///
    /// ```
    /// let e = jointctl_ipc::CommandClient::open(&Default::default(), "nobody-runs-this-arm", "doc-client").err().unwrap();
    /// assert!(matches!(e, jointctl_ipc::CommandError::NoRuntime { .. }), "{e}");
    /// ```
    pub fn open(scope: &IpcScope, arm: &str, node_name: &str) -> Result<CommandClient, CommandError> {
        let service = command_service_name(arm);
        // Looked up before this client makes a node: a node makes its domain's management
        // segment in /dev/shm for good, and `cmd --domain` with a typo left one behind.
        let config = iceoryx2_config_in(scope)?;
        let exists = <ipc::Service as iceoryx2::service::Service>::does_exist(&service_name(&service)?, &config, MessagingPattern::RequestResponse);
        if matches!(exists, Ok(false)) {
            return Err(CommandError::NoRuntime { arm: arm.to_string(), service });
        }
        let node = create_node_in(scope, node_name)?;
        let factory = command_service(&node, &service, None).map_err(|_| CommandError::NoRuntime { arm: arm.to_string(), service: service.clone() })?;
        let client = factory.client_builder().create().map_err(|e| match e {
            iceoryx2::service::port_factory::client::ClientCreateError::ExceedsMaxSupportedClients => CommandError::SlotsTaken { service: service.clone() },
            e => CommandError::Port { service: service.clone(), reason: format!("{e:?}") },
        })?;
        Ok(CommandClient { arm: arm.to_string(), service, client, _node: node })
    }

    /// Sends `request` and waits up to `timeout_s` for the runtime's answer.
    pub fn send(&self, request: CommandRequest, timeout_s: f64) -> Result<CommandResponse, CommandError> {
        let port = |e: &dyn std::fmt::Debug| CommandError::Port { service: self.service.clone(), reason: format!("{e:?}") };
        let pending = self.client.send_copy(request).map_err(|e| port(&e))?;
        let start = std::time::Instant::now();
        loop {
            match pending.receive().map_err(|e| port(&e))? {
                Some(response) => return Ok(*response.payload()),
                None if start.elapsed().as_secs_f64() < timeout_s => std::thread::sleep(std::time::Duration::from_millis(1)),
                None => return Err(CommandError::NoAnswer { arm: self.arm.clone(), timeout_s }),
            }
        }
    }
}
