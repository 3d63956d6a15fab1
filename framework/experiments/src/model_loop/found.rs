//! What `identify` named, as the model loop takes it: each cause's plant and observer terms, in
//! one record or at each pivot setting.

use serde_json::{Map, Value};

/// A cause `identify` named, with what it adds to each side.
#[derive(Clone, Debug, PartialEq)]
pub struct Found {
    /// The cause's name.
    pub effect: String,
    /// Its keys of the joint's `sim.effects`.
    pub plant: Map<String, Value>,
    /// Its keys of the joint's `model_extension`.
    pub observer: Map<String, Value>,
}

/// The causes `identify` named at one pivot setting of a record.
#[derive(Clone, Debug)]
pub struct SettingFound {
    /// The setting [mm].
    pub pivot_mm: f64,
    /// Its samples in the record, in time order.
    pub samples: Vec<usize>,
    /// The causes named on them.
    pub found: Vec<Found>,
}
