//! Arms of any size for scale tests and benchmarks: N joints of one kind, each with its own
//! drive (eight to a CAN bus) and output encoder (eight to an SPI bus), simulated.

/// The kind of every joint of a generated arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// `rigid` plugin, a rigid simulated element (section 3.1's harmonic drive stiffness).
    Rigid,
    /// `elastic` plugin, a linear simulated spring (section 3.3.2's elbow stiffness).
    Elastic,
}

impl JointKind {
    /// The plugin's name.
    pub fn plugin(self) -> &'static str {
        match self {
            JointKind::Rigid => "rigid",
            JointKind::Elastic => "elastic",
        }
    }
}

/// The YAML of arm `name` with `dofs` joints `j0`, `j1`, ... of `kind` at `rate_hz`, every
/// joint a free link of 0.5 kg m^2 with 2 Nms/rad of damping, position limits of +-2 rad and
/// a torque limit of 50 Nm (assumptions: any plausible link; the figures measured on it are
/// the runtime's, not the link's). The stiffnesses are the thesis' (section 3.1: 8.3e4 Nm/rad;
/// section 3.3.2: 113.78 Nm/rad).
///
/// ```
/// use jointctl_test_support::generated_arm::{JointKind, arm_yaml};
/// let text = arm_yaml("big", 20, JointKind::Elastic, 1000.0);
/// assert!(text.contains("name: j19"));
/// assert_eq!(text.matches("plugin: elastic").count(), 20);
/// ```
pub fn arm_yaml(name: &str, dofs: usize, kind: JointKind, rate_hz: f64) -> String {
    const PER_BUS: usize = 8;
    let mut can = String::new();
    let mut spi = String::new();
    for bus in 0..dofs.div_ceil(PER_BUS) {
        can.push_str(&format!("    - interface: can{bus}\n      drives:\n"));
        spi.push_str(&format!("    - device: /dev/spidev{bus}.0\n      encoders:\n"));
        for slot in 0..PER_BUS.min(dofs - bus * PER_BUS) {
            let i = bus * PER_BUS + slot;
            can.push_str(&format!("        - {{name: m{i}, node_id: {}}}\n", slot + 1));
            spi.push_str(&format!("        - {{name: e{i}, chip_select: {slot}, sim: {{signal: j{i}.output}}}}\n"));
        }
    }
    let (element, params) = match kind {
        JointKind::Rigid => ("{kind: rigid}", "{stiffness_nm_per_rad: 8.3e4, position_pi: {kp: 0.2, ki: 0.5, output_limit: 0.05}}"),
        JointKind::Elastic => (
            "{kind: linear, stiffness_nm_per_rad: 113.78}",
            "{stiffness_nm_per_rad: 113.78, output_per_motor: 1.0, position_pi: {kp: 0.2, ki: 0.5, output_limit: 0.05}}",
        ),
    };
    let mut joints = String::new();
    for i in 0..dofs {
        joints.push_str(&format!(
            "  - name: j{i}\n    plugin: {}\n    encoders: {{output: e{i}}}\n    drives: {{motor: m{i}}}\n    limits: {{position_rad: [-2.0, 2.0], torque_nm: 50}}\n    sim: {{drives: [m{i}], matrix: [[1.0]], element: {element}, environment: {{kind: free, inertia_kgm2: 0.5, damping_nms_per_rad: 2.0}}}}\n    params: {params}\n",
            kind.plugin()
        ));
    }
    format!("version: 1\narm: {name}\nrate_hz: {rate_hz}\nhal: {{backend: sim}}\nbuses:\n  can:\n{can}  spi:\n{spi}joints:\n{joints}")
}
