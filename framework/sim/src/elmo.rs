//! The simulated ELMO drive (thesis section 3.2, figure 3.4): a trapezoidal motion profile from
//! the maximal acceleration and velocity, whose deceleration starts in time to stop at the
//! set-point without overshoot, followed by a PID on the motor encoder, driving the motor and
//! gearbox inertia through a torque (current) limit, against the load and the arctan gear
//! friction of eq. 3.5.

use jointctl_config::ElmoConfig;
use jointctl_models::transmission::eq_3_5_friction;

/// The trapezoidal profile: a reference position and velocity that reach the target with at most
/// `v_max` and `a_max`, braking as late as possible but never past the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    /// Reference position [rad].
    pub position: f64,
    /// Reference velocity [rad/s].
    pub velocity: f64,
}

impl Profile {
    /// Advances the profile by `dt` towards `target`.
    ///
    /// ```
    /// use jointctl_sim::elmo::Profile;
    /// let mut p = Profile { position: 0.0, velocity: 0.0 };
    /// let mut max_v: f64 = 0.0;
    /// for _ in 0..4000 {
    ///     p.step(1.0, 0.5, 2.0, 0.001);
    ///     assert!(p.position <= 1.0 + 1e-12, "no overshoot");
    ///     max_v = max_v.max(p.velocity);
    /// }
    /// assert!((p.position - 1.0).abs() < 1e-9 && max_v <= 0.5 + 1e-12);
    /// ```
    pub fn step(&mut self, target: f64, v_max: f64, a_max: f64, dt: f64) {
        let error = target - self.position;
        let dir = error.signum();
        let stopping = self.velocity * self.velocity / (2.0 * a_max);
        let moving_towards = self.velocity * dir > 0.0;
        let v_goal = if error.abs() < 1e-12 {
            0.0
        } else if moving_towards && stopping >= error.abs() {
            // Deceleration, started in time: the velocity that stops exactly at the target.
            dir * (2.0 * a_max * error.abs()).sqrt().min(v_max)
        } else {
            dir * v_max
        };
        let dv = (v_goal - self.velocity).clamp(-a_max * dt, a_max * dt);
        let v_new = self.velocity + dv;
        let mut p_new = self.position + 0.5 * (self.velocity + v_new) * dt;
        // Land exactly on the target rather than chatter around it.
        if (target - p_new) * dir <= 0.0 || (error.abs() < a_max * dt * dt && v_new.abs() < a_max * dt) {
            p_new = target;
            self.velocity = 0.0;
        } else {
            self.velocity = v_new;
        }
        self.position = p_new;
    }
}

/// One drive: profile, PID, motor + gearbox, friction.
#[derive(Clone, Copy, Debug)]
pub struct ElmoDrive {
    cfg: ElmoConfig,
    /// The motion profile.
    pub profile: Profile,
    target: f64,
    integral: f64,
    /// Gearbox output position [rad].
    pub position: f64,
    /// Gearbox output velocity [rad/s].
    pub velocity: f64,
    /// Torque the drive applied in the last step [Nm].
    pub torque: f64,
    /// Software position limits (0x607D) [rad]: a target outside is held at the nearer limit,
    /// as a CiA 402 drive does (the config's `setpoint_window_rad`).
    pub position_limits_rad: Option<[f64; 2]>,
}

impl ElmoDrive {
    /// A drive at rest at `position`, holding it.
    pub fn new(cfg: ElmoConfig, position: f64) -> Self {
        ElmoDrive { cfg, profile: Profile { position, velocity: 0.0 }, target: position, integral: 0.0, position, velocity: 0.0, torque: 0.0, position_limits_rad: None }
    }

    /// The drive with software position limits [rad] (`None`: none).
    pub fn with_position_limits(self, position_limits_rad: Option<[f64; 2]>) -> Self {
        ElmoDrive { position_limits_rad, ..self }
    }

    /// The drive's settings.
    pub fn config(&self) -> ElmoConfig {
        self.cfg
    }

    /// A new set-point (the ELMO replans its profile from where the profile is).
    pub fn set_target(&mut self, target: f64) {
        if target.is_finite() {
            self.target = match self.position_limits_rad {
                Some([lo, hi]) => target.clamp(lo, hi),
                None => target,
            };
        }
    }

    /// The current set-point.
    pub fn target(&self) -> f64 {
        self.target
    }

    /// One integration step of `dt` against a load torque [Nm] (reaction of what the drive
    /// moves), semi-implicit Euler.
    pub fn step(&mut self, load_nm: f64, dt: f64) {
        let c = self.cfg;
        let v_before = self.profile.velocity;
        self.profile.step(self.target, c.max_velocity_rad_s, c.max_acceleration_rad_s2, dt);
        // Section 3.2: the ELMO's loops carry feed-forward terms; here the profile's acceleration
        // through the inertia, so that the PID only corrects what the model misses.
        let feed_forward = c.inertia_kgm2 * (self.profile.velocity - v_before) / dt;
        let e = self.profile.position - self.position;
        let unsaturated = feed_forward + c.kp * e + c.ki * (self.integral + e * dt) + c.kd * (self.profile.velocity - self.velocity);
        let u = unsaturated.clamp(-c.torque_limit_nm, c.torque_limit_nm);
        if u == unsaturated {
            self.integral += e * dt;
        }
        let friction = eq_3_5_friction(c.friction_ka_nm, c.friction_kb_s_per_rad, self.velocity);
        let accel = (u - load_nm - friction) / c.inertia_kgm2;
        self.velocity += accel * dt;
        self.position += self.velocity * dt;
        self.torque = u;
    }
}
