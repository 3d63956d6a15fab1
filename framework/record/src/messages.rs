//! The JSON form of each recorded sample and the JSON schema of each channel: what Foxglove
//! shows and plots, and what `fit`, `identify` and `replay` read back. Every number is SI with its
//! unit in the field name; a value that is not known (a missing reading, an unobserved field) is
//! `null`, never a number.

use jointctl_ipc::raw::{CommandRecord, RawDescriptor, RawFrame, RawReading};
use jointctl_ipc::CommandRequest;
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

/// Reads a joint-state sample back from its JSON ([`write_joint_state`]'s form; a network
/// client gets it from a bridge): a `null` field is unobserved (its bit clear, its value NaN).
///
/// ```
/// let mut s = jointctl_ipc::ArmState::EMPTY;
/// s.cycle = 7;
/// s.joints.push(jointctl_ipc::JointSample::EMPTY);
/// s.joints[0].name = jointctl_ipc::encode_name("q2");
/// s.joints[0].torque_nm = 1.5;
/// s.joints[0].valid_mask = jointctl_ipc::FieldMask::TORQUE;
/// let back = jointctl_record::messages::parse_joint_state(&jointctl_record::messages::joint_state(&s)).unwrap();
/// assert_eq!((back.cycle, back.joints()[0].torque_nm, back.joints()[0].valid_mask), (7, 1.5, jointctl_ipc::FieldMask::TORQUE));
/// assert!(back.joints()[0].position_rad.is_nan());
/// ```
pub fn parse_joint_state(v: &Value) -> Result<ArmState, MessageError> {
    let count = |key: &str| v[key].as_u64().ok_or_else(|| MessageError::new(key, "is not a count"));
    let mut s = ArmState::EMPTY;
    s.cycle = count("cycle")?;
    s.stamp_ns = count("stamp_ns")?;
    s.final_sample = u32::from(v["final"].as_bool().unwrap_or(false));
    let joints = v["joints"].as_array().ok_or_else(|| MessageError::new("joints", "is not an array"))?;
    s.joints = vec![jointctl_ipc::JointSample::EMPTY; joints.len()];
    for (i, (out, j)) in s.joints.iter_mut().zip(joints).enumerate() {
        let at = |key: &str| format!("joints[{i}].{key}");
        let name = j["name"].as_str().ok_or_else(|| MessageError::new(at("name"), "is not a string"))?;
        out.name = jointctl_ipc::encode_name(name);
        let mut field = |key: &str, bit: u32| -> Result<f64, MessageError> {
            match &j[key] {
                Value::Null => Ok(f64::NAN),
                x => {
                    let value = x.as_f64().ok_or_else(|| MessageError::new(at(key), "is not a number"))?;
                    out.valid_mask |= bit;
                    Ok(value)
                }
            }
        };
        out.position_rad = field("position_rad", FieldMask::POSITION)?;
        out.velocity_rad_s = field("velocity_rad_s", FieldMask::VELOCITY)?;
        out.deflection_rad = field("deflection_rad", FieldMask::DEFLECTION)?;
        out.torque_nm = field("torque_nm", FieldMask::TORQUE)?;
        out.stiffness_nm_per_rad = field("stiffness_nm_per_rad", FieldMask::STIFFNESS)?;
        out.pivot_mm = field("pivot_mm", FieldMask::PIVOT)?;
        // Not observed fields: no bit.
        out.reference_torque_nm = field("reference_torque_nm", 0)?;
        out.sensor_torque_nm = field("sensor_torque_nm", 0)?;
        out.gravity_nm = field("gravity_nm", 0)?;
        let mode = j["mode"].as_str().unwrap_or("hold");
        out.mode = jointctl_ipc::JointMode::from_name(mode).ok_or_else(|| MessageError::new(at("mode"), format!("unknown mode `{mode}`")))?;
        out.enabled = u32::from(j["enabled"].as_bool().unwrap_or(true));
        out.fault_code = j["fault_code"].as_u64().and_then(|c| u32::try_from(c).ok()).unwrap_or(0);
    }
    Ok(s)
}

/// A JSON message that does not have the shape of a jointctl message ([`parse_joint_state`],
/// [`parse_request`]): the field, as a path into the message, and what is wrong with it.
///
/// ```
/// let e = jointctl_record::messages::parse_request(&serde_json::json!({"kind": "fly"})).unwrap_err();
/// assert_eq!(e.field, "kind");
/// assert!(e.to_string().starts_with("`kind`: unknown command `fly`"), "{e}");
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MessageError {
    /// Where: `kind`, `values[2]`, `joints[0].mode`; empty for the message as a whole.
    pub field: String,
    /// What is wrong.
    pub problem: String,
}

impl std::fmt::Display for MessageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.field.as_str(), self.problem.starts_with("is ") || self.problem.starts_with("must ")) {
            ("", _) => write!(f, "{}", self.problem),
            (field, true) => write!(f, "`{field}` {}", self.problem),
            (field, false) => write!(f, "`{field}`: {}", self.problem),
        }
    }
}

impl std::error::Error for MessageError {}

impl MessageError {
    /// The error of `field`.
    pub fn new(field: impl Into<String>, problem: impl Into<String>) -> Self {
        MessageError { field: field.into(), problem: problem.into() }
    }
}

/// A joint-state sample.
///
/// ```
/// let mut s = jointctl_ipc::ArmState::EMPTY;
/// s.joints.push(jointctl_ipc::JointSample::EMPTY);
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
    j.objects("joints", &d.joints, |j, x| {
        j.str("name", decode_name(&x.name))
            .int("fault_code", u64::from(x.fault_code))
            .str("fault_message", decode_name(&x.fault_message))
            .bool("held", x.held != 0)
            .int("invalid_cycles", x.invalid_cycles)
            .int("fault_count", x.fault_count)
            .int("setpoint_clamps", x.setpoint_clamps)
            .int("torque_clamps", x.torque_clamps)
            .int("rate_limited", x.rate_limited)
            .int("watchdog_trips", x.watchdog_trips)
            .int("missing_inputs", x.missing_inputs)
            .int("plugin_max_ns", x.plugin_max_ns)
            .int("over_budget_cycles", x.over_budget_cycles)
            .int("setpoint_rejections", x.setpoint_rejections);
    });
    j.objects("devices", &d.devices, |j, x| {
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
        j.raw("}").key("torque_nm").raw("{");
        reading(j, &r.torque_nm);
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
/// f.encoders.push(RawReading::from_reading(&jointctl_api::Reading::valid(0.25)));
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
    let mut v = request(&r.request);
    if let Value::Object(map) = &mut v {
        map.insert("sequence".into(), r.sequence.into());
        map.insert("stamp_ns".into(), r.stamp_ns.into());
        map.insert("message".into(), r.response.text().into());
    }
    v
}

/// A command request as JSON: what a network client sends (`jointctl cmd --zenoh`) and what
/// [`parse_request`] reads back.
///
/// ```
/// use jointctl_ipc::{CommandKind, CommandRequest};
/// let v = jointctl_record::messages::request(&CommandRequest::new(CommandKind::POSITION, "q4", &[0.5]));
/// let expected: serde_json::Value = serde_json::from_str(r#"{"kind":"position","joint":"q4","streamed":false,"waveform":"step","values":[0.5],"points":[]}"#).unwrap();
/// assert_eq!(v, expected);
/// ```
pub fn request(q: &CommandRequest) -> Value {
    // Trailing unset values (NaN) are not part of the command.
    let used = q.values.iter().rposition(|v| !v.is_nan()).map_or(0, |i| i + 1);
    let values: Vec<Value> = q.values[..used].iter().map(|v| finite(*v)).collect();
    let points: Vec<Value> = q.points[..(q.point_count as usize).min(q.points.len())].iter().map(|p| json!([finite(p[0]), finite(p[1]), finite(p[2])])).collect();
    json!({
        "kind": q.kind.name(),
        "joint": decode_name(&q.joint),
        "streamed": q.streamed != 0,
        "waveform": q.waveform.name(),
        "values": values,
        "points": points,
    })
}

/// Reads a command request from its JSON ([`request`]'s form), refusing what the runtime could
/// not have been sent from its own command line: an unknown kind or waveform, a name longer
/// than a joint name, too many values or points, a value that is not a number. `null` is an
/// unset value (NaN). The runtime validates the rest (joint, limits) as for every command.
///
/// ```
/// use jointctl_record::messages::{parse_request, request};
/// let v = serde_json::json!({"kind": "torque", "joint": "q2", "waveform": "sine", "values": [5.0, 0.1]});
/// let r = parse_request(&v).unwrap();
/// assert_eq!((r.kind, r.waveform, r.values[1]), (jointctl_ipc::CommandKind::TORQUE, jointctl_ipc::TorqueWaveform::SINE, 0.1));
/// assert_eq!(request(&r)["values"], serde_json::json!([5.0, 0.1]));
/// assert_eq!(parse_request(&serde_json::json!({"kind": "fly"})).unwrap_err().field, "kind");
/// ```
pub fn parse_request(v: &Value) -> Result<CommandRequest, MessageError> {
    let object = v.as_object().ok_or_else(|| MessageError::new("", "a command is a JSON object"))?;
    for key in object.keys() {
        if !["kind", "joint", "streamed", "waveform", "values", "points"].contains(&key.as_str()) {
            return Err(MessageError::new(key.as_str(), "is an unknown field (expected kind, joint, streamed, waveform, values, points)"));
        }
    }
    let text = |key: &str| -> Result<Option<&str>, MessageError> {
        match object.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(other) => Err(MessageError::new(key, format!("must be a string, got {other}"))),
        }
    };
    let kind_name = text("kind")?.ok_or_else(|| MessageError::new("kind", "is missing"))?;
    let kind = jointctl_ipc::CommandKind::from_name(kind_name).ok_or_else(|| {
        MessageError::new("kind", format!("unknown command `{kind_name}` (one of {})", jointctl_ipc::CommandKind::ALL.iter().map(|(_, n)| *n).collect::<Vec<_>>().join(", ")))
    })?;
    let joint = text("joint")?.unwrap_or("");
    if joint.len() >= jointctl_ipc::NAME_LEN {
        return Err(MessageError::new("joint", format!("`{joint}` is longer than any joint name ({} bytes at most)", jointctl_ipc::NAME_LEN - 1)));
    }
    let number = |x: &Value, at: String| -> Result<f64, MessageError> {
        match x {
            Value::Null => Ok(f64::NAN),
            Value::Number(n) => n.as_f64().filter(|f| f.is_finite()).ok_or_else(|| MessageError::new(at, format!("{n} is not a finite number"))),
            other => Err(MessageError::new(at, format!("{other} is not a number"))),
        }
    };
    let values: Vec<f64> = match object.get("values") {
        None | Some(Value::Null) => Vec::new(),
        Some(Value::Array(a)) if a.len() <= 8 => a.iter().enumerate().map(|(i, x)| number(x, format!("values[{i}]"))).collect::<Result<_, _>>()?,
        Some(Value::Array(a)) => return Err(MessageError::new("values", format!("at most 8, got {}", a.len()))),
        Some(other) => return Err(MessageError::new("values", format!("must be an array of numbers, got {other}"))),
    };
    let mut r = CommandRequest::new(kind, joint, &values);
    if let Some(w) = text("waveform")? {
        r.waveform = jointctl_ipc::TorqueWaveform::from_name(w).ok_or_else(|| MessageError::new("waveform", format!("unknown waveform `{w}` (step, sine or cosine)")))?;
    }
    r.streamed = match object.get("streamed") {
        None | Some(Value::Null) | Some(Value::Bool(false)) => 0,
        Some(Value::Bool(true)) => 1,
        Some(other) => return Err(MessageError::new("streamed", format!("must be true or false, got {other}"))),
    };
    match object.get("points") {
        None | Some(Value::Null) => {}
        Some(Value::Array(points)) if points.len() <= jointctl_ipc::MAX_COMMAND_POINTS => {
            for (i, p) in points.iter().enumerate() {
                let triple = p.as_array().filter(|t| (2..=3).contains(&t.len())).ok_or_else(|| MessageError::new(format!("points[{i}]"), "must be [t, q] or [t, q, v]"))?;
                for (k, x) in triple.iter().enumerate() {
                    r.points[i][k] = number(x, format!("points[{i}][{k}]"))?;
                }
            }
            r.point_count = points.len() as u32;
        }
        Some(Value::Array(points)) => return Err(MessageError::new("points", format!("at most {}, got {}", jointctl_ipc::MAX_COMMAND_POINTS, points.len()))),
        Some(other) => return Err(MessageError::new("points", format!("must be an array, got {other}"))),
    }
    Ok(r)
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
                "name": {"type": "string"}, "position_rad": reading_schema(), "velocity_rad_s": reading_schema(), "torque_nm": reading_schema(),
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

    /// Finding: the JSON form of a recording read an F/T torque of 0.012394129711854647 Nm back as
    /// ...648 (serde_json's default float parser is not correctly rounded), where the ROS 2 form
    /// of the same cycle gave the recorded bits. A number written here reads back to its bits.
    #[test]
    fn a_written_number_reads_back_to_the_same_bits() {
        let mut state = jointctl_ipc::ArmState::EMPTY;
        state.joints.push(jointctl_ipc::JointSample::EMPTY);
        for x in [0.012394129711854647, -0.005743346888941898, 1.0 / 3.0, 2.2250738585072014e-308, 123456.78901234567] {
            state.joints[0].sensor_torque_nm = x;
            let mut text = String::new();
            super::write_joint_state(&mut text, &state);
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            assert_eq!(v["joints"][0]["sensor_torque_nm"].as_f64().map(f64::to_bits), Some(x.to_bits()), "{x:e} via {text}");
        }
    }
}
