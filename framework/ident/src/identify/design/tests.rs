//! The design's tests: its column cache, the inputs a term sees, and parts read with their history.

use super::*;

#[test]
fn the_column_cache_stays_within_its_budget_and_returns_what_was_computed() {
    let cache = ColumnCache::default();
    let column = 1 << 20; // 8 MiB per entry: two fit the 16 MiB budget, a third evicts
    for k in 0..3u64 {
        let got = cache.get_or(([k, 0, 0, 0, 0], Vec::new(), (0, Vec::new())), || vec![vec![k as f64; column]]);
        assert_eq!(got[0][0], k as f64);
        assert!(cache.entries.lock().unwrap().bytes <= ColumnCache::BUDGET_BYTES);
    }
    // The most recent is kept (not computed again).
    let again = cache.get_or(([2, 0, 0, 0, 0], Vec::new(), (0, Vec::new())), || panic!("recomputed"));
    assert_eq!(again[0][0], 2.0);
}

#[test]
fn a_term_keeps_its_columns_across_transforms_it_does_not_see() {
    use super::super::causes::{CoulombFriction, DeadZone, Hysteresis, StiffnessNonlinearity, TimeDelay};
    let causes: [&dyn CandidateCause; 5] = [&CoulombFriction, &DeadZone, &TimeDelay, &Hysteresis, &StiffnessNonlinearity];
    let model = Model { baseline: &BaselineModel::Polynomial(1), centre_rad: 0.0, middle_s: 0.0, friction_record: false, causes: &causes, held_out: Default::default(), columns: Default::default() };
    let (dead_zone, delay) = ((1, vec![1e-3f64.to_bits()], false), (2, vec![0.01f64.to_bits()], false));
    // A dead zone maps the spring's deflection: the arctan (the rate) and the loop (the
    // deflection) do not see it, the spring's curve does.
    assert_eq!(model.seen_by(&vec![dead_zone.clone()], 0), Vec::new());
    assert_eq!(model.seen_by(&vec![dead_zone.clone()], 3), Vec::new());
    assert_eq!(model.seen_by(&vec![dead_zone.clone()], 4), vec![dead_zone.clone()]);
    // A delay shifts every input: everyone sees it, and the dead zone before it too, since
    // the delay reads the spring's deflection the dead zone wrote.
    assert_eq!(model.seen_by(&vec![dead_zone.clone(), delay.clone()], 0), vec![dead_zone.clone(), delay.clone()]);
    assert_eq!(model.seen_by(&vec![delay.clone(), dead_zone.clone()], 0), vec![delay.clone()]);
}

fn part(t0: f64, d: &[f64], warm: &[f64]) -> Part {
    let t: Vec<f64> = (0..d.len()).map(|i| t0 + 0.01 * i as f64).collect();
    Part { warm: warm.to_vec(), lead: Default::default(), restarts: Vec::new(), t, d: d.to_vec(), v: vec![0.0; d.len()], tau: vec![0.0; d.len()], pivot: vec![0.0; d.len()], rep: Vec::new(), rate_edges: Vec::new(), bin_width_s: 0.01, dt: 0.01 }
}

fn loop_column(p: &Part) -> Vec<f64> {
    let zeros = vec![0.0; p.len()];
    let s = Samples { t_s: &p.t, deflection_rad: &p.d, velocity_rad_per_s: &p.v, elastic_rad: &p.d, pivot_mm: &p.pivot, repetition: &p.rep, history_rad: &p.warm, restarts: &p.restarts, model_nm: &zeros, rate_edges_rad_per_s: &p.rate_edges, bin_width_s: p.bin_width_s, record_middle_s: 0.0 };
    // A Dahl loop of 1 mrad, no dead band.
    super::super::causes::Hysteresis.columns(&[1e-3, 0.0, 1.0], &s).remove(0)
}

#[test]
fn a_delayed_part_reads_its_inputs_and_its_loop_as_the_whole_record_does() {
    // A part that starts inside the record is the record's slice: its delayed deflection
    // reads the samples before it (the lead), and a loop's state runs in from a history
    // delayed alike. Held at the part's first value, a 70 ms delay put its first 7 samples
    // where the joint had been before; with a raw history, the delayed part replayed the
    // delay's last stretch after it and the loop's state was off at the part's start.
    use super::super::causes::{Hysteresis, TimeDelay};
    use super::super::part::Lead;
    let causes: [&dyn CandidateCause; 2] = [&TimeDelay, &Hysteresis];
    let model = Model { baseline: &BaselineModel::Polynomial(1), centre_rad: 0.0, middle_s: 0.0, friction_record: false, causes: &causes, held_out: Default::default(), columns: Default::default() };
    let term = |cause, params: &[f64]| Term { cause, params: params.to_vec(), grids: Vec::new(), baseline: false };
    let spec = Spec { terms: vec![term(0, &[0.07]), term(1, &[1e-3, 0.0, 1.0])] };
    let w = 2.0 * std::f64::consts::PI * 0.5;
    let d: Vec<f64> = (0..600).map(|i| 5e-3 * (w * 0.01 * i as f64).sin()).collect();
    let v: Vec<f64> = (0..600).map(|i| 5e-3 * w * (w * 0.01 * i as f64).cos()).collect();
    let mut whole = part(0.0, &d, &[]);
    whole.v = v.clone();
    let start = 300;
    let mut slice = part(3.0, &d[start..], &d[..start]);
    slice.v = v[start..].to_vec();
    slice.lead = Lead { t: whole.t[..start].to_vec(), v: v[..start].to_vec() };
    let (all, own) = (model.design(&spec, &whole), model.design(&spec, &slice));
    for i in 0..slice.len() {
        let (x, y) = (all.inputs.deflection_rad[start + i], own.inputs.deflection_rad[i]);
        assert!((x - y).abs() < 1e-12, "sample {i}: deflection {y}, the record's {x}");
        let (x, y) = (all.cols[1][start + i], own.cols[1][i]);
        assert!((x - y).abs() < 1e-9, "sample {i}: loop {y}, the record's {x}");
    }
}

#[test]
fn a_piece_joined_after_another_starts_its_loop_from_its_own_history() {
    // Found on the blind generator: with the searches' samples taken in pieces over the
    // training part (`prepare::pieces`), a Dahl state carried from one piece's end into the
    // next piece as if the joint had jumped there, and five loops' limits moved outside 25 %.
    let rising: Vec<f64> = (0..50).map(|i| 1e-4 * i as f64).collect();
    let falling: Vec<f64> = (0..50).map(|i| 5e-3 - 1e-4 * i as f64).collect();
    // Before the falling piece the joint rose to 5 mrad: its loop starts at the upper limit.
    let before_falling: Vec<f64> = (0..60).map(|i| 1e-4 * i as f64 - 1e-3).collect();
    let (a, b) = (part(0.0, &rising, &[]), part(10.0, &falling, &before_falling));
    let joined = a.then(&b);
    let column = loop_column(&joined);
    let alone = loop_column(&b);
    for (i, (x, y)) in column[rising.len()..].iter().zip(&alone).enumerate() {
        assert!((x - y).abs() < 1e-12, "sample {i} of the second piece: {x} joined, {y} alone");
    }
    assert_eq!(&column[..rising.len()], &loop_column(&a)[..]);
}
