//! The ROS 2 message types the arm's samples are written as, field for field in the order of
//! their `.msg` definitions (CDR has no field names: the order is the format), and each type's
//! definition as ROS 2 tools read it from an MCAP schema (`ros2msg`: the type's text, then every
//! type it uses after a line of `=`, as `ros2 bag record` writes them).
//!
//! Two standard types carry what every ROS 2 tool knows: `sensor_msgs/msg/JointState` and
//! `diagnostic_msgs/msg/DiagnosticArray`. The `jointctl_msgs` types carry the rest, with their
//! units in their field names; a value that is not known is NaN (ROS 2 has no null).

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`: the wall clock (UNIX time).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds since 1970-01-01 UTC.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// UNIX time [ns] as a ROS 2 time. Beyond what `int32` seconds hold (2038) it stays at the
    /// last time they hold, rather than wrapping to 1901.
    ///
    /// ```
    /// use jointctl_ros2::msg::Time;
    /// let t = Time::from_unix_ns(1_700_000_000_250_000_000);
    /// assert_eq!((t.sec, t.nanosec), (1_700_000_000, 250_000_000));
    /// assert_eq!(Time::from_unix_ns(u64::MAX), Time { sec: i32::MAX, nanosec: 999_999_999 });
    /// ```
    pub fn from_unix_ns(ns: u64) -> Time {
        match i32::try_from(ns / 1_000_000_000) {
            Ok(sec) => Time { sec, nanosec: (ns % 1_000_000_000) as u32 },
            Err(_) => Time { sec: i32::MAX, nanosec: 999_999_999 },
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the sample was taken, on the wall clock.
    pub stamp: Time,
    /// The frame; jointctl writes the arm's name.
    pub frame_id: String,
}

/// `sensor_msgs/msg/JointState`: one entry per DOF; `effort` is the observed joint torque [Nm].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Header.
    pub header: Header,
    /// DOF names.
    pub name: Vec<String>,
    /// Link-side positions [rad].
    pub position: Vec<f64>,
    /// Velocities [rad/s].
    pub velocity: Vec<f64>,
    /// Observed joint torques [Nm].
    pub effort: Vec<f64>,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value, as text.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`], `WARN`, `ERROR` or `STALE`.
    pub level: u8,
    /// What it is about: `jointctl/<arm>/loop`, `.../joint/<name>`, `.../device/<name>`.
    pub name: String,
    /// One line for a person.
    pub message: String,
    /// The arm's name.
    pub hardware_id: String,
    /// The counters, by name.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// Level: fine.
    pub const OK: u8 = 0;
    /// Level: works, with a problem.
    pub const WARN: u8 = 1;
    /// Level: does not work.
    pub const ERROR: u8 = 2;
    /// Level: no news (jointctl does not send it: a bridge that stops sends nothing).
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Header.
    pub header: Header,
    /// One status per part.
    pub status: Vec<DiagnosticStatus>,
}

/// `jointctl_msgs/msg/JointDetail`: one DOF's observed state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointDetail {
    /// DOF name.
    pub name: String,
    /// Link-side position [rad].
    pub position_rad: f64,
    /// Velocity [rad/s].
    pub velocity_rad_s: f64,
    /// Deflection of the elastic element [rad].
    pub deflection_rad: f64,
    /// Observed joint torque [Nm].
    pub torque_nm: f64,
    /// Stiffness now [Nm/rad].
    pub stiffness_nm_per_rad: f64,
    /// VSA pivot setting [mm] (section 3.3).
    pub pivot_mm: f64,
    /// Torque reference [Nm] (NaN outside torque modes).
    pub reference_torque_nm: f64,
    /// The F/T sensor's torque about the axis [Nm].
    pub sensor_torque_nm: f64,
    /// Gravity torque of the pose [Nm].
    pub gravity_nm: f64,
    /// Control mode (`hold`, `position`, `torque`, ...).
    pub mode: String,
    /// Accepts commands.
    pub enabled: bool,
    /// 0, or the joint's fault.
    pub fault_code: u32,
}

/// `jointctl_msgs/msg/JointDetails`: every DOF's observed state in one cycle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointDetails {
    /// Header (the cycle's sensor read on the wall clock).
    pub header: Header,
    /// Cycle counter.
    pub cycle: u64,
    /// CLOCK_MONOTONIC of the cycle's sensor read [ns] (the runtime's clock).
    pub stamp_ns: u64,
    /// The runtime's last sample (the arm stopped).
    pub final_sample: bool,
    /// One per DOF.
    pub joints: Vec<JointDetail>,
}

/// `jointctl_msgs/msg/RawReading`: one device reading as the HAL gave it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RawReading {
    /// Device name (empty inside a [`RawDrive`]).
    pub name: String,
    /// Value [rad or Nm]; NaN when there is none.
    pub value: f64,
    /// `missing`, `valid`, `stale` or `invalid`.
    pub status: String,
    /// Age [s]; infinite when it never arrived.
    pub age_s: f64,
}

/// `jointctl_msgs/msg/RawDrive`: one drive's reading and what it was sent.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RawDrive {
    /// Drive name.
    pub name: String,
    /// Its position reading [rad].
    pub position_rad: RawReading,
    /// Its velocity reading [rad/s].
    pub velocity_rad_s: RawReading,
    /// Its motor torque at the gearbox output [Nm] (the drive's current reading).
    pub torque_nm: RawReading,
    /// Enabled (CiA 402 operation enabled).
    pub enabled: bool,
    /// In fault.
    pub fault: bool,
    /// What it was sent (`hold`, `move`, ...).
    pub action: String,
    /// Position set-point sent [rad] (NaN: none).
    pub setpoint_rad: f64,
    /// Velocity feed-forward sent [rad/s].
    pub velocity_ff_rad_s: f64,
}

/// `jointctl_msgs/msg/RawFrame`: every device's reading and every set-point of one cycle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RawFrame {
    /// Header.
    pub header: Header,
    /// Cycle counter.
    pub cycle: u64,
    /// CLOCK_MONOTONIC of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// Accepted commands applied up to this cycle.
    pub commands_applied: u64,
    /// Encoders [rad].
    pub encoders: Vec<RawReading>,
    /// Drives.
    pub drives: Vec<RawDrive>,
    /// F/T sensors, about their joint's axis [Nm].
    pub torque_sensors: Vec<RawReading>,
}

/// `jointctl_msgs/msg/CommandPoint`: one point of a position trajectory.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandPoint {
    /// Time from the trajectory's start [s].
    pub t_s: f64,
    /// Position [rad].
    pub position_rad: f64,
    /// Velocity [rad/s] (NaN: not given).
    pub velocity_rad_s: f64,
}

/// `jointctl_msgs/msg/CommandRecord`: a command the runtime accepted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandRecord {
    /// Header (the acceptance, on the wall clock).
    pub header: Header,
    /// Accepted commands so far, from 1.
    pub sequence: u64,
    /// CLOCK_MONOTONIC of the acceptance [ns].
    pub stamp_ns: u64,
    /// `hold`, `position`, `trajectory`, `torque`, ...
    pub kind: String,
    /// The DOF (empty: the whole arm).
    pub joint: String,
    /// Part of a stream of set-points.
    pub streamed: bool,
    /// A torque command's `step`, `sine` or `cosine`.
    pub waveform: String,
    /// The command's numbers (SI units).
    pub values: Vec<f64>,
    /// A trajectory's points.
    pub points: Vec<CommandPoint>,
    /// The runtime's answer.
    pub message: String,
}

/// A message type: its ROS 2 name and its `.msg` text.
pub trait Message: Serialize + for<'de> Deserialize<'de> {
    /// `package/msg/Type`.
    const NAME: &'static str;
    /// The `.msg` text of this type alone.
    const DEFINITION: &'static str;
    /// The types its fields use, nested ones included, each once.
    const USES: &'static [(&'static str, &'static str)];

    /// The MCAP `ros2msg` schema: this type's text, then each used type after a separator and
    /// `MSG: package/Type`.
    ///
    /// ```
    /// use jointctl_ros2::msg::{JointState, Message};
    /// let s = JointState::schema();
    /// assert!(s.starts_with("std_msgs/Header header\n"));
    /// assert!(s.contains("\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"));
    /// ```
    fn schema() -> String {
        let mut out = Self::DEFINITION.to_string();
        for (name, text) in Self::USES {
            out.push_str(SEPARATOR);
            out.push_str("MSG: ");
            out.push_str(&name.replace("/msg/", "/"));
            out.push('\n');
            out.push_str(text);
        }
        out
    }
}

const SEPARATOR: &str = "================================================================================\n";

const TIME: (&str, &str) = ("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n");
const HEADER: (&str, &str) = ("std_msgs/msg/Header", "builtin_interfaces/Time stamp\nstring frame_id\n");

impl Message for JointState {
    const NAME: &'static str = "sensor_msgs/msg/JointState";
    const DEFINITION: &'static str = "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME];
}

const KEY_VALUE: (&str, &str) = ("diagnostic_msgs/msg/KeyValue", "string key\nstring value\n");
const DIAGNOSTIC_STATUS: (&str, &str) = (
    "diagnostic_msgs/msg/DiagnosticStatus",
    "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\ndiagnostic_msgs/KeyValue[] values\n",
);

impl Message for DiagnosticArray {
    const NAME: &'static str = "diagnostic_msgs/msg/DiagnosticArray";
    const DEFINITION: &'static str = "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME, DIAGNOSTIC_STATUS, KEY_VALUE];
}

const JOINT_DETAIL: (&str, &str) = (
    "jointctl_msgs/msg/JointDetail",
    "string name\nfloat64 position_rad\nfloat64 velocity_rad_s\nfloat64 deflection_rad\nfloat64 torque_nm\nfloat64 stiffness_nm_per_rad\nfloat64 pivot_mm\n\
     float64 reference_torque_nm\nfloat64 sensor_torque_nm\nfloat64 gravity_nm\nstring mode\nbool enabled\nuint32 fault_code\n",
);

impl Message for JointDetail {
    const NAME: &'static str = "jointctl_msgs/msg/JointDetail";
    const DEFINITION: &'static str = JOINT_DETAIL.1;
    const USES: &'static [(&'static str, &'static str)] = &[];
}

impl Message for JointDetails {
    const NAME: &'static str = "jointctl_msgs/msg/JointDetails";
    const DEFINITION: &'static str = "# Every DOF's observed state, once per cycle (SI units; NaN: not known).\n\
         std_msgs/Header header\nuint64 cycle\nuint64 stamp_ns\nbool final_sample\njointctl_msgs/JointDetail[] joints\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME, JOINT_DETAIL];
}

const RAW_READING: (&str, &str) = ("jointctl_msgs/msg/RawReading", "string name\nfloat64 value\nstring status\nfloat64 age_s\n");
const RAW_DRIVE: (&str, &str) = (
    "jointctl_msgs/msg/RawDrive",
    "string name\njointctl_msgs/RawReading position_rad\njointctl_msgs/RawReading velocity_rad_s\njointctl_msgs/RawReading torque_nm\nbool enabled\nbool fault\nstring action\nfloat64 setpoint_rad\nfloat64 velocity_ff_rad_s\n",
);

impl Message for RawReading {
    const NAME: &'static str = "jointctl_msgs/msg/RawReading";
    const DEFINITION: &'static str = RAW_READING.1;
    const USES: &'static [(&'static str, &'static str)] = &[];
}

impl Message for RawFrame {
    const NAME: &'static str = "jointctl_msgs/msg/RawFrame";
    const DEFINITION: &'static str = "# Every device's reading as the HAL gave it and every set-point written, once per cycle.\n\
         std_msgs/Header header\nuint64 cycle\nuint64 stamp_ns\nuint64 commands_applied\njointctl_msgs/RawReading[] encoders\njointctl_msgs/RawDrive[] drives\njointctl_msgs/RawReading[] torque_sensors\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME, RAW_READING, RAW_DRIVE];
}

const COMMAND_POINT: (&str, &str) = ("jointctl_msgs/msg/CommandPoint", "float64 t_s\nfloat64 position_rad\nfloat64 velocity_rad_s\n");

impl Message for CommandPoint {
    const NAME: &'static str = "jointctl_msgs/msg/CommandPoint";
    const DEFINITION: &'static str = COMMAND_POINT.1;
    const USES: &'static [(&'static str, &'static str)] = &[];
}

impl Message for CommandRecord {
    const NAME: &'static str = "jointctl_msgs/msg/CommandRecord";
    const DEFINITION: &'static str = "# A command the runtime accepted.\n\
         std_msgs/Header header\nuint64 sequence\nuint64 stamp_ns\nstring kind\nstring joint\nbool streamed\nstring waveform\nfloat64[] values\njointctl_msgs/CommandPoint[] points\nstring message\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME, COMMAND_POINT];
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Duration {
    /// In seconds.
    ///
    /// ```
    /// assert_eq!(jointctl_ros2::msg::Duration { sec: 1, nanosec: 500_000_000 }.seconds(), 1.5);
    /// ```
    pub fn seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// `trajectory_msgs/msg/JointTrajectoryPoint`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// One per joint of the trajectory [rad].
    pub positions: Vec<f64>,
    /// One per joint [rad/s], or empty.
    pub velocities: Vec<f64>,
    /// One per joint [rad/s^2], or empty (not used).
    pub accelerations: Vec<f64>,
    /// One per joint [Nm], or empty (not used).
    pub effort: Vec<f64>,
    /// When the point is to be reached, from the trajectory's start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/msg/JointTrajectory`: what ROS 2 sends a joint trajectory controller.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// Header.
    pub header: Header,
    /// The DOFs the points are for, in the points' order.
    pub joint_names: Vec<String>,
    /// The points.
    pub points: Vec<JointTrajectoryPoint>,
}

/// `jointctl_msgs/msg/CommandRequest`: a command for the arm (what `jointctl cmd` sends).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandRequest {
    /// `hold`, `position`, `torque`, `impedance`, `stiffness`, ... (`jointctl cmd --help`).
    pub kind: String,
    /// The DOF; empty for the whole arm (`hold`, `stop`).
    pub joint: String,
    /// A torque command's `step`, `sine` or `cosine`; empty otherwise.
    pub waveform: String,
    /// The command's numbers, as `jointctl cmd` takes them (SI units).
    pub values: Vec<f64>,
    /// A trajectory's points.
    pub points: Vec<CommandPoint>,
}

/// `jointctl_msgs/msg/CommandResponse`: what became of a command from ROS 2.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandResponse {
    /// Header (when it was answered).
    pub header: Header,
    /// The command's kind.
    pub kind: String,
    /// Its DOF.
    pub joint: String,
    /// Accepted by the runtime.
    pub accepted: bool,
    /// The runtime's answer, or why the bridge refused it.
    pub message: String,
}

const DURATION: (&str, &str) = ("builtin_interfaces/msg/Duration", "int32 sec\nuint32 nanosec\n");
const TRAJECTORY_POINT: (&str, &str) = (
    "trajectory_msgs/msg/JointTrajectoryPoint",
    "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\nbuiltin_interfaces/Duration time_from_start\n",
);

impl Message for JointTrajectory {
    const NAME: &'static str = "trajectory_msgs/msg/JointTrajectory";
    const DEFINITION: &'static str = "std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint[] points\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME, TRAJECTORY_POINT, DURATION];
}

impl Message for CommandRequest {
    const NAME: &'static str = "jointctl_msgs/msg/CommandRequest";
    const DEFINITION: &'static str = "# A command for the arm, as jointctl cmd sends it (SI units).\n\
         string kind\nstring joint\nstring waveform\nfloat64[] values\njointctl_msgs/CommandPoint[] points\n";
    const USES: &'static [(&'static str, &'static str)] = &[COMMAND_POINT];
}

impl Message for CommandResponse {
    const NAME: &'static str = "jointctl_msgs/msg/CommandResponse";
    const DEFINITION: &'static str = "# What became of a command from ROS 2.\n\
         std_msgs/Header header\nstring kind\nstring joint\nbool accepted\nstring message\n";
    const USES: &'static [(&'static str, &'static str)] = &[HEADER, TIME];
}
