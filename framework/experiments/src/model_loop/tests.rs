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
