//! # jointctl-models
//!
//! The joint models of the thesis, one function per equation so that a reader can go from the
//! thesis to the code by searching "Eq. 3.8":
//! - [`lever_arm`]: the VSA lever-arm stiffness, eq. 2.1-2.6;
//! - [`characteristic`]: torque-deflection characteristics as polynomials through zero
//!   (sections 3.3.2, 3.4.2, 3.5.2), interpolated between pivot settings (section 4.2) and, for
//!   the wrist, between deflection directions in polar coordinates (section 4.2, appendix B);
//! - [`transmission`]: the elbow tendons (eq. 3.1/3.2), shoulder differential (eq. 3.3), wrist
//!   planetary differential (eq. 3.4), belt, bevel differential (eq. 3.6/3.7), wrist deflection
//!   (eq. 3.8), and the arctan friction of eq. 3.5;
//! - [`fit`]: least-squares polynomial fits, as the thesis' Matlab step.
//! - [`play`]: the dead zone of an element, ideal or with a contact that stiffens over a band.
//! - [`effect`]: the effects beyond the thesis' model, one typed list shared by `identify`, the
//!   observer's extension and the simulated plant.
//!
//! Everything evaluated in a control cycle is allocation-free.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod assumed;
pub mod characteristic;
pub mod effect;
pub mod extension;
pub mod fit;
pub mod lever_arm;
pub mod play;
pub mod transmission;
