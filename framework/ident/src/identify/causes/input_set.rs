//! Which of the transformable inputs a cause reads and a transform changes: a term's columns
//! depend on the transforms in the model only through the inputs it reads, so models that differ
//! in a transform it does not see share its columns (see `design::ColumnCache`). A dead zone's
//! search refits the model for every width; before, it recomputed the Dahl loop and eq. 3.5's
//! arctan at each one, though neither reads the spring's deflection the dead zone maps.

/// A set of the inputs a transform may change ([`super::Inputs`]): the deflection and its rate as
/// the torque channel sees them, and the deflection the spring transmits (with the given
/// characteristic's torque on it, [`super::Samples::model_nm`]). Time, the repetitions, a piece's
/// history and the bins' edges are the part's own and no transform changes them.
///
/// ```
/// use jointctl_ident::identify::causes::InputSet;
/// let friction = InputSet::VELOCITY;
/// assert!(friction.meets(InputSet::ALL));
/// assert!(!friction.meets(InputSet::ELASTIC));
/// assert_eq!(friction.union(InputSet::ELASTIC), InputSet { deflection: false, velocity: true, elastic: true });
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputSet {
    /// [`super::Inputs::deflection_rad`].
    pub deflection: bool,
    /// [`super::Inputs::velocity_rad_per_s`].
    pub velocity: bool,
    /// [`super::Inputs::elastic_rad`] and the given characteristic's torque on it.
    pub elastic: bool,
}

impl InputSet {
    /// Every transformable input: what a cause reads, and a transform changes, unless it says less.
    pub const ALL: InputSet = InputSet { deflection: true, velocity: true, elastic: true };
    /// None of them (an offset, a line in time, a mode in time).
    pub const NONE: InputSet = InputSet { deflection: false, velocity: false, elastic: false };
    /// The deflection as the torque channel sees it (the reversals; a Dahl loop with the rate).
    pub const DEFLECTION: InputSet = InputSet { deflection: true, velocity: false, elastic: false };
    /// The deflection rate (the frictions, the vibrations' envelopes).
    pub const VELOCITY: InputSet = InputSet { deflection: false, velocity: true, elastic: false };
    /// The spring's deflection (its curve, its scale, a dead zone's map).
    pub const ELASTIC: InputSet = InputSet { deflection: false, velocity: false, elastic: true };

    /// Whether the two share an input.
    pub fn meets(self, other: InputSet) -> bool {
        (self.deflection && other.deflection) || (self.velocity && other.velocity) || (self.elastic && other.elastic)
    }

    /// The inputs in either.
    pub fn union(self, other: InputSet) -> InputSet {
        InputSet { deflection: self.deflection || other.deflection, velocity: self.velocity || other.velocity, elastic: self.elastic || other.elastic }
    }
}

#[cfg(test)]
mod tests {
    //! Every built-in cause against what it says: columns and segments that do not change when an
    //! input it does not read does, and a transform that changes no input it does not write and
    //! reads none it does not say. A wrong declaration would hand a model another's columns.

    use super::InputSet;
    use crate::identify::causes::{Excitation, FullRate, Inputs, Parameter, Restart, RestSamples, Samples, SearchContext, builtin};

    /// A record of two repetitions with a restart, its inputs unrelated to one another.
    fn inputs() -> Inputs {
        let n = 600;
        let t_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.005).collect();
        let deflection_rad = t_s.iter().map(|t| 0.02 * (1.3 * t).sin() + 0.004 * (7.0 * t).sin()).collect();
        let velocity_rad_per_s = t_s.iter().map(|t| 0.03 * (2.1 * t).cos() - 0.01).collect();
        let elastic_rad = t_s.iter().map(|t| 0.015 * (0.9 * t + 0.4).sin()).collect();
        Inputs { t_s, deflection_rad, velocity_rad_per_s, elastic_rad, sample_period_s: 0.005 }
    }

    /// `inputs` with every input outside `keep` replaced by another signal.
    fn changed_outside(inputs: &Inputs, keep: InputSet) -> Inputs {
        let other = |x: &[f64], k: f64| x.iter().enumerate().map(|(i, v)| v * 0.5 + k * (0.37 * i as f64).cos()).collect::<Vec<f64>>();
        Inputs {
            deflection_rad: if keep.deflection { inputs.deflection_rad.clone() } else { other(&inputs.deflection_rad, 0.01) },
            velocity_rad_per_s: if keep.velocity { inputs.velocity_rad_per_s.clone() } else { other(&inputs.velocity_rad_per_s, 0.02) },
            elastic_rad: if keep.elastic { inputs.elastic_rad.clone() } else { other(&inputs.elastic_rad, 0.01) },
            ..inputs.clone()
        }
    }

    /// A value inside each grid: the second point, or the first of a grid of one.
    fn parameters(grids: &[Parameter]) -> Vec<f64> {
        grids.iter().map(|g| g.grid.get(1).or(g.grid.first()).copied().unwrap_or(1.0)).collect()
    }

    /// Columns and segments of `cause` on `inputs`.
    fn read(cause: &dyn crate::identify::CandidateCause, p: &[f64], i: &Inputs) -> (Vec<Vec<f64>>, Option<Vec<usize>>) {
        let n = i.t_s.len();
        let repetition: Vec<u32> = (0..n).map(|k| u32::from(k >= n / 2)).collect();
        let restarts = vec![Restart { at: n / 2, history_rad: vec![0.0, 0.001, 0.002] }];
        let model_nm: Vec<f64> = i.elastic_rad.iter().map(|x| 300.0 * x).collect();
        let history = [0.0, -0.001];
        let pivot = vec![20.0; n];
        let s = Samples {
            t_s: &i.t_s,
            deflection_rad: &i.deflection_rad,
            velocity_rad_per_s: &i.velocity_rad_per_s,
            elastic_rad: &i.elastic_rad,
            pivot_mm: &pivot,
            repetition: &repetition,
            history_rad: &history,
            restarts: &restarts,
            model_nm: &model_nm,
            rate_edges_rad_per_s: &[],
            bin_width_s: 0.0,
            record_middle_s: 1.5,
        };
        (cause.columns(p, &s), cause.segments(p, &s))
    }

    #[test]
    fn every_cause_reads_and_writes_only_what_it_says() {
        let base = inputs();
        // A residual with a mode at 23 Hz, so that the vibrations have a frequency to take.
        let residual: Vec<f64> = base.t_s.iter().map(|t| 0.3 * (std::f64::consts::TAU * 23.0 * t).sin()).collect();
        let excitation = Excitation { amplitude_rad: 0.024, frequency_hz: 0.4, sample_period_s: 0.005, deflection_scatter_rad: 1e-5, resolution_rad: 3.8e-4, quantum_rad: 3.8e-4, turn_step_rad: 3.8e-4, bin_width_s: 0.0 };
        let full_rate = FullRate { t_s: &base.t_s, velocity_rad_per_s: &base.velocity_rad_per_s, residual_nm: &residual };
        let context = SearchContext::new(excitation, &base.t_s, &base.velocity_rad_per_s, &residual, full_rate, RestSamples::default(), true, false);
        for cause in builtin() {
            let p = parameters(&cause.parameters(&context));
            let reads = cause.reads();
            assert_eq!(read(cause.as_ref(), &p, &base), read(cause.as_ref(), &p, &changed_outside(&base, reads)), "{}: its columns read more than {reads:?}", cause.name());
            let writes = cause.writes();
            assert_eq!(cause.transforms(), writes != InputSet::NONE, "{}", cause.name());
            let (mut once, mut other) = (base.clone(), changed_outside(&base, reads));
            cause.transform(&p, &mut once);
            cause.transform(&p, &mut other);
            let kept = |i: &Inputs, before: &Inputs, what: InputSet| (!what.deflection || i.deflection_rad == before.deflection_rad) && (!what.velocity || i.velocity_rad_per_s == before.velocity_rad_per_s) && (!what.elastic || i.elastic_rad == before.elastic_rad);
            let unwritten = InputSet { deflection: !writes.deflection, velocity: !writes.velocity, elastic: !writes.elastic };
            assert!(kept(&once, &base, unwritten), "{}: its transform changes more than {writes:?}", cause.name());
            let written_alike = |a: &Inputs, b: &Inputs| (!writes.deflection || a.deflection_rad == b.deflection_rad) && (!writes.velocity || a.velocity_rad_per_s == b.velocity_rad_per_s) && (!writes.elastic || a.elastic_rad == b.elastic_rad);
            assert!(written_alike(&once, &other), "{}: its transform reads more than {reads:?}", cause.name());
        }
    }

    #[test]
    fn a_cause_that_misstates_what_it_reads_is_caught() {
        // The check above can fail: the arctan's columns differ when the rate does.
        let base = inputs();
        let arctan = crate::identify::causes::CoulombFriction;
        let p = [40.0];
        assert_ne!(read(&arctan, &p, &base), read(&arctan, &p, &changed_outside(&base, InputSet::DEFLECTION)));
    }
}
