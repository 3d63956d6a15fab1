//! The model the baseline starts from, and the one rule that reads a record as a joint's
//! friction rather than a spring. Depends on nothing else of `identify`, so that the design, the
//! search and the report can all use it.

use jointctl_models::effect::Effect;

/// The model the baseline starts from.
pub enum BaselineModel {
    /// A polynomial through zero of this order, fitted on the data (the thesis' structure).
    Polynomial(usize),
    /// A given characteristic `torque(deflection, pivot_mm)` (a joint from a config), not refitted.
    Given(Box<dyn Fn(f64, f64) -> f64 + Send + Sync>),
}

/// The share of the torque's variance that a straight line in the deflection explains below
/// which a record is read as having no spring: its first column a joint position, its torque
/// friction (a friction test of a rigid joint). An assumption of this project, measured on the
/// training parts of the blind generator's and the shared records: spring records lie at 0.40
/// and above (the lowest a large viscous friction beside the spring), friction records at 0.086
/// and below (the highest l3-case036, whose offset follows the position a little).
pub const NO_SPRING_SHARE: f64 = 0.2;

/// The causes that, in a record read as a joint's friction ([`reads_as_friction`]), describe the
/// friction itself and are reported with it, not named: a Dahl loop (its pre-sliding), a
/// Stribeck dip, a lag (see `NoSpring`).
pub(crate) const FRICTION_PARTS: [Effect; 3] = [Effect::Hysteresis, Effect::StribeckFriction, Effect::TimeDelay];

/// Whether a record is read as a joint's friction (no spring): the baseline is fitted on the data
/// (a configured joint has its spring) and a line in the deflection explains less than
/// [`NO_SPRING_SHARE`] of the torque's variance. The one rule the search (which tries the
/// friction's Stribeck dip only then) and the report (which moves the pre-sliding and the dip
/// to [`super::NoSpring`]) both follow.
pub(crate) fn reads_as_friction(spring_share: f64, baseline: &BaselineModel) -> bool {
    matches!(baseline, BaselineModel::Polynomial(_)) && spring_share < NO_SPRING_SHARE
}

/// The causes that, beside a spring, describe the fitted baseline's friction itself and are
/// reported with it, not named: a Stribeck dip, which eq. 3.5's arctan does not have (see
/// `FrictionDip`). A Dahl loop and a lag stay causes there: beside a spring they are the
/// element's hysteresis and the sensors' delay.
pub(crate) const SPRING_FRICTION_PARTS: [Effect; 1] = [Effect::StribeckFriction];

/// Whether `cause` is a part of the fitted baseline's friction (reported with it, not named):
/// one of the [`FRICTION_PARTS`] of a record read as a joint's friction, or of the
/// [`SPRING_FRICTION_PARTS`] beside a spring.
pub(crate) fn is_friction_part(spring_share: f64, baseline: &BaselineModel, cause: &dyn super::CandidateCause) -> bool {
    cause.effect().is_some_and(|e| friction_parts(spring_share, baseline).contains(&e))
}

/// The effects reported as parts of the fitted baseline's friction, not named (see
/// [`is_friction_part`]); none against a given characteristic.
pub(crate) fn friction_parts(spring_share: f64, baseline: &BaselineModel) -> &'static [Effect] {
    if reads_as_friction(spring_share, baseline) {
        &FRICTION_PARTS
    } else if matches!(baseline, BaselineModel::Polynomial(_)) {
        &SPRING_FRICTION_PARTS
    } else {
        &[]
    }
}
