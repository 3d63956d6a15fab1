//! How a searched parameter's best grid value is refined, and which grid values are a simpler
//! model nested in the cause's.

/// How the best value of a parameter's grid is refined.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refine {
    /// Golden-section search between the best value's neighbours (a positive grid, log scale).
    Between,
    /// A whole number of delay steps (full-rate sample periods; on a slow log, finer): the best
    /// within a grid step of the best grid value, on the decimated training part.
    Samples,
    /// The grid value as it is (already refined by the cause).
    Not,
    /// The grid's first value is the simpler model (a dead band of zero width); another value is
    /// taken only when it betters the fit of the training part at the full rate (what it acts
    /// on may not show on the decimated part; the whole training part when it is kept at the
    /// full rate, a contiguous stretch of it otherwise) by more than BIC charges for one more
    /// parameter (`n ln(RSS_0 / RSS) > ln n`): a freedom the data does not need would bend the
    /// cause's shape towards what other causes leave. The search starts from the first value,
    /// so that the other parameters are fitted for the simpler model before a value is
    /// weighed against it.
    Nested,
    /// As [`Refine::Nested`], chosen on the decimated training part, and kept only when the
    /// proposal's BIC there (the selection's own score: the linear coefficients fitted again,
    /// the other terms' grids looked over) is better than the same proposal's with the first
    /// value; the cause's own scale stays where the search put it for the chosen value, which
    /// leans the comparison towards that value. For a choice that shows at the motion's scale
    /// (a loop's shape). The search
    /// ranks values by projection on what the model leaves, which can prefer a value the refit
    /// does not (on one sine, a Dahl loop took shape 4, 43 BIC units worse than shape 1, and
    /// fell out of the confound it is in with a delay).
    NestedDecimated,
}

impl Refine {
    /// Whether the grid's first value is the simpler model ([`Refine::Nested`],
    /// [`Refine::NestedDecimated`]): searched from it, and at it not estimated.
    ///
    /// ```
    /// use jointctl_ident::identify::Refine;
    /// assert!(Refine::NestedDecimated.is_nested() && !Refine::Between.is_nested());
    /// ```
    pub fn is_nested(self) -> bool {
        matches!(self, Refine::Nested | Refine::NestedDecimated)
    }
}
