//! Deserializers that refuse numbers YAML allows but a robot must not get (`.nan`, `.inf`).

use serde::{Deserialize, Deserializer, de::Error};

fn check<E: Error>(v: f64) -> Result<f64, E> {
    if v.is_finite() { Ok(v) } else { Err(E::custom(format!("must be a finite number, got {v}"))) }
}

/// A finite `f64`.
pub fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    check(f64::deserialize(d)?)
}

/// An optional finite `f64`.
pub fn finite_opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    Option::<f64>::deserialize(d)?.map(check).transpose()
}

/// A pair of finite `f64` (a `[lower, upper]` range).
pub fn finite_pair<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    let [a, b] = <[f64; 2]>::deserialize(d)?;
    Ok([check(a)?, check(b)?])
}

/// An optional pair of finite `f64`.
pub fn finite_pair_opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
    Option::<[f64; 2]>::deserialize(d)?.map(|[a, b]| Ok([check(a)?, check(b)?])).transpose()
}

/// Three finite `f64` (a vector).
pub fn finite_triple<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let [a, b, c] = <[f64; 3]>::deserialize(d)?;
    Ok([check(a)?, check(b)?, check(c)?])
}
