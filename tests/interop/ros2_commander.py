"""Commands to the arm from a ROS 2 participant that is not jointctl's (PyPI cyclonedds): a
trajectory_msgs/JointTrajectory on /jointctl/joint_trajectory and a jointctl_msgs/CommandRequest
on /jointctl/command, by their ROS 2 DDS names, with ROS 2's default QoS; then the answers on
/jointctl/command_responses.

usage: ros2_commander.py DOMAIN_ID JOINT POSITION_RAD KIND [late-reader]
Sends a one-point trajectory of JOINT to POSITION_RAD at 1 s, then a CommandRequest of KIND for
JOINT (no values); prints one JSON object: {"responses": [[kind, joint, accepted, message], ...]}.
With `late-reader`, the reader of the answers is created only after the commands are sent: the
bridge learns of it after the commands, as it does when discovery runs late on its side.
"""

import json
import sys
import time
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from ros2_types import CommandRequest, CommandResponse, Duration, Header, JointTrajectory, JointTrajectoryPoint, Time, ros2_qos, valid


def wait_until(condition, seconds):
    deadline = time.time() + seconds
    while time.time() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return False


def main():
    domain, joint, position, kind = int(sys.argv[1]), sys.argv[2], float(sys.argv[3]), sys.argv[4]
    late = sys.argv[5:] == ["late-reader"]
    dp = DomainParticipant(domain)
    qos = ros2_qos(10)
    answers = Topic(dp, "rt/jointctl/command_responses", CommandResponse)
    responses = None if late else DataReader(dp, answers, qos=qos)
    trajectories = DataWriter(dp, Topic(dp, "rt/jointctl/joint_trajectory", JointTrajectory), qos=qos)
    requests = DataWriter(dp, Topic(dp, "rt/jointctl/command", CommandRequest), qos=qos)
    # Volatile topics: what is sent before the bridge's reader has matched is lost.
    matched = wait_until(
        lambda: trajectories.get_matched_subscriptions() and requests.get_matched_subscriptions() and (late or responses.get_matched_publications()), 15
    )
    if not matched:
        sys.exit("the bridge's command topics were not discovered within 15 s")
    point = JointTrajectoryPoint([position], [], [], [], Duration(1, 0))
    trajectories.write(JointTrajectory(Header(Time(0, 0), ""), [joint], [point]))
    requests.write(CommandRequest(kind, joint, "", [], []))
    if late:
        time.sleep(0.5)
        responses = DataReader(dp, answers, qos=qos)
    got = []
    wait_until(lambda: got.extend(
        [r.kind, r.joint, r.accepted, r.message] for r in valid(responses.take(N=10))
    ) or len(got) >= 2, 10)
    print(json.dumps({"responses": got}))


if __name__ == "__main__":
    main()
