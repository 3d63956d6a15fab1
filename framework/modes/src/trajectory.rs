/// Most points one trajectory command carries.
pub const MAX_TRAJECTORY_POINTS: usize = 64;

/// One trajectory point: time from the trajectory's start [s], position [rad] and optional
/// velocity [rad/s] (NaN when not given).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryPoint {
    /// Time since the trajectory started [s].
    pub time_s: f64,
    /// Joint position [rad].
    pub position_rad: f64,
    /// Joint velocity [rad/s], or NaN.
    pub velocity_rad_s: f64,
}

/// Why points do not make a [`Trajectory`].
///
/// ```
/// use jointctl_modes::{Trajectory, TrajectoryError};
/// assert_eq!(Trajectory::new(&[]).unwrap_err(), TrajectoryError::PointCount { got: 0 });
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TrajectoryError {
    /// Fewer than 1 or more than [`MAX_TRAJECTORY_POINTS`] points.
    #[error("a trajectory has 1 to {MAX_TRAJECTORY_POINTS} points, got {got}")]
    PointCount {
        /// Points given.
        got: usize,
    },
    /// A time or position is not finite, or a velocity is infinite.
    #[error("point {index}: time and position must be finite")]
    NotFinite {
        /// The point's index.
        index: usize,
    },
    /// A point's time is not after its predecessor's.
    #[error("point {index}: times must increase strictly")]
    TimesNotIncreasing {
        /// The point's index.
        index: usize,
    },
}

/// A time-stamped joint trajectory (the thesis' MoveIt! path) in fixed storage, interpolated
/// each cycle: cubic Hermite where velocities are given, linear otherwise; before the first
/// point it holds the first, after the last it holds the last.
///
/// ```
/// use jointctl_modes::{Trajectory, TrajectoryPoint};
/// let p = |t, q| TrajectoryPoint { time_s: t, position_rad: q, velocity_rad_s: f64::NAN };
/// let tr = Trajectory::new(&[p(0.0, 0.0), p(1.0, 1.0), p(2.0, 0.5)]).unwrap();
/// assert_eq!(tr.sample(0.5), (0.5, 1.0));
/// assert_eq!(tr.sample(1.5), (0.75, -0.5));
/// assert_eq!(tr.sample(9.0), (0.5, 0.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trajectory {
    points: [TrajectoryPoint; MAX_TRAJECTORY_POINTS],
    len: usize,
}

impl Trajectory {
    /// A trajectory from 1 to [`MAX_TRAJECTORY_POINTS`] points with strictly increasing,
    /// finite times and finite positions.
    pub fn new(points: &[TrajectoryPoint]) -> Result<Self, TrajectoryError> {
        if points.is_empty() || points.len() > MAX_TRAJECTORY_POINTS {
            return Err(TrajectoryError::PointCount { got: points.len() });
        }
        for (i, p) in points.iter().enumerate() {
            if !(p.time_s.is_finite() && p.position_rad.is_finite()) || p.velocity_rad_s.is_infinite() {
                return Err(TrajectoryError::NotFinite { index: i });
            }
            if i > 0 && p.time_s <= points[i - 1].time_s {
                return Err(TrajectoryError::TimesNotIncreasing { index: i });
            }
        }
        let mut storage = [TrajectoryPoint { time_s: 0.0, position_rad: 0.0, velocity_rad_s: f64::NAN }; MAX_TRAJECTORY_POINTS];
        storage[..points.len()].copy_from_slice(points);
        Ok(Trajectory { points: storage, len: points.len() })
    }

    /// The points.
    pub fn points(&self) -> &[TrajectoryPoint] {
        &self.points[..self.len]
    }

    /// Duration [s] from the first to the last point.
    pub fn duration_s(&self) -> f64 {
        self.points[self.len - 1].time_s
    }

    /// (position, velocity) at `t_s` since the start.
    pub fn sample(&self, t_s: f64) -> (f64, f64) {
        let pts = self.points();
        if t_s <= pts[0].time_s {
            return (pts[0].position_rad, 0.0);
        }
        let last = pts[pts.len() - 1];
        if t_s >= last.time_s {
            return (last.position_rad, 0.0);
        }
        let i = pts.partition_point(|p| p.time_s <= t_s) - 1;
        let (a, b) = (pts[i], pts[i + 1]);
        let h = b.time_s - a.time_s;
        let s = (t_s - a.time_s) / h;
        if a.velocity_rad_s.is_nan() || b.velocity_rad_s.is_nan() {
            let v = (b.position_rad - a.position_rad) / h;
            return (a.position_rad + s * (b.position_rad - a.position_rad), v);
        }
        // Cubic Hermite.
        let (s2, s3) = (s * s, s * s * s);
        let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
        let q = h00 * a.position_rad + h10 * h * a.velocity_rad_s + h01 * b.position_rad + h11 * h * b.velocity_rad_s;
        let (d00, d10, d01, d11) = (6.0 * s2 - 6.0 * s, 3.0 * s2 - 4.0 * s + 1.0, -6.0 * s2 + 6.0 * s, 3.0 * s2 - 2.0 * s);
        let v = (d00 * a.position_rad + d01 * b.position_rad) / h + d10 * a.velocity_rad_s + d11 * b.velocity_rad_s;
        (q, v)
    }
}
