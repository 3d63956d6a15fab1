//! The typed arm description. Every field documents its unit; every default says where it comes
//! from (a thesis section, or "assumption").

use std::collections::BTreeMap;
use std::path::PathBuf;

use schemars::JsonSchema;
use serde::{Deserialize, Deserializer, Serialize, de};

use crate::num::{finite, finite_opt, finite_pair, finite_pair_opt, finite_triple};
pub use jointctl_control::PiGains;
pub use jointctl_modes::{ControllerConfig, GainPoint};

/// `#[serde(default = "yes")]`: a switch that is on unless the YAML turns it off.
fn yes() -> bool {
    true
}

mod arm;
mod buses;
mod hal;
mod joints;
mod sim;

pub use arm::*;
pub use buses::*;
pub use hal::*;
pub use joints::*;
pub use sim::*;
