//! The arm as a whole: its loop rate, timing and shared-memory domain.

use super::*;

/// One robot arm: its loop, its hardware and its joints.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ArmConfig {
    /// The file's format ([`crate::FORMAT_VERSION`], 1 today). A file from a newer jointctl is
    /// refused with the reason instead of being read with this one's meanings; without it, the
    /// file is read as format 1.
    #[serde(default)]
    #[schemars(range(min = 1, max = 1))]
    pub version: Option<u64>,
    /// Arm name: letters, digits, `_` and `-` (at most 32). Shared-memory service names are
    /// derived from it (`<arm>/joint_state`, `<arm>/diagnostics`).
    pub arm: String,
    /// Control loop rate [Hz], 1 to 10 000. Default 40 Hz, the thesis' loop rate (sections 2.3
    /// and 4.1).
    #[serde(default = "default_rate_hz", deserialize_with = "finite")]
    #[schemars(range(min = 1.0, max = 10000.0))]
    pub rate_hz: f64,
    /// Which hardware backend the loop talks to.
    pub hal: HalConfig,
    /// Extra folders searched for plugin libraries, relative to this file.
    #[serde(default)]
    pub plugin_dirs: Vec<PathBuf>,
    /// Loop timing.
    #[serde(default)]
    pub timing: TimingConfig,
    /// Shared-memory (iceoryx2) settings.
    #[serde(default)]
    pub ipc: IpcConfig,
    /// Access from other machines (`jointctl bridge zenoh`).
    #[serde(default)]
    pub network: NetworkConfig,
    /// CAN and SPI buses with the devices on them.
    #[serde(default)]
    pub buses: BusesConfig,
    /// The joints, each served by one plugin instance.
    pub joints: Vec<JointConfig>,
    /// The arm's kinematic and inertial description (URDF), for gravity torques.
    #[serde(default)]
    pub kinematics: Option<KinematicsConfig>,
    /// The runtime's own checks between the plugins and the hardware.
    #[serde(default)]
    pub safety: SafetyConfig,
}

/// The runtime's own checks between the plugins and the hardware.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyConfig {
    /// Check every motor set-point a plugin writes before the HAL sees it: finite, inside its
    /// drive's `setpoint_window_rad`, no faster than its `max_setpoint_rate_rad_s`. A violation
    /// holds the joint with a fault naming the plugin, the drive and the value. Default on; off
    /// only to show what the drives' own limits do (a test of the drives, never an arm in use).
    pub check_setpoints: bool,
    /// What every drive is told, in order, when the runtime stops, whatever stopped it (`cmd
    /// stop`, SIGINT/SIGTERM, the end of `--duration`, an error after start, a panic of the
    /// runtime), after the last hold is written. Default `[quick_stop, pre_operational]`: the
    /// drives decelerate and hold where they are, powered (an arm without brakes does not fall),
    /// and stop taking PDOs. `disable_operation` and `disable_voltage` (the motor unpowered,
    /// brakes where fitted) belong only on an arm whose brakes hold it; after `quick_stop` only
    /// `disable_voltage` is a CiA 402 transition. The simulated backend has no drive states:
    /// there the last hold is the stop.
    pub stop_sequence: Vec<StopStep>,
    /// How long each step waits for every drive to report its state [s]; a drive that does not
    /// is named in the log. Assumption: 0.5 s, several heartbeats and SYNC periods.
    #[serde(deserialize_with = "finite")]
    #[schemars(range(min = 0.01, max = 10.0))]
    pub stop_step_timeout_s: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        SafetyConfig { check_setpoints: true, stop_sequence: vec![StopStep::QuickStop, StopStep::PreOperational], stop_step_timeout_s: 0.5 }
    }
}

/// One step of the stop sequence (CiA 402 controlwords, CiA 301 NMT).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StopStep {
    /// Quick stop (controlword 0x0002): decelerate on the quick-stop ramp (0x6085) and hold.
    QuickStop,
    /// Disable operation (0x0007): the motor unpowered in "switched on"; brakes engage where
    /// fitted. Without brakes, a loaded joint falls.
    DisableOperation,
    /// Disable voltage (0x0000): "switch on disabled". Without brakes, a loaded joint falls.
    DisableVoltage,
    /// NMT pre-operational: the drive stops taking and sending PDOs.
    PreOperational,
}

/// The arm's kinematic and inertial description (appendix C).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct KinematicsConfig {
    /// The URDF file, relative to this file. Its movable joints are named after the arm's DOFs
    /// (`q1` .. `q7`); a DOF it does not name gets no gravity torque.
    pub urdf: PathBuf,
    /// Gravity [m/s^2] along -z of the URDF's root frame. Default 9.81, eq. C.3's.
    #[serde(default = "default_gravity", deserialize_with = "finite")]
    pub gravity_m_s2: f64,
}

fn default_gravity() -> f64 {
    9.81
}

fn default_rate_hz() -> f64 {
    40.0
}

/// Loop timing.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TimingConfig {
    /// The loop sleeps until this long before each deadline, then spins [us], trading CPU for
    /// jitter. Assumption: 200 us.
    pub spin_us: u32,
    /// Run the loop thread with SCHED_FIFO at this priority (1-99) when permitted; from 2 on, the
    /// thread that publishes each cycle's state runs one below it, so that it sends as soon as
    /// the loop has handed a cycle over and sleeps, and never delays the loop.
    pub realtime_priority: Option<u8>,
    /// Pin the loop thread, and the thread that publishes its state, to this CPU.
    pub cpu: Option<usize>,
    /// Lock the runtime's memory (`mlockall`) before the loop starts, so that no page fault
    /// stalls a cycle; a refusal (the memlock limit) is a warning that says how to allow it.
    /// Default off: the simulated arm on a laptop does not need it (`jointctl doctor` says
    /// whether this machine permits it).
    pub lock_memory: bool,
    /// Each joint's default time budget for its plugin's observe and control calls in one
    /// cycle, as a fraction of the period (a joint's own `budget_us` overrides it). A joint over
    /// budget is faulted and held and its plugin is not called again, so one stalling plugin
    /// cannot freeze the other joints. Assumption: 0.5, far above what a plugin needs (the
    /// SHERPA plugins take about 1 us per cycle) and low enough that the loop still meets the
    /// next deadline after the overrun that faults the joint.
    #[serde(deserialize_with = "finite")]
    pub joint_budget_fraction: f64,
    /// A joint whose plugin takes longer than this in one cycle, or than the period if that
    /// is longer, is faulted at once [us]: it alone made the loop miss a deadline. Shorter
    /// excesses of the budget fault it only when they repeat (`joint_budget_strikes`), because
    /// the platform can stall a thread too: inside plugin calls that compute in about 1 us,
    /// 10-minute soaks at 1 kHz on the project's shared 2-core VM saw single stalls of up to
    /// 3.4 ms (host steal counts as the thread's CPU time, so no clock tells them apart).
    /// Assumption: 5000 us, about 1.5 times that.
    pub joint_stall_floor_us: u32,
    /// A joint over its budget in this many cycles, none of them a second of in-budget cycles
    /// apart, is faulted. Assumption: 3; a 10-minute soak saw at most 2 excesses per joint in all.
    pub joint_budget_strikes: u32,
}

impl Default for TimingConfig {
    fn default() -> Self {
        TimingConfig { spin_us: 200, realtime_priority: None, cpu: None, lock_memory: false, joint_budget_fraction: 0.5, joint_stall_floor_us: 5000, joint_budget_strikes: 3 }
    }
}

/// Shared-memory settings.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct IpcConfig {
    /// iceoryx2 domain (its file prefix). All processes of one arm must use the same; default:
    /// iceoryx2's own default, which its other-language clients also use.
    pub domain: Option<String>,
    /// Root folder of the arm's shared-memory files (iceoryx2's `root-path`); default
    /// `/tmp/iceoryx2/`. Created owner-only (0700, or 0750 with `group`) and refused when another
    /// user owns it or others may write it, so that no other user can read, create or replace
    /// the arm's files. Inspectors and `jointctl cmd` take the same with `--ipc-root`.
    pub root: Option<PathBuf>,
    /// Group given the root folder when it is created (e.g. `jointctl`): its members may enter it.
    pub group: Option<String>,
    /// Most readers of each published service (inspectors, recorders, bridges) at once.
    /// Assumption: 16, a lab's worth of tools; each costs its buffer of 64 samples.
    pub max_subscribers: usize,
    /// Most command clients connected at once. Assumption: 16. `jointctl cmd stop` does not
    /// need a free one: when every slot is taken it signals the runtime instead.
    pub max_clients: usize,
}

impl Default for IpcConfig {
    fn default() -> Self {
        IpcConfig { domain: None, root: None, group: None, max_subscribers: 16, max_clients: 16 }
    }
}

/// Access from other machines.
#[derive(Clone, Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NetworkConfig {
    /// The Zenoh bridge (`jointctl bridge zenoh`).
    #[serde(default)]
    pub zenoh: ZenohConfig,
    /// The ROS 2 bridge (`jointctl bridge ros2`).
    #[serde(default)]
    pub ros2: Ros2Config,
}

/// The ROS 2 bridge: the arm's topics over DDS. Without `commands` it only publishes and refuses
/// every command from ROS 2, saying why.
#[derive(Clone, Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Ros2Config {
    /// The DDS domain (`ROS_DOMAIN_ID`), 0 to 232 (the RTPS port mapping's limit for UDP).
    #[serde(default)]
    #[schemars(range(min = 0, max = 232))]
    pub domain_id: u16,
    /// Take commands from ROS 2. DDS has no authentication without DDS Security: any host that
    /// reaches the domain can send them. Allow only what such a host may do.
    pub commands: Option<Ros2CommandsConfig>,
}

/// Commands from ROS 2: which kinds, and how many a second.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Ros2CommandsConfig {
    /// The command kinds taken (`trajectory` for `trajectory_msgs/JointTrajectory`; `hold`,
    /// `position`, `torque`, `impedance`, `stiffness`, ... on `/jointctl/command`); any other
    /// is refused with the reason. At least one.
    pub allow: Vec<String>,
    /// Commands a second the bridge forwards to the runtime, 0.1 to 1000 (a trajectory counts
    /// once per DOF); those beyond are refused with the reason. Default 20, as for Zenoh.
    #[serde(default = "default_max_commands_per_s", deserialize_with = "finite")]
    #[schemars(range(min = 0.1, max = 1000.0))]
    pub max_commands_per_s: f64,
}

/// The Zenoh bridge. Without `commands` it only publishes (state, diagnostics, raw readings,
/// accepted commands) and refuses every command, saying why.
#[derive(Clone, Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ZenohConfig {
    /// Serve commands from the network, to authenticated peers only.
    pub commands: Option<ZenohCommandsConfig>,
}

/// Commands over Zenoh: a second Zenoh session of the bridge, which admits only peers that
/// authenticate with Zenoh's user/password scheme (a challenge-response: the password never
/// crosses the network).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ZenohCommandsConfig {
    /// The Zenoh endpoint it listens on, e.g. `tcp/0.0.0.0:7448`.
    pub listen: String,
    /// Zenoh's user/password dictionary, relative to this file: one `user:password` per line.
    /// Refused when users other than its owner may read it, or when a password is shorter than
    /// 16 characters (Zenoh cannot slow down failed logins: a password must be too long to guess).
    pub users_file: PathBuf,
    /// Commands a second the bridge forwards to the runtime, 0.1 to 1000; those beyond are
    /// refused with the reason, not forwarded (a token bucket holding at most a second's worth,
    /// at least one). Default 20: an assumption, half the thesis' 40 Hz loop rate (sections 2.3
    /// and 4.1), above what a person or a base station's set-point stream sends and below a
    /// flood that would keep the bridge answering instead of publishing.
    #[serde(default = "default_max_commands_per_s", deserialize_with = "finite")]
    #[schemars(range(min = 0.1, max = 1000.0))]
    pub max_commands_per_s: f64,
}

fn default_max_commands_per_s() -> f64 {
    20.0
}
