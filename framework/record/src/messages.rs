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

/// Writes JSON text into a buffer that is reused from sample to sample: the recorder encodes
/// three messages per cycle at up to 1 kHz, and building `serde_json::Value` trees for them cost
/// a third of a core (a map allocation per field).
struct Json<'a>(&'a mut String);

impl Json<'_> {
    fn raw(&mut self, text: &str) -> &mut Self {
        self.0.push_str(text);
        self
    }

    /// `"key":` after a comma unless it opens an object.
    fn key(&mut self, k: &str) -> &mut Self {
        if !self.0.ends_with('{') {
            self.0.push(',');
        }
        self.0.push('"');
        self.0.push_str(k);
        self.0.push_str("\":");
        self
    }

    /// A number (shortest text that reads back the same, as serde_json writes it); not
    /// finite: `null` (a value that is not known is not a number).
    fn num(&mut self, k: &str, x: f64) -> &mut Self {
        self.key(k);
        if x.is_finite() {
            self.0.push_str(ryu::Buffer::new().format_finite(x));
        } else {
            self.0.push_str("null");
        }
        self
    }

    fn int(&mut self, k: &str, x: u64) -> &mut Self {
        self.key(k);
        self.0.push_str(itoa::Buffer::new().format(x));
        self
    }

    fn bool(&mut self, k: &str, b: bool) -> &mut Self {
        self.key(k).raw(if b { "true" } else { "false" })
    }

    fn str(&mut self, k: &str, text: &str) -> &mut Self {
        self.key(k);
        self.0.push('"');
        // Names and codes need no escaping: copied whole.
        if !text.bytes().any(|b| b == b'"' || b == b'\\' || b < 0x20) {
            self.0.push_str(text);
            self.0.push('"');
            return self;
        }
        for c in text.chars() {
            match c {
                '"' => self.0.push_str("\\\""),
                '\\' => self.0.push_str("\\\\"),
                c if (c as u32) < 0x20 => {
                    use std::fmt::Write as _;
                    let _ = write!(self.0, "\\u{:04x}", c as u32);
                }
                c => self.0.push(c),
            }
        }
        self.0.push('"');
        self
    }

    /// `"k":[` + one object per item + `]`.
    fn objects<T>(&mut self, k: &str, items: impl IntoIterator<Item = T>, mut each: impl FnMut(&mut Self, T)) -> &mut Self {
        self.key(k).raw("[");
        for (i, item) in items.into_iter().enumerate() {
            self.raw(if i == 0 { "{" } else { ",{" });
            each(self, item);
            self.raw("}");
        }
        self.raw("]")
    }
}

fn finite(x: f64) -> Value {
    if x.is_finite() { Value::from(x) } else { Value::Null }
}

fn known(sample: &JointSample, bit: u32, value: f64) -> f64 {
    sample.get(bit, value).unwrap_or(f64::NAN)
}

/// A joint-state sample as JSON text, into `out` (cleared first).
pub fn write_joint_state(out: &mut String, s: &ArmState) {
    out.clear();
    let mut j = Json(out);
    j.raw("{").int("cycle", s.cycle).int("stamp_ns", s.stamp_ns).bool("final", s.final_sample != 0);
    j.objects("joints", s.joints(), |j, x| {
        j.str("name", decode_name(&x.name))
            .num("position_rad", known(x, FieldMask::POSITION, x.position_rad))
            .num("velocity_rad_s", known(x, FieldMask::VELOCITY, x.velocity_rad_s))
            .num("deflection_rad", known(x, FieldMask::DEFLECTION, x.deflection_rad))
            .num("torque_nm", known(x, FieldMask::TORQUE, x.torque_nm))
            .num("stiffness_nm_per_rad", known(x, FieldMask::STIFFNESS, x.stiffness_nm_per_rad))
            .num("pivot_mm", known(x, FieldMask::PIVOT, x.pivot_mm))
            .num("reference_torque_nm", x.reference_torque_nm)
            .num("sensor_torque_nm", x.sensor_torque_nm)
            .num("gravity_nm", x.gravity_nm)
            .str("mode", x.mode.name())
            .bool("enabled", x.enabled != 0)
            .int("fault_code", u64::from(x.fault_code));
    });
    j.raw("}");
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
    let mut out = String::new();
    write_joint_state(&mut out, s);
    serde_json::from_str(&out).unwrap_or(Value::Null)
}

/// A diagnostics sample as JSON text, into `out` (cleared first).
pub fn write_diagnostics(out: &mut String, d: &Diagnostics) {
    out.clear();
    let mut j = Json(out);
    j.raw("{")
        .int("cycle", d.cycle)
        .int("stamp_ns", d.stamp_ns)
        .int("period_ns", d.period_ns)
        .int("overruns", d.overruns)
        .int("missed_deadlines", d.missed_deadlines)
        .int("hal_errors", d.hal_errors)
        .int("publish_drops", d.publish_drops)
        .int("last_compute_ns", d.last_compute_ns)
        .int("max_compute_ns", d.max_compute_ns)
        .int("max_lateness_ns", d.max_jitter_ns);
    j.objects("lateness_histogram", JITTER_BUCKET_UPPER_US.iter().zip(&d.jitter_histogram), |j, (upper, n)| {
        if *upper == u64::MAX {
            j.key("upper_us").raw("null");
        } else {
            j.int("upper_us", *upper);
        }
        j.int("cycles", *n);
    });
    j.objects("joints", &d.joints[..(d.joint_count as usize).min(d.joints.len())], |j, x| {
        j.str("name", decode_name(&x.name))
            .int("fault_code", u64::from(x.fault_code))
            .bool("held", x.held != 0)
            .int("invalid_cycles", x.invalid_cycles)
            .int("fault_count", x.fault_count)
            .int("setpoint_clamps", x.setpoint_clamps)
            .int("torque_clamps", x.torque_clamps)
            .int("rate_limited", x.rate_limited)
            .int("watchdog_trips", x.watchdog_trips)
            .int("missing_inputs", x.missing_inputs)
            .int("plugin_max_ns", x.plugin_max_ns)
            .int("over_budget_cycles", x.over_budget_cycles);
    });
    j.objects("devices", &d.devices[..(d.device_count as usize).min(d.devices.len())], |j, x| {
        j.str("name", decode_name(&x.name))
            .int("missing", x.missing)
            .int("invalid", x.invalid)
            .int("implausible", x.implausible)
            .int("emcy", x.emcy)
            .int("flags", u64::from(x.flags));
    });
    j.raw("}");
}

/// A diagnostics sample.
///
/// ```
/// let v = jointctl_record::messages::diagnostics(&jointctl_ipc::Diagnostics::EMPTY);
/// assert_eq!(v["lateness_histogram"].as_array().unwrap().len(), 16);
/// assert!(v["lateness_histogram"][15]["upper_us"].is_null(), "the last bucket has no bound");
/// ```
pub fn diagnostics(d: &Diagnostics) -> Value {
    let mut out = String::new();
    write_diagnostics(&mut out, d);
    serde_json::from_str(&out).unwrap_or(Value::Null)
}

fn reading(j: &mut Json, r: &RawReading) {
    j.num("value", r.value).str("status", r.status.name()).num("age_s", r.age_s);
}

/// A raw frame as JSON text, its devices named by the descriptor, into `out` (cleared first).
pub fn write_raw(out: &mut String, f: &RawFrame, d: &RawDescriptor) {
    out.clear();
    let mut j = Json(out);
    j.raw("{").int("cycle", f.cycle).int("stamp_ns", f.stamp_ns).int("commands_applied", f.commands_applied);
    j.objects("encoders", f.encoders().iter().zip(&d.encoders), |j, (r, dev)| {
        j.str("name", decode_name(&dev.name));
        reading(j, r);
    });
    j.objects("drives", f.drives().iter().zip(&d.drives), |j, (r, dev)| {
        j.str("name", decode_name(&dev.name)).key("position_rad").raw("{");
        reading(j, &r.position_rad);
        j.raw("}").key("velocity_rad_s").raw("{");
        reading(j, &r.velocity_rad_s);
        j.raw("}")
            .bool("enabled", r.enabled != 0)
            .bool("fault", r.fault != 0)
            .str("action", r.action.name())
            .num("setpoint_rad", r.setpoint_rad)
            .num("velocity_ff_rad_s", r.velocity_ff_rad_s);
    });
    j.objects("torque_sensors", f.torque_sensors().iter().zip(&d.torque_sensors), |j, (r, dev)| {
        j.str("name", decode_name(&dev.name));
        reading(j, r);
    });
    j.raw("}");
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
    let mut out = String::new();
    write_raw(&mut out, f, d);
    serde_json::from_str(&out).unwrap_or(Value::Null)
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
        "stiffness_nm_per_rad": number(), "pivot_mm": number(), "reference_torque_nm": number(), "sensor_torque_nm": number(), "gravity_nm": number(),
        "mode": {"type": "string"}, "enabled": {"type": "boolean"}, "fault_code": count,
    }});
    let body = match topic {
        "joint_state" => json!({"description": "Every joint's observed state, once per cycle (SI units; null: not known)", "properties": {
            "cycle": count, "stamp_ns": count, "final": {"type": "boolean"}, "joints": {"type": "array", "items": joint},
        }}),
        "raw" => json!({"description": "Every device's reading as the HAL gave it and every set-point written, once per cycle", "properties": {
            "cycle": count, "stamp_ns": count, "commands_applied": count,
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

#[cfg(test)]
mod tests {
    use super::Json;

    #[test]
    fn the_json_writer_escapes_text_and_writes_no_non_finite_number() {
        let mut out = String::new();
        let mut j = Json(&mut out);
        j.raw("{").str("name", "a\"b\\c\u{1}").num("x", f64::NAN).num("y", f64::INFINITY).num("z", -0.25).int("n", u64::MAX).bool("b", true).raw("}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("{out}: {e}"));
        assert_eq!(v["name"], "a\"b\\c\u{1}");
        assert!(v["x"].is_null() && v["y"].is_null());
        assert_eq!((v["z"].as_f64(), v["n"].as_u64(), v["b"].as_bool()), (Some(-0.25), Some(u64::MAX), Some(true)));
    }
}
