//! The significance rule, stated as the report gives it.

use super::{CONFIRMED_SLOPE, CONSISTENCY_PARTS, LARGE_SHARE_OF_EXCESS, LEVEL, RELEVANT_SHARE_OF_EXCESS, RELEVANT_SHARE_OF_NOISE};

impl crate::identify::Significance {
    /// The rule `select` applies, stated, with `blocks` blocks of the held-out part.
    pub(crate) fn stated(blocks: usize) -> Self {
        let test = format!(
            "block t-test of held-out squared-error differences (Diebold-Mariano with batch means, AR(1)-corrected), one-sided; or forecast encompassing (the held-out residual regressed on the cause's correction, batch-means variance, the blocks' effective number as degrees of freedom) with a slope of at least {:.2} in each of {} parts of the held-out record where the correction acts; or, where the residual is structure, a gain of at least {:.0} % of the excess over the noise floor that worsens none of those parts and betters most of those with something to explain; for coefficients fitted on each ring, a gain of at least {:.0} % of the excess (consistent over those parts where the residual is structure) and a chi-square test of the held-out error drop",
            CONFIRMED_SLOPE,
            CONSISTENCY_PARTS,
            100.0 * LARGE_SHARE_OF_EXCESS,
            100.0 * LARGE_SHARE_OF_EXCESS
        );
        let relevance = format!(
            "a held-out MSE gain of at least {:.0} % of the noise floor's variance and {:.0} % of the excess of the model without the cause over that floor",
            100.0 * RELEVANT_SHARE_OF_NOISE,
            100.0 * RELEVANT_SHARE_OF_EXCESS
        );
        crate::identify::Significance { test, level: LEVEL, relevance, blocks }
    }
}
