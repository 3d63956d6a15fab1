"""The ROS 2 message types the interop tests speak, for PyPI cyclonedds: each by its ROS 2 DDS
name (`package::msg::dds_::Type_`), its fields in the `.msg` order (CDR has no field names), and
ROS 2's default QoS. Shared by ros2_listener.py and ros2_commander.py."""

from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint8, uint32, uint64
from cyclonedds.util import duration


def ros2_qos(depth):
    """ROS 2's default QoS (reliable, volatile, keep last) with a history of `depth`."""
    return Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.Volatile, Policy.History.KeepLast(depth))


def valid(samples):
    """The samples that carry data (a writer going away arrives as an InvalidSample)."""
    return [s for s in samples if type(s).__name__ != "InvalidSample"]


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class JointDetail(IdlStruct, typename="jointctl_msgs::msg::dds_::JointDetail_"):
    name: str
    position_rad: float64
    velocity_rad_s: float64
    deflection_rad: float64
    torque_nm: float64
    stiffness_nm_per_rad: float64
    pivot_mm: float64
    reference_torque_nm: float64
    sensor_torque_nm: float64
    gravity_nm: float64
    mode: str
    enabled: bool
    fault_code: uint32


@dataclass
class JointDetails(IdlStruct, typename="jointctl_msgs::msg::dds_::JointDetails_"):
    header: Header
    cycle: uint64
    stamp_ns: uint64
    final_sample: bool
    joints: sequence[JointDetail]


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue]


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header
    status: sequence[DiagnosticStatus]


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectoryPoint_"):
    positions: sequence[float64]
    velocities: sequence[float64]
    accelerations: sequence[float64]
    effort: sequence[float64]
    time_from_start: Duration


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectory_"):
    header: Header
    joint_names: sequence[str]
    points: sequence[JointTrajectoryPoint]


@dataclass
class CommandPoint(IdlStruct, typename="jointctl_msgs::msg::dds_::CommandPoint_"):
    t_s: float64
    position_rad: float64
    velocity_rad_s: float64


@dataclass
class CommandRequest(IdlStruct, typename="jointctl_msgs::msg::dds_::CommandRequest_"):
    kind: str
    joint: str
    waveform: str
    values: sequence[float64]
    points: sequence[CommandPoint]


@dataclass
class CommandResponse(IdlStruct, typename="jointctl_msgs::msg::dds_::CommandResponse_"):
    header: Header
    kind: str
    joint: str
    accepted: bool
    message: str
