//! Tests of the model loop's helpers: merging the loop's values and a cause's plant terms, and
//! the held-out part.

use serde_json::{Map, Value};

use super::gain::held_out_mask;
use super::simulation::merge_plant;
use super::write::merge_yaml;

#[test]
fn the_loops_values_merge_into_hal_sim_and_keep_the_rest() {
    let mut sim: serde_yaml::Value = serde_yaml::from_str("{seed: 1, can_latency_s: 0.03, elmo: {kp: 10.0, max_acceleration_rad_s2: 30.0}}").unwrap();
    merge_yaml(&mut sim, &serde_yaml::from_str("{can_latency_s: 0.05, elmo: {max_acceleration_rad_s2: 8.0}}").unwrap());
    assert_eq!(sim, serde_yaml::from_str::<serde_yaml::Value>("{seed: 1, can_latency_s: 0.05, elmo: {kp: 10.0, max_acceleration_rad_s2: 8.0}}").unwrap());
}

#[test]
fn linear_plant_terms_add_and_the_others_replace() {
    let effects = serde_json::json!({"viscous_nms_per_rad": 0.1, "hysteresis": {"sigma_nm_per_rad": 100.0, "limit_nm": 0.2}});
    let fragment: Map<String, Value> = serde_json::from_value(serde_json::json!({"viscous_nms_per_rad": 0.5, "hysteresis": {"sigma_nm_per_rad": 300.0, "limit_nm": 1.0}, "dead_zone_rad": 0.01})).unwrap();
    let merged = merge_plant(&effects, &fragment);
    assert!((merged["viscous_nms_per_rad"].as_f64().unwrap() - 0.6).abs() < 1e-12);
    assert_eq!(merged["hysteresis"]["limit_nm"], 1.0);
    assert_eq!(merged["dead_zone_rad"], 0.01);
}

#[test]
fn the_held_out_part_is_identifys_last_thirty_per_cent_of_the_time_range() {
    let t: Vec<f64> = (0..=10).map(f64::from).collect();
    let d: Vec<f64> = t.iter().map(|t| (1.3 * t).sin()).collect();
    let mask = held_out_mask(&t, &d, super::Split::of(&jointctl_ident::identify::IdentifyOptions::default()));
    assert_eq!(mask.iter().filter(|m| **m).count(), 4);
    assert!(!mask[6] && mask[7]);
}

/// The gains are measured on the samples identify held out, also when it held out a window like
/// the rest: a sine whose amplitude grows tenfold moves the window, and the mask selects exactly
/// the held-out samples of identify's report.
#[test]
fn the_held_out_window_like_the_rest_is_identifys_held_out_part() {
    use jointctl_ident::identify::{IdentifyOptions, identify, prepare::HeldOut};
    let t: Vec<f64> = (0..20_000).map(|i| i as f64 * 0.005).collect();
    let d: Vec<f64> = t.iter().map(|t| (0.005 + 0.0005 * t * t / 10.0) * (std::f64::consts::TAU * 0.5 * t).sin()).collect();
    let tau: Vec<f64> = d.iter().enumerate().map(|(i, x)| 80.0 * x + 0.002 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)).collect();
    let data = jointctl_ident::csv::Data::from_columns(t.clone(), d.clone(), tau);
    let opts = IdentifyOptions { held_out: HeldOut::LikeTheRest, ..IdentifyOptions::default() };
    let report = identify(&data, &opts).unwrap();
    assert!(report.held_out_window.moved.is_some(), "{:?}", report.held_out_window);
    let mask = held_out_mask(&t, &d, super::Split::of(&opts));
    let masked: Vec<f64> = t.iter().zip(&mask).filter(|(_, m)| **m).map(|(t, _)| *t).collect();
    let held: Vec<f64> = report.held_out.iter().map(|row| row[0]).collect();
    assert_eq!(masked.len(), held.len());
    assert!(masked.iter().zip(&held).all(|(a, b)| (a - b).abs() < 1e-9));
}

/// A DOF's effects put back into its joint: on the wrist (two DOFs, one set for both in the
/// reference arm) q7's go to q7's own set and q6 keeps the configured one, one set or by
/// setting; the list by setting builds the simulated arm; a joint already by setting gives q7's
/// list as configured, and q6's set at a setting between two configured ones is interpolated
/// there.
#[test]
fn a_dofs_effects_go_to_its_own_set_and_the_other_dofs_keep_theirs() {
    use super::simulation::{PlantEffects, configured_plant};
    use jointctl_config::EffectsConfig;
    let mut loaded = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
    let j = loaded.config.joints.iter().position(|j| j.name == "wrist").unwrap();
    let configured = loaded.config.joints[j].sim.as_ref().unwrap().effects;
    let offset = |nm: f64| serde_json::json!({"torque_offset_nm": nm});
    // One set.
    let sim = loaded.config.joints[j].sim.as_mut().unwrap();
    let plant = PlantEffects::One(offset(0.5));
    let super::simulation::JointEffects::PerDof(sets) = plant.joint_effects(sim, 1).unwrap() else { panic!("one set per DOF") };
    assert_eq!((sets[0], sets[1].torque_offset_nm), (configured, 0.5));
    // By setting.
    let plant = PlantEffects::ByPivot(vec![(10.0, offset(0.5)), (30.0, offset(1.5))]);
    let joint = plant.joint_effects(sim, 1).unwrap();
    let super::simulation::JointEffects::ByPivot(entries) = &joint else { panic!("by setting") };
    assert!(entries.iter().all(|e| e.effects_per_dof.len() == 2 && e.effects_per_dof[0] == configured));
    let (key, value) = joint.yaml_entry().unwrap();
    assert_eq!(key, "effects_by_pivot");
    sim.effects = EffectsConfig::default();
    sim.effects_by_pivot = serde_json::from_value(value).unwrap();
    jointctl_sim::SimHal::with_chain(&loaded.config, loaded.chain.as_ref()).map(|_| ()).unwrap();
    // Configured by setting: q7's list as configured, q6's between the settings interpolated.
    let entry = &loaded.config.joints[j];
    let only = |torque_offset_nm| serde_json::to_value(EffectsConfig { torque_offset_nm, ..Default::default() }).unwrap();
    assert_eq!(configured_plant(entry, 1).unwrap(), PlantEffects::ByPivot(vec![(10.0, only(0.5)), (30.0, only(1.5))]));
    let sim = loaded.config.joints[j].sim.as_mut().unwrap();
    sim.effects_by_pivot[1].effects_per_dof[0].torque_offset_nm = configured.torque_offset_nm + 1.0;
    let super::simulation::JointEffects::ByPivot(entries) = PlantEffects::ByPivot(vec![(20.0, offset(2.0))]).joint_effects(sim, 1).unwrap() else { panic!("by setting") };
    assert_eq!(entries[0].effects_per_dof[0], EffectsConfig { torque_offset_nm: configured.torque_offset_nm + 0.5, ..configured });
    assert_eq!(entries[0].effects_per_dof[1].torque_offset_nm, 2.0);
    // One set for a DOF of a joint by setting says what it lacks.
    assert!(PlantEffects::One(offset(0.5)).joint_effects(sim, 1).is_err());
}

/// Finding: a record's settings replaced a joint's configured settings, so the settings it did
/// not visit were lost, and the simulation's gain mixed that resampling with the causes. Pass:
/// the configured settings stay, the record's are added with the configured effects there, and
/// one within 1 mm of a configured setting is that setting.
#[test]
fn a_records_settings_join_the_configured_ones() {
    use super::plant_choice::with_settings;
    use super::simulation::PlantEffects;
    let offset = |nm: f64| serde_json::json!({"torque_offset_nm": nm});
    let configured = PlantEffects::ByPivot(vec![(0.0, offset(0.0)), (40.0, offset(4.0))]);
    // 40.4 mm is the configured 40 mm setting (a record's hold a hair off it).
    let list = with_settings(&configured, &[10.0, 40.4]).unwrap();
    let got: Vec<(f64, f64)> = list.iter().map(|(p, v)| (*p, v["torque_offset_nm"].as_f64().unwrap())).collect();
    assert_eq!(got, vec![(0.0, 0.0), (10.0, 1.0), (40.0, 4.0)]);
    let one = with_settings(&PlantEffects::One(offset(0.5)), &[20.0, 10.0]).unwrap();
    assert_eq!(one, vec![(10.0, offset(0.5)), (20.0, offset(0.5))]);
}

/// Finding: on a joint whose simulated effects are by pivot setting, a record at one setting had
/// a cause's plant terms tried at every configured setting alike. Pass: on the shoulder with
/// effects at 0 and 45 mm, a record at 20 mm whose sensor reads 0.5 Nm high gets the offset at
/// 20 mm alone, and the configured settings keep theirs.
#[test]
fn a_record_at_one_setting_extends_that_setting_alone() {
    use super::found::Found;
    use super::simulation::{PlantEffects, simulated_torque};
    use jointctl_config::{EffectsConfig, PivotEffectsConfig};
    let mut loaded = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
    let j = loaded.config.joints.iter().position(|j| j.name == "shoulder").unwrap();
    let sim = loaded.config.joints[j].sim.as_mut().unwrap();
    let at = |pivot_mm| PivotEffectsConfig { pivot_mm, effects: EffectsConfig::default(), effects_per_dof: Vec::new() };
    (sim.effects, sim.effects_by_pivot) = (EffectsConfig::default(), vec![at(0.0), at(45.0)]);
    let t: Vec<f64> = (0..4000).map(|k| k as f64 * 0.005).collect();
    let d: Vec<f64> = t.iter().map(|t| 0.02 * (std::f64::consts::TAU * 0.25 * t).sin()).collect();
    let pivot = vec![20.0; t.len()];
    let high = PlantEffects::ByPivot(vec![(0.0, serde_json::json!({"torque_offset_nm": 0.5})), (45.0, serde_json::json!({"torque_offset_nm": 0.5}))]);
    let read = simulated_torque(&loaded, "q2", &high, &t, &d, &pivot).unwrap();
    let torque: Vec<f64> = read.iter().enumerate().map(|(k, tau)| tau + 0.01 * ((k * 7919 % 1000) as f64 / 500.0 - 1.0)).collect();
    let mut data = jointctl_ident::csv::Data::from_columns(t, d, torque);
    data.pivot_mm = pivot;
    let found = [Found { effect: "sensor_offset".into(), plant: serde_json::from_value(serde_json::json!({"torque_offset_nm": 0.5})).unwrap(), observer: Map::new() }];
    let ext = super::extend(&loaded, "q2", &found, &data, super::Split::of(&jointctl_ident::identify::IdentifyOptions::default())).unwrap();
    let PlantEffects::ByPivot(list) = &ext.plant_effects else { panic!("{:?}", ext.plant_effects) };
    let offsets: Vec<(f64, f64)> = list.iter().map(|(p, v)| (*p, v["torque_offset_nm"].as_f64().unwrap_or(0.0))).collect();
    assert_eq!(offsets, vec![(0.0, 0.0), (20.0, 0.5), (45.0, 0.0)], "{:?}", ext.notes);
    assert!(ext.simulation.relative() > 0.9, "{:?}", ext.simulation);
}
