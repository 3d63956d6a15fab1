//! JSON Schema of the plugin building blocks' settings that the YAML `controller:` section
//! uses, kept here so that `jointctl-control` (and every plugin built on it) needs no schema
//! generator.


/// Gains and limits of a PI loop (`jointctl_control::PiGains`), as written in YAML.
///
/// The thesis tuned its PI gains experimentally and does not print them (sections 4.3, 5):
/// every default here is an assumption.
#[derive(schemars::JsonSchema)]
#[schemars(remote = "jointctl_control::PiGains", deny_unknown_fields)]
pub struct PiGainsSchema {
    /// Proportional gain [output unit / input unit].
    pub kp: f64,
    /// Integral gain [output unit / (input unit * s)].
    pub ki: f64,
    /// Symmetric output limit (|output| <= limit). Assumption when not given: unlimited.
    #[schemars(default = "unlimited")]
    pub output_limit: f64,
}

fn unlimited() -> f64 {
    f64::INFINITY
}
