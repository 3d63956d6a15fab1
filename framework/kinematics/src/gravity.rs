//! Generalised gravity torques: what each joint must apply to hold a pose.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::Chain;

/// g [m/s^2] as eq. C.3 uses it (and Pinocchio's default model).
pub const STANDARD_GRAVITY_M_S2: f64 = 9.81;

/// Why a pose cannot be evaluated.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PoseError {
    /// The pose or output has the wrong number of joints.
    #[error("{what} has {got} values; the arm has {expected} movable joints")]
    Length {
        /// `pose` or `output`.
        what: &'static str,
        /// The arm's movable joints.
        expected: usize,
        /// Given.
        got: usize,
    },
    /// A joint position that is not a number: never used as a value.
    #[error("joint `{dof}`: position {value} is not finite")]
    NotFinite {
        /// The joint.
        dof: String,
        /// The value.
        value: f64,
    },
}

/// The gravity torques of a [`Chain`]; holds its working memory so that [`Gravity::torques`]
/// allocates nothing (the control cycle calls it).
#[derive(Clone, Debug)]
pub struct Gravity {
    chain: Chain,
    gravity_m_s2: Vector3<f64>,
    /// World pose of each body's frame.
    world: Vec<Isometry3<f64>>,
    /// Mass [kg] and first moment [kg m] (world) of each body with everything it carries.
    subtree_mass: Vec<f64>,
    subtree_moment: Vec<Vector3<f64>>,
}

impl Gravity {
    /// Gravity along -z of the root frame at [`STANDARD_GRAVITY_M_S2`].
    pub fn new(chain: Chain) -> Gravity {
        Gravity::downward(chain, STANDARD_GRAVITY_M_S2)
    }

    /// Gravity of `g_m_s2` along -z of the root frame (the arm description's `gravity_m_s2`).
    ///
    /// ```
    /// # use jointctl_kinematics::{Chain, Gravity};
    /// # let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let mut mars = Gravity::downward(chain, 3.71);
    /// let mut tau = [0.0; 7];
    /// mars.torques(&[0.0, 0.7854, 0.0, 0.0, 0.0, 0.0, 0.0], &mut tau).unwrap();
    /// assert!((tau[1] + 28.482 * 3.71 / 9.81).abs() < 1e-2);
    /// ```
    pub fn downward(chain: Chain, g_m_s2: f64) -> Gravity {
        Gravity::with_gravity(chain, Vector3::new(0.0, 0.0, -g_m_s2))
    }

    /// Gravity as a vector in the root frame [m/s^2] (a rover on a slope: tilted).
    pub fn with_gravity(chain: Chain, gravity_m_s2: Vector3<f64>) -> Gravity {
        let n = chain.bodies().len();
        Gravity { chain, gravity_m_s2, world: vec![Isometry3::identity(); n], subtree_mass: vec![0.0; n], subtree_moment: vec![Vector3::zeros(); n] }
    }

    /// The arm.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// The holding torque of every movable joint [Nm] at the pose `q_rad` (in
    /// [`Chain::dof_names`] order) into `out`: `g(q) = dV/dq`, the torque a joint applies so
    /// that gravity does not move the arm (Pinocchio's `computeGeneralizedGravity`, figure C.2's
    /// sign). Compensation adds it to the joint torque reference.
    ///
    /// For each movable joint at world position `p` with world axis `a`: the bodies it carries
    /// have mass `M` and first moment `S = sum m_i c_i`; gravity's torque about `p` is
    /// `(S - M p) x g`, and the joint holds it with `-a . ((S - M p) x g)`.
    ///
    /// ```
    /// # use jointctl_kinematics::{Chain, Gravity};
    /// let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let mut gravity = Gravity::new(chain);
    /// let mut tau = [0.0; 7];
    /// gravity.torques(&[0.0; 7], &mut tau).unwrap();
    /// assert!(tau.iter().all(|t| t.abs() < 1e-12), "upright: nothing to hold");
    /// assert!(gravity.torques(&[f64::NAN; 7], &mut tau).is_err());
    /// ```
    pub fn torques(&mut self, q_rad: &[f64], out: &mut [f64]) -> Result<(), PoseError> {
        let n = self.chain.dof_names().len();
        if q_rad.len() != n {
            return Err(PoseError::Length { what: "pose", expected: n, got: q_rad.len() });
        }
        if out.len() != n {
            return Err(PoseError::Length { what: "output", expected: n, got: out.len() });
        }
        if let Some(i) = q_rad.iter().position(|q| !q.is_finite()) {
            return Err(PoseError::NotFinite { dof: self.chain.dof_names()[i].clone(), value: q_rad[i] });
        }
        let bodies = self.chain.bodies();
        // Forward: each body's frame in the world (parents come first).
        for (i, b) in bodies.iter().enumerate() {
            self.world[i] = match (&b.parent, &b.joint) {
                (Some(p), Some(j)) => {
                    let motion = j.dof.map_or(Isometry3::identity(), |k| Isometry3::from_parts(Default::default(), UnitQuaternion::from_axis_angle(&j.axis, q_rad[k])));
                    self.world[*p] * j.origin * motion
                }
                _ => Isometry3::identity(),
            };
            self.subtree_mass[i] = b.mass_kg;
            self.subtree_moment[i] = b.mass_kg * (self.world[i] * nalgebra::Point3::from(b.com_m)).coords;
        }
        // Backward: what each body carries.
        for i in (1..bodies.len()).rev() {
            if let Some(p) = bodies[i].parent {
                self.subtree_mass[p] += self.subtree_mass[i];
                let m = self.subtree_moment[i];
                self.subtree_moment[p] += m;
            }
        }
        for (i, b) in bodies.iter().enumerate() {
            let Some((k, axis)) = b.joint.as_ref().and_then(|j| Some((j.dof?, j.axis))) else { continue };
            let frame = self.world[i];
            let p = frame.translation.vector;
            let a = frame.rotation * axis.into_inner();
            let lever = self.subtree_moment[i] - self.subtree_mass[i] * p;
            // (+ 0.0: a torque of -0.0 prints as 0.)
            out[k] = -a.dot(&lever.cross(&self.gravity_m_s2)) + 0.0;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_link() -> Chain {
        // Two 1 kg points: 0.3 m up the first pitch joint, and 0.2 m past a second pitch joint
        // 0.5 m up.
        Chain::from_urdf_str(
            r#"<robot name="two">
          <link name="base"/>
          <link name="a"><inertial><origin xyz="0 0 0.3"/><mass value="1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
          <link name="b"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
          <joint name="j1" type="continuous"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/></joint>
          <joint name="j2" type="continuous"><origin xyz="0 0 0.5"/><parent link="a"/><child link="b"/><axis xyz="0 1 0"/></joint>
        </robot>"#,
        )
        .unwrap()
    }

    #[test]
    fn a_two_link_arm_holds_what_it_carries_by_hand() {
        let mut g = Gravity::new(two_link());
        let (q1, q2) = (0.4f64, -0.9f64);
        let mut tau = [0.0; 2];
        g.torques(&[q1, q2], &mut tau).unwrap();
        // Horizontal lever arms: sin of the absolute angle.
        let x_a = 0.3 * q1.sin();
        let x_b = 0.5 * q1.sin() + 0.2 * (q1 + q2).sin();
        assert!((tau[0] + 9.81 * (x_a + x_b)).abs() < 1e-12, "{tau:?}");
        assert!((tau[1] + 9.81 * 0.2 * (q1 + q2).sin()).abs() < 1e-12, "{tau:?}");
    }

    #[test]
    fn the_torque_is_the_potential_energys_slope() {
        // g(q) = dV/dq, checked by a central difference of V = -m g . c summed over the bodies.
        let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
        let mut g = Gravity::new(chain);
        let q = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9, 0.5];
        let mut tau = [0.0; 7];
        g.torques(&q, &mut tau).unwrap();
        let potential = |g: &mut Gravity, q: &[f64]| {
            let mut t = [0.0; 7];
            g.torques(q, &mut t).unwrap();
            // The root body carries everything: V = -g . S_root.
            -g.gravity_m_s2.dot(&g.subtree_moment[0])
        };
        for k in 0..7 {
            let h = 1e-6;
            let (mut a, mut b) = (q, q);
            a[k] += h;
            b[k] -= h;
            let slope = (potential(&mut g, &a) - potential(&mut g, &b)) / (2.0 * h);
            assert!((slope - tau[k]).abs() < 1e-6, "q{}: dV/dq {slope} vs g(q) {}", k + 1, tau[k]);
        }
    }

    #[test]
    fn a_bad_pose_is_an_error_that_names_the_joint() {
        let mut g = Gravity::new(two_link());
        let mut tau = [0.0; 2];
        assert_eq!(g.torques(&[0.0, f64::INFINITY], &mut tau), Err(PoseError::NotFinite { dof: "j2".into(), value: f64::INFINITY }));
        assert_eq!(g.torques(&[0.0], &mut tau), Err(PoseError::Length { what: "pose", expected: 2, got: 1 }));
    }
}
