//! Dahl hysteresis in the element: `+ F_c u(phi; lambda)` with `du/dphi = (1 - u sgn(dphi)) / lambda`,
//! driven by the deflection reading through a dead band as wide as the reading's flicker.

use serde_json::json;

use super::loop_scales::{LOOP_TURN_COUNTS, scale_grid};
use super::{CandidateCause, InputSet, Fragments, Parameter, Refine, Samples, SearchContext, object};
use jointctl_models::effect::Effect;

/// `+ F_c * u`, `u` the unit Dahl state; deflection scale `lambda = F_c / sigma` [rad].
pub struct Hysteresis;

/// The unit Dahl response (limit 1) to a deflection history with scale `lambda`, exact per step.
///
/// ```
/// let u = jointctl_ident::identify::causes::dahl_unit(&[0.0, 1.0, 2.0], 0.1);
/// assert!(u[2] > 0.999);
/// ```
pub fn dahl_unit(d: &[f64], lambda: f64) -> Vec<f64> {
    loop_unit(d, lambda, 1.0)
}

/// The unit loop's response (limit 1) to a deflection history with scale `lambda` and shape
/// exponent `shape`, one [`jointctl_models::extension::loop_step`] per reading (the step the
/// observer runs; at shape 1 Dahl's exact step, [`dahl_unit`]).
///
/// ```
/// use jointctl_ident::identify::causes::{dahl_unit, loop_unit};
/// assert_eq!(loop_unit(&[0.0, 0.01, 0.03], 0.1, 1.0), dahl_unit(&[0.0, 0.01, 0.03], 0.1));
/// // A sharper loop keeps closer to its first slope on the way up.
/// assert!(loop_unit(&[0.0, 0.05], 0.1, 3.0)[1] > dahl_unit(&[0.0, 0.05], 0.1)[1]);
/// ```
pub fn loop_unit(d: &[f64], lambda: f64, shape: f64) -> Vec<f64> {
    let mut u = 0.0;
    let mut prev = d.first().copied().unwrap_or(0.0);
    d.iter()
        .map(|&x| {
            u = jointctl_models::extension::loop_step(u, x - prev, lambda, shape);
            prev = x;
            u
        })
        .collect()
}

/// The loop's shape exponents tried (1: Dahl's model, the simpler, kept unless the proposal with
/// another has the better BIC on the decimated training part, [`Refine::NestedDecimated`]). Published
/// Bouc-Wen fits of joints, gears and dampers put the exponent between 1 and 3 (an assumption
/// that 4 closes the range). Dahl's exponential approach left 1.6 times the noise of a record
/// whose loop had `n = 2.3`, and a cubic stiffness or an offset was named beside the loop for
/// it. Whole steps only: with 1.5 among them (chosen on the full-rate part, before the BIC
/// check), the blind generator's LuGre loops (Dahl-like,
/// their limit changing with the speed) took 1.5 for what a viscous friction explained and lost
/// it (seed 4's 088).
const SHAPES: [f64; 4] = [1.0, 2.0, 3.0, 4.0];

/// The deflection through a dead band of `width_rad`: the output takes the input once the input
/// is more than half the width from the last value taken, and holds otherwise, starting at the
/// first sample. A reading that flickers between encoder counts reverses at every flicker; a
/// Dahl state driven by it steps back at each reversal and gets less back on the next step
/// (near the loop's limit, almost nothing: the slope after a reversal is twice the slope on the
/// way), so the flicker walks the state off the loop. On a stiff spring read by a fine linear
/// encoder (2e-6 rad counts, 1-2 counts of flicker, 1800 Nm/rad; the shared real-like
/// l3-case002) identify left 8.8 times the noise and named a delay beside the loop; behind a
/// band of a few flickers, 1.7 times and the loop alone.
///
/// A dead band, not a play (a backlash operator, which follows at half the width behind): a
/// play lags the loop's input by half its width all along, which stood in for a lag between
/// the channels (the simulated elbow's recorder: the loop's stiffness 287 Nm/rad instead of 249,
/// then a small cubic named beside it at the loop's ends). The band's output jumps to the
/// reading once it leaves the band, and Dahl's exact step takes the jump whole, so the state is
/// the one the reading's path gives without its wiggles inside the band.
///
/// ```
/// use jointctl_ident::identify::causes::dead_band;
/// let out = dead_band(&[0.0, 1.0, 0.8, 1.2, 1.3, -1.0], 0.5);
/// assert_eq!(out, vec![0.0, 1.0, 1.0, 1.0, 1.3, -1.0]);
/// ```
pub fn dead_band(d: &[f64], width_rad: f64) -> Vec<f64> {
    let mut held = None;
    d.iter()
        .map(|&x| {
            let f = jointctl_models::extension::dead_band_step(held, x, width_rad);
            held = Some(f);
            f
        })
        .collect()
}

/// The dead bands tried in front of the Dahl state, in units of the deflection reading's
/// scatter beyond its quantisation (see [`crate::identify::Excitation::deflection_scatter_rad`]):
/// none, and up to 8 (+-4 standard deviations, beyond which a flicker is rare). Chosen on the
/// full-rate stretch of the training part, a band only when it betters the fit there by more
/// than BIC's charge for a parameter ([`Refine::Nested`]): the searches run on a decimated part
/// (100 samples a cycle), where successive samples lie many counts apart and no flicker shows.
/// Not one fixed width: a band of 4 standard deviations took the viscous friction of a 20 Hz
/// friction record (l3-case008), whose scatter is its motion, not a flicker. Scaled by the
/// scatter, not by the quantisation: a 14-bit encoder that steps cleanly gets bands of a
/// fraction of a count, which pass every count.
const DEAD_BAND_IN_SCATTER: [f64; 5] = [0.0, 1.0, 2.0, 4.0, 8.0];

/// The pre-sliding damping's time constants tried [s]: none, then from 2 to 50 ms (an
/// assumption: LuGre fits of joints and drives put `sigma1 / sigma0` between a few and a few
/// tens of milliseconds). The loop's torque is then `F_c (u + tau_d du/dt)`: LuGre's
/// `sigma0 z + sigma1 dz/dt` (Canudas de Wit et al. 1995) with `sigma1 = sigma tau_d`, the
/// bristles' damping, which acts while they deflect and not once they slide. Not searched with
/// the loop: tried after the selection, in place of a lead named beside it and on a friction
/// record beside the loop alone (see `identify::presliding`).
pub(crate) fn presliding_damping_parameter() -> Parameter {
    Parameter { name: "presliding_damping_s".into(), grid: PRESLIDING_DAMPING_S.to_vec(), refine: Refine::Nested }
}

const PRESLIDING_DAMPING_S: [f64; 6] = [0.0, 0.002, 0.005, 0.01, 0.02, 0.05];

/// A loop that runs the other way turns within this share of the amplitude (its inverse; see
/// `impossible_given`).
const NEGATIVE_LOOP_STROKE_SHARE: f64 = 6.0;

/// The index of the pre-sliding damping among the loop's parameters (after the scale, the dead
/// band and the shape, which the search always sets).
pub(crate) const PRESLIDING_DAMPING_AT: usize = 3;

/// The input dead band's value that reads the loop averaged over each bin's interval instead,
/// with no band (see [`loop_over_bins`]): one choice of how the loop reads its input with the
/// band's widths, so that the data weighs the two readings each with its best band. As a
/// parameter of its own, searched after the band, a band chosen at the samples was dropped
/// while the interval was being tried (the band does nothing there) and not found again (the
/// shared real-like l3-case008: 0.0181 Nm held out for 0.0151).
const OVER_INTERVAL: f64 = -1.0;

impl CandidateCause for Hysteresis {
    fn name(&self) -> &str {
        Effect::Hysteresis.name()
    }
    fn reads(&self) -> InputSet {
        // The rate too: the pre-sliding damping's `du/dt` and the path within a bin.
        InputSet::DEFLECTION.union(InputSet::VELOCITY)
    }
    fn effect(&self) -> Option<Effect> {
        Some(Effect::Hysteresis)
    }
    fn coefficient_names(&self) -> Vec<String> {
        vec!["limit_nm".into()]
    }
    fn parameters(&self, c: &SearchContext) -> Vec<Parameter> {
        let scatter = c.excitation.deflection_scatter_rad;
        let mut band: Vec<f64> = if scatter > 0.0 && scatter.is_finite() { DEAD_BAND_IN_SCATTER.iter().map(|k| k * scatter).collect() } else { vec![0.0] };
        // A record read as bin averages: the loop at each sample's mean deflection, or its mean
        // over the interval, taken when the data says so (see `loop_over_bins`). Not on a
        // friction record: its turns, where the pre-sliding loop turns and the two readings
        // differ, are left out of the fit (`prepare::turns`), so the fit cannot judge them (the
        // shared real-like l3-case008, 20 Hz bins of a LuGre friction: the interval taken on
        // the sliding samples, 0.0278 Nm held out over every sample for 0.0151 at the points).
        if c.excitation.bin_width_s > 0.0 && !c.no_spring {
            band.push(OVER_INTERVAL);
        }
        vec![
            Parameter { name: "lambda_rad".into(), grid: scale_grid(c), refine: Refine::Between },
            Parameter { name: "input_dead_band_rad".into(), grid: band, refine: Refine::Nested },
            Parameter { name: "shape".into(), grid: SHAPES.to_vec(), refine: Refine::NestedDecimated },
        ]
    }
    fn columns(&self, p: &[f64], s: &Samples) -> Vec<Vec<f64>> {
        let band = p.get(1).copied().unwrap_or(0.0);
        let n = s.deflection_rad.len();
        // Each piece's loop from its own history.
        let starts = std::iter::once((0, s.history_rad)).chain(s.restarts.iter().map(|r| (r.at.min(n), r.history_rad.as_slice())));
        let ends = s.restarts.iter().map(|r| r.at.min(n)).chain(std::iter::once(n));
        let mut unit = Vec::with_capacity(n);
        let damping_s = presliding_damping_s(p);
        if over_interval(p) && s.rate_edges_rad_per_s.len() == n && s.bin_width_s > 0.0 {
            for ((a, before), b) in starts.zip(ends) {
                unit.extend(loop_over_bins(before, s, a..b.max(a), p[0], shape(p), damping_s));
            }
            return vec![unit];
        }
        for ((a, before), b) in starts.zip(ends) {
            let mut history = before.to_vec();
            history.extend_from_slice(&s.deflection_rad[a..b.max(a)]);
            if band > 0.0 {
                history = dead_band(&history, band);
            }
            // LuGre's curve on Dahl's shape only (`identify::presliding` tries it there; a loop
            // over a bin's interval returned above).
            if stribeck(p).0 > 0.0 && shape(p) == 1.0 {
                // The history has no rates: it starts the state at the limit at speed (Dahl's),
                // which the record's first turn forgets.
                let x0 = if before.is_empty() { history.first().copied().unwrap_or(0.0) } else { history[before.len() - 1] };
                let u0 = loop_unit(&history[..before.len()], p[0], 1.0).last().copied().unwrap_or(0.0);
                unit.extend(lugre_unit(&history[before.len()..], &s.velocity_rad_per_s[a..b.max(a)], u0, x0, p[0], stribeck(p)));
                continue;
            }
            unit.extend_from_slice(&loop_unit(&history, p[0], shape(p))[before.len()..]);
        }
        if damping_s > 0.0 {
            // `u + tau_d du/dt`, the state's rate from the loop's law at the rate reading; with
            // LuGre's curve, Dahl's law towards the limit `g(v) / F_c`.
            let (ratio, speed) = stribeck(p);
            let limit = |v: f64| if ratio > 0.0 && shape(p) == 1.0 { stribeck_limit(v, ratio, speed) } else { 1.0 };
            for (u, v) in unit.iter_mut().zip(s.velocity_rad_per_s) {
                *u += damping_s * jointctl_models::extension::loop_rate(*u / limit(*v), *v, p[0], shape(p));
            }
        }
        vec![unit]
    }
    /// A loop of either sign. One that runs the other way in the torque reading (a negative
    /// limit) is a friction in a path beside the torque sensor: a bearing that carries part of
    /// the element's torque past the sensor slides in pre-sliding with the sensor's own small
    /// deflection, which follows the element's, and takes a loop's worth of torque from the
    /// reading, more as the element loads. Refused as impossible, such a loop was what a plain
    /// least-squares fit with a free-signed Dahl state explained and identify did not: on the
    /// rig generator's records (`tools/ident_reference/rig_generator`, a bypass bearing beside
    /// the sensor) 22 of 128 above 1.25 times that fit's held-out error, 14 with either sign.
    fn impossible(&self, _: &[f64], c: &[f64]) -> Option<String> {
        (c[0] == 0.0).then(|| "a loop of zero size".into())
    }
    /// One that runs the other way must also turn within the stroke, and over more of the
    /// reading than its quantisation. Within the stroke: its scale (the deflection over which
    /// it reaches 63 % of its limit) at most a sixth of the amplitude, half the bound the search
    /// keeps for every loop (a third, see `parameters`). A loop that has not turned is, on the
    /// data, a damping of its sign; a negative one is a lead of the torque, which a delay is to
    /// first order, and beside a delay or a lag it took up what their models missed (the
    /// project's own delay and lag records, `delay_behind_a_lag`: loops of scale 0.28-0.35 of
    /// the largest deflection, at the search's bound). Over the quantisation: its turn (three
    /// scales, 95 % of its limit) over at least [`LOOP_TURN_COUNTS`] counts of the reading's
    /// coarsest quantiser (`Excitation::quantum_rad`), the project's rule for a shape told from
    /// its quantisation. The coarsest, not the smallest common step: the simulated elbow's
    /// deflection is a 14-bit output encoder less a fine motor encoder through the ratio, and its
    /// clean recordings (`tests/tests/ident_cli.rs`, 100 Hz) named loops of -0.005 Nm a fifth of
    /// the output's count in scale, which took what the reading does at the turns (a residual of
    /// about 0.015 Nm either side of each, a third of a count's torque); at 100 Hz the reading
    /// never holds, so that count is read from the lattice its steps lie on. A clean 100 Hz record of a 14-bit encoder
    /// (`viscous_beside_small_arctan`) named a loop of one count's scale and 0.014 Nm, the
    /// spring's torque over about a count. The sixth is an assumption placed between what was
    /// measured: the loops of a bearing beside the sensor turned within 0.013-0.058 of the
    /// amplitude on the rig generator's records (60-430 counts of its 2e-6 rad encoder) and
    /// 0.12 on `loop_beside_the_sensor`. A loop of the element's own sign keeps the search's
    /// bounds.
    fn impossible_given(&self, p: &[f64], c: &[f64], excitation: &super::Excitation) -> Option<String> {
        self.impossible(p, c).or_else(|| {
            let (wide, counts) = (p[0] > excitation.amplitude_rad / NEGATIVE_LOOP_STROKE_SHARE, 3.0 * p[0] / excitation.quantum_rad);
            if c[0] >= 0.0 {
                None
            } else if wide {
                Some(format!("a loop that runs the other way and does not turn within the stroke (scale {:.3e} rad, above a {NEGATIVE_LOOP_STROKE_SHARE}th of the amplitude {:.3e}): a lead of the torque", p[0], excitation.amplitude_rad))
            } else if counts < LOOP_TURN_COUNTS {
                Some(format!("a loop that runs the other way and turns within {counts:.1} counts of the reading (scale {:.3e} rad): not told from its quantisation", p[0]))
            } else {
                None
            }
        })
    }
    fn report(&self, p: &[f64], _: &[String], c: &[f64]) -> std::collections::BTreeMap<String, f64> {
        let mut out: std::collections::BTreeMap<String, f64> = [("limit_nm".to_string(), c[0]), ("sigma_nm_per_rad".to_string(), c[0] / p[0])].into_iter().collect();
        let band = p.get(1).copied().unwrap_or(0.0);
        if band > 0.0 {
            out.insert("input_dead_band_rad".into(), band);
        }
        if over_interval(p) {
            out.insert("over_interval".into(), 1.0);
        }
        if shape(p) != 1.0 {
            out.insert("shape".into(), shape(p));
        }
        if presliding_damping_s(p) > 0.0 {
            out.insert("presliding_damping_s".into(), presliding_damping_s(p));
        }
        if stribeck(p).0 > 0.0 {
            out.insert("stribeck_nm".into(), c[0] * stribeck(p).0);
            out.insert("stribeck_speed_rad_per_s".into(), stribeck(p).1);
        }
        out
    }
    fn fragments(&self, p: &[f64], c: &[f64]) -> Fragments {
        let mut h = json!({"sigma_nm_per_rad": c[0] / p[0], "limit_nm": c[0]});
        if shape(p) != 1.0 {
            h["shape"] = json!(shape(p));
        }
        if presliding_damping_s(p) > 0.0 {
            h["presliding_damping_s"] = json!(presliding_damping_s(p));
        }
        // A Stribeck curve in the loop is tried on a friction record only, whose loop is
        // reported with the friction and writes no fragment (`friction_parts::no_spring`): the
        // observer's and the simulation's joints are springs.
        // The band filters the reading the observer sees; the simulated plant's loop is driven
        // by its true deflection and needs none.
        let band = p.get(1).copied().unwrap_or(0.0);
        let mut observed = h.clone();
        if band > 0.0 {
            observed["input_dead_band_rad"] = json!(band);
        }
        // A loop that runs the other way is the reading's (a friction beside the sensor, see
        // `impossible`): the observer, which predicts the reading, takes it; the plant's element
        // does not, where it would give energy (the simulator has no path beside its sensor).
        let plant = if c[0] > 0.0 { object([("hysteresis", h)]) } else { object([]) };
        Fragments { plant, observer: object([("hysteresis", observed)]) }
    }
}

/// Points of a bin's path the loop is driven through and averaged over (an assumption: on the
/// blind devices' 20 Hz bins the deflection moves up to about ten loop scales within a bin, and
/// the midpoint rule over eight points follows a Dahl state's turn within a few per cent of it).
const BIN_PATH_POINTS: usize = 8;

/// The unit loop, averaged over each bin, of a record read as bin averages (samples `r` of
/// `s`, after the deflections `before`): a logger that averages its readings over an interval
/// averages the loop's torque too, and where the deflection moves several loop scales within
/// the interval (a 20 Hz log of a motion of a few hertz), the loop's state at the interval's
/// mean deflection is not the mean of its states. Evaluated at the mean, the blind generator's
/// Bouc-Wen loops on 20 Hz bins left 7.6 and 9.0 times the noise floor where their full-rate
/// variants left 1.0-1.3 (seeds 46 and 45, device A), took a loop limit of 0.70 Nm for the
/// full-rate records' 0.89-1.02 and named a cubic beside it.
///
/// The path within a bin is the one its rate reading gives: the rate runs linearly from the
/// interval's start (`v + edges[0]`) to the sample's own `v` at its middle and on to its end
/// (as [`crate::identify::numeric::interval_mean`] reads it), the deflection its integral,
/// placed so that its mean over the interval is the sample's deflection. The history before
/// is driven as points (its intervals are not known).
///
/// A choice the data makes (beside the dead band's widths, [`OVER_INTERVAL`], taken when it
/// betters the training part's fit by more than BIC charges for a parameter): a log of 100 Hz or slower is tried as bins when
/// its baseline reads better so, whether or not its logger averaged, and a log sampled at its
/// points then reads the loop at its points (the third generator's 100 Hz point samples, seed
/// 32's 043: held out 0.357 Nm at the points, 0.385 averaged). So does a loop that is not
/// Dahl's (a LuGre friction's pre-sliding with its Stribeck dip, the shared real-like
/// l3-case008: 0.0151 Nm at the points behind a band of one count, 0.0181 averaged).
///
/// No dead band: the band holds a reading's flicker between encoder counts ([`dead_band`]), and
/// a bin's mean of many readings does not flicker so; on the smooth path a band holds the loop's
/// input at each turn, a play in front of the loop. On seed 61's device A at 20 Hz a band of
/// 8.6e-4 rad (six of the bins' steps) bettered the training part and took a limit of 1.70 Nm
/// for the full-rate variants' 1.41-1.42: held out 0.0940 Nm against 0.0611 without.
fn loop_over_bins(before: &[f64], s: &Samples, r: std::ops::Range<usize>, lambda_rad: f64, shape: f64, damping_s: f64) -> Vec<f64> {
    let h = s.bin_width_s;
    let (mut u, mut prev) = (0.0, before.first().or(s.deflection_rad.get(r.start)).copied().unwrap_or(0.0));
    let mut step = |x: f64, u: &mut f64| {
        *u = jointctl_models::extension::loop_step(*u, x - prev, lambda_rad, shape);
        prev = x;
    };
    for &x in before {
        step(x, &mut u);
    }
    r.map(|i| {
        let (v, [e0, e1]) = (s.velocity_rad_per_s[i], s.rate_edges_rad_per_s[i]);
        // The path `c + v t + e t^2 / h` (e = -e0 before the middle, e1 after) has its mean at
        // `c + (e1 - e0) h / 24`.
        let c = s.deflection_rad[i] - (e1 - e0) * h / 24.0;
        let mut sum = 0.0;
        for j in 0..BIN_PATH_POINTS {
            let at = h * ((j as f64 + 0.5) / BIN_PATH_POINTS as f64 - 0.5);
            let e = if at < 0.0 { -e0 } else { e1 };
            step(c + v * at + e * at * at / h, &mut u);
            sum += u;
            if damping_s > 0.0 {
                sum += damping_s * jointctl_models::extension::loop_rate(u, v + 2.0 * e * at / h, lambda_rad, shape);
            }
        }
        sum / BIN_PATH_POINTS as f64
    })
    .collect()
}

/// Whether parameters `p` average the loop over each bin's interval ([`OVER_INTERVAL`]).
fn over_interval(p: &[f64]) -> bool {
    p.get(1).is_some_and(|x| *x < 0.5 * OVER_INTERVAL)
}

/// The shape exponent of parameters `p` (1 when the search left it out).
fn shape(p: &[f64]) -> f64 {
    p.get(2).copied().unwrap_or(1.0)
}

/// The index of the loop's Stribeck ratio among its parameters (its speed follows), after the
/// pre-sliding damping (see [`stribeck_parameters`]).
pub(crate) const STRIBECK_AT: usize = PRESLIDING_DAMPING_AT + 1;

/// The loop's Stribeck ratio and speed [rad/s] of parameters `p` (ratio 0 when none was taken).
pub(crate) fn stribeck(p: &[f64]) -> (f64, f64) {
    (p.get(STRIBECK_AT).copied().unwrap_or(0.0), p.get(STRIBECK_AT + 1).copied().unwrap_or(1.0))
}

/// The friction's Stribeck curve inside a friction record's pre-sliding loop, as LuGre holds it
/// (Canudas de Wit et al. 1995): the bristles' deflection tends to `g(v) / sigma0`, with
/// `g(v) = F_c (1 + ratio exp(-(v / v_s)^2))`, so the loop's limit is higher at low speed and the
/// state gets there over a scale that grows with it. Its parameters, the ratio and the speed
/// `v_s` [rad/s] (a grid over the record's rates, see `identify::presliding`), are set by
/// `identify::presliding`, which tries them after the selection; the search never does. The
/// ratios are an assumption: 10-80 % above the loop's limit, about Canudas de Wit et al.'s
/// example (a breakaway 50 % above the Coulomb level), wider above because the loop's limit
/// can be below the whole Coulomb level where eq. 3.5's arctan takes part of it.
pub(crate) fn stribeck_parameters(speeds_rad_per_s: Vec<f64>) -> [Parameter; 2] {
    [
        // Not nested: neither grid has a simpler first value, so each is charged as a parameter.
        Parameter { name: "stribeck_ratio".into(), grid: STRIBECK_RATIOS.to_vec(), refine: Refine::Not },
        Parameter { name: "stribeck_speed_rad_per_s".into(), grid: speeds_rad_per_s, refine: Refine::Not },
    ]
}

/// The Stribeck ratios tried (see [`stribeck_parameters`]).
pub(crate) const STRIBECK_RATIOS: [f64; 5] = [0.1, 0.2, 0.3, 0.5, 0.8];

/// LuGre's unit state (limit 1 at speed) from `u` at deflection `prev`, over the deflections
/// `x` at rates `v` [rad/s]: Dahl's exact step at each sample's limit `g(v) / F_c`, over a scale
/// `lambda g(v) / F_c` (`dz/dphi = (1 - sgn(dphi) sigma0 z / g(v))`, `z = lambda u`).
fn lugre_unit(x: &[f64], v: &[f64], mut u: f64, mut prev: f64, lambda: f64, (ratio, speed): (f64, f64)) -> Vec<f64> {
    x.iter()
        .zip(v)
        .map(|(&xi, &vi)| {
            let step = xi - prev;
            prev = xi;
            if step != 0.0 {
                let g = stribeck_limit(vi, ratio, speed);
                let s = step.signum() * g;
                u = s + (u - s) * (-step.abs() / (lambda * g)).exp();
            }
            u
        })
        .collect()
}

/// `1 + ratio exp(-(v / speed)^2)`: LuGre's `g(v) / F_c`.
fn stribeck_limit(v: f64, ratio: f64, speed: f64) -> f64 {
    1.0 + ratio * (-(v / speed).powi(2)).exp()
}

/// The pre-sliding damping's time constant of parameters `p` [s] (0 when none was taken).
fn presliding_damping_s(p: &[f64]) -> f64 {
    p.get(PRESLIDING_DAMPING_AT).copied().unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::super::loop_scales::PRESLIDING_SCALE_RAD;
    use super::super::{Excitation, FullRate, RestSamples, SearchContext};
    use super::{CandidateCause, Hysteresis};

    fn scales(amplitude_rad: f64, resolution_rad: f64) -> Vec<f64> {
        let excitation = Excitation { amplitude_rad, frequency_hz: 0.5, sample_period_s: 0.05, deflection_scatter_rad: 0.0, resolution_rad, quantum_rad: resolution_rad, turn_step_rad: resolution_rad, bin_width_s: 0.0 };
        let full_rate = FullRate { t_s: &[], velocity_rad_per_s: &[], residual_nm: &[] };
        let ctx = SearchContext::new(excitation, &[], &[], &[], full_rate, RestSamples::default(), true, false);
        Hysteresis.parameters(&ctx)[0].grid.clone()
    }

    /// The grid on a joint's range of 1.2 rad (18-bit reading), its motion sampled at `dt_s` at
    /// 0.2 rad/s.
    fn scales_on_a_joints_range(dt_s: f64) -> Vec<f64> {
        scales_on_a_joints_range_read_by(dt_s, 2.4e-5)
    }

    /// [`scales_on_a_joints_range`] read in counts of `count_rad`.
    fn scales_on_a_joints_range_read_by(dt_s: f64, count_rad: f64) -> Vec<f64> {
        let excitation = Excitation { amplitude_rad: 1.2, frequency_hz: 0.05, sample_period_s: dt_s, deflection_scatter_rad: 0.0, resolution_rad: count_rad, quantum_rad: count_rad, turn_step_rad: count_rad, bin_width_s: 0.0 };
        let t: Vec<f64> = (0..1000).map(|i| i as f64 * dt_s).collect();
        let v = vec![0.2; t.len()];
        let full_rate = FullRate { t_s: &t, velocity_rad_per_s: &v, residual_nm: &[] };
        let ctx = SearchContext::new(excitation, &[], &[], &[], full_rate, RestSamples::default(), true, true);
        Hysteresis.parameters(&ctx)[0].grid.clone()
    }

    #[test]
    fn a_joints_presliding_is_searched_below_a_thousandth_of_its_range_where_the_samples_resolve_it() {
        let smallest = |grid: &[f64]| grid.iter().copied().fold(f64::INFINITY, f64::min);
        // At 1 kHz a sample moves 0.2 mrad: the grid goes on down towards 0.1 mrad at its
        // spacing.
        // Its turn spans 16 counts from a scale of 0.128 mrad: the grid stops above that.
        let fine = scales_on_a_joints_range(1e-3);
        let floor = (16.0 * 2.4e-5 / 3.0f64).max(PRESLIDING_SCALE_RAD);
        assert!(fine.len() > 16 && smallest(&fine) >= floor && smallest(&fine) < 1.5 * floor, "{fine:?}");
        assert!(fine.windows(2).all(|w| (w[1] / w[0] / (fine[1] / fine[0]) - 1.0).abs() < 1e-9), "{fine:?}");
        // At 20 Hz it moves 10 mrad: a loop narrower than a thousandth of the range closes
        // between two samples; the grid stays at its 16.
        let slow = scales_on_a_joints_range(0.05);
        assert!(slow.len() == 16 && (smallest(&slow) / 1.2e-3 - 1.0).abs() < 1e-9, "{slow:?}");
    }

    #[test]
    fn no_presliding_below_a_thousandth_of_the_range_is_searched_whose_turn_spans_fewer_than_16_counts() {
        // A 14-bit reading (3.8e-4 rad) at 500 Hz, as the blind generator's seed 4's `067`: a
        // loop's turn over 16 counts is 6 mrad wide, a scale of 2 mrad, coarser than a thousandth
        // of the range; the grid stays at its 16.
        let coarse = scales_on_a_joints_range_read_by(2e-3, std::f64::consts::TAU / 16384.0);
        assert!(coarse.len() == 16 && (coarse[0] / 1.2e-3 - 1.0).abs() < 1e-9, "{coarse:?}");
        // A 16-bit one: the turn spans 16 counts from a scale of 0.5 mrad.
        let finer = scales_on_a_joints_range_read_by(2e-3, std::f64::consts::TAU / 65536.0);
        let floor = 16.0 * std::f64::consts::TAU / 65536.0 / 3.0;
        assert!(finer.len() > 16 && finer[0] >= floor && finer[0] < 1.5 * floor, "{finer:?}");
    }

    #[test]
    fn no_loop_narrower_than_one_step_of_the_reading_is_searched() {
        // A 14-bit encoder on a 0.09 rad stroke: a thousandth of it is a quarter of a step.
        let step = std::f64::consts::TAU / 16384.0;
        let grid = scales(0.09, step);
        assert!(grid.iter().all(|s| *s >= step * (1.0 - 1e-12)), "{grid:?}");
        assert!((grid.iter().copied().fold(f64::INFINITY, f64::min) / step - 1.0).abs() < 1e-9);
        // A fine encoder: a thousandth of the amplitude, as before.
        let fine = scales(0.09, 2e-6);
        assert!((fine.iter().copied().fold(f64::INFINITY, f64::min) / 9e-5 - 1.0).abs() < 1e-9, "{fine:?}");
        // A stroke of 20 steps still gets a grid: down to a tenth of its largest scale (a third
        // of the stroke), two thirds of a step.
        let narrow = scales(20.0 * step, step);
        let smallest = narrow.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(narrow.len() == 16 && (smallest / (20.0 * step / 30.0) - 1.0).abs() < 1e-9, "{narrow:?}");
    }

    /// A loop that runs the other way is refused where it has not turned within a sixth of the
    /// stroke (a lead of the torque) or turns within the reading's quantisation; between, it
    /// stands, and a loop of the element's own sign keeps the search's bounds either side.
    #[test]
    fn a_loop_that_runs_the_other_way_turns_within_the_stroke_and_over_the_quantisation() {
        let excitation = Excitation { amplitude_rad: 0.06, frequency_hz: 0.5, sample_period_s: 0.001, deflection_scatter_rad: 0.0, resolution_rad: 2e-6, quantum_rad: 2e-6, turn_step_rad: 2e-6, bin_width_s: 0.0 };
        let judged = |scale_rad: f64, limit_nm: f64| Hysteresis.impossible_given(&[scale_rad, 0.0, 1.0], &[limit_nm], &excitation);
        // A bearing beside the sensor (the rig generator's, 2e-4 rad) and a lead (0.3 of the stroke).
        assert_eq!(judged(2e-4, -0.3), None);
        assert!(judged(0.018, -0.3).is_some_and(|why| why.contains("lead of the torque")));
        // Three scales over 15 counts of the reading, and over 16.
        assert!(judged(10e-6, -0.3).is_some_and(|why| why.contains("quantisation")));
        assert_eq!(judged(10.7e-6, -0.3), None);
        for scale_rad in [10e-6, 2e-4, 0.018] {
            assert_eq!(judged(scale_rad, 0.3), None, "{scale_rad}");
        }
        assert!(judged(2e-4, 0.0).is_some());
    }
}
