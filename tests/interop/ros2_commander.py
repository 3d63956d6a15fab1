"""Commands to the arm from a ROS 2 participant that is not jointctl's (PyPI cyclonedds): a
trajectory_msgs/JointTrajectory on /jointctl/joint_trajectory and a jointctl_msgs/CommandRequest
on /jointctl/command, by their ROS 2 DDS names, with ROS 2's default QoS; then the answers on
/jointctl/command_responses.

usage: ros2_commander.py DOMAIN_ID JOINT POSITION_RAD KIND
Sends a one-point trajectory of JOINT to POSITION_RAD at 1 s, then a CommandRequest of KIND for
JOINT (no values); prints one JSON object: {"responses": [[kind, joint, accepted, message], ...]}.
"""

import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


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


def wait_until(condition, seconds):
    deadline = time.time() + seconds
    while time.time() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return False


def main():
    domain, joint, position, kind = int(sys.argv[1]), sys.argv[2], float(sys.argv[3]), sys.argv[4]
    dp = DomainParticipant(domain)
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.Volatile, Policy.History.KeepLast(10))
    responses = DataReader(dp, Topic(dp, "rt/jointctl/command_responses", CommandResponse), qos=qos)
    trajectories = DataWriter(dp, Topic(dp, "rt/jointctl/joint_trajectory", JointTrajectory), qos=qos)
    requests = DataWriter(dp, Topic(dp, "rt/jointctl/command", CommandRequest), qos=qos)
    # Volatile topics: what is sent before the bridge's reader has matched is lost.
    matched = wait_until(
        lambda: trajectories.get_matched_subscriptions() and requests.get_matched_subscriptions() and responses.get_matched_publications(), 15
    )
    if not matched:
        sys.exit("the bridge's command topics were not discovered within 15 s")
    point = JointTrajectoryPoint([position], [], [], [], Duration(1, 0))
    trajectories.write(JointTrajectory(Header(Time(0, 0), ""), [joint], [point]))
    requests.write(CommandRequest(kind, joint, "", [], []))
    got = []
    wait_until(lambda: got.extend(
        [r.kind, r.joint, r.accepted, r.message] for r in responses.take(N=10) if type(r).__name__ != "InvalidSample"
    ) or len(got) >= 2, 10)
    print(json.dumps({"responses": got}))


if __name__ == "__main__":
    main()
