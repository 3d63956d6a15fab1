//! Rigid-body dynamics of a [`Chain`]: the torques a motion needs (inverse dynamics), the
//! joint-space mass matrix, and the accelerations torques cause (forward dynamics), with some
//! joints locked. The simulated free arm integrates the last; every call is allocation-free
//! after construction.
//!
//! The equation of motion is `M(q) q'' + C(q, q') q' + g(q) = tau`, with `g(q)` the holding
//! torque of [`crate::Gravity`] and `tau` what the joints apply (Pinocchio's convention:
//! `rnea`, `crba`, `aba`).

use nalgebra::{Isometry3, Matrix3, Point3, UnitQuaternion, Vector3};

use crate::{Chain, PoseError};

/// Why forward dynamics has no answer.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DynamicsError {
    /// The pose, a velocity or a torque is unusable.
    #[error(transparent)]
    Pose(#[from] PoseError),
    /// An armature that is negative or not a number.
    #[error("joint `{dof}`: armature {value} kg m^2 must be a finite number >= 0")]
    Armature {
        /// The joint.
        dof: String,
        /// The value given.
        value: f64,
    },
    /// A free joint that moves no inertia (a massless link and no armature): its acceleration
    /// is not defined.
    #[error("joint `{dof}` moves no inertia at this pose (mass matrix not positive definite): give its links mass or the joint an armature")]
    Singular {
        /// The joint.
        dof: String,
    },
}

/// The rigid-body dynamics of a [`Chain`] under a uniform gravity, with the working memory
/// that keeps [`Dynamics::inverse`], [`Dynamics::mass_matrix`] and [`Dynamics::forward`]
/// allocation-free.
#[derive(Clone, Debug)]
pub struct Dynamics {
    chain: Chain,
    gravity_m_s2: Vector3<f64>,
    /// Inertia added to each joint's diagonal of the mass matrix [kg m^2] (a gear's output
    /// flange, a rotor seen through its gear: Pinocchio's `model.armature`).
    armature_kgm2: Vec<f64>,
    // Per body, world frame: pose, joint axis (zero for fixed joints and the root), centre of
    // mass, inertia about it, angular velocity and acceleration, acceleration of the frame's
    // origin and of the centre of mass, and the force and moment (about the frame's origin) the
    // parent joint passes to it.
    world: Vec<Isometry3<f64>>,
    axis: Vec<Vector3<f64>>,
    com: Vec<Vector3<f64>>,
    inertia: Vec<Matrix3<f64>>,
    omega: Vec<Vector3<f64>>,
    alpha: Vec<Vector3<f64>>,
    acc_origin: Vec<Vector3<f64>>,
    force: Vec<Vector3<f64>>,
    moment: Vec<Vector3<f64>>,
    // Joint space: a unit vector, a zero vector, the mass matrix (row-major) and the free
    // joints' system.
    unit: Vec<f64>,
    zeros: Vec<f64>,
    mass: Vec<f64>,
    bias: Vec<f64>,
    free_index: Vec<usize>,
    system: Vec<f64>,
    rhs: Vec<f64>,
}

impl Dynamics {
    /// The chain under gravity of `g_m_s2` along -z of the root frame, no armature.
    ///
    /// ```
    /// use jointctl_kinematics::{Chain, Dynamics};
    /// let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let mut dynamics = Dynamics::downward(chain, 9.81);
    /// // Released at the appendix-C pose, the shoulder starts to fall forward (q2 grows).
    /// let q = [0.0, 0.7854, 0.0, 0.0, 0.0, 0.0, 0.0];
    /// let mut qdd = [0.0; 7];
    /// dynamics.forward(&q, &[0.0; 7], &[0.0; 7], &[false; 7], &mut qdd).unwrap();
    /// assert!(qdd[1] > 0.0);
    /// ```
    pub fn downward(chain: Chain, g_m_s2: f64) -> Dynamics {
        let bodies = chain.bodies().len();
        let n = chain.dof_names().len();
        let v3 = vec![Vector3::zeros(); bodies];
        Dynamics {
            gravity_m_s2: Vector3::new(0.0, 0.0, -g_m_s2),
            armature_kgm2: vec![0.0; n],
            world: vec![Isometry3::identity(); bodies],
            axis: v3.clone(),
            com: v3.clone(),
            inertia: vec![Matrix3::zeros(); bodies],
            omega: v3.clone(),
            alpha: v3.clone(),
            acc_origin: v3.clone(),
            force: v3.clone(),
            moment: v3,
            unit: vec![0.0; n],
            zeros: vec![0.0; n],
            mass: vec![0.0; n * n],
            bias: vec![0.0; n],
            free_index: Vec::with_capacity(n),
            system: vec![0.0; n * n],
            rhs: vec![0.0; n],
            chain,
        }
    }

    /// The same dynamics with an armature per joint [kg m^2], in [`Chain::dof_names`] order.
    ///
    /// ```
    /// # use jointctl_kinematics::{Chain, Dynamics};
    /// # let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let dynamics = Dynamics::downward(chain, 9.81).with_armature(&[0.1; 7]).unwrap();
    /// assert_eq!(dynamics.armature_kgm2(), [0.1; 7]);
    /// ```
    pub fn with_armature(mut self, armature_kgm2: &[f64]) -> Result<Dynamics, DynamicsError> {
        let n = self.armature_kgm2.len();
        if armature_kgm2.len() != n {
            return Err(PoseError::Length { what: "armature", expected: n, got: armature_kgm2.len() }.into());
        }
        if let Some(k) = armature_kgm2.iter().position(|a| !(a.is_finite() && *a >= 0.0)) {
            return Err(DynamicsError::Armature { dof: self.chain.dof_names()[k].clone(), value: armature_kgm2[k] });
        }
        self.armature_kgm2.copy_from_slice(armature_kgm2);
        Ok(self)
    }

    /// The arm.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// The armature per joint [kg m^2].
    pub fn armature_kgm2(&self) -> &[f64] {
        &self.armature_kgm2
    }

    fn check(&self, what: &'static str, v: &[f64]) -> Result<(), PoseError> {
        let n = self.chain.dof_names().len();
        if v.len() != n {
            return Err(PoseError::Length { what, expected: n, got: v.len() });
        }
        match v.iter().position(|x| !x.is_finite()) {
            Some(k) => Err(PoseError::NotFinite { dof: self.chain.dof_names()[k].clone(), value: v[k] }),
            None => Ok(()),
        }
    }

    /// Every body's world pose, joint axis, centre of mass and inertia at `q_rad`.
    fn place(&mut self, q_rad: &[f64]) {
        for (i, b) in self.chain.bodies().iter().enumerate() {
            let (frame, axis) = match (&b.parent, &b.joint) {
                (Some(p), Some(j)) => {
                    let motion = j.dof.map_or(Isometry3::identity(), |k| Isometry3::from_parts(Default::default(), UnitQuaternion::from_axis_angle(&j.axis, q_rad[k])));
                    let frame = self.world[*p] * j.origin * motion;
                    (frame, if j.dof.is_some() { frame.rotation * j.axis.into_inner() } else { Vector3::zeros() })
                }
                _ => (Isometry3::identity(), Vector3::zeros()),
            };
            self.world[i] = frame;
            self.axis[i] = axis;
            self.com[i] = (frame * Point3::from(b.com_m)).coords;
            let r = frame.rotation.to_rotation_matrix();
            self.inertia[i] = r.matrix() * b.inertia_kgm2 * r.matrix().transpose();
        }
    }

    /// One Newton-Euler pass at the placed pose: the joint torques `out` that give the
    /// velocities `qd` the accelerations `qdd`, with gravity or without. Armature not included.
    fn newton_euler(&mut self, qd: &[f64], qdd: &[f64], gravity: bool, out: &mut [f64]) {
        let bodies = self.chain.bodies();
        // Gravity as an upward acceleration of the root: every body then "falls" as it should.
        let root_acc = if gravity { -self.gravity_m_s2 } else { Vector3::zeros() };
        for (i, b) in bodies.iter().enumerate() {
            let o = self.world[i].translation.vector;
            let (omega, alpha, acc) = match (b.parent, b.joint.as_ref()) {
                (Some(p), Some(j)) => {
                    let (w, a, o_p) = (self.omega[p], self.alpha[p], self.world[p].translation.vector);
                    let r = o - o_p;
                    let acc = self.acc_origin[p] + a.cross(&r) + w.cross(&w.cross(&r));
                    match j.dof {
                        Some(k) => {
                            let s = self.axis[i];
                            (w + s * qd[k], a + s * qdd[k] + w.cross(&(s * qd[k])), acc)
                        }
                        None => (w, a, acc),
                    }
                }
                _ => (Vector3::zeros(), Vector3::zeros(), root_acc),
            };
            (self.omega[i], self.alpha[i], self.acc_origin[i]) = (omega, alpha, acc);
            let c = self.com[i] - o;
            let acc_com = acc + alpha.cross(&c) + omega.cross(&omega.cross(&c));
            let f = b.mass_kg * acc_com;
            let inertia = self.inertia[i];
            self.force[i] = f;
            self.moment[i] = inertia * alpha + omega.cross(&(inertia * omega)) + c.cross(&f);
        }
        // Children before parents: each body passes what it needs on to its parent joint.
        for i in (1..bodies.len()).rev() {
            if let Some(p) = bodies[i].parent {
                let r = self.world[i].translation.vector - self.world[p].translation.vector;
                let (f, m) = (self.force[i], self.moment[i]);
                self.force[p] += f;
                self.moment[p] += m + r.cross(&f);
            }
        }
        for (i, b) in bodies.iter().enumerate() {
            if let Some(k) = b.joint.as_ref().and_then(|j| j.dof) {
                out[k] = self.axis[i].dot(&self.moment[i]);
            }
        }
    }

    /// Inverse dynamics: the joint torques [Nm] that move the arm at `q_rad` with velocities
    /// `qd_rad_s` at accelerations `qdd_rad_s2` under gravity, armature included
    /// (Pinocchio's `rnea` with `model.armature`).
    ///
    /// ```
    /// # use jointctl_kinematics::{Chain, Dynamics, Gravity};
    /// # let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let q = [0.1, 0.7, -0.3, 1.0, 0.2, -0.5, 0.4];
    /// let (mut a, mut b) = ([0.0; 7], [0.0; 7]);
    /// Dynamics::downward(chain.clone(), 9.81).inverse(&q, &[0.0; 7], &[0.0; 7], &mut a).unwrap();
    /// Gravity::new(chain).torques(&q, &mut b).unwrap();
    /// assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12), "at rest: the holding torque");
    /// ```
    pub fn inverse(&mut self, q_rad: &[f64], qd_rad_s: &[f64], qdd_rad_s2: &[f64], out_nm: &mut [f64]) -> Result<(), PoseError> {
        self.check("pose", q_rad)?;
        self.check("velocity", qd_rad_s)?;
        self.check("acceleration", qdd_rad_s2)?;
        let n = self.chain.dof_names().len();
        if out_nm.len() != n {
            return Err(PoseError::Length { what: "output", expected: n, got: out_nm.len() });
        }
        self.place(q_rad);
        self.newton_euler(qd_rad_s, qdd_rad_s2, true, out_nm);
        for ((t, a), qdd) in out_nm.iter_mut().zip(&self.armature_kgm2).zip(qdd_rad_s2) {
            *t += a * qdd;
        }
        Ok(())
    }

    /// The joint-space mass matrix at `q_rad` [kg m^2], row-major into `out` (n x n), armature
    /// on the diagonal (Pinocchio's `crba`): column k is the torque that accelerates joint k
    /// alone at 1 rad/s^2 from rest without gravity.
    ///
    /// ```
    /// # use jointctl_kinematics::{Chain, Dynamics};
    /// # let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let mut dynamics = Dynamics::downward(chain, 9.81);
    /// let mut m = [0.0; 49];
    /// dynamics.mass_matrix(&[0.3; 7], &mut m).unwrap();
    /// assert!((m[1] - m[7]).abs() < 1e-12, "symmetric");
    /// ```
    pub fn mass_matrix(&mut self, q_rad: &[f64], out: &mut [f64]) -> Result<(), PoseError> {
        self.check("pose", q_rad)?;
        let n = self.chain.dof_names().len();
        if out.len() != n * n {
            return Err(PoseError::Length { what: "mass matrix", expected: n * n, got: out.len() });
        }
        self.place(q_rad);
        self.fill_mass_matrix(out);
        Ok(())
    }

    fn fill_mass_matrix(&mut self, out: &mut [f64]) {
        let n = self.chain.dof_names().len();
        let (mut unit, zeros, mut column) = (std::mem::take(&mut self.unit), std::mem::take(&mut self.zeros), std::mem::take(&mut self.rhs));
        for k in 0..n {
            unit.iter_mut().enumerate().for_each(|(j, u)| *u = if j == k { 1.0 } else { 0.0 });
            self.newton_euler(&zeros, &unit, false, &mut column);
            for (row, c) in column.iter().enumerate() {
                out[row * n + k] = *c;
            }
            out[k * n + k] += self.armature_kgm2[k];
        }
        (self.unit, self.zeros, self.rhs) = (unit, zeros, column);
    }

    /// Forward dynamics: the accelerations [rad/s^2] that the joint torques `tau_nm` give the
    /// arm at `q_rad` moving at `qd_rad_s`, under gravity (Pinocchio's `aba`). A joint marked in
    /// `locked` is held still (a clamp, a brake): its acceleration is 0, and the other joints
    /// move as the arm with it rigid would (its torque is ignored).
    ///
    /// ```
    /// # use jointctl_kinematics::{Chain, Dynamics};
    /// # let chain = Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let mut dynamics = Dynamics::downward(chain, 9.81);
    /// let q = [0.0, 0.7854, 0.0, 0.0, 0.0, 0.0, 0.0];
    /// let mut hold = [0.0; 7];
    /// dynamics.inverse(&q, &[0.0; 7], &[0.0; 7], &mut hold).unwrap();
    /// let mut qdd = [1.0; 7];
    /// let locked = [true, false, true, false, false, true, false];
    /// dynamics.forward(&q, &[0.0; 7], &hold, &locked, &mut qdd).unwrap();
    /// assert!(qdd.iter().all(|a| a.abs() < 1e-9), "the holding torques hold it: {qdd:?}");
    /// ```
    pub fn forward(&mut self, q_rad: &[f64], qd_rad_s: &[f64], tau_nm: &[f64], locked: &[bool], qdd_out: &mut [f64]) -> Result<(), DynamicsError> {
        self.check("pose", q_rad)?;
        self.check("velocity", qd_rad_s)?;
        self.check("torque", tau_nm)?;
        let n = self.chain.dof_names().len();
        for (what, len) in [("locked", locked.len()), ("output", qdd_out.len())] {
            if len != n {
                return Err(PoseError::Length { what, expected: n, got: len }.into());
            }
        }
        self.place(q_rad);
        // What the motion and gravity take (the torques at zero acceleration), then M.
        let (zeros, mut bias, mut mass) = (std::mem::take(&mut self.zeros), std::mem::take(&mut self.bias), std::mem::take(&mut self.mass));
        self.newton_euler(qd_rad_s, &zeros, true, &mut bias);
        self.zeros = zeros;
        self.fill_mass_matrix(&mut mass);
        self.free_index.clear();
        self.free_index.extend((0..n).filter(|k| !locked[*k]));
        let m = self.free_index.len();
        for (r, &i) in self.free_index.iter().enumerate() {
            self.rhs[r] = tau_nm[i] - bias[i];
            for (c, &j) in self.free_index.iter().enumerate() {
                self.system[r * m + c] = mass[i * n + j];
            }
        }
        (self.bias, self.mass) = (bias, mass);
        cholesky_solve(&mut self.system[..m * m], &mut self.rhs[..m]).map_err(|r| DynamicsError::Singular { dof: self.chain.dof_names()[self.free_index[r]].clone() })?;
        qdd_out.iter_mut().for_each(|a| *a = 0.0);
        for (r, &i) in self.free_index.iter().enumerate() {
            qdd_out[i] = self.rhs[r];
        }
        Ok(())
    }
}

/// Solves `A x = b` in place for a symmetric positive definite `A` (row-major, m x m; its lower
/// triangle is overwritten by the Cholesky factor), `b` becoming `x`. Err(row) where `A` is not
/// positive definite.
fn cholesky_solve(a: &mut [f64], b: &mut [f64]) -> Result<(), usize> {
    let m = b.len();
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        // Relative to the diagonal's size: a massless joint leaves round-off, not zero.
        if !(d > 1e-12 * a[j * m + j].abs().max(1e-300)) {
            return Err(j);
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let mut s = a[i * m + j];
            for k in 0..j {
                s -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = s / d;
        }
    }
    for i in 0..m {
        let mut s = b[i];
        for k in 0..i {
            s -= a[i * m + k] * b[k];
        }
        b[i] = s / a[i * m + i];
    }
    for i in (0..m).rev() {
        let mut s = b[i];
        for k in i + 1..m {
            s -= a[k * m + i] * b[k];
        }
        b[i] = s / a[i * m + i];
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sherpa() -> Chain {
        Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap()
    }

    /// Kinetic energy summed over the bodies from their own velocities (finite differences of
    /// the placed frames): an independent check of the mass matrix, `T = qd' M qd / 2`.
    #[test]
    fn the_mass_matrix_carries_the_bodies_kinetic_energy() {
        let mut d = Dynamics::downward(sherpa(), 9.81);
        let q = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9, 0.5];
        let qd = [0.5, -1.0, 0.8, 0.3, -0.7, 1.2, -0.4];
        let mut m = [0.0; 49];
        d.mass_matrix(&q, &mut m).unwrap();
        let quadratic: f64 = (0..7).map(|i| (0..7).map(|j| qd[i] * m[i * 7 + j] * qd[j]).sum::<f64>()).sum::<f64>() / 2.0;
        // Body velocities by central differences of the poses along qd.
        let h = 1e-6;
        let (mut a, mut b) = (q, q);
        for k in 0..7 {
            a[k] += h * qd[k];
            b[k] -= h * qd[k];
        }
        let mut da = d.clone();
        let mut db = d.clone();
        da.place(&a);
        db.place(&b);
        d.place(&q);
        let mut energy = 0.0;
        for (i, body) in d.chain.bodies().iter().enumerate() {
            let v = (da.com[i] - db.com[i]) / (2.0 * h);
            let r = da.world[i].rotation * db.world[i].rotation.inverse();
            let w = r.scaled_axis() / (2.0 * h);
            energy += 0.5 * body.mass_kg * v.norm_squared() + 0.5 * w.dot(&(d.inertia[i] * w));
        }
        assert!((energy - quadratic).abs() < 1e-6 * quadratic.abs().max(1.0), "bodies {energy} J vs qd'Mqd/2 {quadratic} J");
    }

    #[test]
    fn forward_undoes_inverse_and_locked_joints_stay() {
        let mut d = Dynamics::downward(sherpa(), 9.81).with_armature(&[0.01; 7]).unwrap();
        let q = [0.3, 0.7, -0.4, 1.1, -0.6, 0.9, 0.5];
        let qd = [0.5, -1.0, 0.8, 0.3, -0.7, 1.2, -0.4];
        let qdd = [1.0, -2.0, 0.5, 3.0, -1.5, 0.7, 2.2];
        let mut tau = [0.0; 7];
        d.inverse(&q, &qd, &qdd, &mut tau).unwrap();
        let mut back = [0.0; 7];
        d.forward(&q, &qd, &tau, &[false; 7], &mut back).unwrap();
        for k in 0..7 {
            assert!((back[k] - qdd[k]).abs() < 1e-9, "q{}: {} vs {}", k + 1, back[k], qdd[k]);
        }
        // Locked joints: the free ones get what inverse dynamics with the locked ones at zero
        // acceleration says.
        let locked = [true, false, false, true, false, true, false];
        let mut partial = qdd;
        for k in 0..7 {
            if locked[k] {
                partial[k] = 0.0;
            }
        }
        d.inverse(&q, &qd, &partial, &mut tau).unwrap();
        d.forward(&q, &qd, &tau, &locked, &mut back).unwrap();
        for k in 0..7 {
            assert!((back[k] - partial[k]).abs() < 1e-9, "q{}: {} vs {}", k + 1, back[k], partial[k]);
        }
    }

    #[test]
    fn a_joint_that_moves_nothing_is_named() {
        let chain = Chain::from_urdf_str(
            r#"<robot name="r"><link name="base"/><link name="a"/>
            <joint name="j" type="continuous"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/></joint></robot>"#,
        )
        .unwrap();
        let mut d = Dynamics::downward(chain.clone(), 9.81);
        let mut qdd = [0.0];
        assert_eq!(d.forward(&[0.0], &[0.0], &[1.0], &[false], &mut qdd), Err(DynamicsError::Singular { dof: "j".into() }));
        let mut d = Dynamics::downward(chain, 9.81).with_armature(&[0.5]).unwrap();
        d.forward(&[0.0], &[0.0], &[1.0], &[false], &mut qdd).unwrap();
        assert!((qdd[0] - 2.0).abs() < 1e-12);
        assert!(matches!(Dynamics::downward(d.chain().clone(), 9.81).with_armature(&[-0.1]), Err(DynamicsError::Armature { ref dof, .. }) if dof == "j"));
        assert!(matches!(d.forward(&[f64::NAN], &[0.0], &[1.0], &[false], &mut qdd), Err(DynamicsError::Pose(PoseError::NotFinite { ref dof, .. })) if dof == "j"));
    }
}
