//! The joints: their plugin, wiring, limits, controllers and plugin params.

use super::*;

/// One joint plugin instance: one joint, or several coupled DOFs (the wrist's q6 and q7).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JointConfig {
    /// Name of the instance; also the joint's name when `dofs` is not given.
    pub name: String,
    /// The plugin: a name (`rigid`, looked up as `libjointctl_plugin_rigid.so` or `librigid.so`),
    /// or `{name, path}` for a library anywhere (path relative to this file).
    pub plugin: PluginRef,
    /// For a multi-DOF plugin: each DOF's name and limits. Empty for a 1-DOF joint.
    #[serde(default)]
    pub dofs: Vec<DofConfig>,
    /// Limits of a 1-DOF joint.
    #[serde(default)]
    pub limits: Option<LimitsConfig>,
    /// Encoder role → encoder device name (roles are the plugin's).
    #[serde(default)]
    pub encoders: BTreeMap<String, String>,
    /// Drive role → drive device name.
    #[serde(default)]
    pub drives: BTreeMap<String, String>,
    /// The force/torque sensor that measures this 1-DOF joint's torque (`buses.force_torque`),
    /// for validation and recording; never used by the observer.
    #[serde(default)]
    pub torque_sensor: Option<String>,
    /// Parameters for the plugin, checked by the plugin.
    #[serde(default)]
    pub params: Params,
    /// Controller of a 1-DOF joint (torque PI, gain schedule, rate limit, watchdog).
    #[serde(default)]
    pub controller: Option<ControllerConfig>,
    /// How the simulated backend models this joint.
    #[serde(default)]
    pub sim: Option<JointSimConfig>,
    /// Time budget of this joint's plugin per cycle, observe and control together [us];
    /// default `timing.joint_budget_fraction` of the period. Over it, the joint is faulted.
    #[serde(default, deserialize_with = "finite_opt")]
    pub budget_us: Option<f64>,
}

/// One DOF of a multi-DOF joint.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DofConfig {
    /// Joint name (as published).
    pub name: String,
    /// Its limits.
    #[serde(default)]
    pub limits: Option<LimitsConfig>,
    /// Its controller.
    #[serde(default)]
    pub controller: Option<ControllerConfig>,
    /// The force/torque sensor that measures its torque (`buses.force_torque`).
    #[serde(default)]
    pub torque_sensor: Option<String>,
}

/// Limits enforced by the runtime on every command.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LimitsConfig {
    /// `[lower, upper]` joint position [rad].
    #[serde(deserialize_with = "finite_pair")]
    pub position_rad: [f64; 2],
    /// Largest |joint velocity| [rad/s].
    #[serde(default, deserialize_with = "finite_opt")]
    pub velocity_rad_s: Option<f64>,
    /// Largest |joint torque| [Nm].
    #[serde(default, deserialize_with = "finite_opt")]
    pub torque_nm: Option<f64>,
    /// `[lowest, highest]` stiffness a command may request [Nm/rad] (variable stiffness joints).
    #[serde(default)]
    pub stiffness_nm_per_rad: Option<[f64; 2]>,
}

/// Where a plugin comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PluginRef {
    /// The plugin's name (its descriptor must carry the same).
    pub name: String,
    /// An explicit library path, relative to the config file.
    pub path: Option<PathBuf>,
}

impl<'de> Deserialize<'de> for PluginRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct ByPath {
            name: String,
            path: PathBuf,
        }
        impl<'de> de::Visitor<'de> for V {
            type Value = PluginRef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a plugin name, or a mapping {name, path}")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<PluginRef, E> {
                Ok(PluginRef { name: v.to_string(), path: None })
            }
            fn visit_map<A: de::MapAccess<'de>>(self, map: A) -> Result<PluginRef, A::Error> {
                let p = ByPath::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(PluginRef { name: p.name, path: Some(p.path) })
            }
        }
        d.deserialize_any(V)
    }
}

impl JsonSchema for PluginRef {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "PluginRef".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "A plugin name, or {name, path} for a library anywhere (path relative to the config file).",
            "oneOf": [
                {"type": "string"},
                {"type": "object", "additionalProperties": false, "required": ["name", "path"],
                 "properties": {"name": {"type": "string"}, "path": {"type": "string"}}}
            ]
        })
    }
}

/// A plugin's parameters: any YAML mapping whose numbers are all finite, handed to the plugin
/// as JSON.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params(pub serde_json::Value);

impl<'de> Deserialize<'de> for Params {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let yaml = serde_yaml::Value::deserialize(d)?;
        to_json(&yaml, "").map(Params).map_err(|(path, msg)| {
            de::Error::custom(if path.is_empty() { msg } else { format!("{path}: {msg}") })
        })
    }
}

fn to_json(v: &serde_yaml::Value, path: &str) -> Result<serde_json::Value, (String, String)> {
    use serde_yaml::Value as Y;
    Ok(match v {
        Y::Null => serde_json::Value::Null,
        Y::Bool(b) => serde_json::Value::Bool(*b),
        Y::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into()
            } else if let Some(u) = n.as_u64() {
                u.into()
            } else {
                let f = n.as_f64().unwrap_or(f64::NAN);
                match serde_json::Number::from_f64(f) {
                    Some(num) => serde_json::Value::Number(num),
                    None => return Err((path.to_string(), format!("must be a finite number, got {f}"))),
                }
            }
        }
        Y::String(s) => serde_json::Value::String(s.clone()),
        Y::Sequence(items) => serde_json::Value::Array(
            items.iter().enumerate().map(|(i, x)| to_json(x, &format!("{path}[{i}]"))).collect::<Result<_, _>>()?,
        ),
        Y::Mapping(m) => {
            let mut out = serde_json::Map::new();
            for (k, x) in m {
                let key = match k {
                    Y::String(s) => s.clone(),
                    other => return Err((path.to_string(), format!("keys must be strings, got {other:?}"))),
                };
                let child = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
                out.insert(key, to_json(x, &child)?);
            }
            serde_json::Value::Object(out)
        }
        Y::Tagged(t) => to_json(&t.value, path)?,
    })
}

impl JsonSchema for Params {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Params".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "Plugin parameters; each plugin documents its own.",
            "type": "object"
        })
    }
}

impl JointConfig {
    /// The names of the DOFs this instance serves, in order.
    pub fn dof_names(&self) -> Vec<&str> {
        if self.dofs.is_empty() { vec![self.name.as_str()] } else { self.dofs.iter().map(|d| d.name.as_str()).collect() }
    }

    /// The force/torque sensor of each DOF, in order, with its field path relative to the joint.
    pub fn dof_torque_sensors(&self) -> Vec<(String, Option<&str>)> {
        if self.dofs.is_empty() {
            vec![("torque_sensor".into(), self.torque_sensor.as_deref())]
        } else {
            self.dofs.iter().enumerate().map(|(i, d)| (format!("dofs[{i}].torque_sensor"), d.torque_sensor.as_deref())).collect()
        }
    }

    /// The limits of each DOF, in order.
    pub fn dof_limits(&self) -> Vec<Option<LimitsConfig>> {
        if self.dofs.is_empty() { vec![self.limits] } else { self.dofs.iter().map(|d| d.limits).collect() }
    }

    /// The controller settings of each DOF (defaults where not given), with their field paths
    /// relative to the joint.
    pub fn dof_controllers(&self) -> Vec<(String, ControllerConfig)> {
        if self.dofs.is_empty() {
            vec![("controller".into(), self.controller.clone().unwrap_or_default())]
        } else {
            self.dofs.iter().enumerate().map(|(i, d)| (format!("dofs[{i}].controller"), d.controller.clone().unwrap_or_default())).collect()
        }
    }
}
