//! # jointctl-config
//!
//! One YAML file describes a whole arm: loop rate, hardware backend and buses, and each joint
//! with its plugin, wiring, limits and parameters. [`load`] turns it into a typed, validated
//! [`ArmConfig`]; every problem is a [`ConfigError`] naming file, line, column and field path.
//!
//! ```
//! let yaml = "arm: demo\nhal: {backend: sim}\njoints:\n  - {name: q1, plugin: rigid, limits: {position_rad: [1.0, -1.0]}}\n";
//! let err = jointctl_config::parse_str(yaml, "demo.yaml").unwrap_err();
//! assert_eq!(err.0[0].to_string(), "demo.yaml:4:54: joints[0].limits.position_rad: lower limit 1 must be below upper limit -1");
//! ```

#![warn(missing_docs)]
#![forbid(unsafe_code)]

mod error;
mod model;
mod num;
mod spans;
mod validate;

use std::path::{Path, PathBuf};

pub use error::{ConfigError, ConfigErrors, bounded_message, short_number};
pub use model::*;
pub use spans::{Location, SpanIndex};
pub use validate::{COMMAND_KINDS, MAX_JOINT_NAME, MAX_LOOP_DEVICES, MAX_LOOP_DOF};

/// A parsed and validated arm description with what is needed to point back into its file.
#[derive(Clone, Debug)]
pub struct LoadedConfig {
    /// The description.
    pub config: ArmConfig,
    /// The file it came from and where each field is in it.
    pub source: ConfigSource,
    /// The files its joints' `params: {include: FILE}` named, resolved, in joint order.
    pub included: Vec<PathBuf>,
    /// The arm's kinematic chain (`kinematics.urdf`), read and checked against the DOFs.
    pub chain: Option<jointctl_kinematics::Chain>,
}

/// The file a config came from and the location of each field in it.
#[derive(Clone, Debug)]
pub struct ConfigSource {
    /// The file as given.
    pub file: PathBuf,
    /// Field path → location.
    pub spans: SpanIndex,
}

impl ConfigSource {
    /// An error about `field`, located at the field (or its nearest existing ancestor).
    ///
    /// ```
    /// let src = jointctl_config::ConfigSource { file: "a.yaml".into(), spans: jointctl_config::SpanIndex::build("x:\n  y: 1\n") };
    /// assert_eq!(src.error("x.y", "bad").to_string(), "a.yaml:2:6: x.y: bad");
    /// ```
    pub fn error(&self, field: &str, message: impl Into<String>) -> ConfigError {
        let at = self.spans.nearest(field);
        ConfigError {
            file: self.file.clone(),
            line: at.line,
            column: at.column,
            field: bounded_message(field),
            message: bounded_message(&message.into()),
        }
    }

    /// Resolves a path written in the file relative to the file's folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() { p.to_path_buf() } else { self.file.parent().unwrap_or(Path::new(".")).join(p) }
    }
}

/// Reads, parses and validates an arm description.
pub fn load(path: impl AsRef<Path>) -> Result<LoadedConfig, ConfigErrors> {
    let path = path.as_ref();
    let text = jointctl_files::read_to_string(path, jointctl_files::FileKind::Config).map_err(|e| ConfigError {
        file: path.to_path_buf(),
        line: 0,
        column: 0,
        field: String::new(),
        message: e.reason(),
    })?;
    parse_str(&text, path)
}

/// Deepest `[`/`{` nesting an arm description may have. Assumption: 64; the deepest real one
/// (a wrist characteristic under `params`) nests 6 deep, and the YAML parser needs time and
/// stack in proportion to the depth (100 000 brackets took 36 s to refuse).
pub const MAX_NESTING: usize = 64;

/// The first place where flow brackets nest deeper than [`MAX_NESTING`], as (line, column),
/// 1-based. Quoted strings and comments are skipped. Linear in the text, no allocation.
fn too_deep(text: &str) -> Option<(usize, usize)> {
    let (mut depth, mut line, mut column) = (0usize, 1usize, 0usize);
    let (mut quote, mut comment, mut previous) = (None::<char>, false, ' ');
    for c in text.chars() {
        column += 1;
        match (quote, c) {
            (_, '\n') => {
                (line, column, comment) = (line + 1, 0, false);
                // A quoted scalar may span lines; a comment ends here.
            }
            _ if comment => {}
            (Some('"'), '"') if previous == '\\' => {}
            (Some(q), c) if c == q => quote = None,
            (Some(_), _) => {}
            // A quote opens a scalar only where a scalar starts (`the thesis' arm` is plain).
            (None, '"' | '\'') if column == 1 || previous.is_whitespace() || matches!(previous, '[' | '{' | ',' | ':') => quote = Some(c),
            (None, '#') if previous.is_whitespace() => comment = true,
            (None, '[' | '{') => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Some((line, column));
                }
            }
            (None, ']' | '}') => depth = depth.saturating_sub(1),
            _ => {}
        }
        previous = c;
    }
    None
}

/// Parses and validates an arm description from text; `file` names it in errors.
pub fn parse_str(text: &str, file: impl AsRef<Path>) -> Result<LoadedConfig, ConfigErrors> {
    if let Some((line, column)) = too_deep(text) {
        return Err(ConfigError {
            file: file.as_ref().to_path_buf(),
            line,
            column,
            field: String::new(),
            message: format!("brackets nest deeper than {MAX_NESTING} levels here; an arm description never needs that many"),
        }
        .into());
    }
    let source = ConfigSource { file: file.as_ref().to_path_buf(), spans: SpanIndex::build(text) };
    // The format is checked before the fields: a newer file's fields are not this jointctl's.
    if let Ok(serde_yaml::Value::Mapping(doc)) = serde_yaml::from_str::<serde_yaml::Value>(text)
        && let Some(v) = doc.get("version")
        && let Err(message) = format_version(v)
    {
        return Err(ConfigErrors(vec![source.error("version", message.to_string())]));
    }
    let de = serde_yaml::Deserializer::from_str(text);
    let config: ArmConfig = serde_path_to_error::deserialize(de).map_err(|e| {
        let field = e.path().to_string();
        let field = if field == "." { String::new() } else { field };
        let inner = e.into_inner();
        let mut message = inner.to_string();
        // serde_yaml appends its own " at line L column C"; the location is printed in front.
        if let Some(cut) = message.find(" at line ") {
            message.truncate(cut);
        }
        // serde_yaml also starts its message with the path of the enclosing mapping; the field
        // path is printed in front already.
        if let Some((prefix, rest)) = message.split_once(": ")
            && !prefix.is_empty()
            && !prefix.contains(' ')
            && field.starts_with(prefix)
        {
            message = rest.to_string();
        }
        // Prefer the span index: serde_yaml places some errors (custom ones, missing fields) at
        // the enclosing mapping. A key beats its value: an unknown field is best shown at its key.
        let spanned = source.spans.key(&field).or_else(|| source.spans.value(&field)).filter(|_| !field.is_empty());
        let (line, column) = match (spanned, inner.location()) {
            (Some(at), _) => (at.line, at.column),
            (None, Some(l)) => (l.line(), l.column()),
            (None, None) => {
                let at = source.spans.nearest(&field);
                (at.line, at.column)
            }
        };
        ConfigError { file: source.file.clone(), line, column, field: bounded_message(&field), message: bounded_message(&message) }
    })?;
    let mut config = config;
    let mut include_errors = Vec::new();
    let mut included = Vec::new();
    for (j, joint) in config.joints.iter_mut().enumerate() {
        match include_params(&source, &mut joint.params) {
            Ok(file) => included.extend(file),
            Err((field, message)) => include_errors.push(source.error(&format!("joints[{j}].params.{field}"), message)),
        }
    }
    if !include_errors.is_empty() {
        return Err(ConfigErrors(include_errors));
    }
    let problems = validate::validate(&config);
    if !problems.is_empty() {
        return Err(ConfigErrors(problems.into_iter().map(|(p, m)| source.error(&p, m)).collect()));
    }
    let chain = match &config.kinematics {
        Some(k) => Some(read_chain(&source, &config, k).map_err(|m| ConfigErrors(vec![source.error("kinematics.urdf", m)]))?),
        None => None,
    };
    // Gravity feed-forward needs the DOF in the URDF.
    let mut kinematics_errors = Vec::new();
    for (j, joint) in config.joints.iter().enumerate() {
        for ((field, c), dof) in joint.dof_controllers().into_iter().zip(joint.dof_names()) {
            if !c.gravity_feedforward {
                continue;
            }
            let at = format!("joints[{j}].{field}.gravity_feedforward");
            match &chain {
                None => kinematics_errors.push(source.error(&at, "needs the arm's URDF: add `kinematics: {urdf: FILE}`")),
                Some(ch) if !ch.dof_names().iter().any(|d| d == dof) => {
                    kinematics_errors.push(source.error(&at, format!("`{dof}` is not a joint of the URDF ({})", ch.dof_names().join(", "))))
                }
                Some(_) => {}
            }
        }
    }
    // The free arm needs its DOFs in the URDF, and physical numbers.
    for (j, joint) in config.joints.iter().enumerate() {
        let Some(sim) = &joint.sim else { continue };
        let per_dof: Vec<(String, &EnvironmentConfig)> = match (&sim.environment, sim.environments.as_slice()) {
            (Some(e), _) => joint.dof_names().iter().map(|_| ("sim.environment".to_string(), e)).collect(),
            (None, list) => list.iter().enumerate().map(|(i, e)| (format!("sim.environments[{i}]"), e)).collect(),
        };
        for ((field, env), dof) in per_dof.into_iter().zip(joint.dof_names()) {
            let EnvironmentConfig::FreeArm { damping_nms_per_rad, armature_kgm2 } = env else { continue };
            let at = format!("joints[{j}].{field}");
            for (name, v) in [("damping_nms_per_rad", damping_nms_per_rad), ("armature_kgm2", armature_kgm2)] {
                if !(v.is_finite() && *v >= 0.0) {
                    kinematics_errors.push(source.error(&format!("{at}.{name}"), format!("must be a finite number >= 0, got {v}")));
                }
            }
            match &chain {
                None => kinematics_errors.push(source.error(&at, "a free arm needs the arm's URDF: add `kinematics: {urdf: FILE}`")),
                Some(ch) if !ch.dof_names().iter().any(|d| d == dof) => {
                    kinematics_errors.push(source.error(&at, format!("`{dof}` is not a joint of the URDF ({}), so it cannot be a joint of the free arm", ch.dof_names().join(", "))))
                }
                Some(_) => {}
            }
        }
    }
    if !kinematics_errors.is_empty() {
        return Err(ConfigErrors(kinematics_errors));
    }
    Ok(LoadedConfig { config, source, included, chain })
}

/// The URDF of `kinematics.urdf`, its movable joints each a DOF of the arm.
fn read_chain(source: &ConfigSource, config: &ArmConfig, k: &KinematicsConfig) -> Result<jointctl_kinematics::Chain, String> {
    let path = source.resolve(&k.urdf);
    let xml = jointctl_files::read_to_string(&path, jointctl_files::FileKind::Urdf).map_err(|e| e.to_string())?;
    let chain = jointctl_kinematics::Chain::from_urdf_str(&xml).map_err(|e| format!("{}: {e}", path.display()))?;
    let dofs: Vec<&str> = config.joints.iter().flat_map(|j| j.dof_names()).collect();
    let unknown: Vec<&str> = chain.dof_names().iter().map(String::as_str).filter(|d| !dofs.contains(d)).collect();
    if !unknown.is_empty() {
        return Err(format!("the URDF's movable joints {} are not DOFs of the arm ({}): name them after the DOFs they are", unknown.join(", "), dofs.join(", ")));
    }
    Ok(chain)
}

/// `params: {include: FILE, ...}`: the YAML mapping in FILE (relative to the config) is merged
/// into the params; keys written next to `include` win. So that `jointctl fit --out FILE` feeds a
/// joint without editing the arm description.
fn include_params(source: &ConfigSource, params: &mut Params) -> Result<Option<PathBuf>, (String, String)> {
    let Some(obj) = params.0.as_object_mut() else { return Ok(None) };
    let Some(include) = obj.remove("include") else { return Ok(None) };
    let Some(rel) = include.as_str() else {
        return Err(("include".into(), "must be a file path".into()));
    };
    let path = source.resolve(Path::new(rel));
    let text = jointctl_files::read_to_string(&path, jointctl_files::FileKind::Include).map_err(|e| ("include".into(), e.to_string()))?;
    let included: Params = serde_yaml::from_str(&text).map_err(|e| ("include".into(), format!("{}: {e}", path.display())))?;
    let serde_json::Value::Object(mut map) = included.0 else {
        return Err(("include".into(), format!("{} must hold a YAML mapping", path.display())));
    };
    // The included file's own format; not a parameter of the plugin.
    if let Some(v) = map.remove("version") {
        let v: serde_yaml::Value = serde_yaml::to_value(&v).unwrap_or_default();
        format_version(&v).map_err(|m| ("include".into(), format!("{}: version: {m}", path.display())))?;
    }
    for (k, v) in map {
        obj.entry(k).or_insert(v);
    }
    Ok(Some(path))
}

/// The format of the files an arm is configured from (the arm description, the files its
/// joints' params include, what `fit` and `identify` write), in their `version:` field. A file
/// without one is read as format 1, the first that had the field: every file written before
/// it has today's meanings. Raise it when a field changes meaning, and migrate or refuse the
/// older format in [`format_version`].
pub const FORMAT_VERSION: u64 = 1;

/// Why a file's `version:` value cannot be read ([`format_version`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FormatVersionError {
    /// A format this jointctl does not know yet.
    #[error("format {found} is from a newer jointctl; this one reads formats 1 to {FORMAT_VERSION}: upgrade jointctl, or rewrite the file for format {FORMAT_VERSION}")]
    Newer {
        /// The file's format.
        found: u64,
    },
    /// Format 0, which never existed.
    #[error("there is no format 0; this jointctl reads formats 1 to {FORMAT_VERSION}")]
    Zero,
    /// Not a whole number.
    #[error("must be the file format's number, an integer from 1 to {FORMAT_VERSION}, got {got}")]
    NotANumber {
        /// The value as written.
        got: String,
    },
}

/// Checks a file's `version:` value: an integer from 1 to [`FORMAT_VERSION`].
///
/// ```
/// use jointctl_config::{FormatVersionError, format_version};
/// assert!(format_version(&serde_yaml::Value::from(1)).is_ok());
/// assert_eq!(format_version(&serde_yaml::Value::from(7)), Err(FormatVersionError::Newer { found: 7 }));
/// assert!(format_version(&serde_yaml::Value::from(7)).unwrap_err().to_string().contains("newer jointctl"));
/// ```
///
/// # Errors
/// The reason, to be shown at the file's `version` field.
pub fn format_version(v: &serde_yaml::Value) -> Result<u64, FormatVersionError> {
    match v.as_u64() {
        Some(n) if (1..=FORMAT_VERSION).contains(&n) => Ok(n),
        Some(n) if n > FORMAT_VERSION => Err(FormatVersionError::Newer { found: n }),
        Some(_) => Err(FormatVersionError::Zero),
        None => Err(FormatVersionError::NotANumber { got: serde_yaml::to_string(v).unwrap_or_default().trim().to_string() }),
    }
}

/// The JSON Schema of the arm description, for editors.
pub fn json_schema() -> serde_json::Value {
    serde_json::to_value(schemars::schema_for!(ArmConfig)).unwrap_or_default()
}
