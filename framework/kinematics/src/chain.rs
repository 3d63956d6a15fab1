//! A URDF read into a tree of bodies joined by joints, validated.

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Matrix3, Translation3, Unit, UnitQuaternion, Vector3};

/// Why a URDF is not an arm this crate can compute with. Each variant names the element.
#[derive(Debug, thiserror::Error)]
pub enum ChainError {
    /// The file could not be read or is not URDF XML.
    #[error("{path}: not a readable URDF: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What `urdf-rs` said.
        #[source]
        source: urdf_rs::UrdfError,
    },
    /// A string that is not URDF XML.
    #[error("not a URDF: {0}")]
    Parse(#[source] urdf_rs::UrdfError),
    /// A joint names a link that the URDF does not have.
    #[error("joint `{joint}`: its {role} link `{link}` is not a <link> of the robot")]
    UnknownLink {
        /// The joint.
        joint: String,
        /// `parent` or `child`.
        role: &'static str,
        /// The link it names.
        link: String,
    },
    /// Two links or two joints share a name.
    #[error("two {kind}s are named `{name}`")]
    Duplicate {
        /// `link` or `joint`.
        kind: &'static str,
        /// The name.
        name: String,
    },
    /// A link is the child of two joints (a URDF is a tree).
    #[error("link `{link}` is the child of two joints, `{first}` and `{second}`")]
    TwoParents {
        /// The link.
        link: String,
        /// One joint.
        first: String,
        /// The other.
        second: String,
    },
    /// No link, or not exactly one link without a parent joint.
    #[error("a URDF has exactly one root link (no parent joint); this one has {}", if .0.is_empty() { "none".to_string() } else { .0.join(", ") })]
    Roots(Vec<String>),
    /// Links that cannot be reached from the root (a loop of joints).
    #[error("links {} are not connected to the root `{root}` (a loop of joints)", .links.join(", "))]
    Unreachable {
        /// The root.
        root: String,
        /// The links left over.
        links: Vec<String>,
    },
    /// A joint kind the gravity model does not handle.
    #[error("joint `{joint}` is {kind:?}: only revolute, continuous and fixed joints are supported")]
    Unsupported {
        /// The joint.
        joint: String,
        /// Its kind.
        kind: urdf_rs::JointType,
    },
    /// A movable joint with a zero or non-finite axis.
    #[error("joint `{joint}`: axis {axis:?} is not a direction")]
    Axis {
        /// The joint.
        joint: String,
        /// The axis as written.
        axis: [f64; 3],
    },
    /// A number that is not finite, or a negative mass.
    #[error("{element} `{name}`: {field} = {value} is not a {expected}")]
    Value {
        /// `link` or `joint`.
        element: &'static str,
        /// Its name.
        name: String,
        /// The field (`mass`, `inertial origin`, `origin`, ...).
        field: &'static str,
        /// The value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
}

/// A rigid body: a URDF link's inertial properties in its own frame.
#[derive(Clone, Debug)]
pub struct Body {
    /// The link's name.
    pub name: String,
    /// Mass [kg].
    pub mass_kg: f64,
    /// Centre of mass in the link frame [m].
    pub com_m: Vector3<f64>,
    /// Inertia tensor about the centre of mass, in the link frame [kg m^2].
    pub inertia_kgm2: Matrix3<f64>,
    /// The body it hangs from (index into [`Chain::bodies`]); `None` for the root.
    pub parent: Option<usize>,
    /// The joint between the parent and this body; `None` for the root.
    pub joint: Option<JointFrame>,
}

/// A joint: where the child's frame sits in the parent's at zero, and how it moves.
#[derive(Clone, Debug)]
pub struct JointFrame {
    /// The joint's name.
    pub name: String,
    /// The child frame in the parent frame at zero joint position.
    pub origin: Isometry3<f64>,
    /// The rotation axis in the child frame (revolute, continuous).
    pub axis: Unit<Vector3<f64>>,
    /// Its index in a pose vector (movable joints, in the order of [`Chain::dof_names`]);
    /// `None` for a fixed joint.
    pub dof: Option<usize>,
}

/// The arm: bodies in an order where every parent comes before its children.
#[derive(Clone, Debug)]
pub struct Chain {
    /// The robot's name.
    pub name: String,
    bodies: Vec<Body>,
    dofs: Vec<String>,
}

fn finite(element: &'static str, name: &str, field: &'static str, v: &[f64]) -> Result<(), ChainError> {
    match v.iter().find(|x| !x.is_finite()) {
        Some(&value) => Err(ChainError::Value { element, name: name.into(), field, value, expected: "finite number" }),
        None => Ok(()),
    }
}

fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [x, y, z] = p.xyz.0;
    let [r, pi, ya] = p.rpy.0;
    Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::from_euler_angles(r, pi, ya))
}

impl Chain {
    /// Reads and validates a URDF file.
    ///
    /// ```
    /// let chain = jointctl_kinematics::Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// assert_eq!(chain.dof_names(), ["q1", "q2", "q3", "q4", "q5", "q6", "q7"]);
    /// ```
    pub fn from_urdf_file(path: impl AsRef<Path>) -> Result<Chain, ChainError> {
        let path = path.as_ref();
        let robot = urdf_rs::read_file(path).map_err(|source| ChainError::Read { path: path.to_path_buf(), source })?;
        Chain::from_robot(&robot)
    }

    /// Reads and validates URDF XML (see the crate's example).
    pub fn from_urdf_str(xml: &str) -> Result<Chain, ChainError> {
        Chain::from_robot(&urdf_rs::read_from_string(xml).map_err(ChainError::Parse)?)
    }

    fn from_robot(robot: &urdf_rs::Robot) -> Result<Chain, ChainError> {
        let mut seen = std::collections::HashSet::new();
        for l in &robot.links {
            if !seen.insert(l.name.as_str()) {
                return Err(ChainError::Duplicate { kind: "link", name: l.name.clone() });
            }
        }
        let mut joint_names = std::collections::HashSet::new();
        let mut parent_joint: std::collections::HashMap<&str, &urdf_rs::Joint> = std::collections::HashMap::new();
        for j in &robot.joints {
            if !joint_names.insert(j.name.as_str()) {
                return Err(ChainError::Duplicate { kind: "joint", name: j.name.clone() });
            }
            for (role, link) in [("parent", &j.parent.link), ("child", &j.child.link)] {
                if !seen.contains(link.as_str()) {
                    return Err(ChainError::UnknownLink { joint: j.name.clone(), role, link: link.clone() });
                }
            }
            if let Some(first) = parent_joint.insert(j.child.link.as_str(), j) {
                return Err(ChainError::TwoParents { link: j.child.link.clone(), first: first.name.clone(), second: j.name.clone() });
            }
        }
        let roots: Vec<&urdf_rs::Link> = robot.links.iter().filter(|l| !parent_joint.contains_key(l.name.as_str())).collect();
        if roots.len() != 1 {
            return Err(ChainError::Roots(roots.iter().map(|l| l.name.clone()).collect()));
        }
        // Breadth first from the root: parents before children, DOFs in the URDF's joint order
        // along the tree (as Pinocchio numbers them for a chain).
        // Every joint's links were checked above; an error, not a panic, if that ever changes.
        let link_of = |j: &urdf_rs::Joint| {
            robot.links.iter().find(|l| l.name == j.child.link).ok_or_else(|| ChainError::UnknownLink { joint: j.name.clone(), role: "child", link: j.child.link.clone() })
        };
        let mut chain = Chain { name: robot.name.clone(), bodies: Vec::new(), dofs: Vec::new() };
        let mut queue = std::collections::VecDeque::from([(roots[0], None::<usize>, None::<&urdf_rs::Joint>)]);
        while let Some((link, parent, joint)) = queue.pop_front() {
            let frame = match joint {
                None => None,
                Some(j) => Some(Chain::joint_frame(j, &mut chain.dofs)?),
            };
            let i = &link.inertial;
            finite("link", &link.name, "mass", &[i.mass.value])?;
            if i.mass.value < 0.0 {
                return Err(ChainError::Value { element: "link", name: link.name.clone(), field: "mass", value: i.mass.value, expected: "mass >= 0 kg" });
            }
            finite("link", &link.name, "inertial origin", &[i.origin.xyz.0, i.origin.rpy.0].concat())?;
            let t = &i.inertia;
            finite("link", &link.name, "inertia", &[t.ixx, t.ixy, t.ixz, t.iyy, t.iyz, t.izz])?;
            let frame_of_com = pose(&i.origin);
            let local = Matrix3::new(t.ixx, t.ixy, t.ixz, t.ixy, t.iyy, t.iyz, t.ixz, t.iyz, t.izz);
            let r = frame_of_com.rotation.to_rotation_matrix();
            let index = chain.bodies.len();
            chain.bodies.push(Body {
                name: link.name.clone(),
                mass_kg: i.mass.value,
                com_m: frame_of_com.translation.vector,
                inertia_kgm2: r.matrix() * local * r.matrix().transpose(),
                parent,
                joint: frame,
            });
            for j in robot.joints.iter().filter(|j| j.parent.link == link.name) {
                queue.push_back((link_of(j)?, Some(index), Some(j)));
            }
        }
        if chain.bodies.len() != robot.links.len() {
            let reached: std::collections::HashSet<&str> = chain.bodies.iter().map(|b| b.name.as_str()).collect();
            return Err(ChainError::Unreachable { root: roots[0].name.clone(), links: robot.links.iter().filter(|l| !reached.contains(l.name.as_str())).map(|l| l.name.clone()).collect() });
        }
        Ok(chain)
    }

    fn joint_frame(j: &urdf_rs::Joint, dofs: &mut Vec<String>) -> Result<JointFrame, ChainError> {
        finite("joint", &j.name, "origin", &[j.origin.xyz.0, j.origin.rpy.0].concat())?;
        let movable = match j.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => true,
            urdf_rs::JointType::Fixed => false,
            ref kind => return Err(ChainError::Unsupported { joint: j.name.clone(), kind: kind.clone() }),
        };
        let raw = Vector3::from(j.axis.xyz.0);
        let axis = match Unit::try_new(raw, 1e-12) {
            Some(a) if raw.iter().all(|x| x.is_finite()) => a,
            _ if !movable => Vector3::z_axis(),
            _ => return Err(ChainError::Axis { joint: j.name.clone(), axis: j.axis.xyz.0 }),
        };
        let dof = movable.then(|| {
            dofs.push(j.name.clone());
            dofs.len() - 1
        });
        Ok(JointFrame { name: j.name.clone(), origin: pose(&j.origin), axis, dof })
    }

    /// The movable joints' names, in pose-vector order.
    pub fn dof_names(&self) -> &[String] {
        &self.dofs
    }

    /// The bodies, every parent before its children.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// The total mass [kg].
    pub fn mass_kg(&self) -> f64 {
        self.bodies.iter().map(|b| b.mass_kg).sum()
    }

    /// The same arm with other masses (e.g. figure C.1's 1 kg per body): `mass(link name, URDF
    /// mass)` gives each body's mass [kg]; centres of mass stay, inertias scale with the mass.
    ///
    /// ```
    /// # let chain = jointctl_kinematics::Chain::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.urdf")).unwrap();
    /// let light = chain.with_masses(|_, m| 0.5 * m);
    /// assert!((light.mass_kg() - 0.5 * chain.mass_kg()).abs() < 1e-12);
    /// ```
    pub fn with_masses(&self, mass: impl Fn(&str, f64) -> f64) -> Chain {
        let mut out = self.clone();
        for b in &mut out.bodies {
            let m = mass(&b.name, b.mass_kg);
            b.inertia_kgm2 *= if b.mass_kg > 0.0 { m / b.mass_kg } else { 0.0 };
            b.mass_kg = m;
        }
        out
    }
}
