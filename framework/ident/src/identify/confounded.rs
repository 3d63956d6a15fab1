//! Confounds: a named cause and a candidate left out that explains the data about as well in
//! its place (issue 32). The training part's rule (BICs close, or nearly the same improvement)
//! and the held-out part's (a candidate the training part preferred, refused for want of
//! evidence, that gained about as much there as the cause named after it). A leaf: the
//! selection finds the pairs, the report words them.

/// A candidate whose training BIC, in the step a cause was named, lies within this much of the
/// named cause's explains the training part about as well: BIC differences below 10 are not
/// "very strong" evidence for either model (Kass and Raftery 1995, the scale of
/// [`super::BIC_THRESHOLD`]) ...
pub const CONFOUND_BIC: f64 = 10.0;

/// ... and so does one whose training BIC improvement is at least this share of the named
/// cause's (an assumption: on one sine, a Dahl hysteresis's loop is fitted to 95 % as well by a
/// 5 ms time delay and a cubic, and the two are not told apart by the data; with a second
/// frequency the delay's improvement falls to a third of the hysteresis').
pub const CONFOUND_SHARE: f64 = 0.9;

/// A named cause and a candidate left out that explains the data about as well in its place.
#[derive(Clone, Debug)]
pub(crate) struct Confounded {
    pub named: usize,
    pub alternative: usize,
    /// Training BICs of the model with the named cause, with the alternative in its place, and
    /// before either.
    pub bic: [f64; 3],
    /// Held-out MSE gains [Nm^2] of the named cause and of the alternative, where the alternative
    /// was tested first (a better training BIC) and refused for want of evidence.
    pub held_out_gains_nm2: Option<[f64; 2]>,
    /// The alternative's searched (non-linear) parameters as it was fitted in the named cause's
    /// place (eq. 3.5's `k_b` for `coulomb_friction`: whether its arctan is nearly straight
    /// decides the experiment, see `friction_confound::pair_saturates`); empty if not known.
    pub alternative_params: Vec<f64>,
}

impl Confounded {
    /// The candidates refused in the step `named` was named, for want of evidence on the
    /// held-out part, `(cause, training BIC, held-out gain [Nm^2])`, that gained at least
    /// [`CONFOUND_SHARE`] of the named cause's `named_gain_nm2` there: proposed before it (a
    /// better training BIC, required: a ring is tested after the ordinary causes whatever its
    /// BIC) and not told apart from it by the held-out part either. `bic`: the named cause's
    /// training BIC and the model's before it.
    pub(crate) fn on_held_out(named: usize, [named_bic, before]: [f64; 2], named_gain_nm2: f64, refused: &[(usize, f64, f64)]) -> impl Iterator<Item = Confounded> + '_ {
        refused.iter().filter(move |r| r.1 < named_bic && named_gain_nm2 > 0.0 && r.2 >= CONFOUND_SHARE * named_gain_nm2).map(move |&(alternative, bic, gain)| Confounded { named, alternative, bic: [named_bic, bic, before], held_out_gains_nm2: Some([named_gain_nm2, gain]), alternative_params: Vec::new() })
    }

    /// Why, in words, when the held-out part was asked: `None` for the training part's rule
    /// alone (see `confound_evidence`).
    pub(crate) fn held_out_said(&self, named: &str, alternative: &str) -> Option<String> {
        let [named_gain, gain] = self.held_out_gains_nm2?;
        let [named_bic, bic, before] = self.bic;
        Some(format!(
            "{alternative} in place of {named} explains the training part better (it improves the training BIC by {:.0}, {named} by {:.0}) and the held-out part about as well (a gain of {gain:.3e} Nm^2 against {named_gain:.3e}, at least {:.0} % counts as about as well), though without the evidence {named} has there; the name given is one of the two, and an experiment that excites them differently (other amplitudes, frequencies, holds) would tell them apart",
            before - bic,
            before - named_bic,
            100.0 * CONFOUND_SHARE
        ))
    }
}

/// Why a named cause and an alternative are confounded, by the rule that found them (training
/// BICs within 10, or the alternative's improvement at least 90 % of the named cause's; see
/// `docs/identify/significance.md`, "Confounds"): training BICs of the model with the
/// named cause `named_bic`, with the alternative in its place `other_bic`, and before either
/// `before_bic`.
///
/// ```
/// use jointctl_ident::identify::confound_evidence;
/// assert!(confound_evidence("dead_zone", "stiffness_error", -100.0, -95.0, 0.0).contains("a difference of 5, below 10"));
/// // The share rule: 143 apart, but the alternative improves the BIC by 99 % of the named cause's.
/// let why = confound_evidence("dead_zone", "stiffness_error", -19903.0, -19760.0, 0.0);
/// assert!(why.contains("99 % of") && !why.contains("below"), "{why}");
/// ```
pub fn confound_evidence(named: &str, other: &str, named_bic: f64, other_bic: f64, before_bic: f64) -> String {
    let why = confound_rule(named_bic, other_bic, before_bic, "the named cause");
    format!("{other} in place of {named} explains the training part about as well ({why}); the name given is one of the two, and an experiment that excites them differently (other amplitudes, frequencies, holds) would tell them apart")
}

/// Which confound rule holds, in words (see [`confound_evidence`]); `named`: what it stands in for.
pub(crate) fn confound_rule(named_bic: f64, other_bic: f64, before_bic: f64, named: &str) -> String {
    if (named_bic - other_bic).abs() < CONFOUND_BIC {
        format!("BIC {other_bic:.0} against {named_bic:.0}: a difference of {:.0}, below {:.0}, not very strong evidence for either", (named_bic - other_bic).abs(), CONFOUND_BIC)
    } else {
        format!(
            "it improves the training BIC by {:.0}, {:.0} % of the {:.0} {named} does (at least {:.0} % counts as about as well)",
            before_bic - other_bic,
            100.0 * (before_bic - other_bic) / (before_bic - named_bic),
            before_bic - named_bic,
            100.0 * CONFOUND_SHARE
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Finding (issue 32: a confound the data do not resolve, reported as a single cause): a
    /// candidate that the training part preferred and the held-out part refused for want of
    /// evidence, with about the gain of the cause named after it there, was not reported: the
    /// rule took every refusal on the held-out part for the data telling the two apart.
    #[test]
    fn a_candidate_refused_for_want_of_evidence_with_about_the_named_gain_is_confounded() {
        // Refused before the named cause (gain 7.2e-4): one at 97 % of its gain, one at 50 %,
        // and one at 97 % with a worse training BIC (tested first as an ordinary cause before a
        // ring): not a better fit of the training part.
        let refused = [(3, -25815.0, 6.99e-4), (5, -25300.0, 3.6e-4), (6, -25000.0, 6.99e-4)];
        let pairs: Vec<Confounded> = Confounded::on_held_out(1, [-25144.0, -24311.0], 7.2e-4, &refused).collect();
        assert_eq!(pairs.len(), 1, "{pairs:?}");
        assert_eq!((pairs[0].named, pairs[0].alternative), (1, 3));
        let said = pairs[0].held_out_said("hysteresis", "viscous_friction").unwrap_or_default();
        assert!(said.contains("improves the training BIC by 1504, hysteresis by 833") && said.contains("6.990e-4 Nm^2 against 7.200e-4"), "{said}");
        // The training part's rule alone says nothing of the held-out part.
        let trained = Confounded { named: 1, alternative: 3, bic: [-100.0, -95.0, 0.0], held_out_gains_nm2: None, alternative_params: Vec::new() };
        assert!(trained.held_out_said("a", "b").is_none());
    }
}
