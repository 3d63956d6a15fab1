//! Timeline: the continuous motion of a whole record (all repetitions and the pauses between),
//! the states simulated on its fine grid and the noise-free sensor torque.

use super::{FINE_DT_S, Setup};
use crate::excitation;
use crate::model::{self, Physics};

pub struct Timeline {
    pub dt_s: f64,
    pub phi: Vec<f64>,
    pub vel: Vec<f64>,
    /// [start, end) of each repetition [s].
    pub reps: Vec<(f64, f64)>,
}

impl Timeline {
    /// `gaps_s[i]` is the pause after repetition i; `scales[i]` the amplitude factor of rep i
    /// (a person never repeats a test exactly).
    pub fn build(setup: &Setup, scales: &[f64], gaps_s: &[f64]) -> Timeline {
        let dt = FINE_DT_S;
        let one = excitation::render(&setup.program, dt, setup.amp_rad, setup.v_max);
        let mut phi = Vec::new();
        let mut reps = Vec::new();
        for (i, s) in scales.iter().enumerate() {
            let start = phi.len() as f64 * dt;
            phi.extend(one.iter().map(|x| x * s));
            reps.push((start, phi.len() as f64 * dt));
            if let Some(g) = gaps_s.get(i) {
                let n = (g / dt).round() as usize;
                phi.extend(std::iter::repeat_n(0.0, n));
            }
        }
        let mut phi = excitation::smooth(&phi, dt, 0.02);
        phi.iter_mut().for_each(|x| *x += setup.centre_rad);
        let vel = excitation::velocity(&phi, dt);
        Timeline {
            dt_s: dt,
            phi,
            vel,
            reps,
        }
    }

    pub fn total_s(&self) -> f64 {
        self.phi.len() as f64 * self.dt_s
    }
}

/// Fine-grid states of a physics on a timeline.
pub(super) struct States {
    /// Stateful torque: hysteresis + LuGre friction [Nm].
    state: Vec<f64>,
    /// LuGre baseline friction alone (zeros otherwise).
    pub(super) fric_state: Vec<f64>,
    /// Low-pass filtered element torque, when the sensor has a low-pass.
    lp: Option<Vec<f64>>,
}

pub(super) fn states(ph: &Physics, tl: &Timeline) -> States {
    let fric_state = model::simulate_lugre_friction(&ph.friction, &tl.phi, tl.dt_s);
    let mut state = fric_state.clone();
    if let Some(h) = &ph.hysteresis {
        let u = model::simulate_hysteresis_unit(&h.model, &tl.phi, tl.dt_s);
        state
            .iter_mut()
            .zip(&u)
            .for_each(|(s, u)| *s += h.force * u);
    }
    let lp = match &ph.delay {
        Some(d) if d.lp_tau_s > 0.0 => {
            let elem: Vec<f64> = (0..tl.phi.len())
                .map(|i| ph.memoryless(tl.phi[i], tl.vel[i]) + state[i])
                .collect();
            Some(model::lowpass(&elem, tl.dt_s, d.lp_tau_s))
        }
        _ => None,
    };
    States {
        state,
        fric_state,
        lp,
    }
}

/// Noise-free sensor torque at physical time t (repetition rep).
pub(super) fn sensor_at(ph: &Physics, tl: &Timeline, st: &States, t: f64, rep: usize) -> f64 {
    let transport = ph.delay.as_ref().map_or(0.0, |d| d.transport_s);
    let td = t - transport;
    let elem = match &st.lp {
        Some(lp) => model::interp(lp, tl.dt_s, td),
        None => {
            let phi = model::interp(&tl.phi, tl.dt_s, td);
            let v = model::interp(&tl.vel, tl.dt_s, td);
            ph.memoryless(phi, v) + model::interp(&st.state, tl.dt_s, td)
        }
    };
    let total = tl.total_s();
    elem + ph.additive(t, rep, 0.5 * total, total)
}
