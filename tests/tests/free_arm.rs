//! The free arm (appendix C's future work): the URDF's links load each other in the simulation,
//! coupled; and impedance hold with gravity feed-forward holds its poses.

use jointctl_experiments::gravity_hold::{self, Plan};
use jointctl_kinematics::Gravity;
use jointctl_tests::{Edit, arm_name, jointctl, root, sherpa_with};

fn loader() -> jointctl_runtime::PluginLoader {
    let mut loader = jointctl_runtime::PluginLoader::new([]);
    loader.register_static(jointctl_plugin_rigid::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_elastic::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_vsa_shoulder::plugin_descriptor()).unwrap();
    loader.register_static(jointctl_plugin_vsa_wrist::plugin_descriptor()).unwrap();
    loader
}

/// Released from a tilted shoulder with every drive standing still, the free arm sags until
/// each joint's element carries what the URDF says it must: at rest, element torque = g(q) at
/// every joint, q2's carrying the links beyond it (coupled), not one link each.
#[test]
fn the_released_arm_comes_to_rest_where_its_elements_carry_the_urdfs_gravity() {
    let mut loaded = jointctl_config::load(root().join("configs/sherpa_arm.yaml")).unwrap();
    let chain = loaded.chain.clone().unwrap();
    let released = jointctl_sim::free_arm::release(&mut loaded.config, &chain);
    assert_eq!(released, chain.dof_names());
    let mut sim = jointctl_sim::SimHal::load(&loaded).unwrap();
    // The shoulder's actuators a2 = a3 = 0.5 rad: q2 = (a2 + a3) / 2 tilted 0.5 rad, q3 = 0,
    // its VSA at its stiffest (pivot 0 mm: 22.5 + 10 x -2.25); the elbow's motor 0.2 rad:
    // q4 = 2 x 0.2 (eq. 3.1).
    let drive = |name: &str| loaded.config.buses.can.iter().flat_map(|b| &b.drives).position(|d| d.name == name).unwrap();
    let mut start = vec![None; sim.drives().len()];
    for (name, q) in [("elmo_shoulder_a", 0.5), ("elmo_shoulder_b", 0.5), ("elmo_shoulder_pivot", -2.25), ("elmo_q4", 0.2)] {
        start[drive(name)] = Some(q);
    }
    sim.start_at(&start);
    sim.settle_drives(15.0);
    let dofs = chain.dof_names().to_vec();
    let output = |sim: &jointctl_sim::SimHal, d: &str| sim.units().iter().find_map(|u| u.dof_names.iter().position(|n| n == d).map(|i| u.output_state(i))).unwrap();
    let q: Vec<f64> = dofs.iter().map(|d| output(&sim, d).0).collect();
    let mut g = vec![0.0; dofs.len()];
    Gravity::downward(chain.clone(), 9.81).torques(&q, &mut g).unwrap();
    println!("at rest: q {q:.4?}");
    for (k, d) in dofs.iter().enumerate() {
        let (_, v) = output(&sim, d);
        let (element, _) = sim.joint_torque(d).unwrap();
        println!("{d}: element {element:+.4} Nm, g(q) {:+.4} Nm, velocity {v:+.2e} rad/s", g[k]);
        assert!(v.abs() < 1e-3, "{d} still moves: {v} rad/s");
        // The elements carry the holding torque within their hysteresis and friction bands
        // (q2 0.4 + 0.1 Nm, q4 0.2 + 0.05 Nm; configs/sherpa_arm.yaml) and 1 % of the load.
        assert!((element - g[k]).abs() <= 0.6 + 0.01 * g[k].abs(), "{d}: element {element} Nm vs g(q) {} Nm", g[k]);
    }
    // The shoulder carries the whole arm beyond it: far more than one link's 1 kg.
    let q2 = dofs.iter().position(|d| d == "q2").unwrap();
    assert!(q[q2] > 0.5 && g[q2] < -15.0, "q2 sags forward and carries the arm: q {} rad, g {} Nm", q[q2], g[q2]);
    assert_eq!(sim.free_arm().unwrap().failures(), 0);
}

/// Issue's done-when: impedance hold at three poses of the free arm, with gravity feed-forward
/// the steady-state error at least ten times smaller on every held DOF, or (q7, whose element's
/// band over its impedance is more than a tenth of its sag) within that band.
#[test]
fn gravity_feedforward_holds_three_poses_of_the_free_arm_ten_times_closer() {
    let loaded = jointctl_config::load(root().join("configs/sherpa_arm.yaml")).unwrap();
    let plan = Plan::sherpa();
    let (rows, traces) = gravity_hold::run(&loaded, &loader(), &plan).unwrap();
    assert_eq!(rows.len(), plan.poses.len() * plan.impedance.len() * 2);
    assert_eq!(traces.len(), rows.len());
    // A steady state, not a swing caught in the average: the mean error over the two seconds
    // before the averaged ones is within 2 mrad of theirs (with 15 s, q2 at appendix-c with
    // feed-forward was still wandering by 0.1 rad, and its mean read 5x for a steady 13x).
    for tr in &traces {
        let mean = |from: f64, to: f64| {
            let inside: Vec<f64> = tr.points.iter().filter(|(t, e)| *t > from && *t <= to && e.is_finite()).map(|(_, e)| *e).collect();
            inside.iter().sum::<f64>() / inside.len().max(1) as f64
        };
        let (end, avg) = (plan.hold_s, plan.average_s);
        let (before, last) = (mean(end - 2.0 * avg, end - avg), mean(end - avg, end));
        assert!((before - last).abs() < 0.002, "{} {} (feed-forward {}): not settled, mean error {before:+.5} then {last:+.5} rad", tr.pose, tr.dof, tr.feedforward);
    }
    for r in rows.iter().filter(|r| r.feedforward) {
        let without = rows.iter().find(|o| !o.feedforward && o.pose == r.pose && o.dof == r.dof).unwrap();
        println!(
            "{} {}: error {:+.5} rad without, {:+.5} rad with ({:.0}x); g {:+.2} Nm, observed {:+.2} Nm, sensor {:+.2} Nm",
            r.pose, r.dof, without.error_rad, r.error_rad, without.error_rad.abs() / r.error_rad.abs(), r.gravity_nm, r.observed_nm, r.sensed_nm
        );
        // Without: the impedance carries the load, K (q_d - q) = g.
        assert!((without.stiffness_nm_per_rad * without.error_rad + without.reference_nm).abs() < 0.05 * without.reference_nm.abs() + 0.05, "{without:?}");
        assert!(without.error_rad.abs() > 0.05, "gravity pulls {} away from its target: {without:?}", r.dof);
        // With feed-forward the loop holds the *observed* torque. The element's hysteresis (a band
        // of 2 x limit_nm) and friction (arctan, about k_a * pi / 2), which the observer does not
        // model, leave the true torque anywhere inside them, so the pose rests within band / K of
        // its target, where along the band depending on the path there. Where band / K is more
        // than a tenth of the error without feed-forward, ten times cannot be promised, and the
        // band is what is asked: only q7, (2 x 0.05 + 0.03) Nm / 10 Nm/rad = 13 mrad against
        // about 100 mrad. Found when the parameters' JSON was read to the last bit (1 ulp) and
        // folded-back q7 went from 57x to 9.7x.
        let band_nm = plant_band_nm(&loaded, &r.dof);
        let allowed = (without.error_rad.abs() / 10.0).max(band_nm / r.stiffness_nm_per_rad);
        assert!(r.error_rad.abs() <= allowed, "{} {}: with {} rad, without {} rad, allowed {allowed} rad", r.pose, r.dof, r.error_rad, without.error_rad);
        assert!(r.ripple_rad < 0.005 && without.ripple_rad < 0.005, "a hold, not a swing: {r:?} {without:?}");
    }
}

/// The band of the plant effects the observer does not model on `dof` [Nm]: the hysteresis'
/// 2 x limit_nm plus the arctan friction's k_a * pi / 2 (the joint's effects, or the DOF's own).
fn plant_band_nm(loaded: &jointctl_config::LoadedConfig, dof: &str) -> f64 {
    let joint = loaded.config.joints.iter().find(|j| j.dof_names().contains(&dof)).unwrap_or_else(|| panic!("no joint has {dof}"));
    let sim = joint.sim.as_ref().unwrap_or_else(|| panic!("{dof}: no sim section"));
    let k = joint.dof_names().iter().position(|d| *d == dof).unwrap_or(0);
    let effects = sim.effects_per_dof.get(k).unwrap_or(&sim.effects);
    2.0 * effects.hysteresis.as_ref().map_or(0.0, |h| h.limit_nm) + effects.arctan_friction.as_ref().map_or(0.0, |a| a.k_a_nm * std::f64::consts::FRAC_PI_2)
}

/// A free arm without a URDF, or with a URDF joint nobody simulates, is refused with where.
#[test]
fn a_free_arm_without_its_urdf_is_refused_with_where() {
    let no_urdf = sherpa_with("free-arm-no-urdf", &arm_name("free-arm-no-urdf"), &[
        Edit::Remove("kinematics"),
        Edit::Set("joints[q4].sim.environment", serde_yaml::from_str("{kind: free_arm, damping_nms_per_rad: 1.0}").unwrap()),
    ]);
    let out = std::process::Command::new(jointctl()).arg("check").arg(&no_urdf).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("joints[2].sim.environment: a free arm needs the arm's URDF"), "{err}");
    let negative = sherpa_with("free-arm-negative", &arm_name("free-arm-negative"), &[Edit::Set(
        "joints[q4].sim.environment",
        serde_yaml::from_str("{kind: free_arm, armature_kgm2: -0.1}").unwrap(),
    )]);
    let out = std::process::Command::new(jointctl()).arg("check").arg(&negative).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("joints[2].sim.environment.armature_kgm2: must be a finite number >= 0, got -0.1"), "{err}");
    // Built without the chain (the configuration alone): the simulator says what it needs.
    let loaded = jointctl_config::load(sherpa_with("free-arm-bare", &arm_name("free-arm-bare"), &[Edit::Set(
        "joints[q4].sim.environment",
        serde_yaml::from_str("{kind: free_arm}").unwrap(),
    )]))
    .unwrap();
    let err = jointctl_sim::SimHal::new(&loaded.config).err().expect("no URDF given").to_string();
    assert!(err.contains("joints[2].sim.environment") && err.contains("`q4` is a joint of the free arm, which needs the arm's URDF"), "{err}");
    // A URDF joint without a simulated joint: named.
    let unsimulated = jointctl_config::load(sherpa_with("free-arm-unsimulated", &arm_name("free-arm-unsimulated"), &[
        Edit::Set("joints[q4].sim.environment", serde_yaml::from_str("{kind: free_arm}").unwrap()),
        Edit::Remove("joints[q1].sim"),
        Edit::Set("buses.spi[0].encoders[0].sim", serde_yaml::from_str("{fixed_rad: 0.0}").unwrap()),
    ]))
    .unwrap();
    let err = jointctl_sim::SimHal::load(&unsimulated).err().expect("q1 not simulated").to_string();
    assert!(err.contains("joint `q1` of the free arm's URDF is not simulated"), "{err}");
}
