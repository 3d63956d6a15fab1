"""A ROS 2 listener that is not jointctl's: PyPI cyclonedds (Eclipse Cyclone DDS, the DDS of
rmw_cyclonedds) reading the arm's topics the way a ROS 2 node does, by the ROS 2 DDS names
(`rt/joint_states`, type `sensor_msgs::msg::dds_::JointState_`) with ROS 2's default QoS.

usage: ros2_listener.py DOMAIN_ID SECONDS COUNT
Listens until COUNT joint states have arrived or SECONDS have passed; prints one JSON object:
{"joint_states": [[stamp_ns, names, positions, efforts], ...],
 "joint_details": [[cycle, stamp_ns, positions], ...],
 "diagnostics": [[level, name], ...] of the last array, "diagnostic_arrays": n}
"""

import json
import math
import sys
import time
from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from ros2_types import DiagnosticArray, JointDetails, JointState, ros2_qos, valid


def stamp_ns(h):
    return h.stamp.sec * 1_000_000_000 + h.stamp.nanosec


def clean(xs):
    return [None if math.isnan(x) else x for x in xs]


def main():
    domain, seconds, count = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
    dp = DomainParticipant(domain)
    # ROS 2's default QoS: reliable, volatile, keep last (a deeper history so a slow poll here
    # loses nothing).
    qos = ros2_qos(1000)
    states = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=qos)
    details = DataReader(dp, Topic(dp, "rt/jointctl/joint_details", JointDetails), qos=qos)
    diagnostics = DataReader(dp, Topic(dp, "rt/diagnostics", DiagnosticArray), qos=qos)
    out = {"joint_states": [], "joint_details": [], "diagnostics": [], "diagnostic_arrays": 0}
    deadline = time.time() + seconds
    while time.time() < deadline and len(out["joint_states"]) < count:
        for s in valid(states.take(N=1000)):
            out["joint_states"].append([stamp_ns(s.header), list(s.name), clean(s.position), clean(s.effort)])
        for s in valid(details.take(N=1000)):
            out["joint_details"].append([s.cycle, stamp_ns(s.header), clean([j.position_rad for j in s.joints])])
        for s in valid(diagnostics.take(N=100)):
            out["diagnostic_arrays"] += 1
            out["diagnostics"] = [[st.level, st.name] for st in s.status]
        time.sleep(0.005)
    # What arrived with the last joint states.
    for s in valid(details.take(N=1000)):
        out["joint_details"].append([s.cycle, stamp_ns(s.header), clean([j.position_rad for j in s.joints])])
    print(json.dumps(out))


if __name__ == "__main__":
    main()
