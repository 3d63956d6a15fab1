//! Logging: one record of a set-up as a data logger writes it (sample times, noise, quantised
//! deflection, epoch or restarting time, 20 Hz bins) and its answer.

use super::answer::{Truth, answer_params, only_cause};
use super::request::{Cause, Flags};
use super::sizing::{rms, std_dev, unexplained_rms};
use super::timeline::{Timeline, sensor_at, states};
use super::{EPOCH_BASE_US, Setup};
use crate::model;
use crate::rng::Rng;
use crate::{Answer, Case, Drive};
use std::collections::BTreeMap;

/// How an irregular logger spaces its samples: besides a median step jittered by ±25 %, a
/// fraction of long steps and a few stalls per run.
struct Jitter {
    long_frac: f64,
    /// Range of the long steps [µs].
    long_us: (f64, f64),
    /// Number of stalls per run (inclusive range) and their extra length [µs].
    gaps: (usize, usize),
    gap_us: (f64, f64),
}

/// The generic irregular logger: 2.5 % of steps 3-15 ms (99th percentile ~10 ms), 1-3 stalls
/// of 0.1-0.3 s per run.
const LOGGER: Jitter = Jitter {
    long_frac: 0.025,
    long_us: (3.0e3, 15.0e3),
    gaps: (1, 3),
    gap_us: (0.1e6, 0.3e6),
};

/// The series-elastic-actuator rig's logger (`rig550`): 2.5 % of steps 3-23 ms (99th
/// percentile ~15 ms), a stall of 0.05-0.26 s in about half of the runs.
const RIG: Jitter = Jitter {
    long_frac: 0.025,
    long_us: (3.0e3, 23.0e3),
    gaps: (0, 1),
    gap_us: (0.05e6, 0.26e6),
};

/// Physical sample times [µs] of one repetition window.
fn sample_times_us(
    rng: &mut Rng,
    setup: &Setup,
    flags: &Flags,
    start_us: i64,
    end_us: i64,
) -> Vec<i64> {
    let mut out = Vec::new();
    if !flags.irregular {
        let step = (1e6 / setup.fs_hz).round() as i64;
        let mut t = start_us;
        while t < end_us {
            out.push(t);
            t += step;
        }
        return out;
    }
    // Irregular: jittered median step, occasional long steps and a few gaps (a logger that
    // stalled).
    let j = if flags.rig_logger { &RIG } else { &LOGGER };
    let d0 = setup.irregular_dt_s * 1e6;
    let n_gaps = rng.int(j.gaps.0, j.gaps.1);
    let mut gaps: Vec<i64> = (0..n_gaps)
        .map(|_| start_us + ((end_us - start_us) as f64 * rng.range(0.1, 0.9)) as i64)
        .collect();
    gaps.sort();
    let mut gi = 0;
    let mut t = start_us;
    while t < end_us {
        out.push(t);
        let mut step = if rng.chance(j.long_frac) {
            rng.range(j.long_us.0, j.long_us.1)
        } else {
            d0 * (1.0 + rng.range(-0.25, 0.25))
        };
        if gi < gaps.len() && t >= gaps[gi] {
            step += rng.range(j.gap_us.0, j.gap_us.1);
            gi += 1;
        }
        t += step.round().max(50.0) as i64;
    }
    out
}

fn median(mut x: Vec<f64>) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.sort_by(|a, b| a.total_cmp(b));
    x[x.len() / 2]
}

/// Everything needed to describe the output besides the data.
pub struct Meta {
    pub name: String,
    pub device: Option<String>,
    pub effect: String,
    pub seed: u64,
}

/// Logs one record of a set-up with the given flags.
pub fn record(setup: &Setup, flags: &Flags, rng: &mut Rng, meta: Meta) -> (Case, Truth) {
    let ph = &setup.physics;
    let reps = flags.reps.max(1);
    let scales: Vec<f64> = if flags.amplitudes.is_empty() {
        (0..reps)
            .map(|r| if r == 0 { 1.0 } else { rng.range(0.96, 1.04) })
            .collect()
    } else {
        // A drive repeats its amplitude more closely than a hand (±1 %).
        let mut v = Vec::new();
        for a in &flags.amplitudes {
            v.extend((0..reps).map(|r| {
                if r == 0 {
                    *a
                } else {
                    a * rng.range(0.99, 1.01)
                }
            }));
        }
        v
    };
    let gaps: Vec<f64> = (1..scales.len())
        .map(|_| (rng.range(3.0, 10.0) * 1e3).round() / 1e3)
        .collect();
    let tl = Timeline::build(setup, &scales, &gaps);
    let st = states(ph, &tl);
    let base_ph = ph.baseline();
    let base_st = states(&base_ph, &tl);

    // Sample times, repetition by repetition.
    let mut t_us: Vec<i64> = Vec::new();
    let mut rep_of: Vec<usize> = Vec::new();
    for (r, &(a, b)) in tl.reps.iter().enumerate() {
        let ts = sample_times_us(
            rng,
            setup,
            flags,
            (a * 1e6).round() as i64,
            (b * 1e6).round() as i64,
        );
        rep_of.extend(std::iter::repeat_n(r, ts.len()));
        t_us.extend(ts);
    }
    let n = t_us.len();
    let t_phys: Vec<f64> = t_us.iter().map(|&u| u as f64 * 1e-6).collect();

    // Truth at the samples.
    let mut tr = Truth {
        rep: rep_of.clone(),
        ..Default::default()
    };
    for i in 0..n {
        let t = t_phys[i];
        let phi = model::interp(&tl.phi, tl.dt_s, t);
        let v = model::interp(&tl.vel, tl.dt_s, t);
        let fr = ph.friction.memoryless(v) + model::interp(&base_st.fric_state, tl.dt_s, t);
        tr.phi.push(phi);
        tr.vel.push(v);
        tr.friction.push(fr);
        tr.tau_base.push(ph.k * phi + fr);
        tr.tau_clean.push(sensor_at(ph, &tl, &st, t, rep_of[i]));
    }

    // Noise: white plus Ornstein-Uhlenbeck (exact update for any time step).
    let mut col = 0.0;
    let mut t_prev = t_phys.first().copied().unwrap_or(0.0);
    if setup.noise_col > 0.0 {
        col = setup.noise_col * rng.normal();
    }
    for &t in &t_phys {
        if setup.noise_col > 0.0 {
            let a = (-(t - t_prev) / setup.noise_tau_s).exp();
            col = col * a + setup.noise_col * (1.0 - a * a).sqrt() * rng.normal();
        }
        t_prev = t;
        tr.noise.push(setup.noise_white * rng.normal() + col);
    }

    // Measurements: quantised deflection (with flicker for the linear encoder), noisy torque.
    let q = setup.encoder_step;
    let mut defl: Vec<f64> = tr
        .phi
        .iter()
        .map(|p| {
            let d = if setup.flicker_counts > 0.0 {
                setup.flicker_counts * rng.normal()
            } else {
                0.0
            };
            (p / q + d).round() * q
        })
        .collect();
    let mut torque: Vec<f64> = tr
        .tau_clean
        .iter()
        .zip(&tr.noise)
        .map(|(a, b)| a + b)
        .collect();

    // Output time column.
    let epoch_us = if flags.epoch {
        EPOCH_BASE_US + (rng.range(0.0, 5.0e7) * 1e6) as i64
    } else {
        0
    };
    let rep_start_us: Vec<i64> = tl
        .reps
        .iter()
        .map(|(a, _)| (a * 1e6).round() as i64)
        .collect();
    let mut t_out: Vec<f64> = (0..n)
        .map(|i| {
            let rel = if flags.restart {
                t_us[i] - rep_start_us[rep_of[i]]
            } else {
                t_us[i]
            };
            (epoch_us + rel) as f64 / 1e6
        })
        .collect();

    // Per-sample sensor offset truth (for the reported mean).
    let total = tl.total_s();
    let mut offs: Vec<f64> = (0..n)
        .map(|i| {
            ph.offset
                .as_ref()
                .map_or(0.0, |o| o.at(t_phys[i], rep_of[i], 0.5 * total, total))
        })
        .collect();

    // Per-cause clean torque (for the per-cause ratio), evaluated at the samples.
    let mut each_clean: Vec<(Cause, Vec<f64>)> = Vec::new();
    if setup.causes.len() > 1 {
        for &c in &setup.causes {
            let only = only_cause(ph, c);
            let st1 = states(&only, &tl);
            let v: Vec<f64> = (0..n)
                .map(|i| sensor_at(&only, &tl, &st1, t_phys[i], rep_of[i]))
                .collect();
            each_clean.push((c, v));
        }
    }

    // Bin-average to 20 Hz (per repetition, 50 ms bins of physical time).
    let mut fs_out = if flags.irregular {
        let d: Vec<f64> = (1..n)
            .filter(|&i| rep_of[i] == rep_of[i - 1])
            .map(|i| t_phys[i] - t_phys[i - 1])
            .collect();
        1.0 / median(d)
    } else {
        setup.fs_hz
    };
    if flags.bin20 {
        let key = |i: usize| -> (usize, i64) {
            (rep_of[i], (t_us[i] - rep_start_us[rep_of[i]]) / 50_000)
        };
        let mut groups: Vec<(usize, usize)> = Vec::new(); // [start, end) of each bin
        let mut s = 0;
        for i in 1..=n {
            if i == n || key(i) != key(s) {
                groups.push((s, i));
                s = i;
            }
        }
        let avg = |x: &[f64]| -> Vec<f64> {
            groups
                .iter()
                .map(|&(a, b)| x[a..b].iter().sum::<f64>() / (b - a) as f64)
                .collect()
        };
        t_out = avg(&t_out);
        defl = avg(&defl);
        torque = avg(&torque);
        offs = avg(&offs);
        tr.phi = avg(&tr.phi);
        tr.vel = avg(&tr.vel);
        tr.tau_clean = avg(&tr.tau_clean);
        tr.tau_base = avg(&tr.tau_base);
        tr.friction = avg(&tr.friction);
        tr.noise = avg(&tr.noise);
        tr.rep = groups.iter().map(|&(a, _)| rep_of[a]).collect();
        for (_, v) in each_clean.iter_mut() {
            *v = avg(v);
        }
        fs_out = 20.0;
    }
    if flags.epoch {
        // Printed with microseconds; make the truth match what a reader will see.
        t_out.iter_mut().for_each(|t| *t = (*t * 1e6).round() / 1e6);
    }

    // The answer.
    let noise = std_dev(&tr.noise);
    let contrib: Vec<f64> = tr
        .tau_clean
        .iter()
        .zip(&tr.tau_base)
        .map(|(a, b)| a - b)
        .collect();
    let regs: [&[f64]; 2] = [&tr.phi, &tr.friction];
    let unexpl = unexplained_rms(&contrib, &regs);
    let each = level_ratios(setup, &tr, &contrib, &each_clean, noise, |_| true);
    let drive = (!flags.amplitudes.is_empty()).then(|| Drive {
        scales: flags.amplitudes.clone(),
        amplitudes_rad: flags.amplitudes.iter().map(|a| a * setup.amp_rad).collect(),
        runs_per_level: reps,
        effect_rms_each: (0..flags.amplitudes.len())
            .map(|l| level_ratios(setup, &tr, &contrib, &each_clean, noise, |r| r / reps == l))
            .collect(),
    });
    let params = answer_params(setup, &tr, &offs, total);
    let tau_max = tr.tau_clean.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let level = {
        let comp = flags.complications() + usize::from(ph.friction.name() != "atan");
        if setup.causes.len() >= 2 || comp >= 2 {
            3
        } else if comp == 1 {
            2
        } else {
            1
        }
    };
    let answer = Answer {
        effect: meta.effect,
        params,
        noise,
        fs: fs_out,
        k: ph.k,
        tau_max,
        variant: flags.name(),
        device: meta.device,
        level,
        effect_rms_over_noise: unexpl / noise,
        effect_rms_raw_over_noise: rms(&contrib) / noise,
        effect_rms_each: each,
        models: setup.models.clone(),
        friction_model: ph.friction.name().to_string(),
        friction: ph.friction.params(),
        encoder_step: q,
        quantised: !flags.bin20,
        torque_span: setup.span_nm,
        duration: t_phys.last().copied().unwrap_or(0.0) - t_phys.first().copied().unwrap_or(0.0),
        n_samples: t_out.len(),
        repetitions: scales.len(),
        drive,
        noise_white_raw: setup.noise_white,
        seed: meta.seed,
    };
    (
        Case {
            name: meta.name,
            t: t_out,
            deflection: defl,
            torque,
            answer,
        },
        tr,
    )
}

/// `effect_rms_each` over the samples of the runs `runs` selects alone (their own projection on
/// the baseline's regressors): how clearly each cause shows over the record, or at one drive
/// amplitude.
fn level_ratios(
    setup: &Setup,
    tr: &Truth,
    contrib: &[f64],
    each_clean: &[(Cause, Vec<f64>)],
    noise: f64,
    runs: impl Fn(usize) -> bool,
) -> BTreeMap<String, f64> {
    let idx: Vec<usize> = (0..tr.rep.len()).filter(|&i| runs(tr.rep[i])).collect();
    let sub = |x: &[f64]| -> Vec<f64> { idx.iter().map(|&i| x[i]).collect() };
    let (phi, fric) = (sub(&tr.phi), sub(&tr.friction));
    let regs: [&[f64]; 2] = [&phi, &fric];
    let mut m = BTreeMap::new();
    if setup.causes.len() == 1 {
        m.insert(
            setup.causes[0].name().to_string(),
            unexplained_rms(&sub(contrib), &regs) / noise,
        );
    }
    for (c, v) in each_clean {
        let cc: Vec<f64> = idx.iter().map(|&i| v[i] - tr.tau_base[i]).collect();
        m.insert(c.name().to_string(), unexplained_rms(&cc, &regs) / noise);
    }
    m
}
