//! Drawing a set-up: the physics (stiffness, baseline friction, each cause's model and size) and
//! the test program for a request, redrawn while an effect cannot be shown clearly.

use super::request::{Cause, Flags, Request};
use super::sizing::{Grid, output_noise_factor, rms, solve_scale};
use super::timeline::Timeline;
use super::{ENC14_STEP, ENC17_STEP, LINEAR_STEP, RATES_HZ, RIG_MEDIAN_DT_S, Setup};
use crate::excitation;
use crate::model::{
    self, DeadZone, Delay, Friction, HystModel, Hysteresis, Offset, Physics, Spring, Vibration,
};
use crate::rng::Rng;
use std::collections::BTreeMap;
use std::f64::consts::PI;

fn pick_model(rng: &mut Rng, cause: Cause, forced: &Option<String>, flags: &Flags) -> String {
    if let Some(m) = forced {
        return m.clone();
    }
    let m = match cause {
        Cause::Hysteresis => {
            let u = rng.uniform();
            if u < 0.4 {
                "bouc_wen"
            } else if u < 0.8 {
                "lugre"
            } else {
                "dahl"
            }
        }
        Cause::Offset if flags.reps > 1 => {
            if rng.chance(0.7) {
                "per_repetition"
            } else {
                "drift"
            }
        }
        Cause::Offset => {
            if rng.chance(0.5) {
                "constant"
            } else {
                "drift"
            }
        }
        other => rng.pick(other.models()),
    };
    m.to_string()
}

/// Why a set-up could not be drawn.
#[derive(Debug)]
pub enum SetupError {
    /// The request is impossible (e.g. vibration with bin20).
    Invalid(String),
    /// This draw cannot show the effect clearly; another draw (other motion) may.
    Unreachable(String),
}

/// Draws a set-up, redrawing (other motion, other physics) while an effect cannot be made
/// clearly present.
pub fn draw_setup_retrying(rng: &mut Rng, req: &Request) -> Result<Setup, String> {
    let mut last = String::new();
    for attempt in 0..20 {
        match draw_setup(&mut rng.fork(&format!("setup{attempt}")), req) {
            Ok(s) => return Ok(s),
            Err(SetupError::Invalid(e)) => return Err(e),
            Err(SetupError::Unreachable(e)) => last = e,
        }
    }
    Err(format!(
        "no set-up shows the effects clearly after 20 draws: {last}"
    ))
}

/// Draws the physics and program for a request, with each hidden effect sized so its
/// unexplained RMS is a drawn multiple (1.5-8) of the output noise std.
pub fn draw_setup(rng: &mut Rng, req: &Request) -> Result<Setup, SetupError> {
    let f = &req.flags;
    let causes: Vec<Cause> = req.causes.iter().map(|(c, _)| *c).collect();
    if f.friction_position
        && causes
            .iter()
            .any(|c| !matches!(c, Cause::Viscous | Cause::Offset))
    {
        return Err(SetupError::Invalid(
            "friction_position records only take viscous_friction or sensor_offset".into(),
        ));
    }
    if f.bin20 && causes.contains(&Cause::Vibration) {
        return Err(SetupError::Invalid(
            "vibration (8-60 Hz) cannot be seen below 0.4 x 20 Hz: not with bin20".into(),
        ));
    }

    // Logging rates.
    let fs_hz = if f.bin20 || f.long || req.for_device {
        *rng.pick(&RATES_HZ[3..])
    } else {
        *rng.pick(&RATES_HZ)
    };
    let mut irregular_dt_s = rng.range(1.0e-3, 2.0e-3);
    if f.rig_logger {
        irregular_dt_s = rng.range(RIG_MEDIAN_DT_S.0, RIG_MEDIAN_DT_S.1);
    }
    let fs_eff = if f.irregular {
        1.0 / irregular_dt_s
    } else {
        fs_hz
    };

    // Program duration (per repetition).
    let reps = f.reps.max(1);
    let program_s = if let Some(d) = req.duration_s {
        d
    } else if f.long {
        let n = rng.log_range(1.0e5, 1.0e6);
        (n / fs_eff / reps as f64).clamp(60.0, 600.0)
    } else if reps > 1 {
        rng.range(15.0, 35.0)
    } else {
        rng.range(20.0, 60.0)
    };
    let program = excitation::random_program(rng, program_s);

    // Encoder.
    let encoder_step = if f.linear {
        LINEAR_STEP
    } else if f.encoder17 {
        ENC17_STEP
    } else {
        ENC14_STEP
    };
    let flicker_counts = if f.linear { rng.range(0.35, 0.7) } else { 0.0 };

    // Stiffness and amplitude.
    // `span_target`: the spring torque span [Nm] the motion should produce (3-30 Nm).
    let (k, amp_rad, centre_rad, v_max, span_target) = if f.friction_position {
        let centre = rng.sign() * rng.range(0.2, 0.8);
        (0.0, rng.range(0.3, 1.0), centre, 2.0, 0.0)
    } else if f.linear {
        // A stiff spring and a span of a few mrad (hundreds to thousands of counts).
        let k = rng.log_range(1000.0, 3000.0);
        let amp = rng.range(1.2e-3, 4.0e-3);
        let span = (2.0 * k * amp).clamp(3.0, 30.0);
        (k, span / (2.0 * k), 0.0, 3.0, span)
    } else {
        let span = rng.log_range(3.0, 30.0);
        // At least 40 counts of half span, so the deflection is not a few quantisation levels.
        let amp_min = 40.0 * encoder_step;
        let k_max = (span / (2.0 * amp_min)).clamp(30.0, 3000.0);
        let k = rng.log_range(30.0, k_max.max(30.0 + 1e-9));
        let amp = (span / (2.0 * k)).min(0.6);
        (k, amp, 0.0, 3.0, span)
    };

    // A provisional set-up to render the motion.
    let mut setup = Setup {
        physics: Physics {
            k,
            friction: Friction::Atan { ka: 0.0, kb: 1.0 },
            viscous_b: 0.0,
            hysteresis: None,
            dead_zone: None,
            spring: Spring::Linear,
            delay: None,
            vibration: None,
            offset: None,
        },
        program,
        amp_rad,
        centre_rad,
        v_max,
        fs_hz,
        irregular_dt_s,
        noise_white: 0.0,
        noise_col: 0.0,
        noise_tau_s: 0.1,
        encoder_step,
        flicker_counts,
        causes: causes.clone(),
        models: BTreeMap::new(),
        span_nm: 0.0,
        friction_position: f.friction_position,
    };
    let mut tl = Timeline::build(&setup, &[1.0], &[]);
    // Segments use 45-100 % of the amplitude and fast ones are velocity-limited: scale the
    // amplitude until the spring torque really spans the target.
    if span_target > 0.0 {
        for _ in 0..4 {
            let (lo, hi) = tl
                .phi
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
            let actual = k * (hi - lo);
            if actual <= 0.0 || (actual / span_target - 1.0).abs() < 0.03 {
                break;
            }
            let amp_new = (setup.amp_rad * span_target / actual).min(0.6);
            if (amp_new / setup.amp_rad - 1.0).abs() < 1e-3 {
                break;
            }
            setup.amp_rad = amp_new;
            tl = Timeline::build(&setup, &[1.0], &[]);
        }
    }
    let phi_max = tl
        .phi
        .iter()
        .fold(0.0_f64, |m, p| m.max((p - centre_rad).abs()));
    let (pmin, pmax) = tl
        .phi
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
    let v_rms = rms(&tl.vel).max(1e-6);
    let v_peak = tl.vel.iter().fold(0.0_f64, |m, v| m.max(v.abs())).max(1e-6);

    // Baseline friction.
    let spring_span = k * (pmax - pmin);
    let baseline = req.baseline.clone().unwrap_or_else(|| {
        if f.friction_position {
            if rng.chance(0.5) { "lugre" } else { "stribeck" }.to_string()
        } else if rng.chance(0.25) {
            "stribeck".to_string()
        } else {
            "atan".to_string()
        }
    });
    let friction = if f.friction_position {
        let fc = rng.range(0.5, 5.0);
        let fs = fc * rng.range(1.1, 1.7);
        let vs = rng.log_range(0.01, 0.1);
        match baseline.as_str() {
            "lugre" => {
                // Stiff bristles: presliding well below one encoder count's worth of motion
                // matters little; this is friction, not a hidden hysteresis.
                let x_p = rng.log_range(1e-4, 5e-4);
                let sigma0 = fs / x_p;
                let sigma1 = rng.range(0.02, 0.1) * fc / v_rms;
                Friction::LuGre {
                    fc,
                    fs,
                    vs,
                    sigma0,
                    sigma1,
                }
            }
            "stribeck" => Friction::Stribeck { fc, fs, vs },
            other => {
                return Err(SetupError::Invalid(format!(
                    "baseline `{other}` not for friction_position"
                )));
            }
        }
    } else {
        let ka = rng.range(0.01, 0.05) * spring_span;
        let kb = rng.log_range(20.0, 200.0);
        match baseline.as_str() {
            "atan" => Friction::Atan { ka, kb },
            "stribeck" => {
                let fc = ka * PI / 2.0 * rng.range(0.8, 1.2);
                Friction::Stribeck {
                    fc,
                    fs: fc * rng.range(1.1, 1.8),
                    vs: rng.log_range(0.005, 0.05).min(0.3 * v_rms),
                }
            }
            other => {
                return Err(SetupError::Invalid(format!(
                    "baseline `{other}` not for deflection records"
                )));
            }
        }
    };
    setup.physics.friction = friction;
    let base_ph = setup.physics.clone();
    let grid = Grid::new(&base_ph, &tl);
    let span = if f.friction_position {
        let (a, b) = grid
            .fric
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
        b - a
    } else {
        spring_span
    };
    setup.span_nm = span;

    // Noise: white, sometimes plus a little coloured noise.
    let noise_frac = rng.log_range(0.005, 0.05);
    let (col_rel, noise_tau) = if rng.chance(0.3) {
        (rng.range(0.2, 0.5), rng.log_range(0.02, 0.2))
    } else {
        (0.0, 0.1)
    };
    let out_factor = output_noise_factor(fs_hz, col_rel, noise_tau, f.bin20);
    let mut noise_out = noise_frac * span * out_factor;

    // Model shapes (everything but the size).
    let models: Vec<String> = req
        .causes
        .iter()
        .map(|(c, m)| pick_model(rng, *c, m, f))
        .collect();
    for ((c, _), m) in req.causes.iter().zip(&models) {
        setup.models.insert(c.name().to_string(), m.clone());
    }
    let f_max = setup.program.max_freq_hz();
    let steady = setup.program.steady_freqs_hz();
    let mut hyst_shape: Option<HystModel> = None;
    let mut dz_ramp_rel = 0.0;
    let mut delay_lp_share = 0.0;
    let mut offset_shape = Offset {
        scale_nm: 0.0,
        rep_rel: Vec::new(),
        drift_rel: 0.0,
    };
    let mut offset_sign = 1.0_f64;
    let mut vib = Vibration {
        freq_hz: 0.0,
        amp_nm: 0.0,
        phase_rad: 0.0,
    };
    for ((c, _), m) in req.causes.iter().zip(&models) {
        match c {
            Cause::Hysteresis => {
                let x_h = rng.range(0.08, 0.4) * phi_max;
                hyst_shape = Some(match m.as_str() {
                    "dahl" => HystModel::Dahl { x_h },
                    "bouc_wen" => HystModel::BoucWen {
                        x_h,
                        n: rng.range(1.0, 2.5),
                        beta_frac: rng.range(0.55, 0.9),
                    },
                    _ => HystModel::LuGre {
                        x_h,
                        fs_ratio: rng.range(1.1, 1.6),
                        vs: rng.range(0.05, 0.3) * v_rms,
                        c1: rng.range(0.02, 0.15) / v_rms,
                    },
                });
            }
            Cause::DeadZone => {
                dz_ramp_rel = if m == "ramp" {
                    rng.range(0.3, 1.0)
                } else {
                    0.0
                };
            }
            Cause::Delay => {
                delay_lp_share = if m == "lowpass" {
                    rng.range(0.4, 1.0)
                } else {
                    0.0
                };
            }
            Cause::Offset => {
                offset_sign = rng.sign();
                if m == "drift" {
                    offset_shape.drift_rel = rng.sign() * rng.range(0.2, 0.8);
                }
                if m == "per_repetition" {
                    offset_shape.rep_rel = (0..reps.max(2)).map(|_| rng.range(-0.4, 0.4)).collect();
                    offset_shape.rep_rel[0] = 0.0;
                }
            }
            Cause::Vibration => {
                let fs_out = fs_eff;
                let lo = 8.0_f64.max(2.5 * f_max);
                let hi = 60.0_f64.min(0.4 * fs_out);
                if hi <= lo + 1.0 {
                    return Err(SetupError::Unreachable(format!(
                        "no room for a vibration between {lo:.1} and {hi:.1} Hz"
                    )));
                }
                let mut fv = rng.range(lo, hi);
                for _ in 0..200 {
                    let near = steady.iter().any(|&fm| {
                        (1..=20).any(|n| (fv - n as f64 * fm).abs() < (0.3_f64).max(0.02 * fv))
                    });
                    if !near {
                        break;
                    }
                    fv = rng.range(lo, hi);
                }
                vib = Vibration {
                    freq_hz: fv,
                    amp_nm: 0.0,
                    phase_rad: rng.range(0.0, 2.0 * PI),
                };
            }
            _ => {}
        }
    }
    let hyst_unit_grid: Option<Vec<f64>> = hyst_shape.as_ref().map(|m| {
        let u = model::simulate_hysteresis_unit(m, &tl.phi, tl.dt_s);
        grid.idx.iter().map(|&i| u[i]).collect()
    });

    // Each cause as "physics with this cause at scale s" and its largest sensible scale.
    let lp_tau_max = 1.0 / (2.0 * PI * 4.0 * f_max);
    let delay_cap = 0.1_f64.min(0.25 / f_max);
    let stiff_cap = |m: &str| -> f64 {
        match m {
            "cubic_softening" => 0.9 * k / (3.0 * phi_max * phi_max),
            "cubic_hardening" => 2.0 * k / (phi_max * phi_max),
            "tanh_softening" => 1.32 / phi_max,
            _ => 1.76 / phi_max,
        }
    };
    let apply = |ph: &mut Physics, c: Cause, m: &str, s: f64| match c {
        Cause::Viscous => ph.viscous_b = s,
        Cause::Hysteresis => {
            ph.hysteresis = Some(Hysteresis {
                force: s,
                model: hyst_shape.clone().expect("hysteresis shape"),
            })
        }
        Cause::DeadZone => {
            ph.dead_zone = Some(DeadZone {
                width: s,
                ramp: dz_ramp_rel * s,
            })
        }
        Cause::Stiffness => {
            ph.spring = match m {
                "cubic_softening" => Spring::Cubic { k3: -s },
                "cubic_hardening" => Spring::Cubic { k3: s },
                "tanh_softening" => Spring::TanhSoft {
                    phi_s: 1.0 / s.max(1e-300),
                },
                _ => Spring::SinhHard {
                    phi_s: 1.0 / s.max(1e-300),
                },
            }
        }
        Cause::Offset => {
            let mut o = offset_shape.clone();
            o.scale_nm = offset_sign * s;
            ph.offset = Some(o);
        }
        Cause::Delay => {
            let lp = (delay_lp_share * s).min(lp_tau_max);
            ph.delay = Some(Delay {
                transport_s: s - lp,
                lp_tau_s: lp,
            });
        }
        Cause::Vibration => {
            let mut v = vib.clone();
            v.amp_nm = s;
            ph.vibration = Some(v);
        }
    };
    let cap = |c: Cause, m: &str| -> f64 {
        match c {
            Cause::Viscous => {
                if f.friction_position {
                    2.0 * span / v_peak
                } else {
                    0.5 * span / v_peak
                }
            }
            Cause::Hysteresis => 0.25 * span,
            Cause::DeadZone => 0.45 * phi_max,
            Cause::Stiffness => stiff_cap(m),
            Cause::Offset => 0.5 * span,
            Cause::Delay => delay_cap,
            Cause::Vibration => 0.3 * span,
        }
    };
    let single_rms = |c: Cause, m: &str, s: f64| -> f64 {
        let mut ph = base_ph.clone();
        apply(&mut ph, c, m, s);
        let u = if c == Cause::Hysteresis {
            hyst_unit_grid.as_deref()
        } else {
            None
        };
        grid.unexplained(&grid.contribution(&ph, &tl, u))
    };

    // Noise low enough that every effect can reach its target within its cap, but not below
    // 0.5 % of the span.
    // Pairs a little smaller each, so that together they stay within about 10 x noise.
    let ratio_hi = if causes.len() > 1 { 6.0 } else { 8.0 };
    let mut targets: Vec<f64> = causes
        .iter()
        .map(|_| req.ratio.unwrap_or_else(|| rng.log_range(1.5, ratio_hi)))
        .collect();
    let cap_rms: Vec<f64> = causes
        .iter()
        .zip(&models)
        .map(|(c, m)| single_rms(*c, m, cap(*c, m)))
        .collect();
    for (t, r) in targets.iter().zip(&cap_rms) {
        noise_out = noise_out.min(0.85 * r / t);
    }
    noise_out = noise_out.max(0.005 * span * out_factor);
    for ((t, r), c) in targets.iter_mut().zip(&cap_rms).zip(&causes) {
        *t = t.min(0.9 * r / noise_out);
        // Not clearly present even at its largest sensible size over the lowest noise: this
        // motion does not show the effect (e.g. a delay on slow motion looks like friction).
        if *t < 1.2 {
            return Err(SetupError::Unreachable(format!(
                "{} reaches only {:.2} x noise",
                c.name(),
                t
            )));
        }
    }

    // Size each cause alone; for pairs, check they do not cancel (e.g. a delay acts like a
    // negative viscous term) and redraw the targets if they do.
    let mut ph = base_ph.clone();
    for attempt in 0..8 {
        ph = base_ph.clone();
        let mut each = Vec::new();
        for ((c, m), t) in causes.iter().zip(&models).zip(&targets) {
            let (s, r) = solve_scale(|s| single_rms(*c, m, s), t * noise_out, cap(*c, m));
            apply(&mut ph, *c, m, s);
            each.push(r);
        }
        if causes.len() < 2 {
            break;
        }
        let both = grid.unexplained(&grid.contribution(&ph, &tl, hyst_unit_grid.as_deref()));
        let max_each = each.iter().cloned().fold(0.0, f64::max);
        if both >= 0.6 * max_each || attempt == 7 {
            break;
        }
        for (t, r) in targets.iter_mut().zip(&cap_rms) {
            *t = rng.log_range(1.5, ratio_hi).min(0.9 * r / noise_out);
        }
    }
    setup.physics = ph;
    setup.noise_white = noise_out / out_factor;
    setup.noise_col = col_rel * setup.noise_white;
    setup.noise_tau_s = noise_tau;
    Ok(setup)
}
