"""A jointctl inspector in Python: reads a running arm's joint states and diagnostics from
shared memory.

It is an outside client of the shared-memory contract (framework/ipc): it uses only the PyPI
package `iceoryx2` 0.10 and ctypes mirrors of the `#[repr(C)]` payloads, and prints one JSON
object per sample in the shape of `jointctl inspect echo --json`:

    {"cycle": int, "stamp_ns": int (monotonic), "wall_ns": int (the cycle on the UNIX clock),
     "joints": [{"name", "position", "velocity", "deflection", "torque", "stiffness", "valid",
     "pivot", "reference_torque", "sensor_torque", "gravity", "mode", "enabled", "fault_code"}]}
    (SI units; null for what is not observed)

With `--diag` it prints the newest diagnostics once, in the shape of `jointctl inspect diag
--json` (the recording's `diagnostics` channel). With `--latest` it reads the arm's latest-state
blackboard instead of the joint-state stream (as `jointctl inspect echo --latest`): each cycle as
soon as the loop observed it, the newest only, a line per new cycle. `--domain D` and `--ipc-root DIR` find an arm
whose YAML sets `ipc.domain` / `ipc.root`, as the Rust tools' options do.

Usage: python jointctl_inspect.py ARM [--domain D] [--ipc-root DIR] [--count N] [--timeout S] [--diag | --latest]
"""

import argparse
import ctypes
import json
import math
import sys
import time

import iceoryx2 as iox2

# framework/ipc/src/lib.rs: NAME_LEN, DEVICE_NAME_LEN, JITTER_BUCKET_UPPER_US; diagnostics.rs:
# FAULT_MESSAGE_LEN; latest.rs: PAGE_JOINTS; framework/api/src/state.rs: FieldMask bits.
PAGE_JOINTS = 16
NAME_LEN = 16
DEVICE_NAME_LEN = 48
FAULT_MESSAGE_LEN = 128
JITTER_BUCKET_UPPER_US = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000, None]
POSITION, VELOCITY, DEFLECTION, TORQUE, STIFFNESS, PIVOT = 1 << 0, 1 << 1, 1 << 2, 1 << 3, 1 << 4, 1 << 5
# framework/ipc/src/lib.rs: JointMode's codes and names.
MODES = {0: "hold", 1: "position", 2: "manual", 3: "trajectory", 4: "torque", 5: "impedance"}


class JointSample(ctypes.Structure):
    """Mirror of `jointctl_ipc::JointSample` (field order and types must match): the
    joint-state service's payload is a slice of them, one per DOF."""

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

    @staticmethod
    def type_name() -> str:
        return "jointctl.JointSample.v1"


class ArmStateHeader(ctypes.Structure):
    """Mirror of `jointctl_ipc::ArmStateHeader`, the joint-state samples' user header;
    iceoryx2 matches it by type name, size and alignment."""

    _fields_ = [
        ("cycle", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("final_sample", ctypes.c_uint32),
        ("joint_count", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "jointctl.ArmStateHeader.v1"


class LatestStatePage(ctypes.Structure):
    """Mirror of `jointctl_ipc::LatestStatePage`: one entry of the latest-state blackboard."""

    _fields_ = [
        ("cycle", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("arm_joint_count", ctypes.c_uint32),
        ("first_joint", ctypes.c_uint32),
        ("joint_count", ctypes.c_uint32),
        ("final_sample", ctypes.c_uint32),
        ("joints", JointSample * PAGE_JOINTS),
    ]

    @staticmethod
    def type_name() -> str:
        return "jointctl.LatestStatePage.v1"


class JointDiagnostics(ctypes.Structure):
    """Mirror of `jointctl_ipc::JointDiagnostics`."""

    _fields_ = [
        ("name", ctypes.c_uint8 * NAME_LEN),
        ("valid_mask", ctypes.c_uint32),
        ("fault_code", ctypes.c_uint32),
        ("held", ctypes.c_uint32),
        ("_reserved", ctypes.c_uint32),
        ("invalid_cycles", ctypes.c_uint64),
        ("fault_count", ctypes.c_uint64),
        ("setpoint_clamps", ctypes.c_uint64),
        ("torque_clamps", ctypes.c_uint64),
        ("rate_limited", ctypes.c_uint64),
        ("watchdog_trips", ctypes.c_uint64),
        ("missing_inputs", ctypes.c_uint64),
        ("plugin_budget_ns", ctypes.c_uint64),
        ("plugin_max_ns", ctypes.c_uint64),
        ("over_budget_cycles", ctypes.c_uint64),
        ("setpoint_rejections", ctypes.c_uint64),
        ("fault_message", ctypes.c_uint8 * FAULT_MESSAGE_LEN),
    ]


class DeviceDiagnostics(ctypes.Structure):
    """Mirror of `jointctl_ipc::DeviceDiagnostics`."""

    _fields_ = [
        ("name", ctypes.c_uint8 * DEVICE_NAME_LEN),
        ("missing", ctypes.c_uint64),
        ("invalid", ctypes.c_uint64),
        ("implausible", ctypes.c_uint64),
        ("emcy", ctypes.c_uint64),
        ("flags", ctypes.c_uint32),
        ("_reserved", ctypes.c_uint32),
    ]


class DiagnosticsHeader(ctypes.Structure):
    """Mirror of `jointctl_ipc::DiagnosticsHeader`, the diagnostics samples' user header; their
    payload is bytes: `joint_count` JointDiagnostics, then `device_count` DeviceDiagnostics."""

    _fields_ = [
        ("cycle", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("period_ns", ctypes.c_uint64),
        ("overruns", ctypes.c_uint64),
        ("missed_deadlines", ctypes.c_uint64),
        ("hal_errors", ctypes.c_uint64),
        ("publish_drops", ctypes.c_uint64),
        ("last_compute_ns", ctypes.c_uint64),
        ("max_compute_ns", ctypes.c_uint64),
        ("max_jitter_ns", ctypes.c_uint64),
        ("jitter_histogram", ctypes.c_uint64 * 16),
        ("joint_count", ctypes.c_uint32),
        ("device_count", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "jointctl.DiagnosticsHeader.v1"


def diagnostics_entries(header: DiagnosticsHeader, payload: bytes):
    """The joints' and devices' entries of a diagnostics sample's byte payload, or a ValueError
    when its length is not what the header says."""
    joints, devices = header.joint_count, header.device_count
    expected = joints * ctypes.sizeof(JointDiagnostics) + devices * ctypes.sizeof(DeviceDiagnostics)
    if len(payload) != expected:
        raise ValueError(f"a diagnostics payload of {len(payload)} bytes, its header says {joints} joints and {devices} devices ({expected} bytes)")
    at = joints * ctypes.sizeof(JointDiagnostics)
    return (JointDiagnostics * joints).from_buffer_copy(payload, 0), (DeviceDiagnostics * devices).from_buffer_copy(payload, at)


def text(raw) -> str:
    """A NUL-padded name field as text."""
    return bytes(raw).split(b"\0", 1)[0].decode("utf-8", "replace")


def diagnostics_json(d: DiagnosticsHeader, payload: bytes) -> dict:
    """The shape of `jointctl inspect diag --json`."""
    joints, devices = diagnostics_entries(d, payload)
    counters = ["cycle", "stamp_ns", "period_ns", "overruns", "missed_deadlines", "hal_errors", "publish_drops", "last_compute_ns", "max_compute_ns"]
    out = {k: getattr(d, k) for k in counters}
    out["max_lateness_ns"] = d.max_jitter_ns
    out["lateness_histogram"] = [{"upper_us": u, "cycles": n} for u, n in zip(JITTER_BUCKET_UPPER_US, d.jitter_histogram)]
    joint_counters = ["invalid_cycles", "fault_count", "setpoint_clamps", "torque_clamps", "rate_limited", "watchdog_trips", "missing_inputs", "plugin_max_ns", "over_budget_cycles", "setpoint_rejections"]
    out["joints"] = [
        {"name": text(j.name), "fault_code": j.fault_code, "fault_message": text(j.fault_message), "held": j.held != 0, **{k: getattr(j, k) for k in joint_counters}}
        for j in joints
    ]
    out["devices"] = [
        {"name": text(x.name), "missing": x.missing, "invalid": x.invalid, "implausible": x.implausible, "emcy": x.emcy, "flags": x.flags}
        for x in devices
    ]
    return out


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


def as_json(header, joints_in) -> dict:
    """A joint-state sample as JSON: its header (`cycle`, `stamp_ns`) and its joints."""
    joints = []
    for j in joints_in:
        joints.append(
            {
                "name": text(j.name),
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
    return {"cycle": header.cycle, "stamp_ns": header.stamp_ns, "wall_ns": wall_clock_ns(header.stamp_ns), "joints": joints}


def node_in(domain, ipc_root):
    """A node in the arm's domain and root (its YAML's `ipc.domain`, `ipc.root`)."""
    config = iox2.config.default()
    g = config.global_cfg
    if domain is not None:
        g.prefix = iox2.FileName.new(domain)
    if ipc_root is not None:
        g.root_path = iox2.Path.new(ipc_root)
    return iox2.NodeBuilder.new().config(config).create(iox2.ServiceType.Ipc)


def read_pages(entries):
    """The latest state from the blackboard's pages: (first page, joints), or None when the loop
    wrote between two pages' reads (they are of different cycles)."""
    pages = [e.get().decode_as(LatestStatePage) for e in entries]
    if any(p.cycle != pages[0].cycle for p in pages):
        return None
    joints = [j for p in pages for j in p.joints[: min(p.joint_count, PAGE_JOINTS)]]
    return pages[0], joints


def latest(node, args, hint) -> int:
    """`--latest`: the arm's latest-state blackboard (`<arm>/latest_state`, keys 0.. of type u32,
    one `LatestStatePage` of up to 16 joints each), a line per new cycle it shows (not before
    the loop's first)."""
    service_name = f"{args.arm}/latest_state"
    try:
        service = node.service_builder(iox2.ServiceName.new(service_name)).blackboard_opener(ctypes.c_uint32).open()
        reader = service.reader_builder().create()
        first = reader.entry(ctypes.c_uint32(0), LatestStatePage)
        pages = max(1, -(-first.get().decode_as(LatestStatePage).arm_joint_count // PAGE_JOINTS))
        entries = [first] + [reader.entry(ctypes.c_uint32(k), LatestStatePage) for k in range(1, pages)]
    except Exception as e:  # the arm is not running, or the layouts differ
        print(f"error: cannot open `{service_name}`: {e!r} (is `jointctl run` running with arm `{args.arm}`?){hint}", file=sys.stderr)
        return 1
    received, shown, last = 0, None, time.monotonic()
    while args.count is None or received < args.count:
        read = read_pages(entries)
        if read is None:
            continue
        state, joints = read
        if state.stamp_ns == 0 or state.cycle == shown:
            if time.monotonic() - last > args.timeout:
                print(f"error: no new cycle on `{service_name}` for {args.timeout} s", file=sys.stderr)
                return 1
            time.sleep(0.0005)
            continue
        shown, last = state.cycle, time.monotonic()
        received += 1
        print(json.dumps(as_json(state, joints)), flush=True)
        if state.final_sample and args.count is None:
            break
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("arm", help="the arm's name (`arm:` in its YAML)")
    parser.add_argument("--domain", default=None, help="iceoryx2 domain of the arm (its YAML `ipc.domain`)")
    parser.add_argument("--ipc-root", default=None, help="shared-memory root of the arm (its YAML `ipc.root`)")
    parser.add_argument("--count", type=int, default=None, help="stop after N samples")
    parser.add_argument("--timeout", type=float, default=5.0, help="give up after S seconds without a sample")
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--diag", action="store_true", help="print the newest diagnostics once (`inspect diag --json`)")
    which.add_argument("--latest", action="store_true", help="read the latest-state blackboard (`inspect echo --latest`)")
    args = parser.parse_args()

    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    node = node_in(args.domain, args.ipc_root)
    hint = f" in domain `{args.domain}`" if args.domain else " (an arm whose YAML sets `ipc.domain` is found with --domain D)"
    if args.latest:
        return latest(node, args, hint)
    topic = "diagnostics" if args.diag else "joint_state"
    service_name = f"{args.arm}/{topic}"
    try:
        builder = node.service_builder(iox2.ServiceName.new(service_name))
        if args.diag:
            service = builder.publish_subscribe(iox2.Slice[ctypes.c_uint8]).user_header(DiagnosticsHeader).open()
        else:
            # A slice of joints sized by the arm, the cycle's fields in the user header.
            service = builder.publish_subscribe(iox2.Slice[JointSample]).user_header(ArmStateHeader).open()
    except Exception as e:  # the arm is not running, or its payload layout differs
        print(f"error: cannot open `{service_name}`: {e!r} (is `jointctl run` running with arm `{args.arm}`?){hint}", file=sys.stderr)
        return 1
    subscriber = service.subscriber_builder().create()
    if args.diag:
        started = time.monotonic()
        newest = None
        while True:
            sample = subscriber.receive()
            if sample is not None:
                newest = diagnostics_json(sample.user_header().contents, bytes(sample.payload().as_memory_view()))
                continue
            if newest is not None:
                print(json.dumps(newest), flush=True)
                return 0
            if time.monotonic() - started > args.timeout:
                print(f"error: no diagnostics from arm `{args.arm}` for {args.timeout} s{hint}", file=sys.stderr)
                return 1
            time.sleep(0.001)
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
        header, joints = sample.user_header().contents, sample.payload()
        # The header says how many joints; the package's slice length is in bytes (0.10) or
        # in elements: anything else is a sample of another layout.
        if joints.len() not in (header.joint_count, header.joint_count * ctypes.sizeof(JointSample)):
            print(f"error: a joint-state sample of {joints.len()} payload units says {header.joint_count} joints", file=sys.stderr)
            return 1
        print(json.dumps(as_json(header, [joints[i] for i in range(header.joint_count)])), flush=True)
        if header.final_sample and args.count is None:
            break
    return 0


if __name__ == "__main__":
    sys.exit(main())
