//! The model effects: one typed list that `jointctl identify` names causes from (each built-in
//! cause is one [`Effect`]), and that says which keys of the observer's `model_extension`
//! ([`crate::extension::ExtensionSpec`]) and of the simulated joint's `sim.effects` carry each
//! one, and what a motion must vary to show it.
//!
//! Adding an effect is a line in the list below (`effects!`, which gives [`Effect`], its names and
//! [`Effect::ALL`] from one list) and its cause module in `jointctl-ident` (the module and one
//! match arm in its list of causes). Every other property below is an exhaustive `match`: the
//! compiler points at each one a new variant must answer, and at identify's list of causes.
//! `docs/identify/adding-a-cause.md` walks through one.

/// Declares [`Effect`] with its variants' names, [`Effect::ALL`] and [`Effect::name`] from one
/// list, so that a variant cannot be left out of either.
macro_rules! effects {
    ($( $(#[$doc:meta])* $variant:ident => $name:literal, )*) => {
        /// One effect that the thesis' model of a joint leaves out, and `identify` can find in
        /// data.
        ///
        /// ```
        /// use jointctl_models::effect::{Dependence, Effect};
        /// let e = Effect::from_name("viscous_friction").unwrap();
        /// assert_eq!(e, Effect::ViscousFriction);
        /// assert_eq!(e.observer_keys(), ["viscous_nms_per_rad"]);
        /// assert_eq!(e.dependence(), Dependence::Rate);
        /// assert!(Effect::from_name("backlash").is_none());
        /// ```
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Effect {
            $( $(#[$doc])* $variant, )*
        }

        impl Effect {
            /// Every effect, in the order `identify` tries their causes (ties go to the earlier
            /// one).
            ///
            /// ```
            /// use jointctl_models::effect::Effect;
            /// assert_eq!(Effect::ALL[0], Effect::ViscousFriction);
            /// assert!(Effect::ALL.iter().all(|e| Effect::from_name(e.name()) == Some(*e)));
            /// ```
            pub const ALL: [Effect; [$( stringify!($variant) ),*].len()] = [$( Effect::$variant ),*];

            /// The name `identify` reports (the `effect` field of its JSON and reports).
            ///
            /// ```
            /// assert_eq!(jointctl_models::effect::Effect::DeadZone.name(), "dead_zone");
            /// ```
            pub const fn name(self) -> &'static str {
                match self {
                    $( Effect::$variant => $name, )*
                }
            }
        }
    };
}

effects! {
    /// Viscous friction in the element: `b dphi/dt`.
    ViscousFriction => "viscous_friction",
    /// Eq. 3.5's arctan friction, `k_a atan(k_b dphi/dt)` (Coulomb-like beyond `1 / k_b`).
    CoulombFriction => "coulomb_friction",
    /// A Stribeck friction: a breakaway torque above the sliding one at low rates.
    StribeckFriction => "stribeck_friction",
    /// An offset of the torque sensor.
    SensorOffset => "sensor_offset",
    /// The characteristic off by a scale: the element stiffer or softer than its table.
    StiffnessError => "stiffness_error",
    /// A cubic term of the stiffness: `k3 phi^3`.
    StiffnessNonlinearity => "stiffness_nonlinearity",
    /// A hysteresis loop of the element (Dahl's model, or Bouc-Wen's with a shape exponent).
    Hysteresis => "hysteresis",
    /// A play (dead zone) of the element, ideal or with a contact that stiffens over a band.
    DeadZone => "dead_zone",
    /// A delay between the deflection's and the torque's readings.
    TimeDelay => "time_delay",
    /// A steady vibration seen by the torque sensor (a mode rung by something else).
    Vibration => "vibration",
    /// A vibration whose size follows the deflection rate (a mode rung by the motion).
    SpeedVibration => "speed_vibration",
    /// A mode rung by each reversal of the motion, decaying until the next.
    ReversalRinging => "reversal_ringing",
    /// A load that follows a joint's position as a link's weight does, `G cos(q - q_G)`: what a
    /// gravity model leaves of a joint's friction record (the deflection column a position).
    GravityError => "gravity_error",
}

/// What an effect's torque depends on, for choosing what an experiment varies to tell two
/// effects apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dependence {
    /// The deflection rate (viscous friction, eq. 3.5's arctan; a small delay acts as
    /// `-k d dphi/dt`): a slower motion along the same path changes it.
    Rate,
    /// The deflection itself (a cubic, a play, a scale error, an offset): the same at any rate,
    /// different at another amplitude.
    Deflection,
    /// The path since the last reversal (a Dahl hysteresis): its loop keeps its width at any
    /// rate, and its shape against the deflection changes with the amplitude.
    Stroke,
    /// Time (a mode, a ring): stays at its frequency whatever the excitation's.
    Time,
}

impl Effect {
    /// The effect of a reported name; `None` for a name that is not one (a user's own cause,
    /// `dropout`).
    ///
    /// ```
    /// use jointctl_models::effect::Effect;
    /// assert_eq!(Effect::from_name("hysteresis"), Some(Effect::Hysteresis));
    /// assert_eq!(Effect::from_name("dropout"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.name() == name)
    }

    /// The keys of the observer's `model_extension` ([`crate::extension::ExtensionSpec`]) that
    /// carry the effect as `identify` writes it; none when the observer has no term of the
    /// cause's form (a Stribeck dip, a delay, a mode).
    ///
    /// ```
    /// use jointctl_models::effect::Effect;
    /// assert_eq!(Effect::StiffnessError.observer_keys(), ["torque_scale"]);
    /// assert!(Effect::TimeDelay.observer_keys().is_empty());
    /// ```
    pub const fn observer_keys(self) -> &'static [&'static str] {
        match self {
            Effect::ViscousFriction => &["viscous_nms_per_rad"],
            Effect::CoulombFriction => &["friction"],
            Effect::SensorOffset => &["torque_offset_nm"],
            Effect::StiffnessError => &["torque_scale"],
            Effect::StiffnessNonlinearity => &["cubic_nm_per_rad3"],
            Effect::Hysteresis => &["hysteresis"],
            Effect::DeadZone => &["dead_zone_rad", "dead_zone_ramp_rad"],
            Effect::StribeckFriction | Effect::TimeDelay | Effect::Vibration | Effect::SpeedVibration | Effect::ReversalRinging | Effect::GravityError => &[],
        }
    }

    /// The keys of the simulated joint's `sim.effects` that carry the effect; none when the
    /// simulated plant has no term for it (a stiffness error: the plant has its own curve). A
    /// cause writes those of them its form fits: a vibration's plant mode is rung by the
    /// element's torque, so `identify`'s steady sine writes none.
    ///
    /// ```
    /// use jointctl_models::effect::Effect;
    /// assert_eq!(Effect::CoulombFriction.plant_keys(), ["arctan_friction"]);
    /// assert!(Effect::StiffnessError.plant_keys().is_empty());
    /// ```
    pub const fn plant_keys(self) -> &'static [&'static str] {
        match self {
            Effect::ViscousFriction => &["viscous_nms_per_rad"],
            Effect::CoulombFriction => &["arctan_friction"],
            Effect::SensorOffset => &["torque_offset_nm"],
            Effect::StiffnessNonlinearity => &["cubic_nm_per_rad3"],
            Effect::Hysteresis => &["hysteresis"],
            Effect::DeadZone => &["dead_zone_rad", "dead_zone_ramp_rad"],
            Effect::Vibration => &["vibration"],
            Effect::StiffnessError | Effect::StribeckFriction | Effect::TimeDelay | Effect::SpeedVibration | Effect::ReversalRinging | Effect::GravityError => &[],
        }
    }

    /// What the effect's torque depends on.
    ///
    /// ```
    /// use jointctl_models::effect::{Dependence, Effect};
    /// assert_eq!(Effect::Hysteresis.dependence(), Dependence::Stroke);
    /// assert_eq!(Effect::TimeDelay.dependence(), Dependence::Rate);
    /// ```
    pub const fn dependence(self) -> Dependence {
        match self {
            Effect::ViscousFriction | Effect::CoulombFriction | Effect::StribeckFriction | Effect::TimeDelay => Dependence::Rate,
            Effect::DeadZone | Effect::StiffnessNonlinearity | Effect::StiffnessError | Effect::SensorOffset | Effect::GravityError => Dependence::Deflection,
            Effect::Hysteresis => Dependence::Stroke,
            Effect::Vibration | Effect::SpeedVibration | Effect::ReversalRinging => Dependence::Time,
        }
    }
}

/// The effects a configuration carries, in [`Effect::ALL`]'s order: those with one of their
/// `keys` (the observer's or the plant's) set in `config` against `defaults` (both as JSON
/// tables, the configuration and its defaults serialised). A key is set by a table (the effect's
/// parameters given) or by a finite number other than its default; a number that is not finite
/// (NaN, serialised as null) sets nothing, as the configuration's own checks refuse it. The keys
/// are looked up by name, so that a new effect on existing keys needs no code where this is used.
///
/// ```
/// use jointctl_models::effect::{Effect, effects_set};
/// let config = serde_json::json!({"viscous_nms_per_rad": 0.2, "torque_offset_nm": 0.0, "hysteresis": {"limit_nm": 1.0}});
/// let defaults = serde_json::json!({"viscous_nms_per_rad": 0.0, "torque_offset_nm": 0.0, "hysteresis": null});
/// assert_eq!(effects_set(Effect::plant_keys, &config, &defaults), [Effect::ViscousFriction, Effect::Hysteresis]);
/// ```
pub fn effects_set(keys: fn(Effect) -> &'static [&'static str], config: &serde_json::Value, defaults: &serde_json::Value) -> Vec<Effect> {
    let set = |key: &&str| match config.get(*key) {
        Some(serde_json::Value::Object(_)) => true,
        Some(v @ serde_json::Value::Number(n)) => n.as_f64().is_some_and(f64::is_finite) && Some(v) != defaults.get(*key),
        _ => false,
    };
    Effect::ALL.into_iter().filter(|e| keys(*e).iter().any(set)).collect()
}

/// `effects` in [`Effect::ALL`]'s order, each once: the union of the sets several parts of a
/// configuration carry.
///
/// ```
/// use jointctl_models::effect::{Effect, in_order};
/// assert_eq!(in_order([Effect::DeadZone, Effect::ViscousFriction, Effect::DeadZone]), [Effect::ViscousFriction, Effect::DeadZone]);
/// ```
pub fn in_order(effects: impl IntoIterator<Item = Effect>) -> Vec<Effect> {
    let all: Vec<Effect> = effects.into_iter().collect();
    Effect::ALL.into_iter().filter(|e| all.contains(e)).collect()
}

impl std::fmt::Display for Effect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::Effect;
    use crate::extension::{ExtensionSpec, Terms};

    /// Every observer key is a field of the extension's terms ([`crate::extension::Terms`], what
    /// [`crate::extension::Terms::effects`] reads, each one a field of `model_extension`): a
    /// key they do not know would be refused by the plugin when it loads what `identify` wrote.
    #[test]
    fn every_observer_key_is_a_field_of_the_extensions_terms() {
        let serde_json::Value::Object(fields) = serde_json::to_value(Terms::default()).unwrap() else { panic!("the terms are a table") };
        for e in Effect::ALL {
            for key in e.observer_keys() {
                assert!(fields.contains_key(*key), "{e}: `{key}` is not a field of the extension's terms");
                // ... and of `model_extension` itself.
                let tried = [serde_json::json!({ *key: 1.0 }), serde_json::json!({ *key: {} })];
                let known = tried.iter().any(|v| serde_json::from_value::<ExtensionSpec>(v.clone()).map_or_else(|err| !err.to_string().contains("unknown field"), |_| true));
                assert!(known, "{e}: `{key}` is not a field of model_extension");
            }
        }
    }

    #[test]
    fn names_are_unique() {
        let mut names: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), Effect::ALL.len());
    }
}
