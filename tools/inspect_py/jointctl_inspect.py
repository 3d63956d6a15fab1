"""A jointctl inspector in Python: reads a running arm's joint states from shared memory.

It is an outside client of the shared-memory contract (framework/ipc): it uses only the PyPI
package `iceoryx2` 0.10 and ctypes mirrors of the `#[repr(C)]` payloads, and prints one JSON
object per sample in the shape of `jointctl inspect echo --json`:

    {"cycle": int, "stamp_ns": int (monotonic), "wall_ns": int (the cycle on the UNIX clock),
     "joints": [{"name", "position", "velocity", "deflection", "torque", "stiffness", "valid",
     "pivot", "reference_torque", "sensor_torque", "gravity", "mode", "enabled", "fault_code"}]}
    (SI units; null for what is not observed)

Usage: python jointctl_inspect.py ARM [--count N] [--timeout S]
"""

import argparse
import ctypes
import json
import math
import sys
import time

import iceoryx2 as iox2

# framework/ipc/src/lib.rs: MAX_JOINTS, NAME_LEN; framework/api/src/state.rs: FieldMask bits.
MAX_JOINTS = 16
NAME_LEN = 16
POSITION, VELOCITY, DEFLECTION, TORQUE, STIFFNESS, PIVOT = 1 << 0, 1 << 1, 1 << 2, 1 << 3, 1 << 4, 1 << 5
# framework/ipc/src/lib.rs: JointMode's codes and names.
MODES = {0: "hold", 1: "position", 2: "manual", 3: "trajectory", 4: "torque", 5: "impedance"}


class JointSample(ctypes.Structure):
    """Mirror of `jointctl_ipc::JointSample` (field order and types must match)."""

    _fields_ = [
        ("name", ctypes.c_uint8 * NAME_LEN),
        ("position_rad", ctypes.c_double),
        ("velocity_rad_s", ctypes.c_double),
        ("deflection_rad", ctypes.c_double),
        ("torque_nm", ctypes.c_double),
        ("stiffness_nm_per_rad", ctypes.c_double),
        ("pivot_mm", ctypes.c_double),
        ("reference_torque_nm", ctypes.c_double),
        ("sensor_torque_nm", ctypes.c_double),
        ("gravity_nm", ctypes.c_double),
        ("valid_mask", ctypes.c_uint32),
        ("fault_code", ctypes.c_uint32),
        ("mode", ctypes.c_uint32),  # jointctl_ipc::JointMode (0 hold .. 5 impedance)
        ("enabled", ctypes.c_uint32),
    ]


class ArmState(ctypes.Structure):
    """Mirror of `jointctl_ipc::ArmState`; iceoryx2 matches it by type name, size and alignment."""

    _fields_ = [
        ("cycle", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("joint_count", ctypes.c_uint32),
        ("final_sample", ctypes.c_uint32),
        ("joints", JointSample * MAX_JOINTS),
    ]

    @staticmethod
    def type_name() -> str:
        return "jointctl.ArmState.v4"


def field(sample: JointSample, bit: int, value: float):
    """The value when its bit is set in the validity mask, else None (JSON null)."""
    if sample.valid_mask & bit and math.isfinite(value):
        return value
    return None


def known(value: float):
    """A finite value, else None (JSON null): NaN means not known."""
    return value if math.isfinite(value) else None


def wall_clock_ns(stamp_ns: int):
    """The runtime's CLOCK_MONOTONIC stamp on the wall clock (same machine)."""
    age = time.monotonic_ns() - stamp_ns
    return time.time_ns() - age if age >= 0 else None


def as_json(state: ArmState) -> dict:
    joints = []
    for j in state.joints[: min(state.joint_count, MAX_JOINTS)]:
        name = bytes(j.name).split(b"\0", 1)[0].decode("utf-8", "replace")
        joints.append(
            {
                "name": name,
                "position": field(j, POSITION, j.position_rad),
                "velocity": field(j, VELOCITY, j.velocity_rad_s),
                "deflection": field(j, DEFLECTION, j.deflection_rad),
                "torque": field(j, TORQUE, j.torque_nm),
                "stiffness": field(j, STIFFNESS, j.stiffness_nm_per_rad),
                "valid": j.fault_code == 0 and bool(j.valid_mask & POSITION),
                "pivot": field(j, PIVOT, j.pivot_mm),
                "reference_torque": known(j.reference_torque_nm),
                "sensor_torque": known(j.sensor_torque_nm),
                "gravity": known(j.gravity_nm),
                "mode": MODES.get(j.mode, "unknown"),
                "enabled": j.enabled != 0,
                "fault_code": j.fault_code,
            }
        )
    return {"cycle": state.cycle, "stamp_ns": state.stamp_ns, "wall_ns": wall_clock_ns(state.stamp_ns), "joints": joints}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("arm", help="the arm's name (`arm:` in its YAML)")
    parser.add_argument("--count", type=int, default=None, help="stop after N samples")
    parser.add_argument("--timeout", type=float, default=5.0, help="give up after S seconds without a sample")
    args = parser.parse_args()

    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    node = iox2.NodeBuilder.new().create(iox2.ServiceType.Ipc)
    service_name = f"{args.arm}/joint_state"
    try:
        service = node.service_builder(iox2.ServiceName.new(service_name)).publish_subscribe(ArmState).open()
    except Exception as e:  # the arm is not running, or its payload layout differs
        print(f"error: cannot open `{service_name}`: {e!r} (is `jointctl run` running with arm `{args.arm}`?)", file=sys.stderr)
        return 1
    subscriber = service.subscriber_builder().create()
    received = 0
    last = time.monotonic()
    while args.count is None or received < args.count:
        sample = subscriber.receive()
        if sample is None:
            if time.monotonic() - last > args.timeout:
                print(f"error: no joint state from arm `{args.arm}` for {args.timeout} s", file=sys.stderr)
                return 1
            time.sleep(0.0005)
            continue
        last = time.monotonic()
        received += 1
        state = sample.payload().contents
        print(json.dumps(as_json(state)), flush=True)
        if state.final_sample and args.count is None:
            break
    return 0


if __name__ == "__main__":
    sys.exit(main())
