//! # jointctl-ident
//!
//! Characterisation and model-discrepancy identification:
//! - [`fit`]: the thesis' curve-fitting step, reproducible, writing the characteristic in the
//!   YAML form the joint plugins load;
//! - [`identify`]: given measured data, what the joint model gets wrong, which physical cause
//!   explains it, the extended model, and the gain on held-out data.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod csv;
pub mod fit;
pub mod identify;
