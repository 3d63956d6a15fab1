//! The JSON form of each recorded sample and the JSON schema of each channel: what Foxglove
//! shows and plots, and what `fit`, `identify` and `replay` read back. Every number is SI with its
//! unit in the field name; a value that is not known (a missing reading, an unobserved field) is
//! `null`, never a number.

use jointctl_ipc::raw::{CommandRecord, RawDescriptor, RawFrame, RawReading};
use jointctl_ipc::{ArmState, Diagnostics, FieldMask, JITTER_BUCKET_UPPER_US, JointSample, decode_name};
use serde_json::{Value, json};

/// The recorded channels, in the order they are written: (topic, schema name).
pub const CHANNELS: [(&str, &str); 4] =
    [("raw", "jointctl.RawFrame"), ("joint_state", "jointctl.ArmState"), ("diagnostics", "jointctl.Diagnostics"), ("commands", "jointctl.CommandRecord")];

fn known(sample: &JointSample, bit: u32, value: f64) -> Value {
    sample.get(bit, value).filter(|v| v.is_finite()).map_or(Value::Null, Value::from)
}

fn finite(x: f64) -> Value {
    if x.is_finite() { Value::from(x) } else { Value::Null }
}

/// A joint-state sample.
///
/// ```
/// let mut s = jointctl_ipc::ArmState::EMPTY;
/// s.joint_count = 1;
/// s.joints[0].name = jointctl_ipc::encode_name("q2");
/// let v = jointctl_record::messages::joint_state(&s);
/// assert_eq!(v["joints"][0]["name"], "q2");
/// assert!(v["joints"][0]["torque_nm"].is_null(), "an unobserved torque is not a number");
/// ```
pub fn joint_state(s: &ArmState) -> Value {
    let joints: Vec<Value> = s
        .joints()
        .iter()
        .map(|j| {
            json!({
                "name": decode_name(&j.name),
                "position_rad": known(j, FieldMask::POSITION, j.position_rad),
                "velocity_rad_s": known(j, FieldMask::VELOCITY, j.velocity_rad_s),
                "deflection_rad": known(j, FieldMask::DEFLECTION, j.deflection_rad),
                "torque_nm": known(j, FieldMask::TORQUE, j.torque_nm),
                "stiffness_nm_per_rad": known(j, FieldMask::STIFFNESS, j.stiffness_nm_per_rad),
                "pivot_mm": known(j, FieldMask::PIVOT, j.pivot_mm),
                "reference_torque_nm": finite(j.reference_torque_nm),
                "sensor_torque_nm": finite(j.sensor_torque_nm),
                "mode": j.mode.name(),
                "enabled": j.enabled != 0,
                "fault_code": j.fault_code,
            })
        })
        .collect();
    json!({"cycle": s.cycle, "stamp_ns": s.stamp_ns, "final": s.final_sample != 0, "joints": joints})
}

/// A diagnostics sample.
///
/// ```
/// let v = jointctl_record::messages::diagnostics(&jointctl_ipc::Diagnostics::EMPTY);
/// assert_eq!(v["lateness_histogram"].as_array().unwrap().len(), 16);
/// ```
pub fn diagnostics(d: &Diagnostics) -> Value {
    let joints: Vec<Value> = d.joints[..(d.joint_count as usize).min(d.joints.len())]
        .iter()
        .map(|j| {
            json!({
                "name": decode_name(&j.name),
                "fault_code": j.fault_code,
                "held": j.held != 0,
                "invalid_cycles": j.invalid_cycles,
                "fault_count": j.fault_count,
                "setpoint_clamps": j.setpoint_clamps,
                "torque_clamps": j.torque_clamps,
                "rate_limited": j.rate_limited,
                "watchdog_trips": j.watchdog_trips,
                "missing_inputs": j.missing_inputs,
                "plugin_max_ns": j.plugin_max_ns,
                "over_budget_cycles": j.over_budget_cycles,
            })
        })
        .collect();
    let devices: Vec<Value> = d.devices[..(d.device_count as usize).min(d.devices.len())]
        .iter()
        .map(|x| json!({"name": decode_name(&x.name), "missing": x.missing, "invalid": x.invalid, "implausible": x.implausible, "emcy": x.emcy, "flags": x.flags}))
        .collect();
    let histogram: Vec<Value> = JITTER_BUCKET_UPPER_US
        .iter()
        .zip(&d.jitter_histogram)
        .map(|(upper, n)| json!({"upper_us": if *upper == u64::MAX { Value::Null } else { Value::from(*upper) }, "cycles": n}))
        .collect();
    json!({
        "cycle": d.cycle,
        "stamp_ns": d.stamp_ns,
        "period_ns": d.period_ns,
        "overruns": d.overruns,
        "missed_deadlines": d.missed_deadlines,
        "hal_errors": d.hal_errors,
        "publish_drops": d.publish_drops,
        "last_compute_ns": d.last_compute_ns,
        "max_compute_ns": d.max_compute_ns,
        "max_lateness_ns": d.max_jitter_ns,
        "lateness_histogram": histogram,
        "joints": joints,
        "devices": devices,
    })
}

fn reading(r: &RawReading) -> Value {
    json!({"value": finite(r.value), "status": r.status.name(), "age_s": finite(r.age_s)})
}

/// A raw frame, its devices named by the descriptor.
///
/// ```
/// use jointctl_ipc::raw::{RawDescriptor, RawFrame, RawReading};
/// let d = RawDescriptor::of(40.0, &[("enc_q2_out", 0)], &[], &[], None);
/// let mut f = RawFrame::EMPTY;
/// f.encoder_count = 1;
/// f.encoders[0] = RawReading::from_reading(&jointctl_api::Reading::valid(0.25));
/// let v = jointctl_record::messages::raw(&f, &d);
/// assert_eq!(v["encoders"][0]["name"], "enc_q2_out");
/// assert_eq!(v["encoders"][0]["value"], 0.25);
/// ```
pub fn raw(f: &RawFrame, d: &RawDescriptor) -> Value {
    let encoders: Vec<Value> = f
        .encoders()
        .iter()
        .zip(&d.encoders)
        .map(|(r, dev)| {
            let mut v = reading(r);
            v["name"] = decode_name(&dev.name).into();
            v
        })
        .collect();
    let drives: Vec<Value> = f
        .drives()
        .iter()
        .zip(&d.drives)
        .map(|(r, dev)| {
            json!({
                "name": decode_name(&dev.name),
                "position_rad": reading(&r.position_rad),
                "velocity_rad_s": reading(&r.velocity_rad_s),
                "enabled": r.enabled != 0,
                "fault": r.fault != 0,
                "action": r.action.name(),
                "setpoint_rad": finite(r.setpoint_rad),
                "velocity_ff_rad_s": finite(r.velocity_ff_rad_s),
            })
        })
        .collect();
    let torque_sensors: Vec<Value> = f
        .torque_sensors()
        .iter()
        .zip(&d.torque_sensors)
        .map(|(r, dev)| {
            let mut v = reading(r);
            v["name"] = decode_name(&dev.name).into();
            v
        })
        .collect();
    json!({"cycle": f.cycle, "stamp_ns": f.stamp_ns, "encoders": encoders, "drives": drives, "torque_sensors": torque_sensors})
}

/// An accepted command.
///
/// ```
/// use jointctl_ipc::{CommandRequest, CommandResponse, TorqueWaveform};
/// let r = jointctl_ipc::raw::CommandRecord {
///     sequence: 1,
///     stamp_ns: 5,
///     request: CommandRequest::torque("q2", TorqueWaveform::SINE, &[5.0, 0.1, 0.0, 0.0]),
///     response: CommandResponse::new(true, "q2: torque sine"),
/// };
/// let v = jointctl_record::messages::command(&r);
/// assert_eq!((v["kind"].as_str(), v["waveform"].as_str()), (Some("torque"), Some("sine")));
/// assert_eq!(v["values"].as_array().unwrap().len(), 4, "only the values given");
/// ```
pub fn command(r: &CommandRecord) -> Value {
    let q = &r.request;
    let values: Vec<Value> = {
        // Trailing unset values (NaN) are not part of the command.
        let used = q.values.iter().rposition(|v| !v.is_nan()).map_or(0, |i| i + 1);
        q.values[..used].iter().map(|v| finite(*v)).collect()
    };
    let points: Vec<Value> = q.points[..(q.point_count as usize).min(q.points.len())].iter().map(|p| json!([finite(p[0]), finite(p[1]), finite(p[2])])).collect();
    json!({
        "sequence": r.sequence,
        "stamp_ns": r.stamp_ns,
        "kind": q.kind.name(),
        "joint": decode_name(&q.joint),
        "streamed": q.streamed != 0,
        "waveform": q.waveform.name(),
        "values": values,
        "points": points,
        "message": r.response.text(),
    })
}

fn number() -> Value {
    json!({"type": ["number", "null"]})
}

fn reading_schema() -> Value {
    json!({"type": "object", "properties": {"value": number(), "status": {"type": "string", "enum": ["missing", "valid", "stale", "invalid"]}, "age_s": number()}})
}

/// The JSON schema of a channel (`raw`, `joint_state`, `diagnostics`, `commands`).
///
/// ```
/// let s = jointctl_record::messages::schema("joint_state").unwrap();
/// assert_eq!(s["properties"]["joints"]["type"], "array");
/// assert!(jointctl_record::messages::schema("nope").is_none());
/// ```
pub fn schema(topic: &str) -> Option<Value> {
    let count = json!({"type": "integer", "minimum": 0});
    let joint = json!({"type": "object", "properties": {
        "name": {"type": "string"},
        "position_rad": number(), "velocity_rad_s": number(), "deflection_rad": number(), "torque_nm": number(),
        "stiffness_nm_per_rad": number(), "pivot_mm": number(), "reference_torque_nm": number(), "sensor_torque_nm": number(),
        "mode": {"type": "string"}, "enabled": {"type": "boolean"}, "fault_code": count,
    }});
    let body = match topic {
        "joint_state" => json!({"description": "Every joint's observed state, once per cycle (SI units; null: not known)", "properties": {
            "cycle": count, "stamp_ns": count, "final": {"type": "boolean"}, "joints": {"type": "array", "items": joint},
        }}),
        "raw" => json!({"description": "Every device's reading as the HAL gave it and every set-point written, once per cycle", "properties": {
            "cycle": count, "stamp_ns": count,
            "encoders": {"type": "array", "items": {"type": "object", "properties": {"name": {"type": "string"}, "value": number(), "status": {"type": "string"}, "age_s": number()}}},
            "drives": {"type": "array", "items": {"type": "object", "properties": {
                "name": {"type": "string"}, "position_rad": reading_schema(), "velocity_rad_s": reading_schema(),
                "enabled": {"type": "boolean"}, "fault": {"type": "boolean"}, "action": {"type": "string"}, "setpoint_rad": number(), "velocity_ff_rad_s": number(),
            }}},
            "torque_sensors": {"type": "array", "items": {"type": "object", "properties": {"name": {"type": "string"}, "value": number(), "status": {"type": "string"}, "age_s": number()}}},
        }}),
        "diagnostics" => json!({"description": "Loop health, once per cycle", "properties": {
            "cycle": count, "stamp_ns": count, "period_ns": count, "overruns": count, "missed_deadlines": count, "hal_errors": count,
            "publish_drops": count, "last_compute_ns": count, "max_compute_ns": count, "max_lateness_ns": count,
            "lateness_histogram": {"type": "array", "items": {"type": "object", "properties": {"upper_us": {"type": ["integer", "null"]}, "cycles": count}}},
            "joints": {"type": "array", "items": {"type": "object"}}, "devices": {"type": "array", "items": {"type": "object"}},
        }}),
        "commands" => json!({"description": "A command the runtime accepted", "properties": {
            "sequence": count, "stamp_ns": count, "kind": {"type": "string"}, "joint": {"type": "string"}, "streamed": {"type": "boolean"},
            "waveform": {"type": "string"}, "values": {"type": "array", "items": number()}, "points": {"type": "array"}, "message": {"type": "string"},
        }}),
        _ => return None,
    };
    let mut s = json!({"$schema": "https://json-schema.org/draft/2020-12/schema", "type": "object"});
    if let (Some(out), Some(body)) = (s.as_object_mut(), body.as_object()) {
        out.extend(body.clone());
    }
    Some(s)
}
