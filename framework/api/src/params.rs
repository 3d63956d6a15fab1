//! Parsing a plugin's parameters with field paths in errors.

use crate::PluginError;

/// Parses the joint's `params` (JSON text from the runtime) into `T`; an error names the field.
///
/// ```
/// #[derive(Debug, serde::Deserialize)]
/// #[serde(deny_unknown_fields)]
/// struct P { stiffness_nm_per_rad: f64 }
/// let p: P = jointctl_api::params::parse(r#"{"stiffness_nm_per_rad": 113.78}"#).unwrap();
/// assert_eq!(p.stiffness_nm_per_rad, 113.78);
/// let e = jointctl_api::params::parse::<P>(r#"{"stiffness_nm_per_rad": "soft"}"#).unwrap_err();
/// assert_eq!(e.field.as_deref(), Some("stiffness_nm_per_rad"));
/// ```
pub fn parse<T: serde::de::DeserializeOwned>(params_json: &str) -> Result<T, PluginError> {
    let mut de = serde_json::Deserializer::from_str(params_json);
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        // serde_json appends " at line L column C" of the JSON text, which means nothing to a
        // YAML author: the runtime points at the YAML instead.
        let mut message = inner.to_string();
        if let Some(cut) = message.rfind(" at line ") {
            message.truncate(cut);
        }
        PluginError { message, field: (path != "." && !path.is_empty()).then_some(path) }
    })
}

/// Checks that a parameter (a ratio or a scale) is finite and not zero.
///
/// ```
/// assert!(jointctl_api::params::nonzero("ratio", -2.0).is_ok());
/// assert!(jointctl_api::params::nonzero("ratio", 0.0).is_err());
/// ```
pub fn nonzero(field: &str, value: f64) -> Result<f64, PluginError> {
    if value.is_finite() && value != 0.0 {
        Ok(value)
    } else {
        Err(PluginError::at(field, format!("must be finite and non-zero, got {value}")))
    }
}

/// Checks that a parameter is finite and strictly positive.
///
/// ```
/// assert!(jointctl_api::params::positive("k", 1.0).is_ok());
/// assert!(jointctl_api::params::positive("k", -1.0).is_err());
/// ```
pub fn positive(field: &str, value: f64) -> Result<f64, PluginError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(PluginError::at(field, format!("must be a finite number > 0, got {value}")))
    }
}
