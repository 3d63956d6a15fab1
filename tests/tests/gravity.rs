//! Gravity torques from the arm's URDF (appendix C): figure C.2 reproduced, Pinocchio (PyPI `pin`,
//! an independent rigid-body library reading the same URDF) agreeing on random poses, and bad
//! input refused with what and where.

use std::io::Write as _;
use std::process::{Command, Stdio};

use jointctl_sim::rng::SplitMix64;
use jointctl_tests::{Edit, arm_name, jointctl, root, scratch, sherpa_with};

fn gravity_json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(jointctl()).arg("gravity").arg(root().join("configs/sherpa_arm.yaml")).args(args).arg("--json").output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn figure_c2_is_reproduced_within_one_percent() {
    let v = gravity_json(&["--pose", "appendix-c"]);
    let tau = &v["torques_nm"];
    assert!((v["pose"]["q2"].as_f64().unwrap() - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    // Figure C.2, numbered from q0 there: its q1, q3, q4, q6 are q2, q4, q5, q7 here.
    for (dof, solver) in [("q2", -28.4263), ("q4", -10.5619), ("q5", -7.06608), ("q7", -0.692195)] {
        let ours = tau[dof].as_f64().unwrap();
        assert!((ours - solver).abs() <= 0.01 * solver.abs(), "{dof}: {ours} Nm vs figure C.2's {solver} Nm");
    }
    // Eq. C.3's hand values, which the thesis prints cut to 3-4 digits.
    for (dof, hand) in [("q2", 28.48), ("q4", 10.58), ("q5", 7.08), ("q7", 0.693)] {
        let ours = -tau[dof].as_f64().unwrap();
        assert!(ours >= hand && ours - hand < 0.01, "{dof}: {ours} Nm vs eq. C.3's {hand} Nm");
    }
    for dof in ["q1", "q3", "q6"] {
        assert!(tau[dof].as_f64().unwrap().abs() < 1e-12, "{dof} carries nothing at figure C.1's pose: {}", tau[dof]);
    }
}

const PINOCCHIO: &str = r#"
import json, sys
import numpy as np
import pinocchio as pin
model = pin.buildModelFromUrdf(sys.argv[1])
data = model.createData()
out = []
for pose in json.load(sys.stdin):
    q = np.zeros(model.nq)
    for j in range(1, model.njoints):
        q[model.joints[j].idx_q] = pose[model.names[j]]
    g = pin.computeGeneralizedGravity(model, data, q)
    out.append({model.names[j]: float(g[model.joints[j].idx_v]) for j in range(1, model.njoints)})
json.dump(out, sys.stdout)
"#;

/// Runs a Pinocchio script (the interop venv's python) on the arm's URDF with `input` on its
/// stdin: the JSON list it prints.
fn pinocchio(script: &str, input: &serde_json::Value) -> Vec<serde_json::Value> {
    let mut py = Command::new(jointctl_tests::interop_python())
        .args(["-c", script])
        .arg(root().join("configs/sherpa_arm.urdf"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the interop venv's python (.ci/setup-python-venv)");
    py.stdin.take().unwrap().write_all(input.to_string().as_bytes()).unwrap();
    let out = py.wait_with_output().unwrap();
    assert!(out.status.success(), "pinocchio: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn pinocchio_agrees_on_random_poses_within_a_micro_newton_metre() {
    let mut rng = SplitMix64(17);
    let dofs = ["q1", "q2", "q3", "q4", "q5", "q6", "q7"];
    let mut poses = Vec::new();
    let mut ours = Vec::new();
    for _ in 0..20 {
        let q: Vec<f64> = dofs.iter().map(|_| (rng.uniform() * 2.0 - 1.0) * std::f64::consts::PI).collect();
        let arg = dofs.iter().zip(&q).map(|(d, v)| format!("{d}={v:.17e}")).collect::<Vec<_>>().join(",");
        let v = gravity_json(&["--q", &arg]);
        // The angles as the CLI read them (round-trip exact).
        poses.push(v["pose"].clone());
        ours.push(v["torques_nm"].clone());
    }
    let theirs = pinocchio(PINOCCHIO, &serde_json::json!(poses));
    assert_eq!(theirs.len(), poses.len());
    let mut worst = 0.0f64;
    for (k, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        for d in dofs {
            let (x, y) = (a[d].as_f64().unwrap(), b[d].as_f64().unwrap());
            worst = worst.max((x - y).abs());
            assert!((x - y).abs() <= 1e-6, "pose {k} {}: {d} ours {x} Nm, Pinocchio {y} Nm", poses[k]);
        }
    }
    println!("20 random poses, 7 joints: largest difference from Pinocchio {worst:.3e} Nm");
}

const PINOCCHIO_DYNAMICS: &str = r#"
import json, sys
import numpy as np
import pinocchio as pin
model = pin.buildModelFromUrdf(sys.argv[1])
cases = json.load(sys.stdin)
model.armature = np.array(cases["armature"])
data = model.createData()
out = []
for c in cases["cases"]:
    q, v, a, tau = (np.array(c[k]) for k in ("q", "v", "a", "tau"))
    out.append({
        "rnea": pin.rnea(model, data, q, v, a).tolist(),
        "crba": pin.crba(model, data, q).tolist(),
        "aba": pin.aba(model, data, q, v, tau).tolist(),
    })
json.dump(out, sys.stdout)
"#;

/// The free arm's equation of motion (`jointctl_kinematics::Dynamics`) against Pinocchio's
/// `rnea`, `crba` and `aba` on the same URDF with the same armature, at random states.
#[test]
fn pinocchio_agrees_on_the_arms_dynamics() {
    use jointctl_kinematics::{Chain, Dynamics};
    let chain = Chain::from_urdf_file(root().join("configs/sherpa_arm.urdf")).unwrap();
    // Pinocchio numbers a chain's joints from the root as we do; checked, not assumed.
    let armature = [0.2, 0.05, 0.01, 0.03, 0.02, 0.005, 0.004];
    let mut dynamics = Dynamics::downward(chain, 9.81).with_armature(&armature).unwrap();
    let mut rng = SplitMix64(23);
    let mut draw = |scale: f64| -> Vec<f64> { (0..7).map(|_| (rng.uniform() * 2.0 - 1.0) * scale).collect() };
    let mut cases = Vec::new();
    let mut ours = Vec::new();
    for _ in 0..20 {
        let (q, v, a, tau) = (draw(std::f64::consts::PI), draw(2.0), draw(5.0), draw(10.0));
        let (mut rnea, mut crba, mut aba) = (vec![0.0; 7], vec![0.0; 49], vec![0.0; 7]);
        dynamics.inverse(&q, &v, &a, &mut rnea).unwrap();
        dynamics.mass_matrix(&q, &mut crba).unwrap();
        dynamics.forward(&q, &v, &tau, &[false; 7], &mut aba).unwrap();
        ours.push((rnea, crba, aba));
        cases.push(serde_json::json!({"q": q, "v": v, "a": a, "tau": tau}));
    }
    let theirs = pinocchio(PINOCCHIO_DYNAMICS, &serde_json::json!({"armature": armature, "cases": cases}));
    let (mut worst_tau, mut worst_m, mut worst_qdd) = (0.0f64, 0.0f64, 0.0f64);
    for (k, ((rnea, crba, aba), p)) in ours.iter().zip(&theirs).enumerate() {
        let row = |key: &str| -> Vec<f64> { p[key].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
        // crba fills the upper triangle only.
        let m: Vec<Vec<f64>> = p["crba"].as_array().unwrap().iter().map(|r| r.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()).collect();
        for i in 0..7 {
            for j in i..7 {
                worst_m = worst_m.max((crba[i * 7 + j] - m[i][j]).abs());
                assert!((crba[i * 7 + j] - m[i][j]).abs() < 1e-9, "case {k}: M[{i}][{j}] ours {} Pinocchio {}", crba[i * 7 + j], m[i][j]);
            }
        }
        for (i, (x, y)) in rnea.iter().zip(row("rnea")).enumerate() {
            worst_tau = worst_tau.max((x - y).abs());
            assert!((x - y).abs() < 1e-6, "case {k}: rnea q{} ours {x} Pinocchio {y}", i + 1);
        }
        for (i, (x, y)) in aba.iter().zip(row("aba")).enumerate() {
            worst_qdd = worst_qdd.max((x - y).abs() / y.abs().max(1.0));
            assert!((x - y).abs() < 1e-6 * y.abs().max(1.0), "case {k}: aba q{} ours {x} Pinocchio {y}", i + 1);
        }
    }
    println!("20 random states: largest difference from Pinocchio: torque {worst_tau:.2e} Nm, mass matrix {worst_m:.2e} kg m^2, acceleration {worst_qdd:.2e} (relative)");
}

#[test]
fn bad_gravity_input_says_what_and_where() {
    let run = |args: &[&str], config: &std::path::Path| {
        let out = Command::new(jointctl()).arg("gravity").arg(config).args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} must fail");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let sherpa = root().join("configs/sherpa_arm.yaml");
    assert!(run(&["--q", "q9=0.1"], &sherpa).contains("`q9` is not a joint of the URDF"));
    assert!(run(&["--q", "q2=inf"], &sherpa).contains("q2: inf is not a finite angle"));
    // No URDF: said so, not a zero torque.
    let bare = sherpa_with("gravity-bare", &arm_name("gravity-bare"), &[Edit::Remove("kinematics")]);
    assert!(run(&[], &bare).contains("no `kinematics: {urdf: FILE}`"));
    // Feed-forward without a URDF: refused where it is asked for.
    let no_urdf = sherpa_with("gravity-ff", &arm_name("gravity-ff"), &[
        Edit::Remove("kinematics"),
        Edit::Set("joints[q4].controller", serde_yaml::from_str("{gravity_feedforward: true}").unwrap()),
    ]);
    let out = Command::new(jointctl()).arg("check").arg(&no_urdf).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("joints[2].controller.gravity_feedforward: needs the arm's URDF"), "{err}");
    // A URDF joint that is no DOF of the arm: `check` names the file, line and field.
    let dir = scratch("gravity-urdf-files");
    let urdf = std::fs::read_to_string(root().join("configs/sherpa_arm.urdf")).unwrap().replace("<joint name=\"q7\"", "<joint name=\"q8\"");
    std::fs::write(dir.join("renamed.urdf"), urdf).unwrap();
    let renamed = sherpa_with("gravity-urdf", &arm_name("gravity-urdf"), &[Edit::Set("kinematics.urdf", dir.join("renamed.urdf").display().to_string().into())]);
    let out = Command::new(jointctl()).arg("check").arg(&renamed).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("kinematics.urdf") && err.contains("the URDF's movable joints q8 are not DOFs of the arm"), "{err}");
    // A broken URDF: the file and the parser's reason.
    std::fs::write(dir.join("broken.urdf"), "<robot name=\"x\"><link name=\"a\"/><joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"nowhere\"/></joint></robot>").unwrap();
    let broken = sherpa_with("gravity-urdf", &arm_name("gravity-broken"), &[Edit::Set("kinematics.urdf", dir.join("broken.urdf").display().to_string().into())]);
    let out = Command::new(jointctl()).arg("check").arg(&broken).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("joint `j`: its child link `nowhere` is not a <link> of the robot"), "{err}");
}

/// A link hanging below the elbow q4 (centre of mass `l` below the joint, `m` kg): the URDF the
/// host computes gravity from, and the simulated plant's own free link with gravity `m g l`.
const HANGING_LINK_M_KG: f64 = 1.0;
const HANGING_LINK_L_M: f64 = 0.5;

fn hanging_link_urdf() -> String {
    format!(
        r#"<robot name="hanging">
  <link name="base"/>
  <link name="forearm"><inertial><origin xyz="0 0 -{HANGING_LINK_L_M}"/><mass value="{HANGING_LINK_M_KG}"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.001"/></inertial></link>
  <joint name="q4" type="continuous"><parent link="base"/><child link="forearm"/><axis xyz="0 1 0"/></joint>
</robot>"#
    )
}

/// The elbow in impedance hold at 0.5 rad (K 20 Nm/rad, D 2 Nms/rad) for 20 s of simulated time,
/// with or without gravity feed-forward: its final position error [rad], the gravity torque it
/// published and the torque reference beyond gravity [Nm].
fn impedance_hold(feedforward: bool) -> (f64, f64, f64) {
    use jointctl_modes::Mode;
    use jointctl_runtime::commands::ArmCommand;
    let name = format!("gravity-hold-{feedforward}");
    let dir = scratch(&format!("{name}-urdf"));
    std::fs::write(dir.join("hanging.urdf"), hanging_link_urdf()).unwrap();
    let mgl = HANGING_LINK_M_KG * 9.81 * HANGING_LINK_L_M;
    let path = sherpa_with(&name, &arm_name(&name), &[
        Edit::Set("kinematics.urdf", dir.join("hanging.urdf").display().to_string().into()),
        Edit::Set("joints[q4].sim.environment", serde_yaml::from_str(&format!("{{kind: free, inertia_kgm2: 0.3, damping_nms_per_rad: 1.0, gravity_nm: {mgl}}}")).unwrap()),
        Edit::Set("joints[q4].controller", serde_yaml::from_str(&format!("{{gravity_feedforward: {feedforward}}}")).unwrap()),
    ]);
    let loaded = jointctl_config::load(&path).unwrap();
    let mut loader = jointctl_runtime::PluginLoader::new([]);
    loader.register_static(jointctl_plugin_rigid::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_elastic::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_vsa_shoulder::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_vsa_wrist::plugin_descriptor()).unwrap();
    let sim = jointctl_sim::SharedSim::new(jointctl_sim::SimHal::load(&loaded).unwrap());
    let mut arm = jointctl_runtime::Arm::build(&loaded, &loader, Box::new(sim)).unwrap();
    arm.run_in_simulated_time();
    arm.activate().unwrap();
    let q4 = arm.dof_names.iter().position(|d| d == "q4").unwrap();
    let (dt, mut t) = (1.0 / arm.rate_hz, 0.0);
    arm.observe(t);
    let target = 0.5;
    arm.apply(ArmCommand::Mode { dof: q4, mode: Mode::Impedance { stiffness_nm_per_rad: 20.0, damping_nms_per_rad: 2.0, target_rad: target }, streamed: false });
    for _ in 0..(20.0 / dt) as usize {
        arm.control();
        t += dt;
        arm.observe(t);
    }
    let q = arm.states[q4].position().expect("q4 observed");
    (q - target, arm.gravity_torques[q4], arm.torque_references[q4])
}

#[test]
fn gravity_feedforward_holds_an_impedance_target_that_gravity_pulls_away() {
    let (error_without, g_without, _) = impedance_hold(false);
    let (error_with, g_with, reference_with) = impedance_hold(true);
    println!("q4 impedance hold at 0.5 rad, K 20 Nm/rad, hanging 1 kg at 0.5 m: error {error_without:.5} rad without feed-forward, {error_with:.6} rad with");
    // Without: K (q_d - q) = m g l sin q, about 0.097 rad short.
    let mgl = HANGING_LINK_M_KG * 9.81 * HANGING_LINK_L_M;
    assert!(error_without < -0.05, "gravity pulls the link down: {error_without}");
    // The published gravity torque is the URDF's at the observed pose, with or without use.
    assert!((g_without - mgl * (0.5 + error_without).sin()).abs() < 1e-6, "{g_without}");
    assert!((g_with - mgl * (0.5 + error_with).sin()).abs() < 1e-6, "{g_with}");
    // With: the reference is the torque beyond gravity (about 0 at the target), and the error at
    // least ten times smaller.
    assert!(error_with.abs() * 10.0 < error_without.abs(), "with {error_with} vs without {error_without}");
    assert!(reference_with.abs() < 0.1, "the torque beyond gravity at the target: {reference_with}");
}
