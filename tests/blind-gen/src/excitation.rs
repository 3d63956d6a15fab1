//! The true deflection (or position) trajectory: what a person moving the joint output by hand
//! during a characterisation experiment produces. A `Program` is a list of segments (holds,
//! chirps, triangles, multi-sines, filtered random motion, tapered sines); `render` turns it into
//! a smooth signal on a fine time grid.
//!
//! Every segment starts and ends at zero motion (relative to the rest position) with zero
//! velocity or a ramp, so segments can be chained in any order; a final 20 ms moving average
//! removes the corners a human hand would not make (triangle tips, ramp starts), which keeps the
//! velocity continuous.

use crate::rng::Rng;
use std::f64::consts::PI;

#[derive(Clone, Debug)]
pub enum Segment {
    /// At rest (zero motion) for `dur_s`.
    Rest { dur_s: f64 },
    /// Move to `level` (fraction of the amplitude) with a raised-cosine ramp, hold, move back.
    Hold {
        level: f64,
        ramp_s: f64,
        hold_s: f64,
    },
    /// Linear frequency sweep from `f0_hz` to `f1_hz`, with a tapered envelope.
    Chirp {
        f0_hz: f64,
        f1_hz: f64,
        dur_s: f64,
        amp: f64,
    },
    /// Constant-speed back-and-forth; the amplitude grows over the first cycle and decays over
    /// the last one.
    Triangle {
        freq_hz: f64,
        cycles: usize,
        amp: f64,
    },
    /// Sum of sines with random phases, tapered ends.
    MultiSine {
        freqs_hz: Vec<f64>,
        weights: Vec<f64>,
        phases: Vec<f64>,
        dur_s: f64,
        amp: f64,
    },
    /// Low-pass filtered Gaussian noise (four cascaded first-order stages), tapered ends.
    FilteredRandom {
        cutoff_hz: f64,
        dur_s: f64,
        amp: f64,
        seed: u64,
    },
    /// A single sine, integer number of cycles, raised-cosine taper over `taper_cycles`.
    Sine {
        freq_hz: f64,
        cycles: usize,
        taper_cycles: f64,
        amp: f64,
    },
}

impl Segment {
    pub fn duration_s(&self) -> f64 {
        match self {
            Segment::Rest { dur_s } => *dur_s,
            Segment::Hold { ramp_s, hold_s, .. } => 2.0 * ramp_s + hold_s,
            Segment::Chirp { dur_s, .. } => *dur_s,
            Segment::Triangle {
                freq_hz, cycles, ..
            } => *cycles as f64 / freq_hz,
            Segment::MultiSine { dur_s, .. } => *dur_s,
            Segment::FilteredRandom { dur_s, .. } => *dur_s,
            Segment::Sine {
                freq_hz, cycles, ..
            } => *cycles as f64 / freq_hz,
        }
    }

    pub fn kind(&self) -> &'static str {
        match self {
            Segment::Rest { .. } => "rest",
            Segment::Hold { .. } => "hold",
            Segment::Chirp { .. } => "chirp",
            Segment::Triangle { .. } => "triangle",
            Segment::MultiSine { .. } => "multisine",
            Segment::FilteredRandom { .. } => "filtered_random",
            Segment::Sine { .. } => "sine",
        }
    }
}

/// One test: what the experimenter does, independent of the joint's physics.
#[derive(Clone, Debug)]
pub struct Program {
    pub segments: Vec<Segment>,
}

impl Program {
    pub fn duration_s(&self) -> f64 {
        self.segments.iter().map(Segment::duration_s).sum()
    }

    /// Frequencies of the periodic parts of the motion (their harmonics make spectral lines a
    /// vibration must not sit on).
    pub fn steady_freqs_hz(&self) -> Vec<f64> {
        let mut out = Vec::new();
        for s in &self.segments {
            match s {
                Segment::Triangle { freq_hz, .. } | Segment::Sine { freq_hz, .. } => {
                    out.push(*freq_hz)
                }
                Segment::MultiSine { freqs_hz, .. } => out.extend_from_slice(freqs_hz),
                _ => {}
            }
        }
        out
    }

    /// The highest frequency with significant motion content.
    pub fn max_freq_hz(&self) -> f64 {
        let mut m: f64 = 0.1;
        for s in &self.segments {
            let f = match s {
                Segment::Chirp { f1_hz, .. } => *f1_hz,
                Segment::Triangle { freq_hz, .. } => 3.0 * freq_hz,
                Segment::Sine { freq_hz, .. } => *freq_hz,
                Segment::MultiSine { freqs_hz, .. } => freqs_hz.iter().cloned().fold(0.0, f64::max),
                Segment::FilteredRandom { cutoff_hz, .. } => 2.0 * cutoff_hz,
                Segment::Hold { ramp_s, .. } => 0.5 / ramp_s,
                Segment::Rest { .. } => 0.0,
            };
            m = m.max(f);
        }
        m
    }

    pub fn kinds(&self) -> Vec<&'static str> {
        self.segments.iter().map(Segment::kind).collect()
    }
}

/// Draws a random test of about `total_s` seconds: rest, a random sequence of motion segments,
/// rest. Frequencies 0.05-5 Hz.
pub fn random_program(rng: &mut Rng, total_s: f64) -> Program {
    let mut segs = vec![Segment::Rest {
        dur_s: rng.range(1.0, 3.0),
    }];
    let end_rest = rng.range(1.0, 2.5);
    let mut used = segs[0].duration_s() + end_rest;
    let mut last_kind = "";
    while total_s - used > 4.0 {
        let rem = total_s - used;
        let seg = random_segment(rng, rem.min(30.0));
        let Some(seg) = seg else { continue };
        // Two identical kinds in a row add little; a person alternates tests.
        if seg.kind() == last_kind && rng.chance(0.6) {
            continue;
        }
        last_kind = seg.kind();
        used += seg.duration_s();
        segs.push(seg);
    }
    // Fill the remainder with rest so the duration is close to the request.
    segs.push(Segment::Rest {
        dur_s: end_rest + (total_s - used).max(0.0),
    });
    Program { segments: segs }
}

/// One random segment that fits in `budget_s` seconds (at least 4 s), or None to draw again.
fn random_segment(rng: &mut Rng, budget_s: f64) -> Option<Segment> {
    let amp = rng.range(0.45, 1.0);
    let dur = rng.range(4.0_f64.min(budget_s), budget_s);
    match rng.index(6) {
        0 => {
            let ramp_s = rng.range(0.4, 2.0);
            let hold_s = (dur - 2.0 * ramp_s).max(0.5);
            if 2.0 * ramp_s + hold_s > budget_s {
                return None;
            }
            Some(Segment::Hold {
                level: rng.sign() * rng.range(0.2, 0.95),
                ramp_s,
                hold_s,
            })
        }
        1 => {
            if dur < 6.0 {
                return None;
            }
            let f0 = rng.log_range(0.05_f64.max(2.0 / dur), 0.5);
            let f1 = rng.log_range(1.0_f64.max(2.0 * f0), 5.0);
            Some(Segment::Chirp {
                f0_hz: f0,
                f1_hz: f1,
                dur_s: dur,
                amp,
            })
        }
        2 => {
            let f = rng.log_range(0.1, 2.0);
            let cycles = ((dur * f).floor() as usize).clamp(2, 20);
            if cycles as f64 / f > budget_s {
                return None;
            }
            Some(Segment::Triangle {
                freq_hz: f,
                cycles,
                amp,
            })
        }
        3 => {
            if dur < 6.0 {
                return None;
            }
            let n = rng.int(3, 8);
            let f_lo = rng.log_range(0.05_f64.max(2.0 / dur), 0.5);
            let f_hi = (f_lo * rng.log_range(3.0, 30.0)).min(5.0);
            let mut freqs: Vec<f64> = (0..n).map(|_| rng.log_range(f_lo, f_hi)).collect();
            freqs.sort_by(|a, b| a.total_cmp(b));
            // Slower components larger, as in hand motion (roughly constant velocity content).
            let weights = freqs.iter().map(|f| (f_lo / f).sqrt()).collect();
            let phases = (0..n).map(|_| rng.range(0.0, 2.0 * PI)).collect();
            Some(Segment::MultiSine {
                freqs_hz: freqs,
                weights,
                phases,
                dur_s: dur,
                amp,
            })
        }
        4 => Some(Segment::FilteredRandom {
            cutoff_hz: rng.log_range(0.2, 3.0),
            dur_s: dur.max(5.0).min(budget_s),
            amp,
            seed: rng.next_u64(),
        }),
        _ => {
            let mut f = rng.log_range(0.05, 5.0);
            // At least three cycles (taper in, one full, taper out).
            if 3.0 / f > budget_s {
                f = 3.0 / budget_s * rng.range(1.0, 1.5);
            }
            let cycles = ((dur * f).floor() as usize).clamp(3, 100);
            if cycles as f64 / f > budget_s {
                return None;
            }
            let taper_cycles = if cycles >= 6 {
                rng.range(1.0, 2.0)
            } else {
                1.0
            };
            Some(Segment::Sine {
                freq_hz: f,
                cycles,
                taper_cycles,
                amp,
            })
        }
    }
}

/// Raised-cosine ramp 0 -> 1 for x in [0, 1].
fn rc(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    0.5 - 0.5 * (PI * x).cos()
}

/// Tukey-like window: raised-cosine rise over `taper_s`, flat, raised-cosine fall.
fn taper(t: f64, dur: f64, taper_s: f64) -> f64 {
    let taper_s = taper_s.min(0.5 * dur).max(1e-9);
    rc(t / taper_s) * rc((dur - t) / taper_s)
}

fn peak_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

fn peak_rate(x: &[f64], dt: f64) -> f64 {
    x.windows(2)
        .fold(0.0, |m, w| m.max((w[1] - w[0]).abs() / dt))
}

/// Scales `x` down (never up) so its peak velocity is at most `v_max`.
fn cap_velocity(x: &mut [f64], dt: f64, v_max: f64) {
    let pr = peak_rate(x, dt);
    if pr > v_max {
        let s = v_max / pr;
        x.iter_mut().for_each(|v| *v *= s);
    }
}

/// Renders one segment (zero at both ends) with peak amplitude `amp_rad * seg.amp`.
fn render_segment(seg: &Segment, dt: f64, amp_rad: f64, v_max: f64) -> Vec<f64> {
    let n = (seg.duration_s() / dt).round().max(1.0) as usize;
    let time = |i: usize| i as f64 * dt;
    let mut x = vec![0.0; n];
    match seg {
        Segment::Rest { .. } => {}
        Segment::Hold {
            level,
            ramp_s,
            hold_s,
        } => {
            // Slow the ramp rather than lower the level if the hand would be too fast.
            let lvl = level * amp_rad;
            let ramp = ramp_s.max(PI * lvl.abs() / (2.0 * v_max));
            let scale = ramp_s / ramp; // keep the total duration: shrink the level instead
            let lvl = lvl * scale.min(1.0);
            for (i, xi) in x.iter_mut().enumerate() {
                let t = time(i);
                let up = rc(t / ramp_s);
                let down = rc((ramp_s + hold_s + ramp_s - t) / ramp_s);
                *xi = lvl * up.min(down);
            }
        }
        Segment::Chirp {
            f0_hz,
            f1_hz,
            dur_s,
            amp,
        } => {
            let a = amp * amp_rad;
            let rate = (f1_hz - f0_hz) / dur_s;
            for (i, xi) in x.iter_mut().enumerate() {
                let t = time(i);
                let f = f0_hz + rate * t;
                let phase = 2.0 * PI * (f0_hz * t + 0.5 * rate * t * t);
                // Hand motion: faster oscillations are smaller (velocity limit).
                let env = a.min(v_max / (2.0 * PI * f));
                *xi = env * taper(t, *dur_s, 0.12 * dur_s) * phase.sin();
            }
            cap_velocity(&mut x, dt, v_max);
        }
        Segment::Triangle {
            freq_hz,
            cycles,
            amp,
        } => {
            // 5 rather than 4: the growing envelope adds to the triangle's own slope.
            let a = (amp * amp_rad).min(v_max / (5.0 * freq_hz));
            let period = 1.0 / freq_hz;
            let total = *cycles as f64 * period;
            for (i, xi) in x.iter_mut().enumerate() {
                let t = time(i);
                let p = (t / period).fract();
                let tri = if p < 0.25 {
                    4.0 * p
                } else if p < 0.75 {
                    2.0 - 4.0 * p
                } else {
                    4.0 * p - 4.0
                };
                let env = (t / period).min((total - t) / period).clamp(0.0, 1.0);
                *xi = a * env * tri;
            }
        }
        Segment::MultiSine {
            freqs_hz,
            weights,
            phases,
            dur_s,
            amp,
        } => {
            for (i, xi) in x.iter_mut().enumerate() {
                let t = time(i);
                let s: f64 = freqs_hz
                    .iter()
                    .zip(weights)
                    .zip(phases)
                    .map(|((f, w), p)| w * (2.0 * PI * f * t + p).sin())
                    .sum();
                *xi = s * taper(t, *dur_s, (0.15 * dur_s).min(4.0));
            }
            let pk = peak_abs(&x).max(1e-300);
            let a = amp * amp_rad / pk;
            x.iter_mut().for_each(|v| *v *= a);
            cap_velocity(&mut x, dt, v_max);
        }
        Segment::FilteredRandom {
            cutoff_hz,
            dur_s,
            amp,
            seed,
        } => {
            let mut r = Rng::new(*seed);
            let tau = 1.0 / (2.0 * PI * cutoff_hz);
            let a = (-dt / tau).exp();
            // Piecewise-constant white input at 100 Hz, then four first-order stages (smooth).
            let hold_n = ((0.01 / dt).round() as usize).max(1);
            let mut st = [0.0_f64; 4];
            let mut u = 0.0;
            // Warm the filter up so the output is stationary from the start.
            let warm = (5.0 * tau / dt) as usize + hold_n;
            for i in 0..(warm + n) {
                if i % hold_n == 0 {
                    u = r.normal();
                }
                st[0] = a * st[0] + (1.0 - a) * u;
                for k in 1..4 {
                    st[k] = a * st[k] + (1.0 - a) * st[k - 1];
                }
                if i >= warm {
                    x[i - warm] = st[3];
                }
            }
            let mean = x.iter().sum::<f64>() / n as f64;
            for (i, xi) in x.iter_mut().enumerate() {
                *xi = (*xi - mean) * taper(time(i), *dur_s, (0.15 * dur_s).min(3.0));
            }
            let pk = peak_abs(&x).max(1e-300);
            let s = amp * amp_rad / pk;
            x.iter_mut().for_each(|v| *v *= s);
            cap_velocity(&mut x, dt, v_max);
        }
        Segment::Sine {
            freq_hz,
            cycles,
            taper_cycles,
            amp,
        } => {
            // 1.3: margin for the taper's own slope.
            let a = (amp * amp_rad).min(v_max / (1.3 * 2.0 * PI * freq_hz));
            let period = 1.0 / freq_hz;
            let total = *cycles as f64 * period;
            for (i, xi) in x.iter_mut().enumerate() {
                let t = time(i);
                *xi = a * taper(t, total, taper_cycles * period) * (2.0 * PI * freq_hz * t).sin();
            }
        }
    }
    x
}

/// Renders a program on a grid of step `dt_s`: motion around zero with peak about `amp_rad`,
/// peak velocity about `v_max` at most.
pub fn render(program: &Program, dt_s: f64, amp_rad: f64, v_max: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for seg in &program.segments {
        out.extend(render_segment(seg, dt_s, amp_rad, v_max));
    }
    out
}

/// Centred moving average over `window_s` (odd number of points), shrinking at the ends.
/// Why: removes corners that would give velocity steps no hand produces.
pub fn smooth(x: &[f64], dt_s: f64, window_s: f64) -> Vec<f64> {
    let half = ((window_s / dt_s / 2.0).round() as usize).max(1);
    let n = x.len();
    let mut prefix = vec![0.0; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + x[i];
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// Central-difference velocity on the grid.
pub fn velocity(x: &[f64], dt_s: f64) -> Vec<f64> {
    let n = x.len();
    if n < 2 {
        return vec![0.0; n];
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(1);
            let hi = (i + 1).min(n - 1);
            (x[hi] - x[lo]) / ((hi - lo) as f64 * dt_s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_start_and_end_at_rest() {
        let mut rng = Rng::new(11);
        for _ in 0..30 {
            let p = random_program(&mut rng, 60.0);
            assert!((p.duration_s() - 60.0).abs() < 1.0, "{}", p.duration_s());
            let dt = 1e-3;
            let x = render(&p, dt, 0.3, 3.0);
            assert!(x[0].abs() < 1e-12 && x[x.len() - 1].abs() < 1e-9);
            assert!(peak_abs(&x) <= 0.3 + 1e-9);
            let s = smooth(&x, dt, 0.02);
            assert!(peak_rate(&s, dt) < 3.3, "{}", peak_rate(&s, dt));
        }
    }
}
